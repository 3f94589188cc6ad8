//! Bad input: non-zero exit, one `error: ` line naming the file (and line for text), no
//! panic, no backtrace (RUST_BACKTRACE=1 is set), no half-written output.

use crate::contract::common::{assert_clean_error, copy_dir, fixture, run};
use std::path::Path;

/// Asserts that `stderr` names `line` of a text file, as `file:LINE` or `line LINE`.
fn assert_names_line(stderr: &str, file: &str, line: usize) {
    assert!(
        stderr.contains(&format!("{file}:{line}")) || stderr.contains(&format!("line {line}")),
        "stderr does not name {file} line {line}: {stderr}"
    );
}

/// Replaces line `n` (1-based) of a text file.
fn replace_line(path: &Path, n: usize, with: &str) {
    let text = std::fs::read_to_string(path).expect("read");
    let mut lines: Vec<&str> = text.lines().collect();
    lines[n - 1] = with;
    std::fs::write(path, lines.join("\n") + "\n").expect("write");
}

/// A copy of scenario `name` with `from` replaced by `to` (which must occur), in `dir`.
fn edited_scenario(dir: &Path, name: &str, from: &str, to: &str, out: &str) -> String {
    let text = std::fs::read_to_string(fixture(&format!("scenarios/{name}"))).expect("read");
    assert!(text.contains(from), "{from:?} in {name}");
    let p = dir.join(out);
    std::fs::write(&p, text.replacen(from, to, 1)).expect("write");
    p.display().to_string()
}

#[test]
fn error_nominal() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let missing = tmp.path().join("no_such_model");
    let m = missing.display().to_string();
    let r = run(["colmap", "info", m.as_str(), "--json"]);
    assert_clean_error(&r, &["no_such_model"]);
}

#[test]
fn error_missing_files_every_command() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let miss = |n: &str| tmp.path().join(n).display().to_string();
    let model = fixture("paper/twoview/model").display().to_string();
    let db = fixture("paper/twoview/database.db").display().to_string();
    let out = miss("out");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["colmap".into(), "info".into(), miss("nothing.db")],
            "nothing.db",
        ),
        (
            vec![
                "colmap".into(),
                "convert".into(),
                miss("in_model"),
                out.clone(),
                "--to".into(),
                "txt".into(),
            ],
            "in_model",
        ),
        (
            vec![
                "calibrate".into(),
                miss("rig_model"),
                "--camera-a".into(),
                "cam_out/".into(),
                "--camera-b".into(),
                "cam_in/".into(),
                "--json".into(),
            ],
            "rig_model",
        ),
        (
            vec![
                "bootstrap".into(),
                miss("boot.db"),
                "--model".into(),
                model.clone(),
                "--image-a".into(),
                "cam_in/000001.png".into(),
                "--image-b".into(),
                "cam_door/000001.png".into(),
                "--iterations".into(),
                "4".into(),
                "--json".into(),
            ],
            "boot.db",
        ),
        (
            vec![
                "bootstrap".into(),
                db,
                "--model".into(),
                miss("boot_model"),
                "--image-a".into(),
                "cam_in/000001.png".into(),
                "--image-b".into(),
                "cam_door/000001.png".into(),
                "--iterations".into(),
                "4".into(),
                "--json".into(),
            ],
            "boot_model",
        ),
        (
            vec!["propagate".into(), miss("sc.toml"), "--json".into()],
            "sc.toml",
        ),
        (
            vec![
                "grid".into(),
                miss("grid.toml"),
                "--out".into(),
                out.clone(),
            ],
            "grid.toml",
        ),
    ];
    for (args, name) in cases {
        let r = run(&args);
        assert_clean_error(&r, &[name]);
    }
    assert!(!Path::new(&out).join("grid.csv").exists());
}

#[test]
fn error_truncated_binary_model() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().join("model");
    copy_dir(&fixture("colmap/rig_opencv/bin"), &dir);
    let images = dir.join("images.bin");
    let len = std::fs::metadata(&images).expect("size").len();
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(&images)
        .expect("open");
    f.set_len(len / 2).expect("truncate");
    let d = dir.display().to_string();
    assert_clean_error(
        &run(["colmap", "info", d.as_str(), "--json"]),
        &["images.bin"],
    );
    assert_clean_error(&run(["colmap", "info", d.as_str()]), &["images.bin"]);
}

#[test]
fn error_text_model_garbage_line() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().join("model");
    copy_dir(&fixture("colmap/rig_opencv/txt"), &dir);
    // Line 5 is the first image line (after four comment lines).
    replace_line(&dir.join("images.txt"), 5, "this is not an image line");
    let d = dir.display().to_string();
    let r = run(["colmap", "info", d.as_str(), "--json"]);
    assert_clean_error(&r, &["images.txt"]);
    assert_names_line(&r.stderr, "images.txt", 5);
}

#[test]
fn error_unknown_camera_model() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().join("model");
    copy_dir(&fixture("colmap/rig_opencv/txt"), &dir);
    let path = dir.join("cameras.txt");
    let text = std::fs::read_to_string(&path).expect("read");
    let n = text
        .lines()
        .position(|l| !l.starts_with('#') && !l.trim().is_empty())
        .expect("a camera line")
        + 1;
    let line = text.lines().nth(n - 1).expect("line").to_string();
    let bad = line.replacen("OPENCV", "NOT_A_CAMERA_MODEL", 1);
    assert_ne!(bad, line);
    replace_line(&path, n, &bad);
    let d = dir.display().to_string();
    let r = run(["colmap", "info", d.as_str(), "--json"]);
    assert_clean_error(&r, &["cameras.txt", "NOT_A_CAMERA_MODEL"]);
    assert_names_line(&r.stderr, "cameras.txt", n);
}

#[test]
fn error_bad_scenarios() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let t = tmp.path();
    let chain = "paper_chain.toml";
    let cases = [
        edited_scenario(
            t,
            chain,
            "position_mm = [61.98,",
            "position_mm = [nan,",
            "nan.toml",
        ),
        edited_scenario(
            t,
            chain,
            "sigma_position_mm = [0.19,",
            "sigma_position_mm = [-0.19,",
            "negative_sigma.toml",
        ),
        edited_scenario(
            t,
            chain,
            "parent = \"cam2\"",
            "parent = \"cam9\"",
            "unknown_parent.toml",
        ),
    ];
    for sc in &cases {
        let name = Path::new(sc)
            .file_name()
            .expect("name")
            .to_string_lossy()
            .to_string();
        let r = run(["propagate", sc.as_str(), "--samples", "4", "--json"]);
        assert_clean_error(&r, &[name.as_str()]);
    }
    // Grid scenario: NaN in an observer, and a single observer.
    let grid_sc = "three_cameras_z0.toml";
    let nan = edited_scenario(
        t,
        grid_sc,
        "sigma_position_mm = [1.52, 1.54, 1.52]",
        "sigma_position_mm = [1.52, nan, 1.52]",
        "grid_nan.toml",
    );
    let text = std::fs::read_to_string(fixture(&format!("scenarios/{grid_sc}"))).expect("read");
    let cut = text.rfind("[[grid.observer]]").expect("two observers");
    let one = t.join("one_observer.toml");
    std::fs::write(&one, &text[..cut]).expect("write");
    let one = one.display().to_string();
    for (sc, name) in [(nan, "grid_nan.toml"), (one, "one_observer.toml")] {
        let out = t.join(format!("out_{name}"));
        let o = out.display().to_string();
        let r = run(["grid", sc.as_str(), "--out", o.as_str(), "--samples", "4"]);
        assert_clean_error(&r, &[name]);
        // No half-written output: a failing grid leaves no grid.csv or summary.json.
        assert!(
            !out.join("grid.csv").exists(),
            "{name}: grid.csv left behind"
        );
        assert!(
            !out.join("summary.json").exists(),
            "{name}: summary.json left behind"
        );
    }
}

#[test]
fn error_bootstrap_image_not_in_model() {
    let model = fixture("paper/twoview/model").display().to_string();
    let db = fixture("paper/twoview/database.db").display().to_string();
    for (a, b, method) in [
        ("cam_in/000001.png", "not_there.png", "absolute"),
        ("not_there.png", "cam_door/000001.png", "relative"),
    ] {
        let r = run([
            "bootstrap",
            db.as_str(),
            "--model",
            model.as_str(),
            "--image-a",
            a,
            "--image-b",
            b,
            "--method",
            method,
            "--iterations",
            "4",
            "--json",
        ]);
        assert_clean_error(&r, &["not_there.png", "model"]);
    }
}

#[test]
fn error_calibrate_unknown_prefix() {
    let model = fixture("rig/paper").display().to_string();
    for (a, b, bad) in [
        ("cam_xx/", "cam_in/", "cam_xx/"),
        ("cam_out/", "cam_yy/", "cam_yy/"),
    ] {
        let r = run([
            "calibrate",
            model.as_str(),
            "--camera-a",
            a,
            "--camera-b",
            b,
            "--mm-per-unit",
            "1",
            "--json",
        ]);
        assert_clean_error(&r, &[bad, "rig/paper"]);
    }
    // A zero-length scale bar (points 1 and 2 of `unpaired` coincide).
    let unpaired = fixture("rig/unpaired").display().to_string();
    let r = run([
        "calibrate",
        unpaired.as_str(),
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "cam_in/",
        "--scale-points",
        "1",
        "2",
        "--scale-length-mm",
        "2000",
        "--json",
    ]);
    assert_clean_error(&r, &["unpaired"]);
    // Camera B absent from the model altogether.
    let one = fixture("rig/one_camera").display().to_string();
    let r = run([
        "calibrate",
        one.as_str(),
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "cam_in/",
        "--json",
    ]);
    assert_clean_error(&r, &["one_camera"]);
}

const FIVE: [&str; 5] = ["cameras", "images", "points3D", "rigs", "frames"];

#[test]
fn error_convert_bad_input_writes_nothing() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().join("in");
    copy_dir(&fixture("colmap/rig_opencv/bin"), &dir);
    let p = dir.join("points3D.bin");
    let len = std::fs::metadata(&p).expect("size").len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&p)
        .expect("open")
        .set_len(len - 3)
        .expect("truncate");
    let out = tmp.path().join("out");
    let (i, o) = (dir.display().to_string(), out.display().to_string());
    for to in ["bin", "txt"] {
        let r = run(["colmap", "convert", i.as_str(), o.as_str(), "--to", to]);
        assert_clean_error(&r, &["points3D.bin"]);
        for s in FIVE {
            assert!(
                !out.join(format!("{s}.{to}")).exists(),
                "{s}.{to} left behind"
            );
        }
    }
}

#[test]
fn error_convert_failed_write_is_not_a_model() {
    // images.bin cannot be written (a directory of that name): the command fails and what is
    // left in OUT does not read as a complete model.
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    std::fs::create_dir_all(out.join("images.bin")).expect("mkdir");
    let src = fixture("colmap/rig_opencv/txt").display().to_string();
    let o = out.display().to_string();
    let r = run(["colmap", "convert", src.as_str(), o.as_str(), "--to", "bin"]);
    assert_clean_error(&r, &["images.bin"]);
    let info = run(["colmap", "info", o.as_str(), "--json"]);
    assert!(
        !info.success,
        "a failed convert left a readable model:\n{}",
        info.stdout
    );
}
