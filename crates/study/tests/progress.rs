//! Progress of `run_study`: the finer reports inside each step (refinement rounds, tie
//! replicates, propagation chunks, grid points) keep the step count within its total, reach it,
//! and change nothing in the result.

use crashrig_study::Study;
use crashrig_study::pipeline::{Options, run_study};
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
