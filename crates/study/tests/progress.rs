//! Progress of `run_study`: the finer reports inside each step (refinement rounds, tie
//! replicates, propagation chunks, grid points) keep the step count within its total, reach it,
//! and change nothing in the result.

use crashrig_study::Study;
use crashrig_study::{Options, run_study};
use std::path::Path;
use std::sync::Mutex;

#[test]
fn study_progress_stays_within_totals_and_changes_nothing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
    let study = Study::from_path(&path).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let seen: Mutex<Vec<(String, u64, u64)>> = Mutex::new(Vec::new());
    let report = |stage: &str, d: u64, t: u64| seen.lock().unwrap().push((stage.to_string(), d, t));
    let with = run_study(
        &study,
        &Options {
            progress: Some(&report),
            ..options
        },
    )
    .expect("study with progress");
    let without = run_study(&study, &options).expect("study");
    assert_eq!(with.to_json(), without.to_json());
    let seen = seen.into_inner().unwrap();
    let total = seen[0].2;
    assert!(
        seen.iter().all(|(_, d, t)| *t == total && d <= t),
        "{seen:?}"
    );
    assert_eq!(seen.iter().map(|r| r.1).max(), Some(total));
    for stage in [
        "calibration ",
        "tie replicates + jackknife ",
        "propagation chunks ",
        ": points ",
    ] {
        assert!(
            seen.iter().any(|(s, _, _)| s.contains(stage)),
            "no report of {stage:?}: {seen:?}"
        );
    }
}

/// A step that fails carries its library's typed error as the source of `Error::Step`, and
/// the one-line message is the study file's line and section, then the library's message.
#[test]
fn study_step_error_has_a_typed_source() {
    use crashrig_calibrate::Error as CalibrationError;
    use crashrig_study::Error;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    // `camera_a` of [calibration] (line 8) matches no image of the model.
    let text = text.replacen("camera_a = \"cam_out/\"", "camera_a = \"nowhere/\"", 1);
    let study = Study::from_toml_str(&text, &path).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let e = run_study(&study, &options).unwrap_err();
    let Error::Step {
        line, key, source, ..
    } = &e
    else {
        panic!("not a step error: {e}");
    };
    assert_eq!((*line, key.as_str()), (Some(8), "calibration"));
    assert!(
        matches!(
            **source,
            Error::Calibration(CalibrationError::NoImagesForCamera { role: 'A', .. })
        ),
        "{source:?}"
    );
    // The step's own context, then its source's message (the chain the CLI prints).
    let prefix = format!("{}:8: [calibration]", path.display());
    assert_eq!(e.to_string(), prefix);
    let line = crashrig_input::message::error_line(&e);
    assert_eq!(
        line,
        format!(
            "{prefix}: {}",
            crashrig_input::message::error_line(&**source)
        )
    );
    assert!(
        line.contains("camera A `nowhere/` matches no image"),
        "{line}"
    );
}
