//! Every study-file error names the file and the line (issue 25 §3: the campaign found 34
//! errors without a line number, mostly study-file errors). A table of bad study files, one
//! per kind of key or section error, each an edit of the own project's `study.toml`; every
//! run must fail with exactly one `error:` line that contains `study.toml:<line>:`, the line
//! of the key (or, where the error is about a whole table, of its header), and leave no
//! output behind.

use crate::contract::common::{assert_clean_error, run};

/// One bad study file: a name, the edit of the own project's study text, and where the error
/// must point: the 1-based line holding the `n`-th occurrence of `marker` in the edited text
/// (`""`: line 1, the file's first line, for a section that is missing altogether).
struct Case {
    name: &'static str,
    edit: fn(&str) -> String,
    marker: &'static str,
    n: usize,
}

/// `t` with the first occurrence of `from` replaced by `to` (the fixture must contain it).
fn once(t: &str, from: &str, to: &str) -> String {
    assert!(t.contains(from), "fixture lacks {from:?}");
    t.replacen(from, to, 1)
}

/// `t` with the `n`-th (0-based) occurrence of `from` replaced by `to`.
fn nth(t: &str, from: &str, n: usize, to: &str) -> String {
    let (i, _) = t
        .match_indices(from)
        .nth(n)
        .unwrap_or_else(|| panic!("fixture lacks {from:?} #{n}"));
    format!("{}{to}{}", &t[..i], &t[i + from.len()..])
}

fn line_of(t: &str, marker: &str, n: usize) -> usize {
    if marker.is_empty() {
        return 1;
    }
    let (i, _) = t
        .match_indices(marker)
        .nth(n)
        .unwrap_or_else(|| panic!("edited text lacks {marker:?} #{n}"));
    t[..i].matches('\n').count() + 1
}

macro_rules! case {
    ($name:expr, $edit:expr, $marker:expr) => {
        case!($name, $edit, $marker, 0)
    };
    ($name:expr, $edit:expr, $marker:expr, $n:expr) => {
        Case {
            name: $name,
            edit: $edit,
            marker: $marker,
            n: $n,
        }
    };
}

fn cases() -> Vec<Case> {
    vec![
        // Top level and TOML itself.
        case!(
            "syntax error",
            |t| once(t, "seed = 11", "seed = = 11"),
            "seed = = 11"
        ),
        case!(
            "wrong type",
            |t| once(t, "seed = 11", "seed = \"eleven\""),
            "seed = \"eleven\""
        ),
        case!(
            "unknown top-level key",
            |t| once(t, "seed = 11", "seed = 11\nsede = 3"),
            "sede = 3"
        ),
        case!(
            "integer too large for TOML",
            |t| once(t, "seed = 11", "seed = 99999999999999999999"),
            "seed = 9999"
        ),
        case!(
            "samples below its bound",
            |t| once(t, "samples = 300", "samples = 1"),
            "samples = 1"
        ),
        case!(
            "samples above its bound",
            |t| once(t, "samples = 300", "samples = 10000001"),
            "samples = 10000001"
        ),
        case!(
            "chain_samples 1e15",
            |t| once(
                t,
                "chain_samples = 20000",
                "chain_samples = 1000000000000000"
            ),
            "chain_samples ="
        ),
        case!(
            "unknown reference",
            |t| once(t, "seed = 11", "seed = 11\nreference = \"nobody\""),
            "reference ="
        ),
        case!(
            "unknown section",
            |t| format!("{t}\n[calibrate]\nmodel = \"calibration\"\n"),
            "[calibrate]"
        ),
        case!(
            "missing section",
            |t| {
                let i = t.find("# The outward camera").unwrap();
                let j = t.find("[[layout]]").unwrap();
                format!("{}{}", &t[..i], &t[j..])
            },
            ""
        ),
        // [calibration]
        case!(
            "calibration: required key missing",
            |t| once(t, "model = \"calibration\"\n", ""),
            "[calibration]"
        ),
        case!(
            "calibration: model does not exist",
            |t| once(t, "model = \"calibration\"", "model = \"nowhere\""),
            "model = \"nowhere\""
        ),
        case!(
            "calibration: two scales",
            |t| once(
                t,
                "scale_length_mm = 1500.0",
                "scale_length_mm = 1500.0\nmm_per_unit = 1000.0"
            ),
            "mm_per_unit = 1000.0"
        ),
        case!(
            "calibration: negative scale bar",
            |t| once(t, "scale_length_mm = 1500.0", "scale_length_mm = -1500.0"),
            "scale_length_mm"
        ),
        case!(
            "calibration: one scale point",
            |t| once(t, "scale_points = [1, 2]", "scale_points = [1]"),
            "scale_points"
        ),
        case!(
            "calibration: empty camera",
            |t| once(t, "camera_a = \"cam_out/\"", "camera_a = \"\""),
            "camera_a"
        ),
        case!(
            "calibration: unknown key",
            |t| once(
                t,
                "camera_b = \"cam_in/\"",
                "camera_b = \"cam_in/\"\ncamera_c = \"x\""
            ),
            "camera_c = \"x\""
        ),
        // [tie]
        case!(
            "tie: iterations at i64::MAX",
            |t| once(t, "iterations = 60", "iterations = 9223372036854775807"),
            "iterations"
        ),
        case!(
            "tie: unknown method",
            |t| once(t, "method = \"absolute\"", "method = \"sideways\""),
            "method"
        ),
        case!(
            "tie: zero scale",
            |t| once(
                t,
                "iterations = 60\nmm_per_unit = 1000.0",
                "iterations = 60\nmm_per_unit = 0.0"
            ),
            "mm_per_unit = 0.0"
        ),
        case!(
            "tie: database does not exist",
            |t| once(
                t,
                "database = \"tie/database.db\"",
                "database = \"tie/none.db\""
            ),
            "database"
        ),
        // [outward]
        case!(
            "outward: four-number position",
            |t| once(
                t,
                "position_mm = [0.0, 0.0, 0.0]",
                "position_mm = [0.0, 0.0, 0.0, 0.0]"
            ),
            "position_mm = [0.0, 0.0, 0.0, 0.0]"
        ),
        case!(
            "outward: negative σ",
            |t| once(
                t,
                "sigma_position_mm = [0.8, 0.8, 1.2]",
                "sigma_position_mm = [-0.8, 0.8, 1.2]"
            ),
            "sigma_position_mm = [-0.8"
        ),
        case!(
            "outward: NaN angle",
            |t| once(
                t,
                "angles_deg = [0.0, 0.0, 0.0]",
                "angles_deg = [nan, 0.0, 0.0]"
            ),
            "angles_deg = [nan"
        ),
        case!(
            "outward: missing σ",
            |t| once(t, "sigma_angles_deg = [0.008, 0.008, 0.012]\n", ""),
            "[outward]"
        ),
        // [[layout]]
        case!(
            "layout: zero count",
            |t| once(t, "x_mm = [400.0, 1800.0, 8]", "x_mm = [400.0, 1800.0, 0]"),
            "x_mm = [400.0, 1800.0, 0]"
        ),
        case!(
            "layout: 2000 × 1000 grid",
            |t| once(
                &once(
                    t,
                    "x_mm = [400.0, 1800.0, 8]",
                    "x_mm = [400.0, 1800.0, 2000]"
                ),
                "y_mm = [-500.0, 500.0, 6]",
                "y_mm = [-500.0, 500.0, 1000]"
            ),
            "[[layout]]"
        ),
        case!(
            "layout: 10 001 z levels",
            |t| once(t, "z_mm = [0.0, 0.0, 1]", "z_mm = [0.0, 300.0, 10001]"),
            "z_mm = [0.0, 300.0, 10001]"
        ),
        case!(
            "layout: axis of two numbers",
            |t| once(t, "x_mm = [400.0, 1800.0, 8]", "x_mm = [400.0, 1800.0]"),
            "x_mm = [400.0, 1800.0]"
        ),
        case!(
            "layout: negative threshold",
            |t| once(t, "threshold_mm = 3.0", "threshold_mm = -3.0"),
            "threshold_mm = -3.0"
        ),
        case!(
            "layout: pixel σ without focal length",
            |t| once(
                t,
                "threshold_mm = 3.0",
                "threshold_mm = 3.0\npixel_sigma_px = 0.5"
            ),
            "pixel_sigma_px = 0.5"
        ),
        case!(
            "layout: duplicate name",
            |t| once(t, "name = \"rear_pair_given\"", "name = \"rear_and_side\""),
            "name = \"rear_and_side\"",
            1
        ),
        case!(
            "layout: empty name",
            |t| once(t, "name = \"rear_and_side\"", "name = \"\""),
            "name = \"\""
        ),
        case!(
            "layout: unknown key",
            |t| once(
                t,
                "threshold_mm = 3.0",
                "threshold_mm = 3.0\nthresold_mm = 2.0"
            ),
            "thresold_mm"
        ),
        case!(
            "layout: one observer",
            |t| {
                let i = t
                    .find("[[layout.observer]]\nname = \"side (tie)\"")
                    .unwrap();
                let j = t[i..].find("[[layout]]").unwrap() + i;
                format!("{}{}", &t[..i], &t[j..])
            },
            "[[layout]]"
        ),
        case!(
            "layout: correlated with a fixed `from` observer",
            |t| nth(
                t,
                "threshold_mm = 3.0",
                2,
                "threshold_mm = 3.0\ncorrelated = true"
            ),
            "from = \"inward\"",
            1
        ),
        // [[layout.observer]]
        case!(
            "observer: unknown chain camera",
            |t| once(t, "from = \"inward\"", "from = \"door\""),
            "from = \"door\""
        ),
        case!(
            "observer: two noise models",
            |t| once(
                t,
                "from = \"tie\"",
                "from = \"tie\"\nsigma_position_mm = [1.0, 1.0, 1.0]"
            ),
            "from = \"tie\""
        ),
        case!(
            "observer: no noise model",
            |t| once(t, "from = \"tie\"\n", ""),
            "[[layout.observer]]",
            1
        ),
        case!(
            "observer: four-number position",
            |t| once(
                t,
                "position_mm = [150.0, 0.0, 0.0]",
                "position_mm = [150.0, 0.0, 0.0, 1.0]"
            ),
            "position_mm = [150.0, 0.0, 0.0, 1.0]"
        ),
        case!(
            "observer: unknown key",
            |t| once(t, "from = \"inward\"", "from = \"inward\"\nfrm = 1"),
            "frm = 1"
        ),
        case!(
            "observer: covariance with five rows",
            |t| once(t, "  [0.0, 0.0, 0.0, 0.0, 0.0, 1.0e-4],\n", ""),
            "covariance_tangent"
        ),
        case!(
            "observer: covariance not positive semi-definite",
            |t| once(
                t,
                "[0.0, 0.0, 0.0, 0.0, 0.0, 1.0e-4]",
                "[0.0, 0.0, 0.0, 0.0, 0.0, -1.0e-4]"
            ),
            "covariance_tangent"
        ),
        case!(
            "observer: unknown aim",
            |t| once(
                t,
                "aim = \"fixed\"\nlook_at_mm",
                "aim = \"glued\"\nlook_at_mm"
            ),
            "aim = \"glued\""
        ),
        case!(
            "observer: lens of a missing camera",
            |t| once(
                t,
                "camera_from = \"tie/model:1\"",
                "camera_from = \"tie/model:9\""
            ),
            "camera_from"
        ),
        case!(
            "observer: fixed without orientation",
            |t| once(t, "look_at_mm = [1100.0, 0.0, 0.0]\n", ""),
            "[[layout.observer]]",
            4
        ),
        // [measure]
        case!(
            "measure: without its third camera",
            |t| once(t, "camera_c = \"3\"\n", ""),
            "[measure]"
        ),
        case!(
            "measure: zero frame rate",
            |t| once(t, "frame_rate_hz = 1000.0", "frame_rate_hz = 0.0"),
            "frame_rate_hz"
        ),
        case!(
            "measure: unknown CFC class",
            |t| once(
                t,
                "frame_rate_hz = 1000.0",
                "frame_rate_hz = 1000.0\ncfc = 7"
            ),
            "cfc = 7"
        ),
        case!(
            "measure: observations do not exist",
            |t| once(
                t,
                "observations = \"measure/observations.csv\"",
                "observations = \"measure/none.csv\""
            ),
            "observations"
        ),
        case!(
            "measure: unknown key",
            |t| once(
                t,
                "pixel_sigma_px = 0.3",
                "pixel_sigma_px = 0.3\npixel_sigma = 0.3"
            ),
            "pixel_sigma = 0.3"
        ),
        case!(
            "measure: negative σ",
            |t| once(
                t,
                "sigma_a_position_mm = [0.3, 0.3, 0.3]",
                "sigma_a_position_mm = [0.3, -0.3, 0.3]"
            ),
            "sigma_a_position_mm"
        ),
        // Errors of a step that runs: named at the line of the key they are about, else at the
        // section's header.
        case!(
            "calibration: camera not in the model",
            |t| once(t, "camera_a = \"cam_out/\"", "camera_a = \"cam_front/\""),
            "camera_a = \"cam_front/\""
        ),
        case!(
            "tie: image not in the database",
            |t| once(
                t,
                "image_b = \"side/0001.png\"",
                "image_b = \"side/0099.png\""
            ),
            "[tie]"
        ),
        case!(
            "layout: observer on a grid point",
            |t| once(
                t,
                "position_mm = [150.0, 400.0, 0.0]",
                "position_mm = [400.0, -500.0, 300.0]"
            ),
            "[[layout]]",
            1
        ),
        case!(
            "measure: camera not in the model",
            |t| once(t, "camera_b = \"2\"", "camera_b = \"9\""),
            "camera_b = \"9\""
        ),
    ]
}

/// Each bad study file → one `error:` line with `study.toml:<line>:`, and no output.
#[test]
fn every_study_file_error_names_its_line() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = crate::contract::study::own_project(tmp.path());
    let study = own.join("study.toml");
    let original = std::fs::read_to_string(&study).expect("study");
    let mut failures = Vec::new();
    for (i, c) in cases().iter().enumerate() {
        let text = (c.edit)(&original);
        assert_ne!(text, original, "{}: the edit changed nothing", c.name);
        let line = line_of(&text, c.marker, c.n);
        std::fs::write(&study, &text).expect("write");
        let out = tmp.path().join(format!("out{i}"));
        let (s, o) = (study.display().to_string(), out.display().to_string());
        let mut r = run(["study", s.as_str(), "--out", o.as_str(), "--samples", "4"]);
        // Finished steps' log lines (stderr not a terminal) precede a later step's failure.
        r.stderr = r
            .stderr
            .lines()
            .filter(|l| !l.starts_with("crashrig study: ["))
            .map(|l| format!("{l}\n"))
            .collect();
        let want = format!("study.toml:{line}:");
        let outcome = std::panic::catch_unwind(|| assert_clean_error(&r, &[&want]));
        if outcome.is_err() || out.exists() {
            failures.push(format!(
                "{}: want `{want}` (output left: {}); stderr: {}",
                c.name,
                out.exists(),
                r.stderr.trim()
            ));
        }
    }
    std::fs::write(&study, &original).expect("restore");
    assert!(
        failures.is_empty(),
        "{} of {} study-file errors without their line:\n{}",
        failures.len(),
        cases().len(),
        failures.join("\n")
    );
}
