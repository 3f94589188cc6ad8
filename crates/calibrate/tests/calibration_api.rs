//! `crashrig_calibrate`: the typed result, its JSON, text report and plots, on the
//! pycolmap-written fixtures in `fixtures/rig/` (numpy statistics in `expected.json`).

use approx::assert_abs_diff_eq;
use crashrig_calibrate::{CalibrationConfig, Error, ResolvedScale, Scale, calibrate};
use serde_json::Value;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/rig")
        .join(name)
}

fn config(name: &str, scale: Scale) -> CalibrationConfig {
    CalibrationConfig {
        model: fixture(name),
        camera_a: "cam_out/".into(),
        camera_b: "cam_in/".into(),
        scale,
        ..CalibrationConfig::default()
    }
}

fn paper() -> crashrig_calibrate::CalibrationResult {
    calibrate(
        &config(
            "paper",
            Scale::ScaleBar {
                points: [1, 2],
                length_mm: 2000.0,
            },
        ),
        None,
    )
    .unwrap()
}

#[test]
fn calibration_json_nominal_has_contract_fields() {
    let r = paper();
    let j = r.to_json();
    let text = std::fs::read_to_string(fixture("paper").join("expected.json")).unwrap();
    let e: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(j["n_epochs"], 140);
    assert_eq!(r.n_epochs, 140);
    let s = &e["stats"];
    for key in [
        "base_mm",
        "base_sigma_mm",
        "base_sem_mm",
        "angles_sigma_deg",
        "angles_sem_deg",
    ] {
        for k in 0..3 {
            // The contract's 1e-6 mm / 1e-6° against numpy on the injected links.
            assert_abs_diff_eq!(
                j[key][k].as_f64().unwrap(),
                s[key][k].as_f64().unwrap(),
                epsilon = 1e-6
            );
        }
    }
    for i in 0..6 {
        for k in 0..6 {
            assert_abs_diff_eq!(
                j["covariance"][i][k].as_f64().unwrap(),
                s["covariance"][i][k].as_f64().unwrap(),
                epsilon = 1e-6
            );
        }
    }
    assert!(matches!(r.scale, ResolvedScale::Bar(_)));
    assert_eq!(j["epochs"].as_array().unwrap().len(), 140);
    // The per-sequence rule flags none of the paper's clean epochs (numpy agrees: []).
    assert_eq!(j["n_outliers"], 0);
    assert_eq!(j["refined"]["n_unknowns"], 846);
    assert!(j["autocorrelation"]["lags"][0].is_array());
    // The typed values are what the JSON prints: covariance_tangent (deg) from the
    // epoch covariance (rad), sem from the link.
    let d = |k: usize| if k < 3 { 1.0 } else { 1f64.to_degrees() };
    for a in 0..6 {
        for b in 0..6 {
            assert_eq!(
                j["covariance_tangent"][a][b].as_f64().unwrap(),
                r.epoch_covariance[(a, b)] * d(a) * d(b)
            );
            assert_eq!(
                j["sem_covariance_tangent"][a][b].as_f64().unwrap(),
                r.link.covariance[(a, b)] * d(a) * d(b)
            );
        }
    }
    assert_eq!(j["sem_rule"], r.sem_rule.as_str());
    // The mean link is the statistics' mean base and Karcher rotation (1e-9: two Karcher
    // runs with different stopping tolerances, both far below).
    for k in 0..3 {
        assert_abs_diff_eq!(
            j["link"]["base_mm"][k].as_f64().unwrap(),
            j["base_mm"][k].as_f64().unwrap(),
            epsilon = 1e-9
        );
        assert_abs_diff_eq!(
            j["link"]["angles_deg"][k].as_f64().unwrap(),
            j["mean_rotation_angles_deg"][k].as_f64().unwrap(),
            epsilon = 1e-9
        );
    }
}

#[test]
fn calibration_refined_never_below_the_sem() {
    let r = paper();
    let refined = r.calibration.refined.as_ref().unwrap();
    for k in 0..6 {
        assert!(
            refined.tangent_covariance[(k, k)] >= r.link.covariance[(k, k)] * (1.0 - 1e-12),
            "axis {k}"
        );
    }
    let j = r.to_json();
    assert!(
        j["refined"]["what"]
            .as_str()
            .unwrap()
            .contains("not independent")
    );
}

#[test]
fn calibration_text_nominal_shows_tables() {
    let t = paper().text_report();
    for needle in [
        "Table 1",
        "Table 2",
        "179.9200",
        "61.980",
        "refined",
        "SE of the mean",
        "not independent evidence",
    ] {
        assert!(t.contains(needle), "{needle} missing:\n{t}");
    }
}

#[test]
fn calibration_plots_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let r = calibrate(&config("wrap", Scale::MmPerUnit(1.0)), None).unwrap();
    r.write_plots(dir.path()).unwrap();
    for p in ["x", "y", "z", "omega", "phi", "kappa"] {
        for kind in ["series", "hist", "acf"] {
            for ext in ["png", "svg"] {
                let f = dir.path().join(format!("{kind}_{p}.{ext}"));
                assert!(
                    std::fs::metadata(&f).unwrap().len() > 1000,
                    "{}",
                    f.display()
                );
            }
        }
    }
    // Exactly the 36 plots: no temporary or staging file left behind, in it or beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 36);
    let parent = dir.path().parent().unwrap();
    let stem = dir
        .path()
        .file_name()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    assert!(std::fs::read_dir(parent).unwrap().flatten().all(|e| {
        !e.file_name()
            .to_string_lossy()
            .contains(&format!(".{stem}.crashrig-staging"))
    }));
    // An earlier run's plots are replaced as a whole; a directory holding anything else is
    // refused and left exactly as it was.
    r.write_plots(dir.path()).unwrap();
    std::fs::write(dir.path().join("notes.txt"), b"mine").unwrap();
    let e = r.write_plots(dir.path()).unwrap_err();
    assert!(e.to_string().contains("notes.txt"), "{e}");
    assert_eq!(
        std::fs::read(dir.path().join("notes.txt")).unwrap(),
        b"mine"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 37);
}

#[test]
fn calibration_rig_constrained_is_refused_with_advice() {
    let mut c = config("shared_frame", Scale::Default);
    c.camera_a = "1".into();
    c.camera_b = "2".into();
    let e = calibrate(&c, None).unwrap_err();
    assert!(matches!(e, Error::RigConstrained { n_epochs: 6, .. }));
    let msg = e.to_string();
    for needle in [
        "shared_frame",
        "rig constraint",
        "without rig constraints",
        "rig_configurator",
        "--accept-rig-constrained",
    ] {
        assert!(msg.contains(needle), "{needle}: {msg}");
    }
    c.accept_rig_constrained = true;
    let r = calibrate(&c, None).unwrap();
    assert!(r.calibration.rig_constrained);
    assert!(r.warnings.iter().any(|w| w.contains("rig-constrained")));
    assert_eq!(r.to_json()["rig_constrained"], true);
}

#[test]
fn calibration_bad_scale_names_the_model() {
    let e = calibrate(&config("paper", Scale::MmPerUnit(-1.0)), None).unwrap_err();
    assert!(e.to_string().contains("paper"), "{e}");
    let e = calibrate(
        &config(
            "paper",
            Scale::ScaleBar {
                points: [1, 2],
                length_mm: 0.0,
            },
        ),
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("--scale-length-mm"), "{e}");
}

/// Cancels at once.
struct Stop;

impl crashrig_stats::progress::Monitor for Stop {
    fn report(&self, _: usize, _: usize) {}
    fn cancelled(&self) -> bool {
        true
    }
}

/// A cancelled calibration is `Error::Cancelled`, not a skipped refinement.
#[test]
fn calibration_cancelled_returns_cancelled() {
    let c = config(
        "paper",
        Scale::ScaleBar {
            points: [1, 2],
            length_mm: 2000.0,
        },
    );
    let e = calibrate(&c, Some(&Stop)).unwrap_err();
    assert!(matches!(e, Error::Cancelled(_)), "{e}");
}
