//! DLT forward intersection: exact recovery, homogeneous vs inhomogeneous, degenerate
//! configurations, covariance against central differences and Monte Carlo.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::look_at::world_from_cam_look_at;
use crashrig_geometry::triangulate::{
    View, dlt, dlt_covariance, dlt_covariance_per_view, dlt_homogeneous,
};
use crashrig_geometry::{Error, Mat3, Rigid3, Vec3, quat};
use crashrig_testkit::fd::central_jacobian;
use crashrig_testkit::scene::{stereo_a_from_b, two_view_scene};
use nalgebra::{DVector, Point3, Translation3, Vector2};
use rand::{RngExt, SeedableRng, rngs::ChaCha8Rng};
use rand_distr::StandardNormal;

/// `cam_from_world` of a camera at `centre` aiming at `target` (no roll).
fn aimed(centre: Vec3, target: Vec3) -> Rigid3 {
    let world_from_cam = world_from_cam_look_at(&centre, &target).unwrap();
    let q = quat::unit_quaternion_from_rotation(&world_from_cam).inverse();
    Rigid3::from_parts(Translation3::from(-(q * centre)), q)
}

fn observe(cam_from_world: Rigid3, p: &Vec3) -> View {
    let pc = cam_from_world * Point3::from(*p);
    View {
        cam_from_world,
        normalized: Vector2::new(pc.x / pc.z, pc.y / pc.z),
    }
}

/// Five cameras 2–3 m from a point near the origin (the grid study's geometry, in mm).
fn five_views(p: &Vec3) -> Vec<View> {
    let target = Vec3::new(10.0, -20.0, 5.0);
    [
        Vec3::new(2200.0, 0.0, 300.0),
        Vec3::new(2000.0, 900.0, 200.0),
        Vec3::new(-1800.0, 1500.0, 400.0),
        Vec3::new(300.0, -2500.0, 100.0),
        Vec3::new(-2100.0, -800.0, 600.0),
    ]
    .into_iter()
    .map(|c| observe(aimed(c, target), p))
    .collect()
}

#[test]
fn dlt_nominal_two_views() {
    let scene = two_view_scene(11, &stereo_a_from_b(), 10, (800.0, 3000.0), 0.0).unwrap();
    for ((p, a), b) in scene
        .points_world
        .iter()
        .zip(&scene.normalized_a)
        .zip(&scene.normalized_b)
    {
        let views = [
            View {
                cam_from_world: scene.a_from_world,
                normalized: *a,
            },
            View {
                cam_from_world: scene.b_from_world,
                normalized: *b,
            },
        ];
        // Noise-free: exact up to rounding amplified by the condition number (~1e2) at ~3e3 mm.
        assert_relative_eq!(dlt(&views).unwrap(), *p, epsilon = 1e-9);
        // The homogeneous form mixes unitless and mm columns in a 4×4 normal matrix, which
        // squares a condition of ~1e3–1e4: ~1e-12 relative is what f64 leaves.
        assert_relative_eq!(dlt_homogeneous(&views).unwrap(), *p, max_relative = 1e-10);
    }
}

#[test]
fn dlt_nominal_five_views() {
    let p = Vec3::new(35.0, -12.0, 40.0);
    let views = five_views(&p);
    assert_relative_eq!(dlt(&views).unwrap(), p, epsilon = 1e-9);
    // Homogeneous and inhomogeneous agree on noise-free data.
    // (Relative tolerance for the homogeneous form: see `dlt_nominal_two_views`.)
    assert_relative_eq!(
        dlt_homogeneous(&views).unwrap(),
        dlt(&views).unwrap(),
        max_relative = 1e-10
    );
}

#[test]
fn dlt_too_few_views() {
    let p = Vec3::new(0.0, 0.0, 0.0);
    let views = five_views(&p);
    assert_eq!(
        dlt(&views[..1]),
        Err(Error::TooFewViews {
            needed: 2,
            found: 1
        })
    );
    assert_eq!(
        dlt_homogeneous(&[]),
        Err(Error::TooFewViews {
            needed: 2,
            found: 0
        })
    );
}

#[test]
fn dlt_parallel_rays_degenerate() {
    // Two cameras with the same orientation, 100 mm apart, both seeing the principal point:
    // the rays are parallel (point at infinity).
    let a = Rigid3::identity();
    let b = Rigid3::translation(-100.0, 0.0, 0.0);
    let views = [
        View {
            cam_from_world: a,
            normalized: Vector2::new(0.0, 0.0),
        },
        View {
            cam_from_world: b,
            normalized: Vector2::new(0.0, 0.0),
        },
    ];
    assert!(matches!(dlt(&views), Err(Error::Degenerate { .. })));
    assert!(matches!(
        dlt_homogeneous(&views),
        Err(Error::Degenerate { .. })
    ));
    // Same centre, same ray: the depth is undetermined.
    let views = [
        View {
            cam_from_world: a,
            normalized: Vector2::new(0.1, 0.2),
        },
        View {
            cam_from_world: a,
            normalized: Vector2::new(0.1, 0.2),
        },
    ];
    assert!(matches!(dlt(&views), Err(Error::Degenerate { .. })));
}

#[test]
fn dlt_rejects_nan() {
    let mut views = five_views(&Vec3::zeros());
    views[2].normalized.x = f64::NAN;
    assert!(matches!(dlt(&views), Err(Error::NonFinite { .. })));
}

/// The 2n observations as one vector, and views rebuilt from such a vector.
fn obs_vector(views: &[View]) -> DVector<f64> {
    DVector::from_iterator(
        views.len() * 2,
        views.iter().flat_map(|v| [v.normalized.x, v.normalized.y]),
    )
}

fn with_obs(views: &[View], x: &DVector<f64>) -> Vec<View> {
    views
        .iter()
        .enumerate()
        .map(|(i, v)| View {
            cam_from_world: v.cam_from_world,
            normalized: Vector2::new(x[2 * i], x[2 * i + 1]),
        })
        .collect()
}

fn covariance_from_fd(views: &[View], sigma: f64) -> Mat3 {
    let f = |x: &DVector<f64>| {
        let p = dlt(&with_obs(views, x)).unwrap();
        DVector::from_column_slice(p.as_slice())
    };
    // Normalized coordinates are O(0.1); h = 1e-7 keeps the (quadratic) nonlinearity small.
    let j = central_jacobian(f, &obs_vector(views), 1e-7);
    let c = &j * j.transpose() * (sigma * sigma);
    Mat3::from_iterator(c.iter().copied())
}

#[test]
fn dlt_covariance_finite_difference_noise_free() {
    let p = Vec3::new(35.0, -12.0, 40.0);
    let views = five_views(&p);
    let sigma = 1e-4;
    let analytic = dlt_covariance(&views, &p, sigma).unwrap();
    let numeric = covariance_from_fd(&views, sigma);
    // Central differences of a function with |X| ~ 1e2 mm: relative 1e-6 is the FD budget.
    assert_relative_eq!(analytic, numeric, max_relative = 1e-6, epsilon = 1e-14);
}

#[test]
fn dlt_covariance_finite_difference_with_residuals() {
    // Perturbed observations: the LS residuals are non-zero and enter the derivative.
    let p = Vec3::new(35.0, -12.0, 40.0);
    let mut views = five_views(&p);
    let offsets = [3e-3, -2e-3, 1e-3, 4e-3, -3e-3];
    for (v, o) in views.iter_mut().zip(offsets) {
        v.normalized += Vector2::new(o, -0.5 * o);
    }
    let x = dlt(&views).unwrap();
    let analytic = dlt_covariance(&views, &x, 1.0).unwrap();
    let numeric = covariance_from_fd(&views, 1.0);
    assert_relative_eq!(analytic, numeric, max_relative = 1e-6, epsilon = 1e-6);
}

#[test]
fn dlt_covariance_per_view_nominal() {
    let p = Vec3::new(35.0, -12.0, 40.0);
    let views = five_views(&p);
    // Equal sigmas reproduce the isotropic version; the sum over views is additive.
    let iso = dlt_covariance(&views, &p, 2e-4).unwrap();
    let per = dlt_covariance_per_view(&views, &p, &[2e-4; 5]).unwrap();
    assert_relative_eq!(per, iso, max_relative = 1e-14);
    let sigmas = [1e-4, 3e-4, 0.0, 2e-4, 5e-4];
    let total = dlt_covariance_per_view(&views, &p, &sigmas).unwrap();
    let mut sum = Mat3::zeros();
    for (i, s) in sigmas.iter().enumerate() {
        let mut only = [0.0; 5];
        only[i] = *s;
        sum += dlt_covariance_per_view(&views, &p, &only).unwrap();
    }
    assert_relative_eq!(total, sum, max_relative = 1e-12);
    // Against central differences with each view's columns scaled by its σ.
    let f = |x: &DVector<f64>| {
        let q = dlt(&with_obs(&views, x)).unwrap();
        DVector::from_column_slice(q.as_slice())
    };
    let mut j = central_jacobian(f, &obs_vector(&views), 1e-7);
    for (i, s) in sigmas.iter().enumerate() {
        j.column_mut(2 * i).scale_mut(*s);
        j.column_mut(2 * i + 1).scale_mut(*s);
    }
    let c = &j * j.transpose();
    // FD budget as in `dlt_covariance_finite_difference_noise_free`.
    assert_relative_eq!(
        total,
        Mat3::from_iterator(c.iter().copied()),
        max_relative = 1e-6,
        epsilon = 1e-14
    );
    assert_eq!(
        dlt_covariance_per_view(&views, &p, &[1.0; 4]),
        Err(Error::LengthMismatch { left: 5, right: 4 })
    );
}

fn monte_carlo_covariance(views: &[View], sigma: f64, n: usize, seed: u64) -> Mat3 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pts = Vec::with_capacity(n);
    for _ in 0..n {
        let noisy: Vec<View> = views
            .iter()
            .map(|v| {
                let e = Vector2::new(
                    rng.sample::<f64, _>(StandardNormal),
                    rng.sample::<f64, _>(StandardNormal),
                );
                View {
                    cam_from_world: v.cam_from_world,
                    normalized: v.normalized + e * sigma,
                }
            })
            .collect();
        pts.push(dlt(&noisy).unwrap());
    }
    let mean: Vec3 = pts.iter().sum::<Vec3>() / n as f64;
    pts.iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<Mat3>()
        / (n as f64 - 1.0)
}

fn check_monte_carlo(n: usize) {
    let p = Vec3::new(35.0, -12.0, 40.0);
    let views = five_views(&p);
    // σ = 1e-5 in normalized units (≈ 0.03 px at f = 3000 px): the first order is exact
    // to ~1e-5 relative, so only sampling error remains.
    let sigma = 1e-5;
    let analytic = dlt_covariance(&views, &p, sigma).unwrap();
    let mc = monte_carlo_covariance(&views, sigma, n, 2024);
    // A sample variance has relative standard error √(2/(n−1)); allow 5 of them on the diagonal.
    let rel = 5.0 * (2.0 / (n as f64 - 1.0)).sqrt();
    for i in 0..3 {
        assert_relative_eq!(mc[(i, i)], analytic[(i, i)], max_relative = rel);
    }
    // Off-diagonals in correlation units: standard error ≈ 1/√n.
    for i in 0..3 {
        for j in 0..i {
            let scale = (analytic[(i, i)] * analytic[(j, j)]).sqrt();
            assert_abs_diff_eq!(
                mc[(i, j)] / scale,
                analytic[(i, j)] / scale,
                epsilon = 5.0 / (n as f64).sqrt()
            );
        }
    }
}

#[test]
fn dlt_covariance_monte_carlo_fast() {
    check_monte_carlo(2_000);
}

#[test]
#[ignore = "slow: 200 000 Monte Carlo draws; run by cargo xtask test --slow"]
fn slow_dlt_covariance_monte_carlo() {
    check_monte_carlo(200_000);
}
