//! The study file's reader: every section read, every error named with its file, line and key.

use super::*;
use crashrig_geometry::Vec3;

fn own() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml")
}

fn text() -> String {
    std::fs::read_to_string(own()).unwrap()
}

/// Parses `t` as if it were the own project's study file (same folder, so paths resolve).
fn parse(t: &str) -> Result<Study, Error> {
    Study::from_toml_str(t, &own())
}

fn message(t: &str) -> String {
    parse(t).unwrap_err().to_string()
}

#[test]
fn own_project_study_file_reads() {
    let s = Study::from_path(&own()).unwrap();
    assert_eq!(s.seed, 11);
    assert_eq!(s.samples, 300);
    assert_eq!(s.layouts.len(), 3);
    assert!(s.calibration.model.is_dir());
    assert_eq!(s.tie.as_ref().unwrap().iterations, 60);
    assert_eq!(
        s.layouts[0].observers[1].noise,
        ObserverNoise::From(ChainCamera::Tie)
    );
    // σ keys → diagonal covariance (mm², rad²).
    let c = s.outward.covariance;
    assert!((c[(2, 2)] - 1.44).abs() < 1e-15);
    assert!((c[(5, 5)] - 0.012_f64.to_radians().powi(2)).abs() < 1e-20);
    // covariance_tangent is taken in mm and deg and kept with its off-diagonal term.
    let ObserverNoise::Given(g) = &s.layouts[1].observers[1].noise else {
        panic!()
    };
    assert!((g[(0, 1)] - 0.2).abs() < 1e-15);
    assert!((g[(3, 3)] - 1e-4 * (std::f64::consts::PI / 180.0).powi(2)).abs() < 1e-20);
}

/// The fixed layout's observers: `look_at_mm` aims the optical axis (third column of
/// `R_vehicle_from_cam`) at the target; `camera_from` takes camera 1 of the tie model; the
/// `[measure]` section resolves its paths against the study file.
#[test]
fn own_project_fixed_layout_and_measure_read() {
    let s = Study::from_path(&own()).unwrap();
    let l = &s.layouts[2];
    let rear = l.observers[0].fixed.as_ref().expect("fixed");
    let axis = rear.rotation.column(2).into_owned();
    let want = (Vec3::new(1100.0, 0.0, 0.0) - l.observers[0].position_mm).normalize();
    assert!((axis - want).norm() < 1e-12, "{axis:?}");
    assert_eq!((rear.lens.width, rear.lens.height), (1920, 1200));
    assert_eq!(rear.lens.params[0], 1400.0);
    assert_eq!(rear.pixel_sigma_px, 0.5);
    assert!(s.layouts[0].observers.iter().all(|o| o.fixed.is_none()));
    let m = s.measure.as_ref().expect("[measure]");
    assert!(m.model.is_dir() && m.observations.is_file());
    assert_eq!(m.camera_c.as_deref(), Some("3"));
    assert_eq!(m.frame_rate_hz, Some(1000.0));
    assert_eq!(
        m.a_noise,
        MeasureANoise::Sigmas(Vec3::repeat(0.3), Vec3::repeat(0.004))
    );
}

#[test]
fn missing_section_names_file_and_section() {
    let t = text().replace("[calibration]", "[calibrationx]");
    let m = message(&t);
    assert!(m.contains("study.toml"), "{m}");
    assert!(m.contains("calibrationx"), "{m}");
    let cut = text();
    let i = cut.find("[outward]").unwrap();
    let j = cut.find("[[layout]]").unwrap();
    let t = format!("{}{}", &cut[..i], &cut[j..]);
    let m = message(&t);
    assert!(
        m.contains("study.toml") && m.contains("[outward]") && m.contains("missing section"),
        "{m}"
    );
}

/// Issue 36: an empty selector would make every image camera A (or B, C); an empty image
/// name finds nothing. Each is refused naming its key and line.
#[test]
fn empty_selectors_name_their_key_and_line() {
    let t = text();
    let lines: Vec<&str> = t.lines().collect();
    for (from, key) in [
        ("camera_a = \"cam_out/\"", "calibration.camera_a"),
        ("camera_b = \"cam_in/\"", "calibration.camera_b"),
        ("image_a = \"in/0001.png\"", "tie.image_a"),
        ("image_b = \"side/0001.png\"", "tie.image_b"),
        ("camera_b = \"2\"", "measure.camera_b"),
        ("camera_c = \"3\"", "measure.camera_c"),
    ] {
        let at = lines.iter().position(|l| *l == from).expect(from);
        let mut edited = lines.clone();
        let blank = format!("{} = \" \"", from.split(' ').next().unwrap());
        edited[at] = &blank;
        let m = message(&edited.join("\n"));
        assert!(
            m.contains(&format!(
                "study.toml:{}: `{key}`: must not be empty",
                at + 1
            )),
            "{m}"
        );
    }
    // [measure] camera_a is the second `camera_a = "cam_out/"`.
    let at = lines
        .iter()
        .rposition(|l| *l == "camera_a = \"cam_out/\"")
        .unwrap();
    let mut edited = lines.clone();
    edited[at] = "camera_a = \"\"";
    let m = message(&edited.join("\n"));
    assert!(
        m.contains(&format!(
            "study.toml:{}: `measure.camera_a`: must not be empty",
            at + 1
        )),
        "{m}"
    );
}

#[test]
fn missing_path_names_key_and_line() {
    let t = text().replace("model = \"calibration\"", "model = \"no/such/model\"");
    let line = t.lines().position(|l| l.contains("no/such/model")).unwrap() + 1;
    let m = message(&t);
    assert!(
        m.contains(&format!("study.toml:{line}: `calibration.model`")),
        "{m}"
    );
    assert!(m.contains("does not exist"), "{m}");
    let t = text().replace("tie/database.db", "tie/nothing.db");
    let m = message(&t);
    assert!(
        m.contains("`tie.database`") && m.contains("nothing.db"),
        "{m}"
    );
}

#[test]
fn bad_values_name_their_keys() {
    let m = message(&text().replace("from = \"tie\"", "from = \"door\""));
    assert!(m.contains("`layout[0].observer[1].from`"), "{m}");
    let m = message(&text().replace(
        "[0.0, 0.0, 0.0, 1.0e-4, 0.0, 0.0]",
        "[0.0, 0.0, 0.0, 1.0e-4, 0.5, 0.0]",
    ));
    assert!(
        m.contains("`layout[1].observer[1].covariance_tangent`") && m.contains("symmetric"),
        "{m}"
    );
    let m = message(&text().replace("threshold_mm = 3.0", "threshold_mm = -3.0"));
    assert!(m.contains("`layout[0].threshold_mm`"), "{m}");
    let m = message(&text().replace("samples = 300", "samples = 300\nsmaples = 3"));
    assert!(m.contains("study.toml:") && m.contains("smaples"), "{m}");
    let m = message(&text().replace("method = \"absolute\"", "method = \"magic\""));
    assert!(m.contains("`tie.method`"), "{m}");
}

/// `[measure]`'s kinematics keys: read into the section, and every bad value is one error
/// naming the key and its line.
#[test]
fn measure_kinematics_keys_and_their_errors() {
    use crashrig_measure::filter::{CfcSpec, Standard};
    let with = |keys: &str| {
        // `pixel_sigma_px = 0.3` is [measure]'s alone (the fixed cameras have 0.5).
        text().replace(
            "pixel_sigma_px = 0.3\n",
            &format!("pixel_sigma_px = 0.3\n{keys}\n"),
        )
    };
    let t = with("cfc = 180\ncfc_standard = \"iso6487\"\nsync_sigma_ms = 0.5");
    let m = parse(&t).unwrap().measure.unwrap();
    assert_eq!(
        m.cfc,
        Some(CfcSpec {
            class: 180,
            standard: Standard::Iso6487
        })
    );
    assert_eq!(m.sync_sigma_ms, 0.5);
    let m = parse(&text()).unwrap().measure.unwrap();
    assert_eq!((m.cfc, m.sync_sigma_ms), (None, 0.0));
    for (keys, key, needle) in [
        ("cfc = 100", "cfc", "100 is not a channel frequency class"),
        ("cfc = -60", "cfc", "-60 is not a channel frequency class"),
        (
            "cfc = 1000",
            "cfc",
            "CFC 1000 is too high for 1000 frames/s",
        ),
        (
            "cfc = 60\ncfc_standard = \"sae\"",
            "cfc_standard",
            "`sae` is not a filter standard",
        ),
        (
            "cfc_standard = \"j211\"",
            "cfc_standard",
            "needs measure.cfc",
        ),
        (
            "sync_sigma_ms = -1.0",
            "sync_sigma_ms",
            "from 0 to 1000 (ms)",
        ),
        (
            "sync_sigma_ms = 2000.0",
            "sync_sigma_ms",
            "from 0 to 1000 (ms)",
        ),
    ] {
        let t = with(keys);
        let last = keys.lines().last().unwrap();
        let line = t.rfind(last).map(|i| t[..i].lines().count() + 1).unwrap();
        let m = message(&t);
        assert!(
            m.contains(&format!("study.toml:{line}: `measure.{key}`")) && m.contains(needle),
            "{keys}: {m}"
        );
    }
    // Without a frame rate the filter and the offset have no time base.
    let t = with("cfc = 60").replace("frame_rate_hz = 1000.0\n", "");
    let m = message(&t);
    assert!(
        m.contains("`measure.cfc`") && m.contains("frame_rate_hz"),
        "{m}"
    );
    let t = with("sync_sigma_ms = 1.0").replace("frame_rate_hz = 1000.0\n", "");
    let m = message(&t);
    assert!(
        m.contains("`measure.sync_sigma_ms`") && m.contains("frame_rate_hz"),
        "{m}"
    );
}

#[test]
fn one_observer_is_an_error() {
    let t = text();
    let i = t
        .find("[[layout.observer]]\nname = \"side (tie)\"")
        .unwrap();
    let j = t[i..].find("\n[[layout]]").unwrap() + i;
    let m = message(&format!("{}{}", &t[..i], &t[j..]));
    assert!(
        m.contains("`layout[0].observer`") && m.contains("at least two"),
        "{m}"
    );
}

/// The 1-based line of the first line of `t` that starts with `start`.
fn line_starting(t: &str, start: &str) -> usize {
    t.lines()
        .position(|l| l.starts_with(start))
        .expect("the line")
        + 1
}

/// A misspelled section is an unknown section with the nearest known name, at its header's
/// line (serde alone calls it an "unknown field").
#[test]
fn misspelled_section_is_an_unknown_section_with_the_nearest_name() {
    let t = text().replace("[calibration]", "[calibraton]");
    let m = message(&t);
    let line = line_starting(&t, "[calibraton]");
    assert!(
        m.contains(&format!("study.toml:{line}: `calibraton`")),
        "{m}"
    );
    assert!(
        m.contains("unknown section; did you mean [calibration]?"),
        "{m}"
    );
    assert!(!m.contains("unknown field"), "{m}");
    let t = text().replace("[outward]", "[outwrad]");
    let m = message(&t);
    assert!(m.contains("did you mean [outward]?"), "{m}");
    assert!(
        m.contains(&format!(":{}:", line_starting(&t, "[outwrad]"))),
        "{m}"
    );
    // An array of tables too.
    let t = format!("{}\n[[layuots]]\nname = \"x\"\n", text());
    let m = message(&t);
    assert!(
        m.contains("`layuots`: unknown section; did you mean [[layout]]?"),
        "{m}"
    );
    assert!(
        m.contains(&format!(":{}:", line_starting(&t, "[[layuots]]"))),
        "{m}"
    );
    // A misspelled key stays an unknown field.
    let m = message(&text().replace("samples = 300", "sampels = 300"));
    assert!(m.contains("unknown field") && m.contains("sampels"), "{m}");
}

/// `required with …` points at the key that is there, not at the section.
#[test]
fn a_lone_partner_key_points_at_its_own_line() {
    let t = text().replace("scale_length_mm = 1500.0\n", "");
    let m = message(&t);
    let line = line_starting(&t, "scale_points");
    assert!(
        m.contains(&format!(
            ":{line}: `calibration.scale_length_mm`: required with scale_points"
        )),
        "{m}"
    );
}

/// Runs the study of `t` without sensitivity; returns the error's message and the steps
/// the progress callback saw.
fn run_error(t: &str) -> (String, Vec<String>) {
    let study = parse(t).expect("the study file reads");
    let steps = std::sync::Mutex::new(Vec::new());
    let cb = |stage: &str, _: u64, _: u64| steps.lock().unwrap().push(stage.to_string());
    let options = crate::Options {
        no_sensitivity: true,
        samples: Some(4),
        progress: Some(&cb),
        ..Default::default()
    };
    let e = crate::run_study(&study, &options).expect_err("the study fails");
    // The one line the CLI prints: the error's own context, then its sources.
    (
        crashrig_input::message::error_line(&e),
        steps.into_inner().unwrap(),
    )
}

/// A calibration camera that matches no image is reported at the key's line, not at
/// `[calibration]`'s.
#[test]
fn a_wrong_calibration_camera_points_at_its_key_line() {
    let t = text().replace("camera_b = \"cam_in/\"", "camera_b = \"cam_ni/\"");
    let (m, _) = run_error(&t);
    let line = line_starting(&t, "camera_b = \"cam_ni/\"");
    assert!(
        m.contains(&format!("study.toml:{line}: [calibration]")),
        "{m}"
    );
    assert!(m.contains("camera B `cam_ni/` matches no image"), "{m}");
    assert!(m.contains("`cam_in/`"), "the nearest name: {m}");
}

/// A camera prefix without its trailing slash selects the images but pairs none: the error
/// gets the hint and points at that key's line.
#[test]
fn a_camera_prefix_without_its_slash_gets_a_hint() {
    let t = text().replace(
        "camera_a = \"cam_out/\"\ncamera_b",
        "camera_a = \"cam_out\"\ncamera_b",
    );
    let (m, _) = run_error(&t);
    let line = line_starting(&t, "camera_a = \"cam_out\"");
    assert!(
        m.contains(&format!("study.toml:{line}: [calibration]")),
        "{m}"
    );
    assert!(m.contains("no epoch pairs camera A and B"), "{m}");
    assert!(
        m.contains("hint: `cam_out` is a directory of the image names: write `cam_out/`"),
        "{m}"
    );
}

/// A wrong `[measure]` camera is reported before any step runs (no calibration, no layout),
/// at the key's line.
#[test]
fn a_wrong_measure_camera_is_reported_before_any_work() {
    let t = text().replace("camera_b = \"2\"", "camera_b = \"27\"");
    let (m, steps) = run_error(&t);
    let line = line_starting(&t, "camera_b = \"27\"");
    assert!(m.contains(&format!("study.toml:{line}: [measure]")), "{m}");
    assert!(m.contains("camera B (27)"), "{m}");
    assert!(steps.is_empty(), "no step ran before the error: {steps:?}");
}

/// `[measure]`'s defaults and rules are `crashrig measure`'s ([`crashrig_measure::MeasureOptions`]),
/// and their errors keep the study file's words, line and key.
#[test]
fn measure_defaults_and_rules_are_the_commands() {
    use crashrig_measure::MeasureOptions;
    let t = text()
        .replace("pixel_sigma_px = 0.3\n", "")
        .replace("threshold_mm = 3.0\n", "");
    let m = parse(&t).unwrap().measure.unwrap();
    assert_eq!((m.pixel_sigma_px, m.threshold_mm), (0.5, 5.0));
    let defaults = MeasureOptions::new("m", "a/", "b", "link.json", "obs.csv");
    assert_eq!(
        (m.pixel_sigma_px, m.threshold_mm),
        (defaults.pixel_sigma_px, defaults.threshold_mm)
    );
    let ends = |t: &str, start: &str, tail: &str| {
        let m = message(t);
        let line = line_starting(t, start);
        assert!(m.ends_with(&format!("study.toml:{line}: {tail}")), "{m}");
    };
    for bad in ["-0.1", "nan", "inf"] {
        let t = text().replace(
            "pixel_sigma_px = 0.3\n",
            &format!("pixel_sigma_px = {bad}\n"),
        );
        // The problem is the rule's own words, the line and key the study file's.
        let problem = crashrig_measure::rules::pixel_sigma_px(bad.parse().unwrap()).unwrap_err();
        ends(
            &t,
            &format!("pixel_sigma_px = {bad}"),
            &format!("`measure.pixel_sigma_px`: {problem}"),
        );
    }
    let t = text().replace(
        "pixel_sigma_px = 0.3\n",
        "pixel_sigma_px = 0.3\na_covariance = \"no/such.json\"\n",
    );
    ends(
        &t,
        "a_covariance = ",
        "`measure.a_covariance`: give either a_covariance or sigma_a_position_mm / sigma_a_angles_deg, not both",
    );
}

/// `[measure] pixel_sigma_px = "estimate"` is `--pixel-sigma-px estimate`; any other word is an
/// error at its line.
#[test]
fn measure_pixel_sigma_estimate_reads() {
    use crashrig_measure::pixel_check::PixelSigmaFrom;
    let m = parse(&text()).unwrap().measure.unwrap();
    assert_eq!(
        (m.pixel_sigma_px, m.pixel_sigma_from),
        (0.3, PixelSigmaFrom::Stated)
    );
    let t = text().replace("pixel_sigma_px = 0.3\n", "pixel_sigma_px = \"estimate\"\n");
    let m = parse(&t).unwrap().measure.unwrap();
    assert_eq!(m.pixel_sigma_from, PixelSigmaFrom::Estimate);
    assert_eq!(
        m.pixel_sigma_px,
        crashrig_measure::rules::DEFAULT_PIXEL_SIGMA_PX
    );
    let t = text().replace("pixel_sigma_px = 0.3\n", "pixel_sigma_px = 1\n");
    assert_eq!(parse(&t).unwrap().measure.unwrap().pixel_sigma_px, 1.0);
    let t = text().replace("pixel_sigma_px = 0.3\n", "pixel_sigma_px = \"guess\"\n");
    let m = message(&t);
    let line = line_starting(&t, "pixel_sigma_px = \"guess\"");
    assert!(
        m.ends_with(&format!(
            "study.toml:{line}: `measure.pixel_sigma_px`: must be a number (px) or \"estimate\", got \"guess\""
        )),
        "{m}"
    );
}

/// `[measure] frame_times` (read with the study file): the time axis and the frame rate of its
/// mean interval; with `frame_rate_hz` too, an error at its line; a file whose times do not
/// increase, an error naming the file's line.
#[test]
fn measure_frame_times_key_reads() {
    let tmp = tempfile::tempdir().unwrap();
    let times = tmp.path().join("frames.csv");
    std::fs::write(&times, "epoch,time_s\nf0,0.0\nf1,0.002\nf2,0.004\n").unwrap();
    let key = format!("frame_times = \"{}\"\n", times.display());
    let t = text().replace("frame_rate_hz = 1000.0\n", &key);
    let m = parse(&t).unwrap().measure.unwrap();
    let ft = m.frame_times.expect("read");
    assert_eq!(ft.frames.len(), 3);
    assert!((m.frame_rate_hz.unwrap() - 500.0).abs() < 1e-9);
    let both = text().replace(
        "frame_rate_hz = 1000.0\n",
        &format!("frame_rate_hz = 1000.0\n{key}"),
    );
    let line = line_starting(&both, "frame_times =");
    let e = message(&both);
    assert!(
        e.contains(&format!("study.toml:{line}: `measure.frame_times`"))
            && e.contains("excludes measure.frame_rate_hz"),
        "{e}"
    );
    std::fs::write(&times, "epoch,time_s\nf0,0.0\nf1,0.0\n").unwrap();
    let e = message(&t);
    assert!(
        e.contains("`measure.frame_times`") && e.contains("frames.csv:3"),
        "{e}"
    );
}
