//! Units are never guessed (issue 25 §2, contract "Units are never guessed"): every case of
//! the issue runs the binary and checks the exact `error:` / `warning:` line — it names the
//! flag or key and its unit — and that nothing is written on an error. Every run is capped
//! (`capped`): a regression to a hang fails instead of blocking CI.

use crate::contract::common::{Run, assert_clean_error, fixture};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Per-run limit of these tests (debug build, tiny inputs: each run takes seconds).
const TIMEOUT: Duration = Duration::from_secs(300);

/// Runs `crashrig args` like [`crate::contract::common::run`], killed (and the test failed) after
/// [`TIMEOUT`].
fn capped(args: &[String]) -> Run {
    let dir = tempfile::tempdir().expect("temp dir");
    let (o, e) = (dir.path().join("stdout"), dir.path().join("stderr"));
    let mut child = Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .env_remove("RAYON_NUM_THREADS")
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&o).expect("stdout file"))
        .stderr(std::fs::File::create(&e).expect("stderr file"))
        .spawn()
        .expect("the crashrig binary runs");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("crashrig {args:?}: no exit within {TIMEOUT:?} (a hang)");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Run {
        success: status.success(),
        code: status.code(),
        stdout: std::fs::read_to_string(&o).expect("stdout is UTF-8"),
        stderr: std::fs::read_to_string(&e).expect("stderr is UTF-8"),
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The `warning:` lines of a run's stderr.
fn warnings(r: &Run) -> Vec<&str> {
    r.stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect()
}

fn seq(name: &str) -> String {
    fixture("measure/sequence").join(name).display().to_string()
}

/// `measure` on `fixtures/measure/sequence` (50 draws, no plots) into `out`, with `extra`;
/// `--mm-per-unit 1000` unless `with_scale` is false.
fn measure_args(out: &Path, observations: &str, with_scale: bool, extra: &[&str]) -> Vec<String> {
    let mut a = strings(&["measure"]);
    a.push(seq("model"));
    a.extend(strings(&[
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "2",
        "--camera-c",
        "3",
        "--link",
    ]));
    a.push(seq("link.json"));
    a.push("--tie".into());
    a.push(seq("tie.json"));
    a.push("--observations".into());
    a.push(observations.to_string());
    a.push("--a-covariance".into());
    a.push(seq("a_covariance.json"));
    if with_scale {
        a.extend(strings(&["--mm-per-unit", "1000"]));
    }
    a.extend(strings(&["--samples", "50", "--no-plots", "--out"]));
    a.push(out.display().to_string());
    a.extend(strings(extra));
    a
}

fn assert_nothing_written(out: &Path) {
    assert!(!out.exists(), "{} written after an error", out.display());
    let parent = out.parent().expect("parent");
    let left: Vec<String> = std::fs::read_dir(parent)
        .expect("list")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("crashrig-staging"))
        .collect();
    assert!(left.is_empty(), "staging left behind: {left:?}");
}

/// A 1.2 m scale bar typed into the mm key: the baseline shrinks to ~0.1 mm and one warning
/// names `--scale-length-mm` and its unit; the right length gives no such warning.
#[test]
fn units_scale_bar_in_metres_warns_naming_the_flag() {
    let model = fixture("rig/paper").display().to_string();
    let calibrate = |len: &str| {
        capped(&strings(&[
            "calibrate",
            &model,
            "--camera-a",
            "cam_out/",
            "--camera-b",
            "cam_in/",
            "--scale-points",
            "1",
            "2",
            "--scale-length-mm",
            len,
            "--no-refine",
            "--json",
        ]))
    };
    let r = calibrate("1.2");
    assert!(r.success, "{}", r.stderr);
    let w: Vec<&str> = warnings(&r)
        .into_iter()
        .filter(|l| l.contains("rig baseline"))
        .collect();
    assert_eq!(w.len(), 1, "{}", r.stderr);
    assert!(
        w[0].starts_with("warning: the rig baseline |base_mm| = 0.1")
            && w[0].contains("outside the plausible 20 mm – 5 m")
            && w[0].contains("check --scale-length-mm = 1.2 (mm:"),
        "{}",
        w[0]
    );
    let v: serde_json::Value = serde_json::from_str(&r.stdout).expect("json");
    assert!(
        v["warnings"].to_string().contains("rig baseline"),
        "the JSON's warnings hold it too"
    );
    let r = calibrate("2000");
    assert!(r.success, "{}", r.stderr);
    assert!(!r.stderr.contains("rig baseline"), "{}", r.stderr);
}

/// `measure` without `--mm-per-unit` is an error naming the flag and its unit, before any
/// work and with nothing written; an A covariance that states `mm_per_unit` gives the units
/// (same result as the flag), and a flag that contradicts it is an error.
#[test]
fn units_measure_without_mm_per_unit_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("m");
    let obs = seq("observations.csv");
    let r = capped(&measure_args(&out, &obs, false, &[]));
    assert_clean_error(
        &r,
        &[
            "--mm-per-unit",
            "missing",
            "mm per model unit",
            "never guessed",
        ],
    );
    assert_nothing_written(&out);

    // The A covariance states the units.
    let mut cov: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seq("a_covariance.json")).expect("read"))
            .expect("json");
    cov["mm_per_unit"] = serde_json::json!(1000.0);
    let stated = tmp.path().join("a_cov_stated.json");
    std::fs::write(&stated, cov.to_string()).expect("write");
    let with_stated = |args: Vec<String>| -> Vec<String> {
        let i = args
            .iter()
            .position(|a| a == "--a-covariance")
            .expect("flag")
            + 1;
        let mut a = args;
        a[i] = stated.display().to_string();
        a
    };
    let out_stated = tmp.path().join("stated");
    let r = capped(&with_stated(measure_args(&out_stated, &obs, false, &[])));
    assert!(r.success, "{}", r.stderr);
    let out_flag = tmp.path().join("flag");
    let r = capped(&with_stated(measure_args(&out_flag, &obs, true, &[])));
    assert!(r.success, "{}", r.stderr);
    assert_eq!(
        std::fs::read(out_stated.join("trajectories.csv")).expect("csv"),
        std::fs::read(out_flag.join("trajectories.csv")).expect("csv"),
        "the stated units and the flag give the same result"
    );
    let out_bad = tmp.path().join("bad");
    let mut a = with_stated(measure_args(&out_bad, &obs, false, &[]));
    a.extend(strings(&["--mm-per-unit", "1"]));
    let r = capped(&a);
    assert_clean_error(
        &r,
        &["--mm-per-unit", "1 mm per model unit", "mm_per_unit = 1000"],
    );
    assert_nothing_written(&out_bad);
}

/// A frame rate below 100 Hz (typed in kHz) warns naming the flag and Hz; a frame rate that
/// makes a marker faster than 100 m/s warns naming the frame rate (Hz) and the scale.
#[test]
fn units_measure_frame_rate_and_velocity_warnings() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let obs = seq("observations.csv");
    let r = capped(&measure_args(
        &tmp.path().join("khz"),
        &obs,
        true,
        &["--frame-rate-hz", "20"],
    ));
    assert!(r.success, "{}", r.stderr);
    assert!(
        warnings(&r).contains(
            &"warning: --frame-rate-hz = 20 Hz is below 100 Hz: crash-test cameras record at 500 Hz or more; give the rate in Hz (e.g. 20000 for 20 kHz)"
        ),
        "{}",
        r.stderr
    );
    let r = capped(&measure_args(
        &tmp.path().join("fast"),
        &obs,
        true,
        &["--frame-rate-hz", "10000000"],
    ));
    assert!(r.success, "{}", r.stderr);
    let w: Vec<&str> = warnings(&r)
        .into_iter()
        .filter(|l| l.contains("m/s"))
        .collect();
    assert_eq!(w.len(), 1, "{}", r.stderr);
    assert!(
        w[0].contains(
            "above 100 m/s: check --frame-rate-hz (Hz) and --mm-per-unit (mm per model unit)"
        ),
        "{}",
        w[0]
    );
    // The fixture's own rate (1000 Hz) gives neither warning.
    let r = capped(&measure_args(
        &tmp.path().join("ok"),
        &obs,
        true,
        &["--frame-rate-hz", "1000"],
    ));
    assert!(r.success, "{}", r.stderr);
    assert!(
        !r.stderr.contains("Hz") && !r.stderr.contains("m/s"),
        "{}",
        r.stderr
    );
}

/// `--mm-per-unit 1e300` (the result would be `inf`), an empty camera and an out-of-range
/// sample count are refused by the option parser, naming the flag; nothing is written.
#[test]
fn units_measure_bad_flags_name_the_flag() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("m");
    let obs = seq("observations.csv");
    let mut a = measure_args(&out, &obs, false, &[]);
    a.extend(strings(&["--mm-per-unit", "1e300"]));
    let r = capped(&a);
    assert_clean_error(&r, &["--mm-per-unit", "mm per model unit"]);
    assert_nothing_written(&out);

    let mut a = measure_args(&out, &obs, true, &[]);
    let i = a.iter().position(|s| s == "--camera-b").expect("flag") + 1;
    a[i] = String::new();
    let r = capped(&a);
    assert_clean_error(&r, &["--camera-b", "must name a camera"]);
    assert_nothing_written(&out);

    for n in ["1000000000", "10000001"] {
        let mut a = measure_args(&out, &obs, true, &[]);
        let i = a.iter().position(|s| s == "--samples").expect("flag") + 1;
        a[i] = n.into();
        let r = capped(&a);
        assert_clean_error(&r, &["--samples", "must be from 2 to 10000000"]);
        assert_nothing_written(&out);
    }
}

/// `u_px = 1e6` (an infinite reprojection before) is an error naming the file, line, column
/// and unit; nothing is written.
#[test]
fn units_measure_pixel_outside_the_image_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("m");
    let text = std::fs::read_to_string(seq("observations.csv")).expect("read");
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[2].split(',').map(String::from).collect();
    f[3] = "1e6".into();
    lines[2] = f.join(",");
    let obs = tmp.path().join("obs.csv");
    std::fs::write(&obs, lines.join("\n") + "\n").expect("write");
    let r = capped(&measure_args(&out, &obs.display().to_string(), true, &[]));
    assert_clean_error(
        &r,
        &["obs.csv", "line 3", "`u_px` = 1000000 px", "outside camera"],
    );
    assert_nothing_written(&out);
}

/// `measure` without camera C: every marker has one view, nothing is measurable — an error,
/// not a table of empty σ with exit 0.
#[test]
fn units_measure_single_camera_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("m");
    let text = std::fs::read_to_string(seq("observations.csv")).expect("read");
    let b_only: String = text
        .lines()
        .filter(|l| !l.contains(",C,"))
        .map(|l| format!("{l}\n"))
        .collect();
    let obs = tmp.path().join("b_only.csv");
    std::fs::write(&obs, b_only).expect("write");
    let mut a = measure_args(&out, &obs.display().to_string(), true, &[]);
    for flag in ["--camera-c", "--tie"] {
        let i = a.iter().position(|s| s == flag).expect("flag");
        a.drain(i..i + 2);
    }
    let r = capped(&a);
    assert_clean_error(
        &r,
        &["b_only.csv", "no marker could be measured", "--camera-c"],
    );
    assert_nothing_written(&out);
}

fn study_line(text: &str, starts: &str) -> usize {
    text.lines()
        .position(|l| l.starts_with(starts))
        .expect("line")
        + 1
}

/// `[measure]` without its third camera, and without `mm_per_unit`, are errors naming the
/// key and the line of `[measure]`; nothing is written.
#[test]
fn units_study_measure_needs_camera_c_and_units() {
    let text = std::fs::read_to_string(fixture("study/own/study.toml")).expect("study");
    let line = study_line(&text, "[measure]");
    crate::contract::study::study_error(
        |t| t.replace("camera_c = \"3\"\n", ""),
        &[
            &format!("study.toml:{line}: `measure.camera_c`: missing"),
            "two views",
        ],
    );
    crate::contract::study::study_error(
        |t| t.replace("mm_per_unit = 1000.0\nsigma_a", "sigma_a"),
        &[
            &format!("study.toml:{line}: `measure.mm_per_unit`: missing"),
            "mm per model unit",
        ],
    );
}

/// A 4-number position and out-of-range counts in a study name the key and its line.
#[test]
fn units_study_values_name_key_and_line() {
    let text = std::fs::read_to_string(fixture("study/own/study.toml")).expect("study");
    let line = study_line(&text, "position_mm = [150.0, 0.0, 0.0]");
    crate::contract::study::study_error(
        |t| {
            t.replacen(
                "position_mm = [150.0, 0.0, 0.0]",
                "position_mm = [150.0, 0.0, 0.0, 1.0]",
                1,
            )
        },
        &[&format!("study.toml:{line}:"), "position_mm"],
    );
    let line = study_line(&text, "samples = 300");
    crate::contract::study::study_error(
        |t| t.replace("samples = 300", "samples = 10000001"),
        &[
            &format!("study.toml:{line}: `samples`"),
            "exceeds the limit of 10000000",
        ],
    );
    let line = study_line(&text, "chain_samples");
    crate::contract::study::study_error(
        |t| t.replace("chain_samples = 20000", "chain_samples = 1000000000000000"),
        &[
            &format!("study.toml:{line}: `chain_samples`"),
            "exceeds the limit",
        ],
    );
    let line = study_line(&text, "iterations = 60");
    crate::contract::study::study_error(
        |t| t.replace("iterations = 60", "iterations = 9223372036854775807"),
        &[
            &format!("study.toml:{line}: `tie.iterations`"),
            "exceeds the limit of 1000000",
        ],
    );
    let line = study_line(&text, "z_mm = [0.0, 0.0, 1]");
    crate::contract::study::study_error(
        |t| t.replacen("z_mm = [0.0, 0.0, 1]", "z_mm = [0.0, 300.0, 10001]", 1),
        &[
            &format!("study.toml:{line}: `layout[0].z_mm`"),
            "exceeds the limit of 10000 values per axis",
        ],
    );
    let line = study_line(&text, "[[layout]]");
    crate::contract::study::study_error(
        |t| {
            t.replacen(
                "x_mm = [400.0, 1800.0, 8]",
                "x_mm = [400.0, 1800.0, 2000]",
                1,
            )
            .replacen(
                "y_mm = [-500.0, 500.0, 6]",
                "y_mm = [-500.0, 500.0, 1000]",
                1,
            )
        },
        &[
            &format!("study.toml:{line}: `layout[0]`"),
            "2000000 grid points exceed the limit of 1000000",
            "MiB",
        ],
    );
    // Coincident observers: σ would be empty (null) for every point; an error naming both.
    let line = study_line(&text, "position_mm = [1200.0, 650.0, 100.0]");
    crate::contract::study::study_error(
        |t| {
            t.replacen(
                "position_mm = [1200.0, 650.0, 100.0]",
                "position_mm = [150.0, 0.0, 0.0]",
                1,
            )
        },
        &[
            &format!("study.toml:{line}: `layout[0].observer[1].position_mm`"),
            "\"side (tie)\" is 0.000 mm from observer[0] \"rear (inward)\"",
            "coincident",
        ],
    );
}

/// Runs `study` (4 draws, no sensitivity) on a copy of the own project whose study file is
/// `edit` of the bundled one; returns the run, the edited text and `report.html`.
fn own_study_edited(edit: impl Fn(&str) -> String) -> (Run, String, String) {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = crate::contract::study::own_project(tmp.path());
    let study = own.join("study.toml");
    let text = edit(&std::fs::read_to_string(&study).expect("study"));
    std::fs::write(&study, &text).expect("write");
    let out = tmp.path().join("out");
    let r = capped(&strings(&[
        "study",
        &study.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--samples",
        "4",
        "--no-sensitivity",
    ]));
    assert!(r.success, "{}", r.stderr);
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    (r, text, html)
}

/// Issue 36 §2, on the bundled own-data study, one edit each (every run exited 0 without a
/// warning): a layout grid in metres, an observer's `position_mm` in metres, the outward
/// camera's `sigma_position_mm` in metres. Each gives a `warning:` naming the file, the key's
/// line, the key and the unit, and the report's verdicts repeat it; the unedited study gives
/// no warning and no such verdict.
#[test]
fn units_study_lengths_in_metres_warn_with_key_line_and_unit_and_in_the_verdict() {
    let (r, _, html) = own_study_edited(|t| t.to_string());
    assert!(warnings(&r).is_empty(), "{}", r.stderr);
    assert!(
        !html.contains("lengths plausible"),
        "unit verdict without a cause"
    );
    let cases: [(&str, &str, &str, &str); 3] = [
        (
            "x_mm = [400.0, 1800.0, 8]\ny_mm = [-500.0, 500.0, 6]",
            "x_mm = [0.4, 1.8, 8]\ny_mm = [-0.5, 0.5, 6]",
            "x_mm = [0.4, 1.8, 8]",
            "`layout[0].x_mm` spans 1.4 mm (less than 20 mm) — a car interior is metres across; lengths are in millimetres",
        ),
        (
            "name = \"side (tie)\"\nposition_mm = [1200.0, 650.0, 100.0]",
            "name = \"side (tie)\"\nposition_mm = [1.2, 0.65, 0.1]",
            "position_mm = [1.2, 0.65, 0.1]",
            "`layout[0].observer[1].position_mm` is 1.368 mm from the origin of the frame without being at it",
        ),
        (
            "sigma_position_mm = [0.8, 0.8, 1.2]",
            "sigma_position_mm = [0.0008, 0.0008, 0.0012]",
            "sigma_position_mm = [0.0008",
            "`outward.sigma_position_mm` σ of 0.0008 mm is below a micrometre (0.001 mm) — no camera pose is known that well; lengths are in millimetres",
        ),
    ];
    for (from, to, at, says) in cases {
        let (r, text, html) = own_study_edited(|t| {
            assert!(t.contains(from), "{from}");
            t.replacen(from, to, 1)
        });
        let line = study_line(&text, at);
        let w = warnings(&r);
        let expected = format!("study.toml:{line}: {says}");
        let hit: Vec<&&str> = w.iter().filter(|l| l.contains(&expected)).collect();
        assert_eq!(hit.len(), 1, "{to}: want {expected}\n{}", r.stderr);
        assert!(hit[0].contains("millimetres"), "{}", hit[0]);
        assert!(
            html.contains("Are the inputs&#39; lengths plausible (millimetres)?")
                && html.contains(&expected)
                && html.contains("unless a length is in the wrong unit"),
            "{to}: the report's verdict does not repeat the warning"
        );
    }
}

/// The bundled paper study (`crashrig paper`, tiny counts) gives no unit warning: the
/// thresholds are far from a real car and lab.
#[test]
fn units_paper_study_has_no_unit_warning() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("paper");
    let r = capped(&strings(&[
        "paper",
        "--out",
        &out.display().to_string(),
        "--samples",
        "2",
        "--chain-samples",
        "2",
        "--iterations",
        "2",
    ]));
    assert!(r.success, "{}", r.stderr);
    assert!(warnings(&r).is_empty(), "{}", r.stderr);
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    assert!(!html.contains("lengths plausible"));
}

/// `scale_length_mm = 1e300` was reported at another line as "a covariance entry is not
/// finite": the key itself is bounded (lengths ≤ 10⁷ mm) and named at its own line.
#[test]
fn units_study_scale_length_beyond_the_bound_names_its_line() {
    let text = std::fs::read_to_string(fixture("study/own/study.toml")).expect("study");
    let line = study_line(&text, "scale_length_mm");
    crate::contract::study::study_error(
        |t| t.replace("scale_length_mm = 1500.0", "scale_length_mm = 1e300"),
        &[
            &format!("study.toml:{line}: `calibration.scale_length_mm`"),
            "1e300 mm exceeds the limit of 10000000 mm",
        ],
    );
}

/// The scenario's keys get the same checks for `grid` and `propagate` (one implementation, in
/// the scenario reader): a grid in metres, an observer σ below a micrometre.
#[test]
fn units_scenario_lengths_in_metres_warn_for_grid_and_propagate() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scen = tmp.path().join("s.toml");
    std::fs::write(
        &scen,
        "seed = 1\nsamples = 50\n\n[[camera]]\nname = \"cam1\"\nposition_mm = [0.0, 0.0, 0.0]\n\
         angles_deg = [0.0, 0.0, 0.0]\nsigma_position_mm = [0.0005, 0.0005, 0.0005]\n\
         sigma_angles_deg = [0.01, 0.01, 0.01]\n\n[grid]\nx_mm = [0.4, 2.0, 5]\n\
         y_mm = [-600.0, 600.0, 3]\nz_mm = [0.0, 0.0, 1]\n\n[[grid.observer]]\n\
         position_mm = [200.0, 0.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\n\
         sigma_angles_deg = [0.01, 0.01, 0.01]\n\n[[grid.observer]]\n\
         position_mm = [1300.0, -700.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\n\
         sigma_angles_deg = [0.01, 0.01, 0.01]\n",
    )
    .expect("scenario");
    let s = scen.display().to_string();
    let axis = "s.toml:12: `grid.x_mm` spans 1.6 mm (less than 20 mm)";
    let sigma = "s.toml:8: `camera[0].sigma_position_mm` σ of 0.0005 mm is below a micrometre";
    let out = tmp.path().join("out").display().to_string();
    let g = capped(&strings(&["grid", &s, "--out", &out, "--no-plots"]));
    assert!(g.success, "{}", g.stderr);
    let w = warnings(&g);
    assert!(
        w.iter().any(|l| l.contains(axis)) && w.iter().any(|l| l.contains(sigma)),
        "{}",
        g.stderr
    );
    let p = capped(&strings(&["propagate", &s]));
    assert!(p.success, "{}", p.stderr);
    assert!(
        warnings(&p).iter().any(|l| l.contains(sigma)),
        "{}",
        p.stderr
    );
}

/// A 1.5 m scale bar typed in metres in a study: the calibration's baseline warning names the
/// line of `scale_length_mm` (it had no line) and the report's verdict repeats it.
#[test]
fn units_study_scale_bar_in_metres_warns_at_its_line() {
    let (r, text, html) =
        own_study_edited(|t| t.replace("scale_length_mm = 1500.0", "scale_length_mm = 1.5"));
    let line = study_line(&text, "scale_length_mm");
    let want = format!("study.toml:{line}: [calibration]: the rig baseline |base_mm| = ");
    let w = warnings(&r);
    assert!(
        w.iter()
            .any(|l| l.contains(&want) && l.contains("check calibration.scale_length_mm = 1.5")),
        "{}",
        r.stderr
    );
    assert!(html.contains(&want), "the verdict does not repeat it");
}

/// `calibrate` on a model with a pose translation of 1e308 printed `null` / NaN with exit 0
/// (issue 36 §4): every number of a model is bounded on reading (±1e12, docs/LIMITS.md) and
/// the error names the file and the record.
#[test]
fn units_calibrate_model_value_beyond_the_bound_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let model = tmp.path().join("model");
    crate::contract::common::copy_dir(&fixture("rig/paper"), &model);
    let frames = model.join("frames.bin");
    let mut b = std::fs::read(&frames).expect("frames.bin");
    // The first frame's TY: count (8), frame and rig id (8), then QW QX QY QZ TX.
    b[56..64].copy_from_slice(&1e308f64.to_le_bytes());
    std::fs::write(&frames, b).expect("write");
    let m = model.display().to_string();
    for json in [false, true] {
        let mut args = strings(&[
            "calibrate",
            &m,
            "--camera-a",
            "cam_out/",
            "--camera-b",
            "cam_in/",
            "--mm-per-unit",
            "1",
        ]);
        if json {
            args.push("--json".into());
        }
        let r = capped(&args);
        assert_clean_error(
            &r,
            &[
                "frames.bin: record 0: a rig_from_world number is not finite or beyond ±1e12 model units",
                "(id 1)",
            ],
        );
    }
}
