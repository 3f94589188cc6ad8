//! The COLMAP quaternion edge: w, x, y, z order, normalisation, errors.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::{Error, Mat3, quat};
use crashrig_testkit::pose::assert_rigid_near_abs;
use crashrig_testkit::strategies::rigid3;

#[test]
fn rotation_from_wxyz_nominal() {
    // 90° about x: w = cos 45°, x = sin 45°.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let q = quat::rotation_from_wxyz([h, h, 0.0, 0.0]).unwrap();
    let rx = Mat3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
    assert_abs_diff_eq!(q.to_rotation_matrix().into_inner(), rx, epsilon = 1e-15);
}

#[test]
fn rotation_from_wxyz_order() {
    // [0, 0, 1, 0] is 180° about y (not about x, as an x,y,z,w reading would give).
    let q = quat::rotation_from_wxyz([0.0, 0.0, 1.0, 0.0]).unwrap();
    let ry180 = Mat3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0);
    assert_abs_diff_eq!(q.to_rotation_matrix().into_inner(), ry180, epsilon = 1e-15);
    assert_eq!(quat::wxyz_from_rotation(&q), [0.0, 0.0, 1.0, 0.0]);
}

#[test]
fn rotation_from_wxyz_normalises() {
    let q = quat::rotation_from_wxyz([2.0, 0.0, 0.0, 0.0]).unwrap();
    assert_relative_eq!(q.w, 1.0, epsilon = 0.0);
    let q = quat::rotation_from_wxyz([1.0, 1.0, 1.0, 1.0]).unwrap();
    assert_relative_eq!(q.into_inner().norm(), 1.0, epsilon = 1e-15);
}

#[test]
fn rotation_from_wxyz_rejects_zero_and_nan() {
    assert_eq!(
        quat::rotation_from_wxyz([0.0; 4]),
        Err(Error::NonUnitQuaternion { norm: 0.0 })
    );
    assert!(matches!(
        quat::rotation_from_wxyz([f64::NAN, 0.0, 0.0, 1.0]),
        Err(Error::NonUnitQuaternion { .. })
    ));
    assert!(matches!(
        quat::rotation_from_wxyz([f64::INFINITY, 0.0, 0.0, 1.0]),
        Err(Error::NonUnitQuaternion { .. })
    ));
}

#[test]
fn rigid_from_colmap_rejects_nan_translation() {
    assert!(matches!(
        quat::rigid_from_colmap([1.0, 0.0, 0.0, 0.0], [0.0, f64::NAN, 0.0]),
        Err(Error::NonFinite { .. })
    ));
}

proptest::proptest! {
    #[test]
    fn colmap_round_trip(t in rigid3()) {
        let (q, tr) = quat::colmap_from_rigid(&t);
        let back = quat::rigid_from_colmap(q, tr).unwrap();
        // Re-normalising a unit quaternion changes it by ≤ 1 ulp; the angular distance goes through matrices (a few ulps).
        assert_rigid_near_abs(&back, &t, 1e-14, 0.0);
    }
}
