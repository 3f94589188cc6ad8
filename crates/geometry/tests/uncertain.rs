//! `UncertainPose`: factor, sampling round trip, composition/inversion Jacobians against finite
//! differences and Monte Carlo, covariance validation, ω φ κ display Jacobian.

use crashrig_geometry::uncertain::{
    CovarianceProblem, UncertainPose, check_covariance, psd_factor,
};
use crashrig_geometry::{Mat6, Rigid3, Vec3, Vec6, opk, quat, so3};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

fn pose(rot: [f64; 3], c: [f64; 3]) -> Rigid3 {
    quat::rigid_from_rotation(&so3::exp(&Vec3::from(rot)), &Vec3::from(c))
}

/// A full, correlated SPD covariance (mm, rad) built as A·Aᵀ from fixed numbers.
fn full_cov(scale_mm: f64, scale_rad: f64) -> Mat6 {
    let a = Mat6::from_fn(|i, j| ((i * 7 + j * 3) % 11) as f64 / 10.0 - 0.4);
    let s = Vec6::new(
        scale_mm, scale_mm, scale_mm, scale_rad, scale_rad, scale_rad,
    );
    let m = a * a.transpose() + Mat6::identity() * 0.05;
    Mat6::from_fn(|i, j| m[(i, j)] * s[i] * s[j])
}

fn normal6(rng: &mut rand::rngs::ChaCha8Rng) -> Vec6 {
    Vec6::from_fn(|_, _| StandardNormal.sample(rng))
}

#[test]
fn factor_reproduces_spd_and_semidefinite_covariances() {
    let c = full_cov(1.0, 1e-3);
    let l = psd_factor(&c);
    assert!((l * l.transpose() - c).amax() < 1e-15 * c.amax().max(1.0));
    assert!(
        (0..6).all(|i| (i + 1..6).all(|j| l[(i, j)] == 0.0)),
        "lower triangular"
    );
    // Rank 3: position only, rotation exactly zero → zero columns, no failure.
    let mut semi = Mat6::zeros();
    semi.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&c.fixed_view::<3, 3>(0, 0));
    let l = psd_factor(&semi);
    assert!((l * l.transpose() - semi).amax() < 1e-15);
    // Rank 1 with cross terms: v·vᵀ.
    let v = Vec6::new(1.0, -2.0, 0.5, 1e-3, 0.0, -2e-3);
    let r1 = v * v.transpose();
    let l = psd_factor(&r1);
    assert!(
        (l * l.transpose() - r1).amax() < 1e-12,
        "{}",
        (l * l.transpose() - r1).amax()
    );
    // Diagonal: exactly the σ.
    let d = Mat6::from_diagonal(&Vec6::new(4.0, 9.0, 1.0, 1e-6, 4e-6, 0.0));
    assert_eq!(
        psd_factor(&d).diagonal(),
        Vec6::new(2.0, 3.0, 1.0, 1e-3, 2e-3, 0.0)
    );
}

#[test]
fn validation_names_the_problem() {
    let mut c = full_cov(1.0, 1.0);
    assert_eq!(check_covariance(&c), Ok(()));
    c[(0, 4)] += 0.1;
    assert_eq!(
        check_covariance(&c),
        Err(CovarianceProblem::NotSymmetric(0, 4))
    );
    let neg = Mat6::from_diagonal(&Vec6::new(1.0, 1.0, 1.0, 1.0, 1.0, -0.01));
    assert!(matches!(
        check_covariance(&neg),
        Err(CovarianceProblem::NotPositiveSemiDefinite(l)) if (l + 0.01).abs() < 1e-12
    ));
    let mut nan = Mat6::identity();
    nan[(2, 2)] = f64::NAN;
    assert_eq!(check_covariance(&nan), Err(CovarianceProblem::NonFinite));
    // Rounding-level asymmetry (1e-12 relative) is accepted and symmetrised.
    let mut r = full_cov(1.0, 1.0);
    r[(1, 2)] *= 1.0 + 1e-12;
    let p = UncertainPose::new(Rigid3::identity(), r).unwrap();
    assert_eq!(p.covariance, p.covariance.transpose());
}

#[test]
fn degree_units_round_trip() {
    let c = full_cov(1.0, 1e-3);
    let p = UncertainPose::new(pose([0.1, 0.2, 0.3], [1.0, 2.0, 3.0]), c).unwrap();
    let deg = p.covariance_deg();
    let k = 180.0 / std::f64::consts::PI;
    assert!((deg[(3, 4)] - c[(3, 4)] * k * k).abs() < 1e-15 * deg[(3, 4)].abs().max(1.0));
    assert!((deg[(0, 5)] - c[(0, 5)] * k).abs() < 1e-15);
    assert_eq!(deg[(1, 2)], c[(1, 2)]);
    let back = UncertainPose::from_covariance_deg(p.b_from_a, deg).unwrap();
    assert!((back.covariance - c).amax() < 1e-18);
}

/// Round trip: draw 200 000 samples from Σ, re-estimate. Criterion: every variance within
/// 4 standard errors (SE of a sample variance = σ²·√(2/(n−1))) and every correlation within
/// 4/√n (SE of a correlation near ρ is (1−ρ²)/√n ≤ 1/√n); the mean within 4 SE.
#[test]
fn sample_and_reestimate_round_trip() {
    let c = full_cov(2.0, 0.01);
    let p = UncertainPose::new(pose([0.3, -1.2, 2.0], [61.98, -1.71, 179.76]), c).unwrap();
    let l = p.factor();
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(7);
    let n = 200_000;
    let samples: Vec<Rigid3> = (0..n)
        .map(|_| p.perturbed(&(l * normal6(&mut rng))))
        .collect();
    let est = UncertainPose::from_samples(&samples).unwrap();
    let nf = n as f64;
    for i in 0..6 {
        let v = c[(i, i)];
        let se = v * (2.0 / (nf - 1.0)).sqrt();
        assert!(
            (est.covariance[(i, i)] - v).abs() < 4.0 * se,
            "var {i}: {} vs {v}",
            est.covariance[(i, i)]
        );
        for j in 0..i {
            let rho = c[(i, j)] / (c[(i, i)] * c[(j, j)]).sqrt();
            let r =
                est.covariance[(i, j)] / (est.covariance[(i, i)] * est.covariance[(j, j)]).sqrt();
            assert!(
                (r - rho).abs() < 4.0 / nf.sqrt(),
                "corr {i}{j}: {r} vs {rho}"
            );
        }
    }
    let d = p.tangent_of(&est.b_from_a);
    for i in 0..6 {
        assert!(
            d[i].abs() < 4.0 * (c[(i, i)] / nf).sqrt(),
            "mean {i}: {}",
            d[i]
        );
    }
}

/// Central finite differences of f(δ) in tangent coordinates of the result.
fn numeric_jacobian(f: impl Fn(&Vec6) -> Vec6, h: f64) -> Mat6 {
    let mut j = Mat6::zeros();
    for k in 0..6 {
        let mut e = Vec6::zeros();
        e[k] = h;
        j.set_column(k, &((f(&e) - f(&-e)) / (2.0 * h)));
    }
    j
}

#[test]
fn compose_and_inverse_jacobians_match_finite_differences() {
    let a = UncertainPose::new(
        pose([0.4, -1.3, 2.2], [100.0, -50.0, 20.0]),
        full_cov(1.0, 0.01),
    )
    .unwrap();
    let b = UncertainPose::new(
        pose([-2.0, 0.7, 0.1], [61.98, -1.71, 179.76]),
        full_cov(0.5, 0.02),
    )
    .unwrap();
    let ab = a.compose(&b);
    let (j1, j2) = crashrig_geometry::uncertain::compose_jacobians(&a, &b);
    let n1 = numeric_jacobian(|d| ab.tangent_of(&(a.perturbed(d) * b.b_from_a)), 1e-6);
    let n2 = numeric_jacobian(|d| ab.tangent_of(&(a.b_from_a * b.perturbed(d))), 1e-6);
    assert!((n1 - j1).amax() < 1e-6, "J1\n{n1}\n{j1}");
    assert!((n2 - j2).amax() < 1e-6, "J2\n{n2}\n{j2}");
    // Inverse: Σ' = J Σ Jᵀ with J from finite differences.
    let inv = a.inverse();
    let ni = numeric_jacobian(|d| inv.tangent_of(&a.perturbed(d).inverse()), 1e-6);
    let expect = ni * a.covariance * ni.transpose();
    assert!(
        (inv.covariance - expect).amax() < 1e-6 * expect.amax(),
        "inverse"
    );
    // Inverse of the inverse gives the covariance back exactly to first order.
    assert!((inv.inverse().covariance - a.covariance).amax() < 1e-12 * a.covariance.amax());
}

/// Monte Carlo of the composition: 100 000 joint draws, covariance of the composed pose within
/// 4 standard errors on the diagonal of the first-order result (σ small, so first order holds
/// to ~1e-4 relative, far below 4 SE ≈ 1.8 %).
#[test]
fn compose_matches_monte_carlo() {
    let a = UncertainPose::new(
        pose([0.4, -1.3, 2.2], [100.0, -50.0, 20.0]),
        full_cov(1.0, 1e-3),
    )
    .unwrap();
    let b = UncertainPose::new(
        pose([-2.0, 0.7, 0.1], [600.0, -100.0, 1700.0]),
        full_cov(0.5, 2e-3),
    )
    .unwrap();
    let ab = a.compose(&b);
    let (la, lb) = (a.factor(), b.factor());
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(11);
    let n = 100_000;
    let samples: Vec<Rigid3> = (0..n)
        .map(|_| {
            let da = la * normal6(&mut rng);
            let db = lb * normal6(&mut rng);
            a.perturbed(&da) * b.perturbed(&db)
        })
        .collect();
    let mc = UncertainPose::from_samples(&samples).unwrap();
    for i in 0..6 {
        let v = ab.covariance[(i, i)];
        let se = v * (2.0 / (n as f64 - 1.0)).sqrt();
        assert!(
            (mc.covariance[(i, i)] - v).abs() < 4.0 * se,
            "{i}: {} vs {v}",
            mc.covariance[(i, i)]
        );
    }
}

#[test]
fn opk_jacobian_matches_finite_differences() {
    let p =
        UncertainPose::new(pose([0.2, -1.1, 0.9], [0.0, 0.0, 0.0]), full_cov(1.0, 1e-3)).unwrap();
    let j = p.opk_jacobian().unwrap();
    let opk3 = |r: &Rigid3| {
        let o = opk::opk_from_rotation(&r.rotation.to_rotation_matrix());
        Vec3::new(o.omega, o.phi, o.kappa)
    };
    let f = |d: &Vec6| {
        let q = p.perturbed(d);
        let o = opk3(&q) - opk3(&p.b_from_a);
        let c = q.translation.vector - p.center();
        Vec6::new(c.x, c.y, c.z, o.x, o.y, o.z)
    };
    let n = numeric_jacobian(f, 1e-7);
    assert!((n - j).amax() < 1e-6, "\n{n}\n{j}");
    // Near φ = 90° ω φ κ are singular and the display Jacobian says so.
    let lock = UncertainPose::certain(quat::rigid_from_rotation(
        &opk::rotation_from_opk(0.3, std::f64::consts::FRAC_PI_2, 0.1),
        &Vec3::zeros(),
    ));
    assert!(lock.opk_jacobian().is_err());
}

#[test]
fn from_samples_rejects_too_few_and_non_finite() {
    assert!(UncertainPose::from_samples(&[Rigid3::identity()]).is_err());
    let mut bad = Rigid3::identity();
    bad.translation.vector.x = f64::NAN;
    assert!(UncertainPose::from_samples(&[Rigid3::identity(), bad]).is_err());
}
