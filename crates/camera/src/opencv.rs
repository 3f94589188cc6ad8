//! The full OpenCV pinhole model (k1–k6, p1 p2, s1–s4, τx τy) in OpenCV's pixel convention,
//! and the explicit 0.5-pixel conversions to and from COLMAP.

use nalgebra::{Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};

use crate::dual::{Dual, Real};
use crate::project::{EPS, finite_jacobian, finite_pixel, newton_undistort};
use crate::{Camera, Error, ModelId, ProjectionReject, UndistortError, Undistorted};

/// COLMAP pixel coordinate minus OpenCV pixel coordinate of the same image point: COLMAP puts
/// the centre of the upper-left pixel at (0.5, 0.5), OpenCV at (0, 0).
pub const COLMAP_MINUS_OPENCV_PIXEL: f64 = 0.5;

/// Converts a pixel position (or principal point) from OpenCV's convention to COLMAP's:
/// `x_colmap = x_opencv + 0.5` (both axes). Focal lengths and distortion are unchanged.
pub fn colmap_from_opencv_pixel(p_opencv: &Vector2<f64>) -> Vector2<f64> {
    p_opencv.add_scalar(COLMAP_MINUS_OPENCV_PIXEL)
}

/// Converts a pixel position (or principal point) from COLMAP's convention to OpenCV's:
/// `x_opencv = x_colmap − 0.5` (both axes).
pub fn opencv_from_colmap_pixel(p_colmap: &Vector2<f64>) -> Vector2<f64> {
    p_colmap.add_scalar(-COLMAP_MINUS_OPENCV_PIXEL)
}

/// Undistortion of [`OpenCvCamera`] stops when ‖step‖² < this (‖step‖ < 1e-12, i.e. at
/// rounding level for normalized coordinates of order 1).
pub const OPENCV_UNDISTORT_STEP_SQ_TOL: f64 = 1e-24;
/// Iteration limit of [`OpenCvCamera::cam_from_img`].
pub const OPENCV_UNDISTORT_MAX_ITERATIONS: usize = 100;

/// OpenCV's full camera model (`cv::projectPoints` with `CALIB_RATIONAL_MODEL`,
/// `CALIB_THIN_PRISM_MODEL` and `CALIB_TILTED_MODEL`), in **OpenCV's pixel convention** (pixel
/// centres at integer coordinates). Zero coefficients switch terms off; `tau = [0, 0]` is no
/// tilt.
///
/// With x = X/Z, y = Y/Z, r² = x² + y²:
/// x'' = x·(1 + k1r² + k2r⁴ + k3r⁶)/(1 + k4r² + k5r⁴ + k6r⁶) + 2p1xy + p2(r² + 2x²) + s1r² + s2r⁴,
/// y'' = y·(…)/(…) + p1(r² + 2y²) + 2p2xy + s3r² + s4r⁴; then the tilt homography
/// R(τx, τy) and u = fx·x' + cx, v = fy·y' + cy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpenCvCamera {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels, OpenCV convention.
    pub cx: f64,
    /// Principal point y, pixels, OpenCV convention.
    pub cy: f64,
    /// Radial coefficients k1..k6 (k4..k6 are the rational denominator).
    pub k: [f64; 6],
    /// Tangential coefficients p1, p2.
    pub p: [f64; 2],
    /// Thin-prism coefficients s1..s4.
    pub s: [f64; 4],
    /// Sensor tilt τx, τy in radians.
    pub tau: [f64; 2],
}

impl OpenCvCamera {
    /// Number of parameters in [`OpenCvCamera::params`].
    pub const NUM_PARAMS: usize = 18;
    /// Parameter names in the order of [`OpenCvCamera::params`] and of the columns of
    /// [`OpenCvCamera::dx_img_from_params`].
    pub const PARAM_NAMES: [&'static str; 18] = [
        "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3",
        "s4", "tau_x", "tau_y",
    ];

    /// A camera from OpenCV's `cameraMatrix` entries and `distCoeffs` in OpenCV's order
    /// (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, τx, τy]]]]); accepted lengths are
    /// 0, 4, 5, 8, 12 and 14.
    pub fn from_dist_coeffs(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        dist: &[f64],
    ) -> Result<OpenCvCamera, Error> {
        if ![0, 4, 5, 8, 12, 14].contains(&dist.len()) {
            return Err(Error::WrongOpenCvCoeffCount { found: dist.len() });
        }
        let mut d = [0.0; 14];
        d[..dist.len()].copy_from_slice(dist);
        let mut q = [0.0; 18];
        q[..4].copy_from_slice(&[fx, fy, cx, cy]);
        q[4..].copy_from_slice(&d);
        OpenCvCamera::from_params(&q)
    }

    /// The 14 distortion coefficients in OpenCV's `distCoeffs` order.
    pub fn dist_coeffs(&self) -> [f64; 14] {
        let mut d = [0.0; 14];
        d.copy_from_slice(&self.params()[4..]);
        d
    }

    /// All 18 parameters in the order of [`OpenCvCamera::PARAM_NAMES`] (`fx fy cx cy` then
    /// OpenCV's `distCoeffs` order).
    pub fn params(&self) -> [f64; 18] {
        let k = self.k;
        [
            self.fx,
            self.fy,
            self.cx,
            self.cy,
            k[0],
            k[1],
            self.p[0],
            self.p[1],
            k[2],
            k[3],
            k[4],
            k[5],
            self.s[0],
            self.s[1],
            self.s[2],
            self.s[3],
            self.tau[0],
            self.tau[1],
        ]
    }

    /// A validated camera from the 18 parameters of [`OpenCvCamera::params`].
    pub fn from_params(q: &[f64; 18]) -> Result<OpenCvCamera, Error> {
        let cam = OpenCvCamera {
            fx: q[0],
            fy: q[1],
            cx: q[2],
            cy: q[3],
            k: [q[4], q[5], q[8], q[9], q[10], q[11]],
            p: [q[6], q[7]],
            s: [q[12], q[13], q[14], q[15]],
            tau: [q[16], q[17]],
        };
        cam.validate()?;
        Ok(cam)
    }

    /// Checks that every parameter is finite, fx, fy > 0 and |τ| < π/2.
    pub fn validate(&self) -> Result<(), Error> {
        let q = self.params();
        for (i, &v) in q.iter().enumerate() {
            let bad = !v.is_finite()
                || (i < 2 && v <= 0.0)
                || (i >= 16 && v.abs() >= std::f64::consts::FRAC_PI_2);
            if bad {
                return Err(Error::InvalidOpenCvParam {
                    name: Self::PARAM_NAMES[i],
                    value: v,
                });
            }
        }
        Ok(())
    }

    /// The equivalent OpenCV camera of a COLMAP camera: SIMPLE_PINHOLE, PINHOLE,
    /// SIMPLE_RADIAL, RADIAL, OPENCV or FULL_OPENCV. The principal point is shifted by
    /// [`opencv_from_colmap_pixel`] (c_opencv = c_colmap − 0.5); other models give
    /// [`Error::NoOpenCvEquivalent`].
    pub fn from_colmap(cam: &Camera) -> Result<OpenCvCamera, Error> {
        cam.validate()?;
        let q = &cam.params;
        let (f, c, dist): ([f64; 2], [f64; 2], Vec<f64>) = match cam.model {
            ModelId::SimplePinhole => ([q[0], q[0]], [q[1], q[2]], vec![]),
            ModelId::Pinhole => ([q[0], q[1]], [q[2], q[3]], vec![]),
            ModelId::SimpleRadial => ([q[0], q[0]], [q[1], q[2]], vec![q[3], 0.0, 0.0, 0.0]),
            ModelId::Radial => ([q[0], q[0]], [q[1], q[2]], vec![q[3], q[4], 0.0, 0.0]),
            ModelId::OpenCv => ([q[0], q[1]], [q[2], q[3]], q[4..8].to_vec()),
            ModelId::FullOpenCv => ([q[0], q[1]], [q[2], q[3]], q[4..12].to_vec()),
            model => return Err(Error::NoOpenCvEquivalent { model }),
        };
        let c_cv = opencv_from_colmap_pixel(&Vector2::new(c[0], c[1]));
        OpenCvCamera::from_dist_coeffs(f[0], f[1], c_cv.x, c_cv.y, &dist)
    }

    /// The equivalent COLMAP camera: OPENCV when k3..k6 are zero, FULL_OPENCV otherwise; the
    /// principal point is shifted by [`colmap_from_opencv_pixel`] (c_colmap = c_opencv + 0.5).
    /// Thin-prism or tilt terms have no COLMAP equivalent ([`Error::NoColmapEquivalent`]).
    pub fn to_colmap(&self, width: u64, height: u64) -> Result<Camera, Error> {
        let q = self.params();
        if let Some(i) = (12..18).find(|&i| q[i] != 0.0) {
            return Err(Error::NoColmapEquivalent {
                name: Self::PARAM_NAMES[i],
                value: q[i],
            });
        }
        let c = colmap_from_opencv_pixel(&Vector2::new(self.cx, self.cy));
        let (k, p) = (self.k, self.p);
        if k[2..].iter().all(|&v| v == 0.0) {
            let params = vec![self.fx, self.fy, c.x, c.y, k[0], k[1], p[0], p[1]];
            Camera::new(ModelId::OpenCv, width, height, params)
        } else {
            let params = vec![
                self.fx, self.fy, c.x, c.y, k[0], k[1], p[0], p[1], k[2], k[3], k[4], k[5],
            ];
            Camera::new(ModelId::FullOpenCv, width, height, params)
        }
    }

    /// Projects a camera-frame point to an OpenCV pixel. Unlike `cv::projectPoints`, points
    /// with z < ε (DBL_EPSILON) are rejected ([`ProjectionReject::BehindCamera`]).
    pub fn img_from_cam(&self, p_cam: &Vector3<f64>) -> Result<Vector2<f64>, ProjectionReject> {
        self.validate()
            .map_err(|_| ProjectionReject::InvalidParams)?;
        let r = img_from_cam_cv(&self.params(), [p_cam.x, p_cam.y, p_cam.z])?;
        finite_pixel(Vector2::new(r[0], r[1]))
    }

    /// Jacobian (2×3) of [`OpenCvCamera::img_from_cam`] with respect to the point.
    pub fn dx_img_from_cam_point(
        &self,
        p_cam: &Vector3<f64>,
    ) -> Result<Matrix2x3<f64>, ProjectionReject> {
        self.validate()
            .map_err(|_| ProjectionReject::InvalidParams)?;
        let q = self.params().map(Dual::<3>::cst);
        let p = [
            Dual::var(p_cam.x, 0),
            Dual::var(p_cam.y, 1),
            Dual::var(p_cam.z, 2),
        ];
        let r = img_from_cam_cv(&q, p)?;
        finite_jacobian(Matrix2x3::from_fn(|i, j| r[i].d[j]))
    }

    /// Jacobian (2×18, columns in [`OpenCvCamera::PARAM_NAMES`] order) of
    /// [`OpenCvCamera::img_from_cam`] with respect to the parameters.
    pub fn dx_img_from_params(
        &self,
        p_cam: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 2, 18>, ProjectionReject> {
        self.validate()
            .map_err(|_| ProjectionReject::InvalidParams)?;
        let mut q = [Dual::<18>::cst(0.0); 18];
        for (i, (d, v)) in q.iter_mut().zip(self.params()).enumerate() {
            *d = Dual::var(v, i);
        }
        let p = [p_cam.x, p_cam.y, p_cam.z].map(Dual::cst);
        let r = img_from_cam_cv(&q, p)?;
        finite_jacobian(SMatrix::<f64, 2, 18>::from_fn(|i, j| r[i].d[j]))
    }

    /// Unprojects an OpenCV pixel to normalized coordinates: inverts the tilt homography
    /// exactly, then Newton iteration with COLMAP's trust region on the distortion, stopping
    /// at ‖step‖² < [`OPENCV_UNDISTORT_STEP_SQ_TOL`] (at most
    /// [`OPENCV_UNDISTORT_MAX_ITERATIONS`] iterations; not converging is an error).
    pub fn cam_from_img(&self, pixel: &Vector2<f64>) -> Result<Undistorted, UndistortError> {
        self.validate().map_err(|_| UndistortError::InvalidParams)?;
        if !(pixel.x.is_finite() && pixel.y.is_finite()) {
            return Err(UndistortError::NotFinite);
        }
        let q = self.params();
        let m = Vector3::new(
            (pixel.x - self.cx) / self.fx,
            (pixel.y - self.cy) / self.fy,
            1.0,
        );
        let tilt = Matrix3::from_row_slice(&tilt_matrix(q[16], q[17]).concat());
        let untilt = tilt
            .try_inverse()
            .ok_or(UndistortError::Singular { iterations: 0 })?
            * m;
        if untilt.z.abs() < EPS {
            return Err(UndistortError::OutsideDomain);
        }
        let x0 = Vector2::new(untilt.x / untilt.z, untilt.y / untilt.z);
        let qd = q.map(Dual::<2>::cst);
        newton_undistort(
            |u, v| radial_tangential(&qd, u, v),
            x0,
            OPENCV_UNDISTORT_STEP_SQ_TOL,
            OPENCV_UNDISTORT_MAX_ITERATIONS,
        )
    }

    /// Unit bearing (camera frame) of an OpenCV pixel: `(u, v, 1)/‖(u, v, 1)‖`.
    pub fn cam_ray_from_img(&self, pixel: &Vector2<f64>) -> Result<Vector3<f64>, UndistortError> {
        let n = self.cam_from_img(pixel)?.normalized;
        Ok(Vector3::new(n.x, n.y, 1.0).normalize())
    }
}

/// OpenCV's `computeTiltProjectionMatrix(τx, τy)` as row-major rows.
fn tilt_matrix<S: Real>(tau_x: S, tau_y: S) -> [[S; 3]; 3] {
    let (z, o) = (S::cst(0.0), S::cst(1.0));
    let (cx, sx, cy, sy) = (tau_x.cos(), tau_x.sin(), tau_y.cos(), tau_y.sin());
    // R = Ry(τy)·Rx(τx) with OpenCV's sign conventions.
    let rot = [
        [cy, sy * sx, -sy * cx],
        [z, cx, sx],
        [sy, -cy * sx, cy * cx],
    ];
    let proj = [
        [rot[2][2], z, -rot[0][2]],
        [z, rot[2][2], -rot[1][2]],
        [z, z, o],
    ];
    let mut out = [[z; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = proj[i][0] * rot[0][j] + proj[i][1] * rot[1][j] + proj[i][2] * rot[2][j];
        }
    }
    out
}

/// Rational radial + tangential + thin-prism distortion (before the tilt), as in
/// `cv::projectPoints`.
fn radial_tangential<S: Real>(q: &[S; 18], x: S, y: S) -> (S, S) {
    let (k1, k2, p1, p2, k3, k4, k5, k6) = (q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11]);
    let (s1, s2, s3, s4) = (q[12], q[13], q[14], q[15]);
    let one = S::cst(1.0);
    let two = S::cst(2.0);
    let r2 = x * x + y * y;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let a1 = two * x * y;
    let a2 = r2 + two * x * x;
    let a3 = r2 + two * y * y;
    let cdist = one + k1 * r2 + k2 * r4 + k3 * r6;
    let icdist2 = one / (one + k4 * r2 + k5 * r4 + k6 * r6);
    (
        x * cdist * icdist2 + p1 * a1 + p2 * a2 + s1 * r2 + s2 * r4,
        y * cdist * icdist2 + p1 * a3 + p2 * a1 + s3 * r2 + s4 * r4,
    )
}

fn img_from_cam_cv<S: Real>(q: &[S; 18], p: [S; 3]) -> Result<[S; 2], ProjectionReject> {
    let [x, y, z] = p;
    if !(x.val().is_finite() && y.val().is_finite() && z.val().is_finite()) {
        return Err(ProjectionReject::NotFinite);
    }
    if z.val() < EPS {
        return Err(ProjectionReject::BehindCamera);
    }
    let (xd0, yd0) = radial_tangential(q, x / z, y / z);
    let t = tilt_matrix(q[16], q[17]);
    let w = [0, 1, 2].map(|i| t[i][0] * xd0 + t[i][1] * yd0 + t[i][2]);
    if w[2].val() == 0.0 {
        return Err(ProjectionReject::OutsideDomain);
    }
    let inv = S::cst(1.0) / w[2];
    Ok([q[0] * w[0] * inv + q[2], q[1] * w[1] * inv + q[3]])
}
