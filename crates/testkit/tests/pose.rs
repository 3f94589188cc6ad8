//! Tests of the pose comparison helpers.

use crashrig_geometry::{Rigid3, Vec3};
use crashrig_testkit::pose::{
    PoseMismatch, assert_rigid_near, assert_rigid_near_abs, assert_rot3_near, rigid_near,
    rigid_near_abs,
};
use nalgebra::{Translation3, UnitQuaternion};

fn pose(axis_angle: Vec3, t: Vec3) -> Rigid3 {
    Rigid3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_scaled_axis(axis_angle),
    )
}

#[test]
fn rigid_near_nominal() {
    let a = pose(Vec3::new(0.1, -0.2, 0.3), Vec3::new(100.0, 20.0, -5.0));
    assert_eq!(rigid_near(&a, &a, 0.0, 0.0), Ok(()));
    assert_rigid_near(&a, &a, 1e-15, 1e-15);
}

#[test]
fn rigid_near_rotation_beyond_tolerance() {
    let e = pose(Vec3::new(0.1, -0.2, 0.3), Vec3::new(100.0, 20.0, -5.0));
    let delta = UnitQuaternion::from_scaled_axis(Vec3::new(0.0, 0.0, 1e-3));
    let a = Rigid3::from_parts(e.translation, e.rotation * delta);
    // The angular distance is the 1e-3 rad of `delta`, whatever the base rotation.
    assert_eq!(rigid_near(&a, &e, 1.1e-3, 0.0), Ok(()));
    match rigid_near(&a, &e, 0.9e-3, 0.0) {
        Err(PoseMismatch::Rotation { angle, tol }) => {
            approx::assert_relative_eq!(angle, 1e-3, max_relative = 1e-9);
            approx::assert_relative_eq!(tol, 0.9e-3);
        }
        other => panic!("expected a rotation mismatch, got {other:?}"),
    }
}

#[test]
fn rigid_near_translation_relative() {
    let e = pose(Vec3::zeros(), Vec3::new(1000.0, 0.0, 0.0));
    let a = pose(Vec3::zeros(), Vec3::new(1000.5, 0.0, 0.0));
    // 0.5 mm off a 1000 mm reference: relative 5e-4.
    assert_eq!(rigid_near(&a, &e, 0.0, 6e-4), Ok(()));
    assert!(matches!(
        rigid_near(&a, &e, 0.0, 4e-4),
        Err(PoseMismatch::Translation { .. })
    ));
}

#[test]
fn rigid_near_translation_absolute_at_zero_reference() {
    let e = pose(Vec3::zeros(), Vec3::zeros());
    let a = pose(Vec3::zeros(), Vec3::new(0.0, 3e-7, 0.0));
    assert_eq!(rigid_near(&a, &e, 0.0, 4e-7), Ok(()));
    assert!(matches!(
        rigid_near(&a, &e, 0.0, 2e-7),
        Err(PoseMismatch::Translation { .. })
    ));
}

#[test]
fn rigid_near_abs_nominal() {
    let e = pose(Vec3::new(0.3, 0.0, 0.0), Vec3::new(1000.0, 0.0, 0.0));
    let a = pose(Vec3::new(0.3, 0.0, 0.0), Vec3::new(1000.5, 0.0, 0.0));
    assert_eq!(rigid_near_abs(&a, &e, 1e-12, 0.6), Ok(()));
    assert!(rigid_near_abs(&a, &e, 1e-12, 0.4).is_err());
    assert_rigid_near_abs(&a, &e, 1e-12, 0.6);
}

#[test]
fn rigid_near_nan_never_matches() {
    let e = pose(Vec3::zeros(), Vec3::new(1.0, 2.0, 3.0));
    let nan_t = pose(Vec3::zeros(), Vec3::new(f64::NAN, 2.0, 3.0));
    assert!(rigid_near(&nan_t, &e, 1.0, 1e9).is_err());
    assert!(rigid_near(&e, &nan_t, 1.0, 1e9).is_err());
    let nan_r = Rigid3::from_parts(
        e.translation,
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0)),
    );
    assert!(matches!(
        rigid_near(&nan_r, &e, 10.0, 1e9),
        Err(PoseMismatch::Rotation { .. })
    ));
}

#[test]
fn assert_rigid_near_panics_on_mismatch() {
    let e = pose(Vec3::zeros(), Vec3::new(1.0, 2.0, 3.0));
    let a = pose(Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.0, 2.0, 3.0));
    let caught = std::panic::catch_unwind(|| assert_rigid_near(&a, &e, 1e-3, 1e-3));
    assert!(caught.is_err());
}

#[test]
fn assert_rot3_near_nominal() {
    let a = UnitQuaternion::from_scaled_axis(Vec3::new(0.2, 0.0, -0.1)).to_rotation_matrix();
    let b = a * UnitQuaternion::from_scaled_axis(Vec3::new(0.0, 1e-4, 0.0)).to_rotation_matrix();
    assert_rot3_near(&a, &b, 1.1e-4);
    assert!(std::panic::catch_unwind(|| assert_rot3_near(&a, &b, 0.9e-4)).is_err());
    let nan = crashrig_geometry::Rot3::from_matrix_unchecked(a.matrix() * f64::NAN);
    assert!(std::panic::catch_unwind(|| assert_rot3_near(&nan, &a, 10.0)).is_err());
}
