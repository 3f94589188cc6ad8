//! Relative orientation: 8-point, cheirality, Sampson LM and covariance.

use super::scene::{self, b_from_world, camera, noisy};
use crashrig_geometry::{Rigid3, so3};
use crashrig_pose::{
    Degeneracy, Error, RansacOptions, essential_8point, essential_from_pose,
    estimate_relative_pose, normalize_pixels, pose_with_cheirality, refine_relative_pose,
    sampson_error,
};
use nalgebra::{Translation3, Vector2};

/// `b_from_a` of the standard scene with its translation normalized.
fn unit_truth() -> Rigid3 {
    let b = b_from_world();
    Rigid3::from_parts(
        Translation3::from(b.translation.vector.normalize()),
        b.rotation,
    )
}

#[test]
fn essential_8point_nominal_exact() {
    let cam = camera();
    let s = scene::scene(10, 8, &cam, &b_from_world());
    let xa = normalize_pixels(&cam, &s.px_a).unwrap();
    let xb = normalize_pixels(&cam, &s.px_b).unwrap();
    let e = essential_8point(&xa, &xb).unwrap();
    let idx: Vec<usize> = (0..8).collect();
    let (pose, front) = pose_with_cheirality(&e, &xa, &xb, &idx).unwrap();
    assert_eq!(front, 8);
    // Exact data, 9×9 eigenproblem of AᵀA (condition squared): ~1e-9.
    crashrig_testkit::pose::assert_rigid_near(&pose, &unit_truth(), 1e-8, 1e-8);
    let e_true = essential_from_pose(&unit_truth());
    for i in 0..8 {
        approx::assert_abs_diff_eq!(sampson_error(&e_true, &xa[i], &xb[i]), 0.0, epsilon = 1e-12);
    }
}

#[test]
fn estimate_relative_pose_nominal_noise_free() {
    let cam = camera();
    let s = scene::scene(11, 100, &cam, &b_from_world());
    let xa = normalize_pixels(&cam, &s.px_a).unwrap();
    let xb = normalize_pixels(&cam, &s.px_b).unwrap();
    let est = estimate_relative_pose(&xa, &xb, 1000.0, &RansacOptions::new(2)).unwrap();
    assert_eq!(est.inliers.len(), 100);
    // LM on exact data: rounding only.
    crashrig_testkit::pose::assert_rigid_near(
        &est.refinement.b_from_a,
        &unit_truth(),
        1e-10,
        1e-10,
    );
}

#[test]
fn estimate_relative_pose_with_outliers() {
    let cam = camera();
    let s = scene::scene(12, 200, &cam, &b_from_world());
    let mut pb = noisy(&s.px_b, 0.5, 3, 0);
    for (i, x) in pb.iter_mut().enumerate() {
        if i % 5 == 0 {
            *x += Vector2::new(-30.0, 45.0 + (i % 7) as f64 * 10.0);
        }
    }
    let pa = noisy(&s.px_a, 0.5, 3, 1);
    let xa = normalize_pixels(&cam, &pa).unwrap();
    let xb = normalize_pixels(&cam, &pb).unwrap();
    let est = estimate_relative_pose(&xa, &xb, 1000.0, &RansacOptions::new(4)).unwrap();
    assert!(
        est.inliers.iter().all(|i| i % 5 != 0),
        "an outlier was kept"
    );
    assert!(est.inliers.len() >= 150);
    let truth = unit_truth();
    let r = &est.refinement;
    let dr = so3::angular_distance(
        &r.b_from_a.rotation.to_rotation_matrix(),
        &truth.rotation.to_rotation_matrix(),
    );
    let dt = (r.b_from_a.translation.vector - truth.translation.vector).norm();
    // 5σ of the first-order covariance (rotation block, direction block).
    let s_rot = (r.covariance[(0, 0)] + r.covariance[(1, 1)] + r.covariance[(2, 2)]).sqrt();
    let s_dir = (r.covariance[(3, 3)] + r.covariance[(4, 4)]).sqrt();
    assert!(dr < 5.0 * s_rot, "rotation error {dr} vs σ {s_rot}");
    assert!(dt < 5.0 * s_dir, "direction error {dt} vs σ {s_dir}");
}

/// Ratio of the mean first-order σ to the empirical σ of rotation (per axis) and direction.
fn covariance_ratio(draws: u64, n: usize) -> Vec<f64> {
    let cam = camera();
    let s = scene::scene(13, n, &cam, &b_from_world());
    let truth = unit_truth();
    let idx: Vec<usize> = (0..n).collect();
    let mut m = crashrig_stats::Moments::<5>::new();
    let mut pred = [0.0; 5];
    let basis = crashrig_pose::tangent_basis(&truth.translation.vector);
    for d in 0..draws {
        let xa = normalize_pixels(&cam, &noisy(&s.px_a, 0.5, 99, 2 * d)).unwrap();
        let xb = normalize_pixels(&cam, &noisy(&s.px_b, 0.5, 99, 2 * d + 1)).unwrap();
        let r = refine_relative_pose(&xa, &xb, &idx, &truth).unwrap();
        let w = so3::log(
            &(r.b_from_a.rotation.to_rotation_matrix()
                * truth.rotation.to_rotation_matrix().inverse()),
        );
        let dt = basis.transpose() * (r.b_from_a.translation.vector - truth.translation.vector);
        m.push(&[w.x, w.y, w.z, dt.x, dt.y]);
        for (k, p) in pred.iter_mut().enumerate() {
            *p += r.covariance[(k, k)].sqrt() / draws as f64;
        }
    }
    let emp = m.std_dev();
    (0..5).map(|k| pred[k] / emp[k]).collect()
}

#[test]
fn covariance_fast_matches_empirical_spread() {
    // 60 draws: empirical σ ±9 % (1σ); ±30 % is > 3σ.
    for (k, r) in covariance_ratio(60, 150).iter().enumerate() {
        assert!((0.7..=1.3).contains(r), "component {k}: ratio {r}");
    }
}

#[test]
#[ignore = "slow: 1000 noise draws; run by cargo xtask test --slow"]
fn slow_covariance_matches_empirical_spread() {
    // 1000 draws: ±2.2 % (1σ); allow 10 %.
    for (k, r) in covariance_ratio(1000, 300).iter().enumerate() {
        assert!((0.9..=1.1).contains(r), "component {k}: ratio {r}");
    }
}

#[test]
fn estimate_relative_pose_errors() {
    let cam = camera();
    let s = scene::scene(14, 40, &cam, &b_from_world());
    let xa = normalize_pixels(&cam, &s.px_a).unwrap();
    let xb = normalize_pixels(&cam, &s.px_b).unwrap();
    let opts = RansacOptions::new(1);
    assert_eq!(
        estimate_relative_pose(&xa[..7], &xb[..7], 1000.0, &opts).unwrap_err(),
        Error::TooFewCorrespondences {
            needed: 15,
            found: 7
        }
    );
    assert_eq!(
        estimate_relative_pose(&xa, &xb[..39], 1000.0, &opts).unwrap_err(),
        Error::LengthMismatch {
            left: 40,
            right: 39
        }
    );
    // Zero baseline (pure rotation), noise-free and with 0.5 px noise: a rotation explains
    // every match, so the base direction is unobservable.
    let rot_only = Rigid3::from_parts(Translation3::identity(), b_from_world().rotation);
    let s0 = scene::scene(15, 40, &cam, &rot_only);
    for sigma in [0.0, 0.5] {
        let ya = normalize_pixels(&cam, &noisy(&s0.px_a, sigma, 8, 0)).unwrap();
        let yb = normalize_pixels(&cam, &noisy(&s0.px_b, sigma, 8, 1)).unwrap();
        let err = estimate_relative_pose(&ya, &yb, 1000.0, &opts);
        assert!(
            matches!(
                err,
                Err(Error::Degenerate {
                    what: Degeneracy::NoParallax | Degeneracy::SingularNormalEquations
                }) | Err(Error::NoConsensus { .. })
            ),
            "σ = {sigma}: {err:?}"
        );
        if sigma > 0.0 {
            assert_eq!(
                err.unwrap_err(),
                Error::Degenerate {
                    what: Degeneracy::NoParallax
                }
            );
        }
    }
}

#[test]
fn link_covariance_relative_matches_monte_carlo() {
    // ξ ~ N(0, Σ) in the 5-dim relative tangent (1e-4 rad rotation, 1e-3 rad direction) mapped
    // to the scaled link; 4000 draws give σ to ±1.1 % (1 s.e.); allow 5 %.
    use rand::RngExt;
    let truth = unit_truth();
    let base = 650.0;
    let mut cov = crashrig_pose::Mat5::zeros();
    for k in 0..3 {
        cov[(k, k)] = 1e-8;
    }
    cov[(3, 3)] = 1e-6;
    cov[(4, 4)] = 4e-6;
    let lin = crashrig_pose::link_covariance_relative(&truth, base, &cov);
    let l = cov.cholesky().unwrap().l();
    let basis = crashrig_pose::tangent_basis(&truth.translation.vector);
    let p0 = crashrig_pose::link_parameters(&crashrig_pose::scaled_a_from_b(&truth, base));
    let mut rng = crashrig_stats::stream(18, 0);
    let mut m = crashrig_stats::Moments::<6>::new();
    for _ in 0..4000 {
        let z = crashrig_pose::Vec5::from_fn(|_, _| rng.sample(rand_distr::StandardNormal));
        let d = l * z;
        let r = so3::exp(&crashrig_geometry::Vec3::new(d[0], d[1], d[2]))
            * truth.rotation.to_rotation_matrix();
        let t = (truth.translation.vector + basis * Vector2::new(d[3], d[4])).normalize();
        let pose = Rigid3::from_parts(
            Translation3::from(t),
            nalgebra::UnitQuaternion::from_rotation_matrix(&r),
        );
        let p = crashrig_pose::link_parameters(&crashrig_pose::scaled_a_from_b(&pose, base));
        let diff: [f64; 6] = std::array::from_fn(|k| {
            let v = p[k] - p0[k];
            if k >= 3 {
                crashrig_geometry::angles::wrap_pi(v)
            } else {
                v
            }
        });
        m.push(&diff);
    }
    let sd = m.std_dev();
    for k in 0..6 {
        approx::assert_relative_eq!(sd[k], lin[(k, k)].sqrt(), max_relative = 0.05);
    }
}

#[test]
fn essential_5point_nominal_exact() {
    // 30 random five-point samples of the standard scene: one of the ≤ 10 solutions is the
    // true essential matrix (up to sign and scale), and its decomposition is the true pose.
    let cam = camera();
    let s = scene::scene(20, 150, &cam, &b_from_world());
    let xa = normalize_pixels(&cam, &s.px_a).unwrap();
    let xb = normalize_pixels(&cam, &s.px_b).unwrap();
    let e_true = essential_from_pose(&unit_truth());
    let e_true = e_true / e_true.norm();
    for k in 0..30 {
        let idx: [usize; 5] = std::array::from_fn(|i| 5 * k + i);
        let a: [Vector2<f64>; 5] = idx.map(|i| xa[i]);
        let b: [Vector2<f64>; 5] = idx.map(|i| xb[i]);
        let sols = crashrig_pose::essential_5point(&a, &b);
        let best = sols
            .iter()
            .map(|e| (e - e_true).norm().min((e + e_true).norm()))
            .fold(f64::INFINITY, f64::min);
        // Exact data through a 10×10 eigenproblem: ~1e-10; 1e-7 allows ill-conditioned
        // samples (nearby roots).
        assert!(
            best < 1e-7,
            "sample {k}: best distance {best} over {} solutions",
            sols.len()
        );
    }
}
