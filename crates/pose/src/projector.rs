//! The camera interface the estimators need, implemented for `crashrig_camera::Camera` and a
//! bare [`Pinhole`].

use nalgebra::{Matrix2x3, Vector2, Vector3};

/// A camera model as the pose estimators use it: projection with its Jacobian and
/// unprojection to a bearing. Camera frame: x right, y down, z forward; pixels in COLMAP's
/// convention (centre of the upper-left pixel at (0.5, 0.5)).
pub trait Projector: Sync {
    /// Pixel of a camera-frame point, `None` outside the model's domain (e.g. behind).
    fn project(&self, p_cam: &Vector3<f64>) -> Option<Vector2<f64>>;
    /// Pixel and its 2×3 Jacobian with respect to the camera-frame point.
    fn project_with_jacobian(&self, p_cam: &Vector3<f64>)
    -> Option<(Vector2<f64>, Matrix2x3<f64>)>;
    /// Normalized image coordinates `(x/z, y/z)` of the ray through a pixel (distortion
    /// removed), `None` if it cannot be unprojected.
    fn normalized(&self, pixel: &Vector2<f64>) -> Option<Vector2<f64>>;
    /// A representative focal length in pixels (converts pixel thresholds to normalized units).
    fn focal_px(&self) -> f64;
}

/// A distortion-free pinhole camera (pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    /// Focal length along x (px).
    pub fx: f64,
    /// Focal length along y (px).
    pub fy: f64,
    /// Principal point x (px).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
}

impl Projector for Pinhole {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        if p.z <= f64::EPSILON {
            return None;
        }
        Some(Vector2::new(
            self.fx * p.x / p.z + self.cx,
            self.fy * p.y / p.z + self.cy,
        ))
    }

    fn project_with_jacobian(&self, p: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let x = self.project(p)?;
        let iz = 1.0 / p.z;
        let j = Matrix2x3::new(
            self.fx * iz,
            0.0,
            -self.fx * p.x * iz * iz,
            0.0,
            self.fy * iz,
            -self.fy * p.y * iz * iz,
        );
        Some((x, j))
    }

    fn normalized(&self, px: &Vector2<f64>) -> Option<Vector2<f64>> {
        Some(Vector2::new(
            (px.x - self.cx) / self.fx,
            (px.y - self.cy) / self.fy,
        ))
    }

    fn focal_px(&self) -> f64 {
        0.5 * (self.fx + self.fy)
    }
}

impl Projector for crashrig_camera::Camera {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        self.img_from_cam(p).ok()
    }

    fn project_with_jacobian(&self, p: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let x = self.img_from_cam(p).ok()?;
        let j = self.dx_img_from_cam_point(p).ok()?;
        Some((x, j))
    }

    fn normalized(&self, px: &Vector2<f64>) -> Option<Vector2<f64>> {
        self.cam_from_img(px).ok().map(|u| u.normalized)
    }

    fn focal_px(&self) -> f64 {
        let idx = self.model.focal_idxs();
        if idx.is_empty() {
            return 1.0;
        }
        idx.iter().map(|&i| self.params[i]).sum::<f64>() / idx.len() as f64
    }
}
