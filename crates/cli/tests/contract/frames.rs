//! `crashrig frames info|export` (docs/FRAMES.md, docs/REFERENCE.md): the fields of a real
//! Phantom and Photron file, the exported PNGs holding the camera's values, `frames.csv`,
//! the range flags, and bad input (one `error:` line naming the file and frame, nothing written).

use crate::contract::common::{assert_clean_error, fixture, json_of, run};
use std::path::Path;

fn cine() -> std::path::PathBuf {
    fixture("frames/real/cine_781_first4.cine")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The 16-bit grey samples of a PNG (decoded by the png crate).
fn png_values(path: &Path) -> (u32, u32, Vec<u16>) {
    let f = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut r = png::Decoder::new(f).read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Sixteen)
    );
    let v = buf[..info.buffer_size()]
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect();
    (info.width, info.height, v)
}

#[test]
fn frames_info_cine_json() {
    let j = json_of(&run(["frames", "info", s(&cine()), "--json"]));
    assert_eq!(j["source"], "cine");
    assert_eq!(j["frames"], 4);
    assert_eq!(
        (j["width"].as_u64(), j["height"].as_u64()),
        (Some(256), Some(256))
    );
    assert_eq!(j["bits"], 12);
    assert_eq!(j["layout"], "16-bit little-endian");
    assert_eq!(j["frame_rate_hz"], 90000.0);
    assert_eq!(j["first_image_number"], -5417);
    assert_eq!(j["trigger_utc"], "2019-02-26T23:17:26.525629000Z");
    assert_eq!(j["time_source"], "timestamps");
    assert_eq!(j["first_epoch"], "000000");
    assert_eq!(j["last_epoch"], "000003");
    assert!(j["trigger_frame"].is_null());
}

#[test]
fn frames_info_mraw_text() {
    let r = run([
        "frames",
        "info",
        s(&fixture("frames/real/ball_12bit_first3.cihx")),
    ]);
    assert!(r.success, "{}", r.stderr);
    for needle in [
        "(mraw)",
        "384 x 384 px",
        "12 (packed 12-bit)",
        "30000 Hz",
        "trigger frame       0",
        "first image number  52",
    ] {
        assert!(r.stdout.contains(needle), "no `{needle}` in:\n{}", r.stdout);
    }
}

#[test]
fn frames_export_cine_nominal() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x");
    let j = json_of(&run([
        "frames",
        "export",
        s(&cine()),
        "--out",
        s(&out),
        "--first",
        "000001",
        "--last",
        "000002",
        "--json",
    ]));
    assert_eq!(j["frames"], 2);
    assert_eq!(j["source"], "cine");
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["000001.png", "000002.png", "frames.csv"]);
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "epoch,time_s");
    assert_eq!(lines.len(), 3);
    // The times of fixtures/frames/expected.json (exact stamp differences), printed so that they read back equal.
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("frames/expected.json")).unwrap())
            .unwrap();
    let g = expected["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["path"] == "real/cine_781_first4.cine")
        .unwrap();
    for (k, line) in lines[1..].iter().enumerate() {
        let (epoch, t) = line.split_once(',').unwrap();
        assert_eq!(epoch, format!("{:06}", k + 1));
        let t: f64 = t.parse().unwrap();
        approx::assert_abs_diff_eq!(t, g["times_s"][k + 1].as_f64().unwrap(), epsilon = 1e-12);
    }
    // The PNG holds the camera's values unscaled: the samples of pims' decoding.
    let (w, h, v) = png_values(&out.join("000001.png"));
    assert_eq!((w, h), (256, 256));
    let mut checked = 0;
    for sample in g["samples"].as_array().unwrap() {
        let s: Vec<u64> = sample
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect();
        if s[0] == 1 {
            assert_eq!(u64::from(v[(s[2] * 256 + s[1]) as usize]), s[3]);
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
    assert!(v.iter().all(|&x| x < 4096), "12-bit values stay below 4096");
}

#[test]
fn frames_export_directory_has_empty_times() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x");
    let r = run([
        "frames",
        "export",
        s(&fixture("frames/synth/dir8")),
        "--out",
        s(&out),
    ]);
    assert!(r.success, "{}", r.stderr);
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert_eq!(
        csv,
        "epoch,time_s\nf000,\nf001,\nf002,\nf003,\nf004,\nf005,\n"
    );
    let (_, _, v) = png_values(&out.join("f001.png"));
    assert!(v.iter().all(|&x| x <= 255), "8-bit data stay in 0..=255");
    assert_eq!(
        v[0], 255,
        "the generator set pixel (0, 0) to white in every channel"
    );
}

#[test]
fn frames_export_replaces_its_own_output_only() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x");
    let src = fixture("frames/synth/grey8.cih");
    assert!(run(["frames", "export", s(&src), "--out", s(&out)]).success);
    // A second export with a smaller range replaces the whole directory.
    assert!(
        run([
            "frames",
            "export",
            s(&src),
            "--out",
            s(&out),
            "--last",
            "000000"
        ])
        .success
    );
    assert!(!out.join("000001.png").exists());
    // A directory holding a file of the user's is not touched.
    std::fs::write(out.join("mine.txt"), "keep").unwrap();
    let r = run(["frames", "export", s(&src), "--out", s(&out)]);
    assert_clean_error(&r, &["mine.txt"]);
    assert_eq!(
        std::fs::read_to_string(out.join("mine.txt")).unwrap(),
        "keep"
    );
}

/// Runs an export that must fail, and checks the error line and that nothing was written.
fn export_fails(src: &Path, extra: &[&str], needles: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x");
    let mut args = vec!["frames", "export", s(src), "--out", s(&out)];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert_clean_error(&r, needles);
    assert!(!out.exists(), "nothing written for {src:?}");
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        0,
        "no staging directory left"
    );
}

#[test]
fn frames_bad_input() {
    let d = tempfile::tempdir().unwrap();
    // A truncated cine names the frame.
    let raw = std::fs::read(cine()).unwrap();
    let cut = d.path().join("cut.cine");
    std::fs::write(&cut, &raw[..raw.len() - 1000]).unwrap();
    export_fails(&cut, &[], &["cut.cine", "truncated", "frame 3"]);
    // A truncated mraw names the frame and the .mraw.
    let m = d.path().join("m");
    std::fs::create_dir(&m).unwrap();
    std::fs::copy(fixture("frames/real/beam_first2.cihx"), m.join("b.cihx")).unwrap();
    let mraw = std::fs::read(fixture("frames/real/beam_first2.mraw")).unwrap();
    std::fs::write(m.join("b.mraw"), &mraw[..mraw.len() - 1]).unwrap();
    export_fails(&m.join("b.cihx"), &[], &["b.mraw", "truncated", "frame 1"]);
    // A header without its .mraw.
    export_fails(
        &fixture("frames/real/sample_60k_16bit.cih"),
        &[],
        &["sample_60k_16bit.cih", "sample_60k_16bit.mraw", "missing"],
    );
    // A compression not supported says which.
    let mut jpeg = raw.clone();
    jpeg[4] = 1;
    let jp = d.path().join("jpeg.cine");
    std::fs::write(&jp, &jpeg).unwrap();
    export_fails(
        &jp,
        &[],
        &["jpeg.cine", "not supported", "compression 1 (JPEG"],
    );
    // A bit depth not supported says which.
    let cih = std::fs::read_to_string(fixture("frames/synth/grey8.cih")).unwrap();
    std::fs::write(
        m.join("ten.cih"),
        cih.replace("Color Bit : 8", "Color Bit : 10"),
    )
    .unwrap();
    std::fs::copy(fixture("frames/synth/grey8.mraw"), m.join("ten.mraw")).unwrap();
    export_fails(&m.join("ten.cih"), &[], &["ten.cih", "Color Bit 10"]);
    // Frames of different sizes name the file.
    let dir = d.path().join("dir");
    std::fs::create_dir(&dir).unwrap();
    std::fs::copy(fixture("frames/synth/dir8/f000.png"), dir.join("a.png")).unwrap();
    std::fs::copy(fixture("frames/synth/dir16/f000.png"), dir.join("b.png")).unwrap();
    export_fails(&dir, &[], &["b.png", "a.png"]);
    // A frame that does not decode names the file.
    std::fs::write(dir.join("b.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    export_fails(&dir, &[], &["b.png", "does not decode"]);
    // No frame in the range; an epoch that is not there.
    export_fails(
        &cine(),
        &["--first", "000003", "--last", "000001"],
        &["cine_781_first4.cine", "no frame in the range"],
    );
    export_fails(
        &cine(),
        &["--first", "000009"],
        &["--first 000009", "no frame"],
    );
    // Not a frame source.
    export_fails(
        &fixture("frames/expected.json"),
        &[],
        &["expected.json", "not a frame source"],
    );
    let empty = d.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    export_fails(&empty, &[], &["empty", "no PNG or TIFF"]);
}

#[test]
fn frames_info_bad_input_is_one_line() {
    let r = run([
        "frames",
        "info",
        s(&fixture("frames/real/sample_60k_16bit.cih")),
    ]);
    assert_clean_error(&r, &["sample_60k_16bit.mraw"]);
    let r = run(["frames", "info", "/nonexistent/x.cine"]);
    assert_clean_error(&r, &["/nonexistent/x.cine"]);
}

/// An export stopped after its second frame (the outdir fault hook aborts the process as a
/// SIGKILL would) leaves no `--out`; the next export cleans up and completes.
#[test]
fn frames_export_interrupted_leaves_nothing() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x");
    let src = fixture("frames/real/cine_781_first4.cine");
    let r = crate::contract::common::run_env(
        ["frames", "export", s(&src), "--out", s(&out)],
        &[("CRASHRIG_OUTDIR_FAULT", "abort-after-file:2")],
    );
    assert!(!r.success);
    assert!(!out.exists(), "an interrupted export left {out:?}");
    let r = run(["frames", "export", s(&src), "--out", s(&out)]);
    assert!(r.success, "{}", r.stderr);
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 5);
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        1,
        "no staging directory left"
    );
}
