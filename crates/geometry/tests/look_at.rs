//! Look-at: known matrix, down-pointing y axis, errors.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::look_at::world_from_cam_look_at;
use crashrig_geometry::{Error, Mat3, Vec3};
use crashrig_testkit::strategies::vec3_in;
use proptest::prelude::*;

#[test]
fn look_at_nominal_along_x() {
    // Camera at the origin looking along +x, world z up: x_cam = −y_world (right),
    // y_cam = −z_world (down), z_cam = +x_world. Columns are the camera axes in world.
    let expected = Mat3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    let r = world_from_cam_look_at(&Vec3::zeros(), &Vec3::new(5.0, 0.0, 0.0)).unwrap();
    assert_abs_diff_eq!(*r.matrix(), expected, epsilon = 0.0);
}

#[test]
fn look_at_errors() {
    let c = Vec3::new(1.0, 2.0, 3.0);
    assert_eq!(world_from_cam_look_at(&c, &c), Err(Error::ZeroDirection));
    assert!(matches!(
        world_from_cam_look_at(&c, &Vec3::new(1.0, 2.0, -10.0)),
        Err(Error::Degenerate { .. })
    ));
    assert!(matches!(
        world_from_cam_look_at(&c, &Vec3::new(f64::NAN, 2.0, -10.0)),
        Err(Error::NonFinite { .. })
    ));
}

proptest! {
    #[test]
    fn look_at_properties(c in vec3_in(3000.0), t in vec3_in(3000.0)) {
        let d = t - c;
        prop_assume!(d.norm() > 1.0 && d.normalize().cross(&Vec3::z()).norm() > 1e-3);
        let r = world_from_cam_look_at(&c, &t).unwrap();
        let m = *r.matrix();
        // Orthonormal, right-handed: rounding only.
        assert_abs_diff_eq!(m.transpose() * m, Mat3::identity(), epsilon = 1e-14);
        assert_relative_eq!(m.determinant(), 1.0, epsilon = 1e-14);
        // Optical axis through the target.
        assert_abs_diff_eq!(m.column(2).into_owned(), d.normalize(), epsilon = 1e-15);
        // No roll: x horizontal; y points down.
        assert_abs_diff_eq!(m[(2, 0)], 0.0, epsilon = 1e-15);
        prop_assert!(m[(2, 1)] < 0.0);
    }
}
