//! Rotation means: known answers, invariance, optimality, errors.

use approx::assert_abs_diff_eq;
use crashrig_geometry::mean::{chordal_mean, karcher_mean, nearest_rotation};
use crashrig_geometry::{Error, Mat3, Rot3, Vec3, so3};
use crashrig_testkit::strategies::{rot3, rotation_vector};
use proptest::prelude::*;

/// Karcher stopping tolerance (rad) used in the tests.
const KARCHER_TOL: f64 = 1e-14;

#[test]
fn chordal_mean_nominal_same_axis() {
    let axis = Vec3::new(1.0, 2.0, -0.5).normalize();
    let rs = [so3::exp(&(axis * 0.2)), so3::exp(&(axis * 0.6))];
    // Two rotations about one axis: both means are the rotation by the mid angle.
    let mid = so3::exp(&(axis * 0.4));
    assert_abs_diff_eq!(
        so3::angular_distance(&chordal_mean(&rs).unwrap(), &mid),
        0.0,
        epsilon = 1e-14
    );
    assert_abs_diff_eq!(
        so3::angular_distance(&karcher_mean(&rs, KARCHER_TOL, 50).unwrap(), &mid),
        0.0,
        epsilon = 1e-14
    );
}

#[test]
fn chordal_mean_single() {
    let r = so3::exp(&Vec3::new(0.3, -2.0, 1.0));
    assert_abs_diff_eq!(
        so3::angular_distance(&chordal_mean(&[r]).unwrap(), &r),
        0.0,
        epsilon = 1e-14
    );
}

#[test]
fn nearest_rotation_nominal() {
    let r = so3::exp(&Vec3::new(0.4, -2.2, 1.0));
    // A rotation scaled and slightly sheared projects back onto (nearly) itself.
    let m = r.matrix() * 3.0 + Mat3::new(0.0, 1e-9, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let p = nearest_rotation(&m).unwrap();
    assert_abs_diff_eq!(so3::angular_distance(&p, &r), 0.0, epsilon = 1e-9);
    assert_abs_diff_eq!(p.matrix().determinant(), 1.0, epsilon = 1e-14);
    // A reflection is mapped to a proper rotation.
    let reflection = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0)) * r.matrix();
    assert_abs_diff_eq!(
        nearest_rotation(&reflection)
            .unwrap()
            .matrix()
            .determinant(),
        1.0,
        epsilon = 1e-14
    );
    assert!(matches!(
        nearest_rotation(&Mat3::zeros()),
        Err(Error::Degenerate { .. })
    ));
    assert!(matches!(
        nearest_rotation(&(Mat3::identity() * f64::NAN)),
        Err(Error::NonFinite { .. })
    ));
}

#[test]
fn mean_errors() {
    assert!(matches!(
        chordal_mean(&[]),
        Err(Error::TooFewSamples { .. })
    ));
    assert!(matches!(
        karcher_mean(&[], 1e-12, 10),
        Err(Error::TooFewSamples { .. })
    ));
    // R + R·Rx(π) = R·diag(2, 0, 0): rank 1, no unique projection.
    let r = so3::exp(&Vec3::new(0.1, 0.2, 0.3));
    let flipped = r * so3::exp(&Vec3::new(std::f64::consts::PI, 0.0, 0.0));
    assert!(matches!(
        chordal_mean(&[r, flipped]),
        Err(Error::Degenerate { .. })
    ));
}

#[test]
fn karcher_mean_no_convergence_reported() {
    let rs = [
        so3::exp(&Vec3::new(0.0, 0.0, 0.3)),
        so3::exp(&Vec3::new(0.4, 0.0, 0.0)),
        Rot3::identity(),
    ];
    assert!(matches!(
        karcher_mean(&rs, 0.0, 3),
        Err(Error::NoConvergence { iterations: 3, .. })
    ));
}

proptest! {
    #[test]
    fn means_left_invariant(
        q in rot3(),
        center in rot3(),
        spread in proptest::collection::vec(rotation_vector(0.0, 0.8), 3..8),
    ) {
        let rs: Vec<Rot3> = spread.iter().map(|w| center * so3::exp(w)).collect();
        let qrs: Vec<Rot3> = rs.iter().map(|r| q * r).collect();
        // SVD and a few Karcher steps: rounding ~1e-15 per step.
        let c0 = chordal_mean(&rs).unwrap();
        let c1 = chordal_mean(&qrs).unwrap();
        assert_abs_diff_eq!(so3::angular_distance(&(q * c0), &c1), 0.0, epsilon = 1e-12);
        let k0 = karcher_mean(&rs, KARCHER_TOL, 100).unwrap();
        let k1 = karcher_mean(&qrs, KARCHER_TOL, 100).unwrap();
        assert_abs_diff_eq!(so3::angular_distance(&(q * k0), &k1), 0.0, epsilon = 1e-12);
    }

    #[test]
    fn karcher_mean_is_stationary(
        center in rot3(),
        spread in proptest::collection::vec(rotation_vector(0.0, 1.0), 2..8),
    ) {
        let rs: Vec<Rot3> = spread.iter().map(|w| center * so3::exp(w)).collect();
        let k = karcher_mean(&rs, KARCHER_TOL, 100).unwrap();
        // First-order optimality of the geodesic mean: Σ Log(R̄ᵀ R_i) = 0.
        let g: Vec3 = rs.iter().map(|r| so3::log(&(k.inverse() * r))).sum();
        assert_abs_diff_eq!(g, Vec3::zeros(), epsilon = 1e-12);
    }
}
