//! Camera A's poses drawn jointly from a joint covariance (`"joint"` of a `crashrig
//! covariance` result): the marginals and the between-epoch covariance of the draws, and a
//! displacement σ that depends on the correlation, against their first-order values.

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Mat3, Mat6, Rigid3, UncertainPose, Vec3, so3};
use crashrig_measure::engine::{Epoch, Measurement, Rig, Settings, measure};
use crashrig_measure::input::{self, Inward, JointA, Observation};
use crashrig_measure::{ANoise, MeasureConfig};
use nalgebra::{DMatrix, Vector2};
use std::path::{Path, PathBuf};

/// The marker in A's frame (mm): B coincides with A, C is 500 mm to its right.
const MARKER_A: [f64; 3] = [250.0, 0.0, 2000.0];
const EPOCHS: usize = 3;
/// Correlation of A's error between epochs i and j: RHO^|i−j| (an AR(1) sequence).
const RHO: f64 = 0.8;

/// A's per-epoch covariance (mm, rad): 0.5, 0.4, 0.3 mm; 0.01°, 0.02°, 0.015° (the rotation
/// reaches the marker 2 m away as ~0.35–0.7 mm).
fn sigma_epoch() -> Mat6 {
    let r = 1.0_f64.to_radians();
    Mat6::from_diagonal(&nalgebra::Vector6::new(
        0.25,
        0.16,
        0.09,
        (0.01 * r).powi(2),
        (0.02 * r).powi(2),
        (0.015 * r).powi(2),
    ))
}

fn joint_covariance_deg() -> DMatrix<f64> {
    let s = sigma_epoch();
    let deg = 1.0_f64.to_degrees();
    let u = |k: usize| if k % 6 >= 3 { deg } else { 1.0 };
    DMatrix::from_fn(6 * EPOCHS, 6 * EPOCHS, |a, b| {
        let (i, j) = (a / 6, b / 6);
        RHO.powi((i as i32 - j as i32).abs()) * s[(a % 6, b % 6)] * u(a) * u(b)
    })
}

fn pinhole() -> Camera {
    Camera::new(
        ModelId::Pinhole,
        1000,
        1000,
        vec![1000.0, 1000.0, 500.0, 500.0],
    )
    .unwrap()
}

/// Everything certain except A (and no pixel noise): the marker's world position is exactly
/// `C_A + R_A·X_A`, so its spread is A's pose error carried over the 2 m lever.
fn scene() -> (Vec<Epoch>, Rig, Vec<Observation>) {
    let rig = Rig {
        a_from_b: UncertainPose::certain(Rigid3::identity()),
        camera_b: pinhole(),
        c: Some((
            UncertainPose::certain(Rigid3::translation(500.0, 0.0, 0.0)),
            pinhole(),
        )),
    };
    let epochs: Vec<Epoch> = (0..EPOCHS)
        .map(|i| Epoch {
            key: format!("{i:04}.png"),
            name: format!("{i:04}"),
            world_from_a: UncertainPose::new(Rigid3::identity(), sigma_epoch()).unwrap(),
        })
        .collect();
    let x = Vec3::from(MARKER_A);
    let mut obs = Vec::new();
    for e in &epochs {
        for (camera, cx) in [(Inward::B, 0.0), (Inward::C, 500.0)] {
            let u = 500.0 + 1000.0 * (x.x - cx) / x.z;
            obs.push(Observation {
                epoch: e.name.clone(),
                camera,
                marker: "head".into(),
                pixel: Vector2::new(u, 500.0),
                sigma: None,
                line: 2 + obs.len() as u64,
            });
        }
    }
    (epochs, rig, obs)
}

fn settings(samples: usize) -> Settings {
    Settings {
        samples,
        seed: 11,
        pixel_sigma_px: 0.0,
        reference_epoch: None,
        frame_rate_hz: None,
        frame_times: None,
        threshold_mm: 5.0,
        max_reprojection_px: None,
        cfc: None,
        sync_sigma_ms: 0.0,
    }
}

/// First order: `δX = δC − R̄·[X_A]×·δθ` with R̄ = I.
fn jacobian() -> nalgebra::Matrix3x6<f64> {
    let mut j = nalgebra::Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
    j.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-so3::hat(&Vec3::from(MARKER_A))));
    j
}

/// Checks every σ of `got` against `want` (per axis) within 4 standard errors of a sample σ
/// from `n` draws of a Gaussian (σ/√(2(n−1))).
fn assert_sigma(got: Vec3, want: Vec3, n: usize, what: &str) {
    for k in 0..3 {
        let se = want[k] / (2.0 * (n as f64 - 1.0)).sqrt();
        assert!(
            (got[k] - want[k]).abs() < 4.0 * se,
            "{what} axis {k}: {} vs {} ± {se}",
            got[k],
            want[k]
        );
    }
}

fn row(m: &Measurement, epoch: usize) -> &crashrig_measure::Row {
    m.rows.iter().find(|r| r.epoch == epoch).unwrap()
}

#[test]
fn joint_draws_give_the_marginals_and_the_correlated_displacement() {
    let (epochs, rig, obs) = scene();
    let n = 20_000;
    let joint = JointA::from_deg(
        Path::new("joint.json"),
        epochs.iter().map(|e| e.name.clone()).collect(),
        joint_covariance_deg(),
    )
    .unwrap();
    let with = measure(&epochs, Some(&joint), &rig, &obs, None, &settings(n)).unwrap();
    let without = measure(&epochs, None, &rig, &obs, None, &settings(n)).unwrap();
    let j = jacobian();
    let marginal = j * sigma_epoch() * j.transpose();
    let sd = |m: nalgebra::Matrix3<f64>| m.diagonal().map(f64::sqrt);
    for e in 0..EPOCHS {
        // The per-epoch marginal is the same whether the epochs are drawn jointly or not.
        assert_sigma(row(&with, e).sigma_mm.unwrap(), sd(marginal), n, "joint");
        assert_sigma(row(&without, e).sigma_mm.unwrap(), sd(marginal), n, "indep");
    }
    // Displacement of epoch k from epoch 0: Var = J(Σₖₖ + Σ₀₀ − Σₖ₀ − Σ₀ₖ)Jᵀ
    // = (2 − 2ρᵏ)·JΣJᵀ jointly, 2·JΣJᵀ independently.
    for k in 1..EPOCHS {
        let joint_want = sd(marginal * (2.0 - 2.0 * RHO.powi(k as i32)));
        let indep_want = sd(marginal * 2.0);
        let got_joint = row(&with, k).displacement_sigma_mm.unwrap();
        let got_indep = row(&without, k).displacement_sigma_mm.unwrap();
        assert_sigma(got_joint, joint_want, n, "joint displacement");
        assert_sigma(got_indep, indep_want, n, "independent displacement");
        // ρ = 0.8 at k = 1: the correlated displacement σ is √0.2 ≈ 0.45 of the independent.
        assert!(got_joint.x < 0.8 * got_indep.x);
    }
}

#[test]
fn a_measured_epoch_missing_from_the_joint_is_an_error() {
    let (epochs, rig, obs) = scene();
    let cov = joint_covariance_deg();
    let two = cov.view((0, 0), (12, 12)).into_owned();
    let joint = JointA::from_deg(
        Path::new("joint.json"),
        vec!["0000".into(), "0001".into()],
        two,
    )
    .unwrap();
    let e = measure(&epochs, Some(&joint), &rig, &obs, None, &settings(10))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("joint.json: joint.epochs: ") && e.contains("`0002`"),
        "{e}"
    );
}

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence")
}

/// Through the file: `measure --a-covariance` with `"joint"` on the bundled sequence. With
/// everything else certain, an A error shared by every epoch (translation only, a rank-3 joint
/// matrix: the semi-definite path) moves every marker by the same vector, so the displacements
/// have no spread at all, while the positions have A's σ; drawn independently, the
/// displacements spread by √2·σ.
#[test]
fn a_fully_correlated_file_cancels_in_the_displacements() {
    let tmp = tempfile::tempdir().unwrap();
    let model = crashrig_colmap::Reconstruction::read(&dir().join("model")).unwrap();
    let seq = crashrig_measure::sequence::a_sequence(
        &model,
        &crashrig_measure::sequence::CameraSelector::parse("cam_out/"),
        1000.0,
    )
    .unwrap();
    let names: Vec<String> = seq.poses.iter().map(|p| p.name.clone()).collect();
    let n = 6 * names.len();
    let sigma = [0.5, 0.4, 0.3];
    let full = |a: usize, b: usize| -> f64 {
        if a % 6 == b % 6 && a % 6 < 3 {
            sigma[a % 6] * sigma[a % 6]
        } else {
            0.0
        }
    };
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|a| (0..n).map(|b| full(a, b)).collect())
        .collect();
    let doc = serde_json::json!({
        "mm_per_unit": 1000.0,
        "joint": {"epochs": names, "covariance_tangent": rows},
    });
    let path = tmp.path().join("a_cov.json");
    std::fs::write(&path, doc.to_string()).unwrap();
    let read = input::read_a_covariance(&path).unwrap();
    assert_eq!(read.joint.as_ref().unwrap().epochs.len(), names.len());
    let link = input::load_link(&dir().join("link.json")).unwrap();
    let tie = input::load_link(&dir().join("tie.json")).unwrap();
    let config = |a_noise: ANoise| MeasureConfig {
        model: dir().join("model"),
        camera_a: "cam_out/".into(),
        camera_b: "2".into(),
        camera_c: Some("3".into()),
        a_from_b: UncertainPose::certain(link.b_from_a),
        b_from_c: Some(UncertainPose::certain(tie.b_from_a)),
        observations: dir().join("observations.csv"),
        mm_per_unit: 1000.0,
        a_noise,
        settings: settings(2_000),
        pixel_sigma_from: Default::default(),
        scale_bars: None,
        out: None,
    };
    let joint = crashrig_measure::run(&config(ANoise::File(path)), None).unwrap();
    let indep = crashrig_measure::run(
        &config(ANoise::Sigmas {
            position_mm: Vec3::from(sigma),
            angles_deg: Vec3::zeros(),
        }),
        None,
    )
    .unwrap();
    let n = 2_000;
    let mut checked = 0;
    for (rj, ri) in joint.measurement.rows.iter().zip(&indep.measurement.rows) {
        let (Some(sj), Some(si)) = (rj.sigma_mm, ri.sigma_mm) else {
            continue;
        };
        assert_sigma(sj, Vec3::from(sigma), n, "joint position");
        assert_sigma(si, Vec3::from(sigma), n, "independent position");
        if rj.epoch == joint.measurement.reference_epoch {
            continue;
        }
        let (Some(dj), Some(di)) = (rj.displacement_sigma_mm, ri.displacement_sigma_mm) else {
            continue;
        };
        // A common shift cancels to rounding (positions ~1e3–1e4 mm, 1e-16 relative).
        assert!(dj.max() < 1e-9, "{dj:?}");
        assert_sigma(
            di,
            Vec3::from(sigma) * 2.0_f64.sqrt(),
            n,
            "independent displacement",
        );
        checked += 1;
    }
    assert!(checked > 50, "{checked} displacement rows checked");
}

#[test]
fn bad_joint_matrices_name_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let write = |name: &str, doc: serde_json::Value| {
        let p = tmp.path().join(name);
        std::fs::write(&p, doc.to_string()).unwrap();
        p
    };
    let eye = |n: usize| -> Vec<Vec<f64>> {
        (0..n)
            .map(|a| (0..n).map(|b| f64::from(u8::from(a == b))).collect())
            .collect()
    };
    // Wrong size for the epochs.
    let p = write(
        "size.json",
        serde_json::json!({"joint": {"epochs": ["a", "b"], "covariance_tangent": eye(6)}}),
    );
    let e = input::read_a_covariance(&p).unwrap_err().to_string();
    assert!(
        e.contains("joint.covariance_tangent: must be 12 rows"),
        "{e}"
    );
    // Not symmetric.
    let mut m = eye(12);
    m[0][7] = 0.5;
    let p = write(
        "asym.json",
        serde_json::json!({"joint": {"epochs": ["a", "b"], "covariance_tangent": m}}),
    );
    let e = input::read_a_covariance(&p).unwrap_err().to_string();
    assert!(e.contains("not symmetric: entry (1, 8)"), "{e}");
    // A block that disagrees with the epoch's own entry.
    let p = write(
        "block.json",
        serde_json::json!({"epochs": {"a": eye(6)}, "joint": {"epochs": ["a"], "covariance_tangent": (0..6).map(|a| (0..6).map(|b| if a == b { 2.0 } else { 0.0 }).collect::<Vec<f64>>()).collect::<Vec<_>>()}}),
    );
    let e = input::read_a_covariance(&p).unwrap_err().to_string();
    assert!(e.contains("the block of epoch `a` differs"), "{e}");
    // Too many epochs: refused before the matrix is read.
    let names: Vec<String> = (0..=input::MAX_JOINT_EPOCHS)
        .map(|i| i.to_string())
        .collect();
    let p = write(
        "many.json",
        serde_json::json!({"joint": {"epochs": names, "covariance_tangent": []}}),
    );
    let e = input::read_a_covariance(&p).unwrap_err().to_string();
    assert!(e.contains("joint.epochs: 501 epochs"), "{e}");
    // Not positive semi-definite: found when factored (a correlation of 2).
    let mut m = eye(12);
    m[0][6] = 2.0;
    m[6][0] = 2.0;
    let joint = JointA::from_deg(
        Path::new("npsd.json"),
        vec!["0000".into(), "0001".into()],
        DMatrix::from_fn(12, 12, |a, b| m[a][b]),
    )
    .unwrap();
    let (mut epochs, rig, obs) = scene();
    epochs.truncate(2);
    let obs: Vec<Observation> = obs.into_iter().filter(|o| o.epoch != "0002").collect();
    let e = measure(&epochs, Some(&joint), &rig, &obs, None, &settings(10))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("npsd.json: joint.covariance_tangent: not positive semi-definite"),
        "{e}"
    );
}
