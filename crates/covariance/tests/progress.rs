//! `crashrig_covariance::run` with a [`Monitor`]: one report per phase, monotone and ending at
//! [`PHASES`]; a monitor that cancels stops the call with [`Error::Cancelled`]; the result is
//! the same with and without a monitor.

use crashrig_covariance::{CovarianceConfig, Error, Intrinsics, PHASES, Scale, run};
use crashrig_stats::progress::Recorder;
use std::path::PathBuf;

fn config() -> CovarianceConfig {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/covariance/mc");
    CovarianceConfig {
        model: dir.join("model"),
        camera_a: "cam_out/".into(),
        control_points: dir.join("control_points.csv"),
        scale: Scale::MmPerUnit(1000.0),
        pixel_sigma_px: None,
        intrinsics: Intrinsics::All,
    }
}

#[test]
fn one_report_per_phase_and_the_same_result() {
    let m = Recorder::new();
    let with = run(&config(), Some(&m)).unwrap();
    let without = run(&config(), None).unwrap();
    assert_eq!(with, without);
    let seen = m.seen();
    let want: Vec<(usize, usize)> = (1..=PHASES).map(|d| (d, PHASES)).collect();
    assert_eq!(seen, want);
}

#[test]
fn a_monitor_that_cancels_stops_between_phases() {
    // Cancelled after phase k: the call stops before phase k + 1 (the last phase has no
    // check after it: the result is complete then).
    for k in 1..PHASES {
        let m = Recorder::cancelling_after(k);
        let e = run(&config(), Some(&m)).unwrap_err();
        assert!(matches!(e, Error::Cancelled(_)), "after {k}: {e}");
        assert_eq!(m.seen().len(), k);
    }
}
