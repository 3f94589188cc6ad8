//! SE(3): exp/log round trips, group laws, adjoint.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::{Mat6, Rigid3, Vec3, Vec6, projection_center, se3};
use crashrig_testkit::pose::assert_rigid_near_abs;
use crashrig_testkit::strategies::{rigid3, se3_tangent};
use nalgebra::{Point3, Translation3, UnitQuaternion};

#[test]
fn exp_nominal_pure_translation() {
    let t = se3::exp(&Vec6::new(0.0, 0.0, 0.0, 1.0, 2.0, 3.0));
    assert_rigid_near_abs(&t, &Rigid3::translation(1.0, 2.0, 3.0), 0.0, 0.0);
}

#[test]
fn exp_known_screw() {
    // ω = π/2 about z, v = (1, 0, 0): t = Jl(ω)·v = ((sin θ)/θ, (1 − cos θ)/θ, 0) = (2/π, 2/π, 0).
    let t = se3::exp(&Vec6::new(
        0.0,
        0.0,
        std::f64::consts::FRAC_PI_2,
        1.0,
        0.0,
        0.0,
    ));
    let c = 2.0 / std::f64::consts::PI;
    assert_relative_eq!(t.translation.vector, Vec3::new(c, c, 0.0), epsilon = 1e-15);
}

#[test]
fn projection_center_nominal() {
    // R = Rz(90°), t = (1, 2, 3): Rᵀt = (2, −1, 3), so C = (−2, 1, −3).
    let cam_from_world = Rigid3::from_parts(
        Translation3::new(1.0, 2.0, 3.0),
        UnitQuaternion::from_axis_angle(&Vec3::z_axis(), std::f64::consts::FRAC_PI_2),
    );
    let c = projection_center(&cam_from_world);
    assert_relative_eq!(c, Vec3::new(-2.0, 1.0, -3.0), epsilon = 1e-15);
    assert_abs_diff_eq!(
        (cam_from_world * Point3::from(c)).coords,
        Vec3::zeros(),
        epsilon = 1e-15
    );
}

#[test]
fn adjoint_nominal_block_structure() {
    let t = Rigid3::from_parts(
        Translation3::new(1.0, -2.0, 0.5),
        UnitQuaternion::from_scaled_axis(Vec3::new(0.2, 0.1, -0.3)),
    );
    let ad = se3::adjoint(&t);
    let r = t.rotation.to_rotation_matrix().into_inner();
    assert_relative_eq!(ad.fixed_view::<3, 3>(0, 0).into_owned(), r, epsilon = 0.0);
    assert_abs_diff_eq!(
        ad.fixed_view::<3, 3>(0, 3).into_owned(),
        nalgebra::Matrix3::zeros(),
        epsilon = 0.0
    );
    assert_relative_eq!(ad.fixed_view::<3, 3>(3, 3).into_owned(), r, epsilon = 0.0);
}

#[test]
fn adjoint_finite_difference() {
    // Ad(T) = d/dξ Log(T·Exp(ξ)·T⁻¹) at ξ = 0. Translation ~1e3 mm, h = 1e-5:
    // rounding ≈ ε·1e3/h ≈ 2e-8, so compare to 1e-6.
    let t = Rigid3::from_parts(
        Translation3::new(800.0, -200.0, 350.0),
        UnitQuaternion::from_scaled_axis(Vec3::new(0.7, -1.1, 0.4)),
    );
    let h = 1e-5;
    let mut numeric = Mat6::zeros();
    for i in 0..6 {
        let mut e = Vec6::zeros();
        e[i] = h;
        let f = |x: &Vec6| se3::log(&(t * se3::exp(x) * t.inverse()));
        numeric.set_column(i, &((f(&e) - f(&-e)) / (2.0 * h)));
    }
    assert_abs_diff_eq!(se3::adjoint(&t), numeric, epsilon = 1e-6);
}

proptest::proptest! {
    #[test]
    fn log_exp_round_trip(xi in se3_tangent(1000.0)) {
        // Translation up to 1e3 mm; Jl⁻¹ grows like 1/(π − θ) near π: 1e-9 relative is ample.
        let back = se3::log(&se3::exp(&xi));
        assert_relative_eq!(back, xi, epsilon = 1e-9, max_relative = 1e-9);
    }

    #[test]
    fn exp_log_round_trip(t in rigid3()) {
        assert_rigid_near_abs(&se3::exp(&se3::log(&t)), &t, 1e-13, 1e-9);
    }

    #[test]
    fn inverse_laws(t in rigid3()) {
        let id = Rigid3::identity();
        // |t| ≤ 1.8e4 mm: ε·|t| ≈ 4e-12 mm per operation, a few operations.
        assert_rigid_near_abs(&(t * t.inverse()), &id, 1e-14, 5e-11);
        assert_rigid_near_abs(&(t.inverse() * t), &id, 1e-14, 5e-11);
        assert_rigid_near_abs(&t.inverse().inverse(), &t, 1e-15, 5e-11);
    }

    #[test]
    fn exp_of_negative_is_inverse(xi in se3_tangent(1000.0)) {
        assert_rigid_near_abs(&se3::exp(&-xi), &se3::exp(&xi).inverse(), 1e-13, 1e-9);
    }

    #[test]
    fn composition_associative(a in rigid3(), b in rigid3(), c in rigid3()) {
        // Three poses up to 1e4 mm: rounding ~1e-11 mm.
        assert_rigid_near_abs(&((a * b) * c), &(a * (b * c)), 1e-14, 1e-10);
    }

    #[test]
    fn adjoint_conjugation(t in rigid3(), xi in se3_tangent(10.0)) {
        // T·Exp(ξ)·T⁻¹ = Exp(Ad(T)·ξ); translations up to ~1e4 mm.
        let lhs = t * se3::exp(&xi) * t.inverse();
        let rhs = se3::exp(&(se3::adjoint(&t) * xi));
        assert_rigid_near_abs(&lhs, &rhs, 1e-9, 1e-7);
    }

    #[test]
    fn adjoint_of_inverse(t in rigid3()) {
        let prod = se3::adjoint(&t) * se3::adjoint(&t.inverse());
        assert_abs_diff_eq!(prod, Mat6::identity(), epsilon = 1e-10);
    }
}
