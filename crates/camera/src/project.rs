//! Projection (`img_from_cam`), its Jacobians and unprojection (`cam_from_img`) for the
//! 18 COLMAP models, following COLMAP 4.2 (`sensor/models.h`).

use nalgebra::{Matrix2, Matrix2x3, Matrix2xX, Vector2, Vector3};

use crate::dual::{Dual, Real};
use crate::model::validate_params;
use crate::{Camera, ModelId, ProjectionReject, UndistortError};

/// DBL_EPSILON: COLMAP's cheirality threshold (a point needs z ≥ ε) and its other guards.
pub(crate) const EPS: f64 = f64::EPSILON;
/// COLMAP's undistortion stops when ‖step‖² < this (normalized units).
pub const COLMAP_UNDISTORT_STEP_SQ_TOL: f64 = 1e-10;
/// COLMAP's undistortion gives up after this many Newton iterations.
pub const COLMAP_UNDISTORT_MAX_ITERATIONS: usize = 100;
/// FOV model: COLMAP's switch to series expansions when ω² or r² is below this.
const FOV_SERIES_EPS: f64 = 1e-4;
/// Largest parameter count of any model (RAD_TAN_THIN_PRISM_FISHEYE).
const MAX_PARAMS: usize = 16;

/// Result of an unprojection, with a convergence report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Undistorted {
    /// Normalized image coordinates (x/z, y/z) of the ray, no unit.
    pub normalized: Vector2<f64>,
    /// Newton iterations used (0 for closed-form models).
    pub iterations: usize,
    /// Norm of the last Newton step in normalized units (0 for closed-form models).
    pub step_norm: f64,
}

/// Focal lengths, principal point and extra (distortion) parameters of a model with a
/// focal length (every model except EQUIRECTANGULAR).
fn split<S: Real>(model: ModelId, params: &[S]) -> (S, S, S, S, &[S]) {
    if model.focal_idxs().len() == 1 {
        (params[0], params[0], params[1], params[2], &params[3..])
    } else {
        (params[0], params[1], params[2], params[3], &params[4..])
    }
}

/// COLMAP's `FisheyeFromNormal`: (u, v) ↦ (u, v)·θ/r with θ = atan r (identity for r ≤ ε).
fn fisheye_from_normal<S: Real>(u: S, v: S) -> (S, S) {
    let r2 = u * u + v * v;
    if r2.val().sqrt() > EPS {
        let r = r2.sqrt();
        let s = r.atan() / r;
        (u * s, v * s)
    } else {
        (u, v)
    }
}

/// The distortion map of the pinhole/fisheye-class models: undistorted (u, v) ↦ distorted
/// (u_d, v_d) (for fisheye models both are in the equidistant (a, b) plane). `e` are the
/// extra parameters. Identity for models without distortion.
pub(crate) fn distort<S: Real>(model: ModelId, e: &[S], u: S, v: S) -> (S, S) {
    use ModelId as M;
    let two = S::cst(2.0);
    let (u2, v2, uv) = (u * u, v * v, u * v);
    let r2 = u2 + v2;
    match model {
        M::SimpleRadial | M::SimpleRadialFisheye => {
            let radial = e[0] * r2;
            (u + u * radial, v + v * radial)
        }
        M::Radial | M::RadialFisheye => {
            let radial = e[0] * r2 + e[1] * r2 * r2;
            (u + u * radial, v + v * radial)
        }
        M::OpenCv => {
            let (k1, k2, p1, p2) = (e[0], e[1], e[2], e[3]);
            let radial = k1 * r2 + k2 * r2 * r2;
            (
                u + u * radial + two * p1 * uv + p2 * (r2 + two * u2),
                v + v * radial + two * p2 * uv + p1 * (r2 + two * v2),
            )
        }
        M::OpenCvFisheye => {
            let (t2, t4) = (r2, r2 * r2);
            let radial = e[0] * t2 + e[1] * t4 + e[2] * t4 * t2 + e[3] * t4 * t4;
            (u + u * radial, v + v * radial)
        }
        M::FullOpenCv => {
            let (k1, k2, p1, p2, k3, k4, k5, k6) = (e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7]);
            let (r4, r6) = (r2 * r2, r2 * r2 * r2);
            let one = S::cst(1.0);
            let radial = (one + k1 * r2 + k2 * r4 + k3 * r6) / (one + k4 * r2 + k5 * r4 + k6 * r6);
            (
                u * radial + two * p1 * uv + p2 * (r2 + two * u2),
                v * radial + two * p2 * uv + p1 * (r2 + two * v2),
            )
        }
        M::Fov => {
            let omega = e[0];
            let omega2 = omega * omega;
            let factor = if omega2.val() < FOV_SERIES_EPS {
                omega2 * r2 / S::cst(3.0) - omega2 / S::cst(12.0) + S::cst(1.0)
            } else if r2.val() < FOV_SERIES_EPS {
                let t = (omega / two).tan();
                (S::cst(-2.0) * t * (S::cst(4.0) * r2 * t * t - S::cst(3.0)))
                    / (S::cst(3.0) * omega)
            } else {
                let r = r2.sqrt();
                (r * two * (omega / two).tan()).atan() / (r * omega)
            };
            (u * factor, v * factor)
        }
        M::ThinPrismFisheye => {
            let (k1, k2, p1, p2, k3, k4, sx1, sy1) =
                (e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7]);
            let (r4, r6, r8) = (r2 * r2, r2 * r2 * r2, r2 * r2 * r2 * r2);
            let radial = k1 * r2 + k2 * r4 + k3 * r6 + k4 * r8;
            (
                u + u * radial + two * p1 * uv + p2 * (r2 + two * u2) + sx1 * r2,
                v + v * radial + two * p2 * uv + p1 * (r2 + two * v2) + sy1 * r2,
            )
        }
        M::RadTanThinPrismFisheye => {
            let t2 = r2;
            let t4 = t2 * t2;
            let t6 = t4 * t2;
            let t8 = t4 * t4;
            let t10 = t8 * t2;
            let t12 = t6 * t6;
            let rho = S::cst(1.0)
                + e[0] * t2
                + e[1] * t4
                + e[2] * t6
                + e[3] * t8
                + e[4] * t10
                + e[5] * t12;
            let (x, y) = (u * rho, v * rho);
            let (p0, p1) = (e[6], e[7]);
            let (s0, s1, s2, s3) = (e[8], e[9], e[10], e[11]);
            let (x2, y2, xy) = (x * x, y * y, x * y);
            let q2 = x2 + y2;
            let q4 = q2 * q2;
            (
                x + two * p1 * xy + p0 * (q2 + two * x2) + s0 * q2 + s1 * q4,
                y + two * p0 * xy + p1 * (q2 + two * y2) + s2 * q2 + s3 * q4,
            )
        }
        _ => (u, v),
    }
}

/// True when the model's unprojection needs COLMAP's Newton iteration.
fn is_iterative(model: ModelId) -> bool {
    use ModelId as M;
    matches!(
        model,
        M::SimpleRadial
            | M::Radial
            | M::OpenCv
            | M::FullOpenCv
            | M::OpenCvFisheye
            | M::SimpleRadialFisheye
            | M::RadialFisheye
            | M::ThinPrismFisheye
            | M::RadTanThinPrismFisheye
    )
}

/// `img_from_cam` for any model, generic over the scalar (value or dual number).
pub(crate) fn img_from_cam_g<S: Real>(
    model: ModelId,
    params: &[S],
    p: [S; 3],
) -> Result<[S; 2], ProjectionReject> {
    use ModelId as M;
    let [x, y, z] = p;
    if !(x.val().is_finite() && y.val().is_finite() && z.val().is_finite()) {
        return Err(ProjectionReject::NotFinite);
    }
    match model {
        M::Equirectangular => {
            if x.val() == 0.0 && y.val() == 0.0 && z.val() == 0.0 {
                return Err(ProjectionReject::OutsideDomain);
            }
            let (w, h) = (params[0], params[1]);
            let theta = x.atan2(z);
            let phi = (-y).atan2((x * x + z * z).sqrt());
            let half = S::cst(0.5);
            Ok([
                (theta.scale(1.0 / std::f64::consts::TAU) + half) * w,
                (half - phi.scale(1.0 / std::f64::consts::PI)) * h,
            ])
        }
        M::SimpleDivision | M::Division => {
            let (fx, fy, cx, cy, e) = split(model, params);
            let k = e[0];
            let rho2 = x * x + y * y;
            let disc = z * z - S::cst(4.0) * rho2 * k;
            if disc.val() < 0.0 {
                return Err(ProjectionReject::OutsideDomain);
            }
            let den = z + disc.sqrt();
            if den.val().abs() < EPS {
                return Err(ProjectionReject::OutsideDomain);
            }
            let s = S::cst(2.0) / den;
            Ok([fx * s * x + cx, fy * s * y + cy])
        }
        M::Eucm => {
            if z.val() < EPS {
                return Err(ProjectionReject::BehindCamera);
            }
            let (fx, fy, cx, cy, e) = split(model, params);
            let (alpha, beta) = (e[0], e[1]);
            let rho = (beta * (x * x + y * y) + z * z).sqrt();
            let d = alpha * rho + (S::cst(1.0) - alpha) * z;
            if d.val() < EPS {
                return Err(ProjectionReject::OutsideDomain);
            }
            Ok([fx * x / d + cx, fy * y / d + cy])
        }
        _ => {
            if z.val() < EPS {
                return Err(ProjectionReject::BehindCamera);
            }
            let (fx, fy, cx, cy, e) = split(model, params);
            let (u, v) = (x / z, y / z);
            let (u, v) = if model.is_fisheye() {
                fisheye_from_normal(u, v)
            } else {
                (u, v)
            };
            let (ud, vd) = distort(model, e, u, v);
            Ok([fx * ud + cx, fy * vd + cy])
        }
    }
}

/// Newton iteration with COLMAP's trust region: solves `f(x) = x0` from `x = x0`.
/// Stops when ‖step‖² < `step_sq_tol`; fails after `max_iterations`.
pub(crate) fn newton_undistort(
    f: impl Fn(Dual<2>, Dual<2>) -> (Dual<2>, Dual<2>),
    x0: Vector2<f64>,
    step_sq_tol: f64,
    max_iterations: usize,
) -> Result<Undistorted, UndistortError> {
    let mut x = x0;
    let mut step_norm = f64::INFINITY;
    for i in 0..max_iterations {
        let (fu, fv) = f(Dual::var(x.x, 0), Dual::var(x.y, 1));
        let residual = Vector2::new(fu.v - x0.x, fv.v - x0.y);
        let jac = Matrix2::new(fu.d[0], fu.d[1], fv.d[0], fv.d[1]);
        let mut step = jac
            .lu()
            .solve(&residual)
            .filter(|s| s.iter().all(|c| c.is_finite()))
            .ok_or(UndistortError::Singular { iterations: i })?;
        let max_norm = (0.1 * x.norm()).max(0.1);
        let norm = step.norm();
        if norm > max_norm {
            step *= max_norm / norm;
        }
        x -= step;
        step_norm = step.norm();
        if step.norm_squared() < step_sq_tol {
            return Ok(Undistorted {
                normalized: x,
                iterations: i + 1,
                step_norm,
            });
        }
    }
    Err(UndistortError::NotConverged {
        iterations: max_iterations,
        step_norm,
    })
}

/// COLMAP's `NormalFromFisheye`: (a, b) ↦ (a, b)·tan θ/θ with θ = ‖(a, b)‖. Unlike COLMAP,
/// a point at or beyond 90° from the axis is an error instead of a meaningless value.
fn normal_from_fisheye(ab: Vector2<f64>) -> Result<Vector2<f64>, UndistortError> {
    let theta = ab.norm();
    let tct = theta * theta.cos();
    if tct > EPS {
        Ok(ab * (theta.sin() / tct))
    } else if theta < 1.0 {
        Ok(ab)
    } else {
        Err(UndistortError::OutsideDomain)
    }
}

fn closed(normalized: Vector2<f64>) -> Result<Undistorted, UndistortError> {
    if normalized.iter().all(|c| c.is_finite()) {
        Ok(Undistorted {
            normalized,
            iterations: 0,
            step_norm: 0.0,
        })
    } else {
        Err(UndistortError::OutsideDomain)
    }
}

/// A projection result that overflowed (e.g. a point almost on the principal plane of a
/// division model) is a reject, not a garbage pixel.
pub(crate) fn finite_pixel(px: Vector2<f64>) -> Result<Vector2<f64>, ProjectionReject> {
    if px.iter().all(|c| c.is_finite()) {
        Ok(px)
    } else {
        Err(ProjectionReject::OutsideDomain)
    }
}

/// Same guard for Jacobians (infinite at domain boundaries such as the division model's
/// discriminant = 0).
pub(crate) fn finite_jacobian<R: nalgebra::Dim, C: nalgebra::Dim, St>(
    j: nalgebra::Matrix<f64, R, C, St>,
) -> Result<nalgebra::Matrix<f64, R, C, St>, ProjectionReject>
where
    St: nalgebra::RawStorage<f64, R, C>,
{
    if j.iter().all(|c| c.is_finite()) {
        Ok(j)
    } else {
        Err(ProjectionReject::OutsideDomain)
    }
}

/// Unit bearing of an equirectangular pixel (COLMAP's convention).
fn equirect_ray(params: &[f64], px: &Vector2<f64>) -> Vector3<f64> {
    use std::f64::consts::PI;
    let theta = 2.0 * PI * (px.x / params[0] - 0.5);
    let phi = PI * (0.5 - px.y / params[1]);
    Vector3::new(phi.cos() * theta.sin(), -phi.sin(), phi.cos() * theta.cos())
}

impl Camera {
    /// Projects a point in camera coordinates (x right, y down, z forward; any length unit)
    /// to a pixel in COLMAP's convention.
    ///
    /// Cheirality: pinhole- and fisheye-class models and EUCM need z ≥ ε (DBL_EPSILON);
    /// the division models and EQUIRECTANGULAR have no such check (as in COLMAP).
    pub fn img_from_cam(&self, p_cam: &Vector3<f64>) -> Result<Vector2<f64>, ProjectionReject> {
        self.check_projectable()?;
        let r = img_from_cam_g(self.model, &self.params, [p_cam.x, p_cam.y, p_cam.z])?;
        finite_pixel(Vector2::new(r[0], r[1]))
    }

    /// Guards the public maps against a camera built without [`Camera::new`].
    fn check_projectable(&self) -> Result<(), ProjectionReject> {
        validate_params(self.model, &self.params).map_err(|_| ProjectionReject::InvalidParams)
    }

    /// Jacobian (2×3, pixels per unit of the point) of [`Camera::img_from_cam`] with respect
    /// to the camera-frame point. Exact derivatives (forward-mode chain rule).
    pub fn dx_img_from_cam_point(
        &self,
        p_cam: &Vector3<f64>,
    ) -> Result<Matrix2x3<f64>, ProjectionReject> {
        self.check_projectable()?;
        let mut buf = [Dual::<3>::cst(0.0); MAX_PARAMS];
        for (b, &v) in buf.iter_mut().zip(&self.params) {
            *b = Dual::cst(v);
        }
        let params = &buf[..self.params.len()];
        let p = [
            Dual::var(p_cam.x, 0),
            Dual::var(p_cam.y, 1),
            Dual::var(p_cam.z, 2),
        ];
        let r = img_from_cam_g(self.model, params, p)?;
        finite_jacobian(Matrix2x3::from_fn(|i, j| r[i].d[j]))
    }

    /// Jacobian (2×N, N = number of parameters, COLMAP order) of [`Camera::img_from_cam`]
    /// with respect to the camera parameters. Exact derivatives.
    pub fn dx_img_from_params(
        &self,
        p_cam: &Vector3<f64>,
    ) -> Result<Matrix2xX<f64>, ProjectionReject> {
        self.check_projectable()?;
        if self.params.len() > MAX_PARAMS {
            return Err(ProjectionReject::UnsupportedModel);
        }
        let mut buf = [Dual::<MAX_PARAMS>::cst(0.0); MAX_PARAMS];
        for (i, (b, &v)) in buf.iter_mut().zip(&self.params).enumerate() {
            *b = Dual::var(v, i);
        }
        let params = &buf[..self.params.len()];
        let p = [p_cam.x, p_cam.y, p_cam.z].map(Dual::cst);
        let r = img_from_cam_g(self.model, params, p)?;
        finite_jacobian(Matrix2xX::from_fn(self.params.len(), |i, j| r[i].d[j]))
    }

    /// Unprojects a pixel (COLMAP convention) to normalized coordinates (x/z, y/z) with a
    /// convergence report.
    ///
    /// Closed form for SIMPLE_PINHOLE, PINHOLE, FOV, the division models, EUCM,
    /// SIMPLE_FISHEYE, FISHEYE and EQUIRECTANGULAR; COLMAP's Newton iteration otherwise
    /// (trust region max(0.1‖x‖, 0.1), ‖step‖² < 1e-10, ≤ 100 iterations; not converging is
    /// an error). EQUIRECTANGULAR fails for rays with z ≤ ε; fisheye models fail beyond 90°.
    pub fn cam_from_img(&self, pixel: &Vector2<f64>) -> Result<Undistorted, UndistortError> {
        self.cam_from_img_with(
            pixel,
            COLMAP_UNDISTORT_STEP_SQ_TOL,
            COLMAP_UNDISTORT_MAX_ITERATIONS,
        )
    }

    /// [`Camera::cam_from_img`] with a custom stopping rule (‖step‖² < `step_sq_tol`,
    /// at most `max_iterations`) for the iterative models.
    pub fn cam_from_img_with(
        &self,
        pixel: &Vector2<f64>,
        step_sq_tol: f64,
        max_iterations: usize,
    ) -> Result<Undistorted, UndistortError> {
        use ModelId as M;
        if validate_params(self.model, &self.params).is_err() {
            return Err(UndistortError::InvalidParams);
        }
        if !(pixel.x.is_finite() && pixel.y.is_finite()) {
            return Err(UndistortError::NotFinite);
        }
        let model = self.model;
        if model == M::Equirectangular {
            let ray = equirect_ray(&self.params, pixel);
            if ray.z <= EPS {
                return Err(UndistortError::OutsideDomain);
            }
            return closed(Vector2::new(ray.x / ray.z, ray.y / ray.z));
        }
        let (fx, fy, cx, cy, e) = split(model, &self.params);
        let m = Vector2::new((pixel.x - cx) / fx, (pixel.y - cy) / fy);
        match model {
            M::SimplePinhole | M::Pinhole => closed(m),
            M::SimpleDivision | M::Division => {
                // As in COLMAP, a negative denominator (the pixel of a point behind the
                // camera) still gives the normalized coordinates of the line through it.
                let den = 1.0 + e[0] * m.norm_squared();
                if den.abs() < EPS {
                    return Err(UndistortError::OutsideDomain);
                }
                closed(m / den)
            }
            M::Eucm => {
                let (alpha, beta) = (e[0], e[1]);
                let gamma = 1.0 - alpha;
                let m2 = m.norm_squared();
                let q = 1.0 - (alpha - gamma) * beta * m2;
                if q < 0.0 {
                    return Err(UndistortError::OutsideDomain);
                }
                let hd = alpha * q.sqrt() + gamma;
                if hd < EPS {
                    return Err(UndistortError::OutsideDomain);
                }
                let h = (1.0 - alpha * alpha * beta * m2) / hd;
                if h < EPS {
                    return Err(UndistortError::OutsideDomain);
                }
                closed(m / h)
            }
            M::Fov => {
                let omega = e[0];
                let omega2 = omega * omega;
                let r2 = m.norm_squared();
                let g = if omega2 < FOV_SERIES_EPS {
                    omega2 * r2 / 3.0 - omega2 / 12.0 + 1.0
                } else if r2 < FOV_SERIES_EPS {
                    omega * (omega2 * r2 + 3.0) / (6.0 * (omega / 2.0).tan())
                } else {
                    let r = r2.sqrt();
                    (r * omega).tan() / (r * 2.0 * (omega / 2.0).tan())
                };
                closed(m * g)
            }
            M::SimpleFisheye | M::Fisheye => closed(normal_from_fisheye(m)?),
            _ if is_iterative(model) => {
                let mut buf = [Dual::<2>::cst(0.0); MAX_PARAMS];
                for (b, &v) in buf.iter_mut().zip(e) {
                    *b = Dual::cst(v);
                }
                let e_dual = &buf[..e.len()];
                let mut out = newton_undistort(
                    |u, v| distort(model, e_dual, u, v),
                    m,
                    step_sq_tol,
                    max_iterations,
                )?;
                if model.is_fisheye() {
                    out.normalized = normal_from_fisheye(out.normalized)?;
                }
                Ok(out)
            }
            _ => Err(UndistortError::UnsupportedModel),
        }
    }

    /// Unit bearing (camera frame) of a pixel. For EQUIRECTANGULAR this is the full-sphere
    /// ray (any direction); for the other models it is `(u, v, 1)/‖(u, v, 1)‖` from
    /// [`Camera::cam_from_img`].
    pub fn cam_ray_from_img(&self, pixel: &Vector2<f64>) -> Result<Vector3<f64>, UndistortError> {
        if self.model == ModelId::Equirectangular {
            if validate_params(self.model, &self.params).is_err() {
                return Err(UndistortError::InvalidParams);
            }
            if !(pixel.x.is_finite() && pixel.y.is_finite()) {
                return Err(UndistortError::NotFinite);
            }
            return Ok(equirect_ray(&self.params, pixel));
        }
        let n = self.cam_from_img(pixel)?.normalized;
        Ok(Vector3::new(n.x, n.y, 1.0).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn cam_from_img_nominal_report() {
        let pinhole =
            Camera::new(ModelId::Pinhole, 100, 80, vec![50.0, 60.0, 50.0, 40.0]).expect("valid");
        let u = pinhole
            .cam_from_img(&Vector2::new(75.0, 10.0))
            .expect("closed form");
        assert_abs_diff_eq!(u.normalized, Vector2::new(0.5, -0.5), epsilon = 1e-15);
        assert_eq!((u.iterations, u.step_norm), (0, 0.0));

        let radial = Camera::new(ModelId::SimpleRadial, 100, 80, vec![50.0, 50.0, 40.0, -0.1])
            .expect("valid");
        let u = radial
            .cam_from_img(&Vector2::new(75.0, 10.0))
            .expect("converges");
        assert!(u.iterations >= 2 && u.iterations <= COLMAP_UNDISTORT_MAX_ITERATIONS);
        assert!(u.step_norm * u.step_norm < COLMAP_UNDISTORT_STEP_SQ_TOL);
    }

    #[test]
    fn cam_from_img_not_converged() {
        // One iteration cannot reach ‖step‖² < 1e-10 from a distorted start: a typed error
        // reporting the iterations and the last step.
        let radial = Camera::new(ModelId::SimpleRadial, 100, 80, vec![50.0, 50.0, 40.0, -0.1])
            .expect("valid");
        let r = radial.cam_from_img_with(&Vector2::new(75.0, 10.0), 1e-10, 1);
        assert!(
            matches!(r, Err(UndistortError::NotConverged { iterations: 1, step_norm }) if step_norm > 1e-5)
        );
    }

    #[test]
    fn newton_undistort_trust_region() {
        // f(x) = x + x³ (per axis) solved for x0 = 10: the first Newton step from 10 is ≈ 6.7,
        // longer than the trust region max(0.1·‖x‖, 0.1) ≈ 1.41, so it is clipped.
        let f = |u: Dual<2>, v: Dual<2>| (u + u * u * u, v + v * v * v);
        let x0 = Vector2::new(10.0, 10.0);
        let out = newton_undistort(f, x0, 1e-24, 100).expect("converges");
        let x = out.normalized;
        assert_abs_diff_eq!(x.x + x.x.powi(3), 10.0, epsilon = 1e-12);
        assert!(out.iterations > 5);
    }
}
