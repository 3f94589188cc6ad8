//! One reprojection residual and its exact Jacobians.
//!
//! An image belongs to a frame; the frame's pose is the unknown. Its tangent is the contract's
//! (`docs/REFERENCE.md`, the tangent covariance of `docs/CONVENTIONS.md`) for `world_from_rig`: the rig centre moves in
//! world axes, the rotation is `R̄_world_from_rig · Exp(δθ)` about the rig's own axes. For a
//! legacy model (one frame per image, trivial rig) this is exactly `world_from_cam`'s tangent.
//! The image's `sensor_from_rig` is held at its model value.
//!
//! With `x_rig = R_rig_from_world · (X − C_rig)` and `x_cam = R_s · x_rig + t_s`:
//! `∂x_cam/∂δC = −R_s·R_rig_from_world`, `∂x_cam/∂δθ = R_s·[x_rig]×`,
//! `∂x_cam/∂X = R_s·R_rig_from_world`; the pixel's Jacobians follow through the camera model's
//! exact point and parameter Jacobians ([`crashrig_camera::Camera::dx_img_from_cam_point`],
//! [`crashrig_camera::Camera::dx_img_from_params`]).

use crashrig_camera::{Camera, ProjectionReject};
use crashrig_geometry::{Mat3, Rigid3, Vec3, Vec6, so3};
use nalgebra::{Matrix2x3, Matrix2xX, SMatrix, Vector2};

/// 2×6 Jacobian of a pixel with respect to a pose tangent.
pub type Matrix2x6 = SMatrix<f64, 2, 6>;

/// The predicted pixel of one observation and its Jacobians.
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// Predicted pixel (COLMAP convention).
    pub pixel: Vector2<f64>,
    /// With respect to the frame's tangent `(δC, δθ)` (model units, rad).
    pub d_pose: Matrix2x6,
    /// With respect to the 3-D point (model units).
    pub d_point: Matrix2x3<f64>,
    /// With respect to every camera parameter (COLMAP order).
    pub d_params: Matrix2xX<f64>,
}

/// `rig_from_world` after the tangent perturbation `delta` (model units, rad).
pub fn perturbed_rig_from_world(rig_from_world: &Rigid3, delta: &Vec6) -> Rigid3 {
    crashrig_geometry::UncertainPose::certain(rig_from_world.inverse())
        .perturbed(delta)
        .inverse()
}

/// The predicted pixel of `x_world` seen by `camera` mounted at `sensor_from_rig` on a rig at
/// `rig_from_world`, with its Jacobians.
///
/// # Errors
/// The camera model's [`ProjectionReject`] (behind the camera, outside the model's domain).
pub fn project(
    camera: &Camera,
    sensor_from_rig: &Rigid3,
    rig_from_world: &Rigid3,
    x_world: &Vec3,
) -> Result<Projection, ProjectionReject> {
    let r_rw: Mat3 = rig_from_world.rotation.to_rotation_matrix().into_inner();
    let r_s: Mat3 = sensor_from_rig.rotation.to_rotation_matrix().into_inner();
    let x_rig = rig_from_world * nalgebra::Point3::from(*x_world);
    let x_cam = sensor_from_rig * x_rig;
    let x_cam = x_cam.coords;
    let pixel = camera.img_from_cam(&x_cam)?;
    let j_x = camera.dx_img_from_cam_point(&x_cam)?;
    let d_params = camera.dx_img_from_params(&x_cam)?;
    let d_point_cam = r_s * r_rw;
    let d_point = j_x * d_point_cam;
    let mut d_pose = Matrix2x6::zeros();
    d_pose.fixed_view_mut::<2, 3>(0, 0).copy_from(&(-d_point));
    d_pose
        .fixed_view_mut::<2, 3>(0, 3)
        .copy_from(&(j_x * r_s * so3::hat(&x_rig.coords)));
    Ok(Projection {
        pixel,
        d_pose,
        d_point,
        d_params,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_camera::ModelId;
    use crashrig_geometry::quat::rigid_from_rotation;

    fn fd<const N: usize>(
        f: impl Fn(&[f64; N]) -> Vector2<f64>,
        x0: [f64; N],
        h: f64,
    ) -> Matrix2xX<f64> {
        let mut j = Matrix2xX::zeros(N);
        for k in 0..N {
            let mut a = x0;
            let mut b = x0;
            a[k] += h;
            b[k] -= h;
            j.set_column(k, &((f(&a) - f(&b)) / (2.0 * h)));
        }
        j
    }

    fn cameras() -> Vec<Camera> {
        ModelId::ALL
            .iter()
            .filter(|m| **m != ModelId::Equirectangular)
            .map(|&m| {
                let params: Vec<f64> = m
                    .param_names()
                    .iter()
                    .enumerate()
                    .map(|(i, n)| match *n {
                        "f" | "fx" => 800.0,
                        "fy" => 810.0,
                        "cx" => 320.5,
                        "cy" => 240.25,
                        "omega" => 0.3,
                        "alpha" => 0.6,
                        "beta" => 1.1,
                        _ => 0.01 * (i as f64 - 5.0),
                    })
                    .collect();
                Camera::new(m, 640, 480, params).unwrap()
            })
            .collect()
    }

    /// Every Jacobian block against central differences, for every camera model, with a rig
    /// whose sensor is not at its origin.
    #[test]
    fn jacobians_match_central_differences() {
        let rig_from_world = rigid_from_rotation(
            &so3::exp(&Vec3::new(0.2, -0.3, 0.1)),
            &Vec3::new(0.3, -0.2, 1.0),
        );
        let sensor_from_rig = rigid_from_rotation(
            &so3::exp(&Vec3::new(-0.05, 0.1, 0.02)),
            &Vec3::new(0.1, 0.05, -0.2),
        );
        let x = Vec3::new(0.4, 0.3, 4.0);
        for cam in cameras() {
            let p = project(&cam, &sensor_from_rig, &rig_from_world, &x).unwrap();
            let px = |c: &Camera, r: &Rigid3, x: &Vec3| {
                project(c, &sensor_from_rig, r, x).unwrap().pixel
            };
            let scale = p.d_pose.abs().max().max(1.0);
            let jp = fd(
                |d: &[f64; 6]| {
                    let r = perturbed_rig_from_world(&rig_from_world, &Vec6::from_row_slice(d));
                    px(&cam, &r, &x)
                },
                [0.0; 6],
                1e-6,
            );
            // Central differences with h = 1e-6: truncation ~h²·|f'''| and rounding
            // ~1e-16·|f|/h, both below 1e-6 of the Jacobian's scale here.
            assert!(
                (&jp - p.d_pose).abs().max() < 1e-6 * scale,
                "{}: pose\n{jp}\n{}",
                cam.model,
                p.d_pose
            );
            let jx = fd(
                |v: &[f64; 3]| px(&cam, &rig_from_world, &Vec3::from_row_slice(v)),
                [x.x, x.y, x.z],
                1e-6,
            );
            assert!(
                (&jx - p.d_point).abs().max() < 1e-6 * scale,
                "{}: point",
                cam.model
            );
            let n = cam.params.len();
            for k in 0..n {
                let h = 1e-5 * cam.params[k].abs().max(1.0);
                let mut a = cam.clone();
                let mut b = cam.clone();
                a.params[k] += h;
                b.params[k] -= h;
                let col = (px(&a, &rig_from_world, &x) - px(&b, &rig_from_world, &x)) / (2.0 * h);
                let want = p.d_params.column(k);
                let tol = 1e-6 * want.abs().max().max(1.0);
                assert!(
                    (col - want).abs().max() < tol,
                    "{} param {k}: {col} vs {want}",
                    cam.model
                );
            }
        }
    }
}
