//! SO(3): exp/log round trips, known answers, Jacobians against central differences.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::tolerance::SO3_SERIES_ANGLE;
use crashrig_geometry::{Mat3, Rot3, Vec3, so3};
use crashrig_testkit::strategies::{rot3, rotation_vector, rotation_vector_any, vec3_in};
use std::f64::consts::{FRAC_PI_2, PI};

/// Central-difference step for Jacobians of O(1) functions: truncation h² ≈ 1e-12 and
/// rounding ε/h ≈ 2e-11, so agreement to ~1e-9 is expected.
const H: f64 = 1e-5;
/// Tolerance for analytic vs central-difference Jacobians (see [`H`]).
const FD_TOL: f64 = 1e-8;

fn fd_columns(f: impl Fn(&Vec3) -> Vec3) -> Mat3 {
    let mut m = Mat3::zeros();
    for i in 0..3 {
        let mut e = Vec3::zeros();
        e[i] = H;
        m.set_column(i, &((f(&e) - f(&-e)) / (2.0 * H)));
    }
    m
}

#[test]
fn hat_nominal() {
    let w = Vec3::new(1.0, -2.0, 3.0);
    let v = Vec3::new(0.5, 4.0, -1.0);
    assert_relative_eq!(so3::hat(&w) * v, w.cross(&v), epsilon = 1e-15);
    assert_relative_eq!(so3::vee(&so3::hat(&w)), w, epsilon = 0.0);
}

#[test]
fn exp_nominal_rx90() {
    // Hand-written Rx(90°).
    let expected = Mat3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
    let r = so3::exp(&Vec3::new(FRAC_PI_2, 0.0, 0.0));
    // cos(π/2) ≈ 6e-17 in f64.
    assert_abs_diff_eq!(*r.matrix(), expected, epsilon = 1e-15);
}

#[test]
fn exp_zero_is_identity() {
    assert_abs_diff_eq!(
        *so3::exp(&Vec3::zeros()).matrix(),
        Mat3::identity(),
        epsilon = 0.0
    );
    assert_abs_diff_eq!(so3::log(&Rot3::identity()), Vec3::zeros(), epsilon = 0.0);
}

#[test]
fn log_at_pi() {
    // Rx(π) exactly: the angle must be π and the axis ±x (both are valid logarithms).
    let r = Rot3::from_matrix_unchecked(Mat3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0));
    let w = so3::log(&r);
    assert_relative_eq!(w.norm(), PI, epsilon = 1e-15);
    assert_relative_eq!(w.x.abs(), PI, epsilon = 1e-15);
    assert_abs_diff_eq!(*so3::exp(&w).matrix(), *r.matrix(), epsilon = 1e-15);
}

#[test]
fn log_tiny_angle() {
    // 1e-10 rad: series branches, relative accuracy to a few ulps.
    let w = Vec3::new(1e-10, -2e-10, 0.5e-10);
    assert_relative_eq!(so3::log(&so3::exp(&w)), w, max_relative = 1e-12);
}

#[test]
fn jacobians_continuous_at_series_switch() {
    let axis = Vec3::new(0.48, -0.6, 0.64);
    let below = axis * (SO3_SERIES_ANGLE * (1.0 - 1e-15));
    let above = axis * (SO3_SERIES_ANGLE * (1.0 + 1e-15));
    assert!(below.norm() < SO3_SERIES_ANGLE && above.norm() >= SO3_SERIES_ANGLE);
    // The two branches must agree to the closed form's cancellation error (~ε/θ² · θ² = ε);
    // the Jacobians themselves change by only ~1e-16 over the 2e-16 rad between the points.
    for f in [
        so3::right_jacobian,
        so3::right_jacobian_inv,
        so3::left_jacobian,
        so3::left_jacobian_inv,
    ] {
        assert_abs_diff_eq!(f(&below), f(&above), epsilon = 2e-15);
    }
}

#[test]
fn right_jacobian_known_relations() {
    let w = Vec3::new(0.3, -1.2, 2.0);
    // Jl(w) = Jr(w)ᵀ = Jr(−w); rounding only.
    assert_relative_eq!(
        so3::left_jacobian(&w),
        so3::right_jacobian(&w).transpose(),
        epsilon = 1e-15
    );
    assert_relative_eq!(
        so3::left_jacobian(&w),
        so3::right_jacobian(&-w),
        epsilon = 1e-15
    );
    assert_relative_eq!(
        so3::right_jacobian(&w) * so3::right_jacobian_inv(&w),
        Mat3::identity(),
        epsilon = 1e-14
    );
    assert_relative_eq!(
        so3::left_jacobian(&w) * so3::left_jacobian_inv(&w),
        Mat3::identity(),
        epsilon = 1e-14
    );
}

/// Angles where the central differences are checked: tiny, inside the series, moderate and
/// close to (but not at) π, where Log is still smooth.
fn fd_points() -> Vec<Vec3> {
    let axis = Vec3::new(2.0, -1.0, 0.5).normalize();
    [1e-9, 1e-3, 0.05, 0.5, 1.5, 3.0]
        .into_iter()
        .map(|a| axis * a)
        .collect()
}

#[test]
fn right_jacobian_finite_difference() {
    for w in fd_points() {
        let r0_inv = so3::exp(&w).inverse();
        let numeric = fd_columns(|d| so3::log(&(r0_inv * so3::exp(&(w + d)))));
        assert_abs_diff_eq!(so3::right_jacobian(&w), numeric, epsilon = FD_TOL);
    }
}

#[test]
fn left_jacobian_finite_difference() {
    for w in fd_points() {
        let r0_inv = so3::exp(&w).inverse();
        let numeric = fd_columns(|d| so3::log(&(so3::exp(&(w + d)) * r0_inv)));
        assert_abs_diff_eq!(so3::left_jacobian(&w), numeric, epsilon = FD_TOL);
    }
}

#[test]
fn right_jacobian_inv_finite_difference() {
    // d/dδ Log(Exp(w)·Exp(δ)) at δ = 0 is Jr⁻¹(w).
    for w in fd_points() {
        let r0 = so3::exp(&w);
        let numeric = fd_columns(|d| so3::log(&(r0 * so3::exp(d))));
        assert_abs_diff_eq!(so3::right_jacobian_inv(&w), numeric, epsilon = FD_TOL);
    }
}

#[test]
fn left_jacobian_inv_finite_difference() {
    // d/dδ Log(Exp(δ)·Exp(w)) at δ = 0 is Jl⁻¹(w).
    for w in fd_points() {
        let r0 = so3::exp(&w);
        let numeric = fd_columns(|d| so3::log(&(so3::exp(d) * r0)));
        assert_abs_diff_eq!(so3::left_jacobian_inv(&w), numeric, epsilon = FD_TOL);
    }
}

#[test]
fn angular_distance_nominal() {
    let a = so3::exp(&Vec3::new(0.1, 0.2, -0.3));
    let b = a * so3::exp(&Vec3::new(0.0, 0.25, 0.0));
    assert_relative_eq!(so3::angular_distance(&a, &b), 0.25, epsilon = 1e-14);
}

proptest::proptest! {
    #[test]
    fn log_exp_round_trip(w in rotation_vector_any()) {
        // Angles up to π − 1e-12: the quaternion route keeps ~1e-15 absolute accuracy.
        assert_abs_diff_eq!(so3::log(&so3::exp(&w)), w, epsilon = 1e-13);
    }

    #[test]
    fn exp_log_round_trip(r in rot3()) {
        assert_abs_diff_eq!(*so3::exp(&so3::log(&r)).matrix(), *r.matrix(), epsilon = 1e-14);
        proptest::prop_assert!(so3::log(&r).norm() <= PI + 1e-15);
    }

    #[test]
    fn exp_is_orthonormal(w in vec3_in(10.0)) {
        let m = *so3::exp(&w).matrix();
        assert_abs_diff_eq!(m.transpose() * m, Mat3::identity(), epsilon = 1e-14);
        assert_relative_eq!(m.determinant(), 1.0, epsilon = 1e-14);
    }

    #[test]
    fn exp_of_negative_is_inverse(w in rotation_vector_any()) {
        assert_abs_diff_eq!(*(so3::exp(&w) * so3::exp(&-w)).matrix(), Mat3::identity(), epsilon = 1e-14);
    }

    #[test]
    fn right_jacobian_finite_difference_random(w in rotation_vector(1e-4, 3.0)) {
        let r0_inv = so3::exp(&w).inverse();
        let numeric = fd_columns(|d| so3::log(&(r0_inv * so3::exp(&(w + d)))));
        assert_abs_diff_eq!(so3::right_jacobian(&w), numeric, epsilon = FD_TOL);
    }
}
