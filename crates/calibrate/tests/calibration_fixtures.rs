//! Integration tests of the calibration (`crashrig_calibrate::epochs_from_model` + `crashrig-rig`) on the
//! pycolmap-written fixtures in `fixtures/rig/`.
//!
//! Each fixture directory holds a COLMAP model and `expected.json`, the injected per-epoch links
//! and the statistics computed from them directly with numpy (see `fixtures/rig/README.md`).

use approx::assert_abs_diff_eq;
use crashrig_calibrate::Error;
use crashrig_calibrate::{CameraSelector, epochs_from_model, scale_from_points};
use crashrig_colmap::Reconstruction;
use crashrig_geometry::angles::wrap_pi;
use crashrig_rig::{CalibrateOptions, Calibration, calibrate};
use serde_json::Value;
use std::path::PathBuf;

/// The contract's precision for "equal to the values computed from the injected poses".
const MM_TOL: f64 = 1e-6;
const DEG_TOL: f64 = 1e-6;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/rig")
        .join(name)
}

fn expected(name: &str) -> Value {
    let text = std::fs::read_to_string(fixture(name).join("expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn v3(v: &Value) -> [f64; 3] {
    std::array::from_fn(|i| v[i].as_f64().unwrap())
}

fn sel(s: &str) -> CameraSelector {
    CameraSelector::parse(s)
}

fn run(name: &str, mm_per_unit: f64) -> Calibration {
    let model = Reconstruction::read(&fixture(name)).unwrap();
    let set = epochs_from_model(&model, &sel("cam_out/"), &sel("cam_in/")).unwrap();
    calibrate(&set.epochs, mm_per_unit, &CalibrateOptions::default(), None).unwrap()
}

/// Compares the statistics with the numpy values of `expected.json` (angles in degrees).
fn check_stats(s: &crashrig_rig::LinkStatistics, e: &Value) {
    assert_eq!(s.n as u64, e["n"].as_u64().unwrap());
    let b = v3(&e["base_mm"]);
    let bs = v3(&e["base_sigma_mm"]);
    let be = v3(&e["base_sem_mm"]);
    let a = v3(&e["angles_deg"]);
    let as_ = v3(&e["angles_sigma_deg"]);
    let ae = v3(&e["angles_sem_deg"]);
    for k in 0..3 {
        assert_abs_diff_eq!(s.base_mm[k], b[k], epsilon = MM_TOL);
        assert_abs_diff_eq!(s.base_sigma_mm[k], bs[k], epsilon = MM_TOL);
        assert_abs_diff_eq!(s.base_sem_mm[k], be[k], epsilon = MM_TOL);
        // Means compared modulo 360° (numpy wraps to [−180, 180), we to (−180, 180]).
        assert_abs_diff_eq!(
            wrap_pi(s.angles[k] - a[k].to_radians()).to_degrees(),
            0.0,
            epsilon = DEG_TOL
        );
        assert_abs_diff_eq!(s.angles_sigma[k].to_degrees(), as_[k], epsilon = DEG_TOL);
        assert_abs_diff_eq!(s.angles_sem[k].to_degrees(), ae[k], epsilon = DEG_TOL);
    }
    // Covariance: numpy's is in (mm, deg); ours in (mm, rad).
    let c = &e["covariance"];
    for i in 0..6 {
        for j in 0..6 {
            let f = |k: usize| if k < 3 { 1.0 } else { 1f64.to_degrees() };
            let tol = if i < 3 && j < 3 { 1e-6 } else { 1e-7 };
            assert_abs_diff_eq!(
                s.covariance[(i, j)] * f(i) * f(j),
                c[i][j].as_f64().unwrap(),
                epsilon = tol
            );
        }
    }
    // The SO(3) chordal and Karcher means differ by O(σ⁴) here (≪ 1e-6°).
    let m = v3(&e["chordal_mean_angles_deg"]);
    for (k, mk) in m.iter().enumerate() {
        assert_abs_diff_eq!(
            wrap_pi(s.mean_rotation_angles[k] - mk.to_radians()).to_degrees(),
            0.0,
            epsilon = DEG_TOL
        );
    }
}

mod paper {
    use super::*;

    #[test]
    fn paper_nominal_matches_injected_statistics() {
        let e = expected("paper");
        let c = run("paper", e["mm_per_unit"].as_f64().unwrap());
        check_stats(&c.all, &e["stats"]);
        assert_eq!(c.links.len(), 140);
        // Per-epoch links equal the injected ones.
        for (l, ee) in c.links.iter().zip(e["epochs"].as_array().unwrap()) {
            assert_eq!(l.name, ee["name"].as_str().unwrap());
            let b = v3(&ee["base_mm"]);
            let a = v3(&ee["angles_deg"]);
            for k in 0..3 {
                assert_abs_diff_eq!(l.base_mm[k], b[k], epsilon = MM_TOL);
                assert_abs_diff_eq!(
                    wrap_pi(l.angles[k] - a[k].to_radians()).to_degrees(),
                    0.0,
                    epsilon = DEG_TOL
                );
            }
        }
        let flagged: Vec<usize> = e["outliers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(c.outliers.indices(), flagged);
    }

    #[test]
    fn paper_scale_bar_gives_model_scale() {
        let e = expected("paper");
        let model = Reconstruction::read(&fixture("paper")).unwrap();
        let ids = &e["scale_points"];
        let bar = scale_from_points(
            &model,
            ids[0].as_u64().unwrap(),
            ids[1].as_u64().unwrap(),
            e["scale_length_mm"].as_f64().unwrap(),
        )
        .unwrap();
        // The bar was written as f64 coordinates of 2000 mm × 2.7e-3: relative rounding ~1e-15.
        assert_abs_diff_eq!(
            bar.mm_per_unit / e["mm_per_unit"].as_f64().unwrap(),
            1.0,
            epsilon = 1e-12
        );
        let c = run("paper", bar.mm_per_unit);
        check_stats(&c.all, &e["stats"]);
    }

    #[test]
    fn paper_scale_is_linear() {
        // Doubling mm per unit doubles base, σ and SEM and leaves the angles untouched.
        let f = expected("paper")["mm_per_unit"].as_f64().unwrap();
        let one = run("paper", f);
        let two = run("paper", 2.0 * f);
        for k in 0..3 {
            // Products by 2 are exact; the remaining differences are summation rounding.
            assert_abs_diff_eq!(two.all.base_mm[k], 2.0 * one.all.base_mm[k], epsilon = 1e-9);
            assert_abs_diff_eq!(
                two.all.base_sigma_mm[k],
                2.0 * one.all.base_sigma_mm[k],
                epsilon = 1e-9
            );
            assert_abs_diff_eq!(two.all.angles[k], one.all.angles[k], epsilon = 1e-15);
        }
        assert_eq!(two.outliers.indices(), one.outliers.indices());
    }

    #[test]
    fn paper_refinement_agrees_with_epoch_statistics() {
        let e = expected("paper");
        let c = run("paper", e["mm_per_unit"].as_f64().unwrap());
        let r = c.refined.as_ref().unwrap();
        assert_eq!(r.n_unknowns, 846);
        // The constrained link is a weighted mean of the epoch links: within 3 SEM of the
        // plain mean, and its σ is of the order of the SEM (the same data, other weights).
        for k in 0..3 {
            assert_abs_diff_eq!(
                r.base_mm[k],
                c.all.base_mm[k],
                epsilon = 3.0 * c.all.base_sem_mm[k]
            );
            assert_abs_diff_eq!(
                wrap_pi(r.angles[k] - c.all.angles[k]),
                0.0,
                epsilon = 3.0 * c.all.angles_sem[k]
            );
            // The normal-equation σ (epochs as independent) is of the order of σ/√n (the same
            // data, other weights); the reported σ is floored at the uncertainty of the mean.
            let independent = r.tangent_covariance_independent[(k, k)].sqrt();
            let ratio = independent / c.all.base_sem_mm[k];
            assert!((0.5..2.0).contains(&ratio), "base {k}: σ/SEM = {ratio}");
            assert!(r.tangent_covariance[(k, k)] >= c.sem.covariance[(k, k)] * (1.0 - 1e-12));
        }
    }
}

mod wrap {
    use super::*;

    #[test]
    fn wrap_nominal_straddles_180() {
        let e = expected("wrap");
        // Both signs occur in ω and κ: the case is really across the wrap.
        for k in [0, 2] {
            let signs: Vec<bool> = e["epochs"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x["angles_deg"][k].as_f64().unwrap() > 0.0)
                .collect();
            assert!(signs.contains(&true) && signs.contains(&false));
        }
        let c = run("wrap", 1.0);
        check_stats(&c.all, &e["stats"]);
        // Small spread, not tens of degrees.
        assert!(c.all.angles_sigma[0].to_degrees() < 0.1);
        assert!(c.all.angles_sigma[2].to_degrees() < 0.1);
    }
}

mod outliers {
    use super::*;

    #[test]
    fn outliers_injected_are_flagged() {
        let e = expected("outliers");
        let c = run("outliers", 1000.0);
        let injected: Vec<usize> = e["injected_outliers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        let flagged = c.outliers.indices();
        for i in &injected {
            assert!(flagged.contains(i), "epoch {i} not flagged: {flagged:?}");
        }
        let expected_flags: Vec<usize> = e["outliers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(flagged, expected_flags);
        check_stats(&c.all, &e["stats"]);
        check_stats(
            c.without_outliers.as_ref().unwrap(),
            &e["stats_without_outliers"],
        );
    }
}

mod pairing {
    use super::*;

    #[test]
    fn pairing_unpaired_images_are_reported() {
        let e = expected("unpaired");
        let model = Reconstruction::read(&fixture("unpaired")).unwrap();
        let set = epochs_from_model(&model, &sel("cam_out/"), &sel("cam_in/")).unwrap();
        assert_eq!(set.epochs.len(), 8);
        assert_eq!(set.paired_by_name, 8);
        assert_eq!(set.unpaired_a, vec!["cam_out/000100.png".to_string()]);
        assert_eq!(set.unpaired_b, vec!["cam_in/000200.png".to_string()]);
        let c = calibrate(&set.epochs, 1.0, &CalibrateOptions::default(), None).unwrap();
        check_stats(&c.all, &e["stats"]);
    }

    #[test]
    fn pairing_by_camera_id_strips_directory() {
        let model = Reconstruction::read(&fixture("unpaired")).unwrap();
        let set = epochs_from_model(&model, &sel("1"), &sel("2")).unwrap();
        assert_eq!(set.epochs.len(), 8);
        assert_eq!(set.epochs[0].name, "000001.png");
    }

    #[test]
    fn pairing_by_shared_frame_rig_constrained_is_refused() {
        // The shared_frame model was adjusted with a rig constraint: every epoch has the same
        // link, so the epochs are no independent evidence of it (issue 12).
        let model = Reconstruction::read(&fixture("shared_frame")).unwrap();
        let set = epochs_from_model(&model, &sel("1"), &sel("2")).unwrap();
        let r = calibrate(&set.epochs, 1.0, &CalibrateOptions::default(), None);
        assert!(
            matches!(
                r,
                Err(crashrig_rig::Error::RigConstrained { n_epochs: 6, .. })
            ),
            "{r:?}"
        );
    }

    #[test]
    fn pairing_by_shared_frame() {
        let e = expected("shared_frame");
        let model = Reconstruction::read(&fixture("shared_frame")).unwrap();
        let set = epochs_from_model(&model, &sel("1"), &sel("2")).unwrap();
        assert_eq!(set.paired_by_frame, 6);
        assert_eq!(set.paired_by_name, 0);
        let options = CalibrateOptions {
            accept_rig_constrained: true,
            ..CalibrateOptions::default()
        };
        let c = calibrate(&set.epochs, 1.0, &options, None).unwrap();
        // Accepted for inspection: flagged, no autocorrelation analysis of rounding noise.
        assert!(c.rig_constrained);
        assert!(c.drift.is_none());
        assert_eq!(c.sem.rule, crashrig_rig::sem::RULE_IID);
        let b = v3(&e["base_mm"]);
        let a = v3(&e["angles_deg"]);
        for k in 0..3 {
            assert_abs_diff_eq!(c.all.base_mm[k], b[k], epsilon = MM_TOL);
            assert_abs_diff_eq!(
                wrap_pi(c.all.angles[k] - a[k].to_radians()).to_degrees(),
                0.0,
                epsilon = DEG_TOL
            );
            // The pairing recovers the rig's link; its spread is rounding only.
            assert!(c.all.base_sigma_mm[k] < 1e-9);
        }
        assert!(c.outliers.indices().is_empty());
    }
}

mod errors {
    use super::*;

    #[test]
    fn errors_prefix_matching_nothing() {
        let model = Reconstruction::read(&fixture("paper")).unwrap();
        let r = epochs_from_model(&model, &sel("cam_out/"), &sel("cam_inside/"));
        assert!(matches!(r, Err(Error::NoImagesForCamera { role: 'B', .. })));
        let msg = r.unwrap_err().to_string();
        assert!(
            msg.contains("cam_inside/") && msg.contains("paper"),
            "{msg}"
        );
    }

    /// Issue 36: an empty selector would select every image: refused as such; a prefix that
    /// matches nothing names the nearest image-name beginnings.
    #[test]
    fn errors_empty_selector_and_nearest_names() {
        let model = Reconstruction::read(&fixture("paper")).unwrap();
        for blank in ["", " "] {
            let r = epochs_from_model(&model, &sel("cam_out/"), &sel(blank));
            assert!(matches!(r, Err(Error::EmptyCamera { role: 'B' })), "{r:?}");
            let msg = r.unwrap_err().to_string();
            assert!(
                msg.starts_with("camera B is empty (--camera-b / camera_b)"),
                "{msg}"
            );
        }
        let msg = epochs_from_model(&model, &sel("cam_inn/"), &sel("cam_out/"))
            .unwrap_err()
            .to_string();
        assert!(
            msg.ends_with(
                "the model has 280 images; nearest image-name beginnings: `cam_in/` (140 images), \
                 `cam_out/` (140 images))"
            ),
            "{msg}"
        );
    }

    #[test]
    fn errors_one_camera_absent() {
        let model = Reconstruction::read(&fixture("one_camera")).unwrap();
        let r = epochs_from_model(&model, &sel("cam_out/"), &sel("cam_in/"));
        assert!(matches!(r, Err(Error::NoImagesForCamera { role: 'B', .. })));
        let r = epochs_from_model(&model, &sel("1"), &sel("2"));
        assert!(matches!(r, Err(Error::NoImagesForCamera { role: 'B', .. })));
    }

    #[test]
    fn errors_same_camera_twice() {
        let model = Reconstruction::read(&fixture("unpaired")).unwrap();
        let r = epochs_from_model(&model, &sel("cam_"), &sel("cam_in/"));
        assert!(matches!(r, Err(Error::OverlappingCameras { .. })));
    }

    #[test]
    fn errors_nothing_pairs() {
        let model = Reconstruction::read(&fixture("unpaired")).unwrap();
        // Prefix `cam_out/0000` leaves keys like `01.png`, B keys are `000001.png`.
        let r = epochs_from_model(&model, &sel("cam_out/0000"), &sel("cam_in/"));
        assert!(matches!(r, Err(Error::NoEpochs { .. })));
    }

    #[test]
    fn errors_unknown_point_id() {
        let model = Reconstruction::read(&fixture("paper")).unwrap();
        let r = scale_from_points(&model, 1, 999_999, 2000.0);
        assert!(matches!(
            r,
            Err(Error::UnknownPoint {
                point_id: 999_999,
                ..
            })
        ));
    }

    #[test]
    fn errors_zero_length_scale() {
        let e = expected("unpaired");
        let model = Reconstruction::read(&fixture("unpaired")).unwrap();
        let ids = &e["coincident_points"];
        let (p, q) = (ids[0].as_u64().unwrap(), ids[1].as_u64().unwrap());
        let r = scale_from_points(&model, p, q, 2000.0);
        assert!(matches!(r, Err(Error::ZeroLengthScaleBar { .. })));
        for bad in [0.0, -5.0, f64::NAN] {
            let r = scale_from_points(&model, 1, 3, bad);
            assert!(matches!(r, Err(Error::InvalidScaleLength { .. })));
        }
        let ok = &e["scale_points_2000mm"];
        let bar = scale_from_points(
            &model,
            ok[0].as_u64().unwrap(),
            ok[1].as_u64().unwrap(),
            2000.0,
        )
        .unwrap();
        // Points written 2000 model units apart in a mm model: scale 1 up to rounding.
        assert_abs_diff_eq!(bar.mm_per_unit, 1.0, epsilon = 1e-12);
    }
}
