//! Resection: P3P, LO-RANSAC, LM and covariance.

use super::scene::{self, b_from_world, camera, noisy};
use crashrig_geometry::{Vec3, Vec6, se3};
use crashrig_pose::{
    Degeneracy, Error, Projector, RansacOptions, dx_img_from_pose_left, estimate_absolute_pose,
    p3p, refine_absolute_pose,
};
use crashrig_testkit::fd::central_jacobian;
use crashrig_testkit::pose::{assert_rigid_near, rigid_near};
use nalgebra::{DVector, Vector2};

#[test]
fn p3p_nominal_exact_recovery() {
    // 50 random configurations: one of the ≤ 4 solutions is the truth.
    let cam = camera();
    for k in 0..50u64 {
        let truth = se3::exp(&Vec6::new(
            0.3 * (k as f64).sin(),
            0.2 * (k as f64 * 1.7).cos(),
            0.5 * (k as f64 * 0.3).sin(),
            100.0 * (k as f64 * 2.1).sin(),
            50.0,
            -80.0,
        ));
        let s = scene::scene(k, 3, &cam, &truth);
        let bearings = s
            .px_b
            .iter()
            .map(|x| {
                let u = cam.normalized(x).unwrap();
                Vec3::new(u.x, u.y, 1.0).normalize()
            })
            .collect::<Vec<_>>();
        let sols = p3p(
            &[bearings[0], bearings[1], bearings[2]],
            &[s.points[0], s.points[1], s.points[2]],
        );
        // Exact data through a quartic root (Newton polished) and an SVD: ~1e-10 typically,
        // but near a double root of the quartic the root is only good to √ε (case 44 measured
        // 1.6e-8 relative in translation); 1e-6 still proves recovery, LM polishes the rest.
        let found = sols
            .iter()
            .any(|p| rigid_near(p, &truth, 1e-6, 1e-6).is_ok());
        let errs: Vec<_> = sols
            .iter()
            .map(|p| rigid_near(p, &truth, 1e-6, 1e-6))
            .collect();
        assert!(
            found,
            "case {k}: truth not among {} solutions {errs:?}",
            sols.len()
        );
    }
}

#[test]
fn estimate_absolute_pose_nominal_noise_free() {
    let cam = camera();
    let truth = b_from_world();
    let s = scene::scene(1, 100, &cam, &truth);
    let est = estimate_absolute_pose(&cam, &s.px_b, &s.points, &RansacOptions::new(3)).unwrap();
    // Noise-free: LM converges to the exact pose up to rounding (poses ~600 mm, 1e-12 relative).
    assert_rigid_near(&est.refinement.cam_from_world, &truth, 1e-10, 1e-10);
    assert_eq!(est.inliers.len(), 100);
    assert!(est.refinement.sigma0_px < 1e-6);
}

#[test]
fn estimate_absolute_pose_distorted_camera_exact() {
    // The real camera model, with radial and tangential distortion (COLMAP OPENCV).
    let cam = crashrig_camera::Camera::new(
        crashrig_camera::ModelId::from_name("OPENCV").unwrap(),
        1600,
        1200,
        vec![1000.0, 1010.0, 800.0, 600.0, -0.1, 0.02, 0.001, -0.0005],
    )
    .unwrap();
    let truth = b_from_world();
    let s = scene::scene(2, 80, &cam, &truth);
    let est = estimate_absolute_pose(&cam, &s.px_b, &s.points, &RansacOptions::new(5)).unwrap();
    // Undistortion by Newton to ‖step‖² < 1e-10 limits the P3P seeds, LM then polishes on the
    // forward model: exact up to rounding.
    assert_rigid_near(&est.refinement.cam_from_world, &truth, 1e-10, 1e-10);
}

#[test]
fn estimate_absolute_pose_with_outliers() {
    let cam = camera();
    let truth = b_from_world();
    let s = scene::scene(3, 200, &cam, &truth);
    let mut px = noisy(&s.px_b, 0.5, 9, 0);
    // 30 % gross outliers: shifted by 40–100 px.
    for (i, x) in px.iter_mut().enumerate() {
        if i % 10 < 3 {
            *x += Vector2::new(40.0 + i as f64 % 60.0, -50.0);
        }
    }
    let est = estimate_absolute_pose(&cam, &px, &s.points, &RansacOptions::new(11)).unwrap();
    assert!(
        est.inliers.iter().all(|i| i % 10 >= 3),
        "an outlier was kept"
    );
    assert!(est.inliers.len() >= 130, "{} inliers", est.inliers.len());
    // 0.5 px noise on 140 points at 2–5 m: the pose is good to ~1e-3 rad and a few mm; the
    // covariance's σ says how good, so allow 5σ.
    let cov = est.refinement.covariance;
    let err = se3::log(&(est.refinement.cam_from_world * truth.inverse()));
    for k in 0..6 {
        assert!(
            err[k].abs() < 5.0 * cov[(k, k)].sqrt(),
            "component {k}: error {} vs σ {}",
            err[k],
            cov[(k, k)].sqrt()
        );
    }
}

#[test]
fn estimate_absolute_pose_is_seed_deterministic() {
    let cam = camera();
    let s = scene::scene(4, 60, &cam, &b_from_world());
    let px = noisy(&s.px_b, 1.0, 4, 0);
    let a = estimate_absolute_pose(&cam, &px, &s.points, &RansacOptions::new(21)).unwrap();
    let b = estimate_absolute_pose(&cam, &px, &s.points, &RansacOptions::new(21)).unwrap();
    assert_eq!(a, b);
}

#[test]
fn dx_img_from_pose_left_matches_finite_differences() {
    let cam = camera();
    let pose = b_from_world();
    let x_world = Vec3::new(300.0, -200.0, 3000.0);
    let f = |xi: &DVector<f64>| {
        let t = se3::exp(&Vec6::from_column_slice(xi.as_slice())) * pose;
        let p = t.transform_point(&x_world.into()).coords;
        let x = cam.project(&p).unwrap();
        DVector::from_column_slice(x.as_slice())
    };
    let fd = central_jacobian(f, &DVector::zeros(6), 1e-6);
    let p = pose.transform_point(&x_world.into()).coords;
    let (_, jp) = cam.project_with_jacobian(&p).unwrap();
    let an = dx_img_from_pose_left(&jp, &p);
    for i in 0..2 {
        for j in 0..6 {
            // Central differences with h = 1e-6 (rad / mm) on pixel values ~1e3: truncation
            // O(h²·f‴) ≈ 1e-9, rounding ε·|f|/h ≈ 2e-7 px per unit; entries are up to ~1e3.
            approx::assert_abs_diff_eq!(
                an[(i, j)],
                fd[(i, j)],
                epsilon = 1e-5 * (1.0 + an[(i, j)].abs())
            );
        }
    }
}

#[test]
fn pinhole_project_with_jacobian_matches_finite_differences() {
    let cam = camera();
    let p0 = Vec3::new(120.0, -80.0, 900.0);
    let f = |p: &DVector<f64>| {
        let x = cam.project(&Vec3::new(p[0], p[1], p[2])).unwrap();
        DVector::from_column_slice(x.as_slice())
    };
    let fd = central_jacobian(f, &DVector::from_column_slice(p0.as_slice()), 1e-4);
    let (_, j) = cam.project_with_jacobian(&p0).unwrap();
    for i in 0..2 {
        for k in 0..3 {
            // h = 1e-4 mm on a point at 900 mm: truncation ~1e-11, rounding ~1e-9 px/mm.
            approx::assert_abs_diff_eq!(j[(i, k)], fd[(i, k)], epsilon = 1e-7);
        }
    }
}

/// Empirical spread of the resected pose over `draws` noise draws, against the mean
/// first-order σ; returns the ratios (first-order / empirical) per tangent component.
fn covariance_ratio(draws: u64, n: usize, sigma_px: f64) -> [f64; 6] {
    let cam = camera();
    let truth = b_from_world();
    let s = scene::scene(5, n, &cam, &truth);
    let idx: Vec<usize> = (0..n).collect();
    let mut m = crashrig_stats::Moments::<6>::new();
    let mut predicted = [0.0; 6];
    for d in 0..draws {
        let px = noisy(&s.px_b, sigma_px, 77, d);
        let r = refine_absolute_pose(&cam, &px, &s.points, &idx, &truth).unwrap();
        let err = se3::log(&(r.cam_from_world * truth.inverse()));
        m.push_vec(&err);
        for (k, p) in predicted.iter_mut().enumerate() {
            *p += r.covariance[(k, k)].sqrt() / draws as f64;
        }
    }
    let emp = m.std_dev();
    std::array::from_fn(|k| predicted[k] / emp[k])
}

#[test]
fn covariance_fast_matches_empirical_spread() {
    // 60 draws: the empirical σ has relative standard error 1/√(2·59) = 9 %; 3 of those is 28 %,
    // so the first-order σ must match within ±30 %.
    for (k, r) in covariance_ratio(60, 150, 0.5).iter().enumerate() {
        assert!((0.7..=1.3).contains(r), "component {k}: ratio {r}");
    }
}

#[test]
#[ignore = "slow: 1000 noise draws; run by cargo xtask test --slow"]
fn slow_covariance_matches_empirical_spread() {
    // 1000 draws: relative standard error 2.2 %; 3 of those is 7 %; allow 10 %.
    for (k, r) in covariance_ratio(1000, 300, 0.5).iter().enumerate() {
        assert!((0.9..=1.1).contains(r), "component {k}: ratio {r}");
    }
}

#[test]
fn estimate_absolute_pose_errors() {
    let cam = camera();
    let s = scene::scene(6, 30, &cam, &b_from_world());
    let opts = RansacOptions::new(1);
    assert_eq!(
        estimate_absolute_pose(&cam, &s.px_b[..5], &s.points[..5], &opts).unwrap_err(),
        Error::TooFewCorrespondences {
            needed: 15,
            found: 5
        }
    );
    assert_eq!(
        estimate_absolute_pose(&cam, &s.px_b[..20], &s.points[..19], &opts).unwrap_err(),
        Error::LengthMismatch {
            left: 20,
            right: 19
        }
    );
    let mut bad = s.px_b.clone();
    bad[4].x = f64::NAN;
    assert_eq!(
        estimate_absolute_pose(&cam, &bad, &s.points, &opts).unwrap_err(),
        Error::NotFinite { index: 4 }
    );
    // Pure noise: pixels unrelated to the points → no consensus.
    let junk: Vec<Vector2<f64>> = (0..30)
        .map(|i| Vector2::new((i * 397 % 1600) as f64, (i * 211 % 1200) as f64))
        .collect();
    assert!(matches!(
        estimate_absolute_pose(&cam, &junk, &s.points, &opts).unwrap_err(),
        Error::NoConsensus { needed: 15, .. }
    ));
    let truth0 = b_from_world();
    assert_eq!(
        refine_absolute_pose(&cam, &s.px_b, &s.points, &[0, 1, 2, 30], &truth0).unwrap_err(),
        Error::IndexOutOfRange { index: 30, len: 30 }
    );
    // A resample made of one correspondence repeated.
    let truth = b_from_world();
    assert_eq!(
        refine_absolute_pose(&cam, &s.px_b, &s.points, &[3; 10], &truth).unwrap_err(),
        Error::Degenerate {
            what: Degeneracy::TooFewDistinct
        }
    );
    // Collinear world points: the rotation about their line is unobservable.
    let line: Vec<Vec3> = (0..20)
        .map(|i| Vec3::new(f64::from(i) * 50.0, 0.0, 3000.0))
        .collect();
    let px: Vec<Vector2<f64>> = line
        .iter()
        .map(|p| {
            cam.project(&truth.transform_point(&(*p).into()).coords)
                .unwrap()
        })
        .collect();
    let idx: Vec<usize> = (0..20).collect();
    assert_eq!(
        refine_absolute_pose(&cam, &px, &line, &idx, &truth).unwrap_err(),
        Error::Degenerate {
            what: Degeneracy::SingularNormalEquations
        }
    );
}

#[test]
fn link_parameters_nominal_paper_link() {
    // The contract's convention: base = B's centre in A (the translation of A_from_B), angles
    // ω φ κ of R_A_from_B; the paper's link is (61.98, −1.71, 179.76) mm, (179.92, −0.09,
    // 179.76)°.
    let p = crashrig_pose::link_parameters(&crashrig_testkit::scene::paper_a_from_b());
    let expected = [61.98, -1.71, 179.76];
    for k in 0..3 {
        // Stored exactly; rounding only.
        approx::assert_abs_diff_eq!(p[k], expected[k], epsilon = 1e-12);
    }
    let angles = [179.92_f64, -0.09, 179.76];
    for k in 0..3 {
        // opk → R → opk away from gimbal lock: ~1e-15 rad.
        approx::assert_abs_diff_eq!(p[3 + k], angles[k].to_radians(), epsilon = 1e-12);
    }
}

#[test]
fn link_covariance_absolute_matches_monte_carlo() {
    // Draw ξ ~ N(0, Σ) in B's left tangent, map through the link, compare the sample σ of the
    // six parameters with the first-order σ. Σ is small (1e-4 rad, 0.5 mm), so the map is
    // linear to < 1e-3 relative; 4000 draws give σ to ±1.1 % (1 s.e.); allow 5 %.
    use rand::RngExt;
    let a_from_world = crashrig_testkit::scene::paper_a_from_b().inverse();
    let b_from_world = b_from_world();
    let mut cov = crashrig_geometry::Mat6::zeros();
    for k in 0..3 {
        cov[(k, k)] = 1e-8;
        cov[(k + 3, k + 3)] = 0.25;
    }
    cov[(0, 4)] = 2e-5;
    cov[(4, 0)] = 2e-5;
    let lin = crashrig_pose::link_covariance_absolute(&a_from_world, &b_from_world, &cov);
    let l = cov.cholesky().unwrap().l();
    let mut rng = crashrig_stats::stream(17, 0);
    let mut m = crashrig_stats::Moments::<6>::new();
    let p0 = crashrig_pose::link_parameters(&(a_from_world * b_from_world.inverse()));
    for _ in 0..4000 {
        let z = Vec6::from_fn(|_, _| rng.sample(rand_distr::StandardNormal));
        let xi = l * z;
        let p = crashrig_pose::link_parameters(
            &(a_from_world * (se3::exp(&xi) * b_from_world).inverse()),
        );
        let d: [f64; 6] = std::array::from_fn(|k| {
            let v = p[k] - p0[k];
            if k >= 3 {
                crashrig_geometry::angles::wrap_pi(v)
            } else {
                v
            }
        });
        m.push(&d);
    }
    let sd = m.std_dev();
    for k in 0..6 {
        approx::assert_relative_eq!(sd[k], lin[(k, k)].sqrt(), max_relative = 0.05);
    }
}
