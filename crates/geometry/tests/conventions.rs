//! The worked examples of docs/CONVENTIONS.md, pinned so the document stays true.

use approx::assert_abs_diff_eq;
use crashrig_geometry::angles::wrapped_stats;
use crashrig_geometry::look_at::world_from_cam_look_at;
use crashrig_geometry::opk::{opk_from_rotation, rotation_from_opk};
use crashrig_geometry::{Mat3, Rigid3, Vec3, projection_center};
use nalgebra::{Translation3, UnitQuaternion};

#[test]
fn conventions_projection_centre_example() {
    // cam_from_world with R = I, t = (0, 0, 5): centre (0, 0, −5).
    let p = Rigid3::from_parts(Translation3::new(0.0, 0.0, 5.0), UnitQuaternion::identity());
    assert_abs_diff_eq!(
        projection_center(&p),
        Vec3::new(0.0, 0.0, -5.0),
        epsilon = 0.0
    );
}

#[test]
fn conventions_paper_link_matrix() {
    // The matrix printed in CONVENTIONS.md, to its 6 decimals.
    let r = rotation_from_opk(
        179.92f64.to_radians(),
        (-0.09f64).to_radians(),
        179.76f64.to_radians(),
    );
    let printed = Mat3::new(
        -0.999990, -0.004189, -0.001571, //
        -0.004187, 0.999990, -0.001396, //
        0.001577, -0.001390, -0.999998,
    );
    assert_abs_diff_eq!(*r.matrix(), printed, epsilon = 5e-7);
}

#[test]
fn conventions_level_camera_along_x_is_gimbal_locked() {
    let r = world_from_cam_look_at(&Vec3::zeros(), &Vec3::new(1000.0, 0.0, 0.0)).unwrap();
    let expected = Mat3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    assert_abs_diff_eq!(*r.matrix(), expected, epsilon = 0.0);
    // = Rx(−90°)·Ry(90°), at φ = 90°: gimbal lock is flagged.
    let rx_ry = rotation_from_opk((-90f64).to_radians(), 90f64.to_radians(), 0.0);
    assert_abs_diff_eq!(*rx_ry.matrix(), expected, epsilon = 1e-15);
    assert!(opk_from_rotation(&r).gimbal_lock);
}

#[test]
fn conventions_wrap_safe_example() {
    // 179.95° and −179.97°: circular mean 179.99°, σ = 0.0566° (differences ±0.04°).
    let s = wrapped_stats(&[179.95f64.to_radians(), (-179.97f64).to_radians()]).unwrap();
    assert_abs_diff_eq!(s.mean.to_degrees(), 179.99, epsilon = 1e-9);
    assert_abs_diff_eq!(s.sigma.to_degrees(), 0.04 * 2f64.sqrt(), epsilon = 1e-9);
}
