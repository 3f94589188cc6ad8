//! Forward intersection (triangulation) of one point from n ≥ 2 views by linear least squares.
//!
//! Each view contributes the two DLT rows `(u·r3 − r1)·X = t1 − u·t3` and
//! `(v·r3 − r2)·X = t2 − v·t3`, where `r_i` are the rows of `R_cam_from_world`, `t` its
//! translation and `(u, v)` the observation in normalized camera coordinates (x/z, y/z).

use crate::tolerance::{DLT_MAX_CONDITION, DLT_MIN_HOMOGENEOUS_W};
use crate::{Error, Mat3, Rigid3, Vec3};
use nalgebra::{DMatrix, RowVector4, Vector2};

/// One view of the point: the camera pose and the normalized image observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// `cam_from_world` (mm).
    pub cam_from_world: Rigid3,
    /// Observation in normalized camera coordinates `(x/z, y/z)`.
    pub normalized: Vector2<f64>,
}

/// The two DLT rows of a view in normalized image coordinates `(x, y)`: `a = x·c₃ − c₁`,
/// `b = y·c₃ − c₂`, with `cᵢ` the columns of `R_world_from_cam` (the rows of
/// `R_cam_from_world`). The point `X` seen there from the centre `C` satisfies `a·(X − C) = 0`
/// and `b·(X − C) = 0`. The one copy of the rows: [`dlt`], the Monte Carlo kernels of
/// `crashrig-mc` and their first-order maps call it.
#[inline(always)]
pub fn dlt_rows(world_from_cam: &Mat3, x: f64, y: f64) -> [Vec3; 2] {
    let c1 = world_from_cam.column(0).into_owned();
    let c2 = world_from_cam.column(1).into_owned();
    let c3 = world_from_cam.column(2).into_owned();
    [c3 * x - c1, c3 * y - c2]
}

/// The two DLT rows `(a, b)` of a view: `a·X = b`.
fn rows(view: &View) -> [(Vec3, f64); 2] {
    let r = view
        .cam_from_world
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let t = view.cam_from_world.translation.vector;
    let (u, v) = (view.normalized.x, view.normalized.y);
    let [a, b] = dlt_rows(&r.transpose(), u, v);
    [(a, t.x - u * t.z), (b, t.y - v * t.z)]
}

fn check_views(views: &[View]) -> Result<(), Error> {
    if views.len() < 2 {
        return Err(Error::TooFewViews {
            needed: 2,
            found: views.len(),
        });
    }
    let finite = views.iter().all(|v| {
        v.normalized.iter().all(|x| x.is_finite())
            && v.cam_from_world
                .translation
                .vector
                .iter()
                .all(|x| x.is_finite())
            && v.cam_from_world
                .rotation
                .coords
                .iter()
                .all(|x| x.is_finite())
    });
    if finite {
        Ok(())
    } else {
        Err(Error::NonFinite { what: "view" })
    }
}

/// Normal matrix `AᵀA` and right-hand side `Aᵀb`.
fn normal_equations(views: &[View]) -> (Mat3, Vec3) {
    let mut n = Mat3::zeros();
    let mut rhs = Vec3::zeros();
    for view in views {
        for (a, b) in rows(view) {
            n += a * a.transpose();
            rhs += a * b;
        }
    }
    (n, rhs)
}

/// Largest and smallest eigenvalue of a symmetric 3×3 matrix, closed form (Smith 1961).
///
/// The absolute error is a few ε·λmax, ample for a condition check up to ~1e6 on cond(A).
fn extreme_eigenvalues(n: &Mat3) -> (f64, f64) {
    let p1 = n[(0, 1)].powi(2) + n[(0, 2)].powi(2) + n[(1, 2)].powi(2);
    let q = n.trace() / 3.0;
    let p2 = (n[(0, 0)] - q).powi(2) + (n[(1, 1)] - q).powi(2) + (n[(2, 2)] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    if p == 0.0 {
        return (q, q);
    }
    let b = (n - Mat3::identity() * q) / p;
    let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let lmax = q + 2.0 * p * phi.cos();
    let lmin = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    (lmax, lmin)
}

/// `N⁻¹` of the normal matrix after a condition check (cond(A) = √(λmax/λmin)).
fn checked_inverse(n: &Mat3) -> Result<Mat3, Error> {
    let (lmax, lmin) = extreme_eigenvalues(n);
    let condition = if lmin > 0.0 {
        (lmax / lmin).sqrt()
    } else {
        f64::INFINITY
    };
    if condition.is_nan() || condition > DLT_MAX_CONDITION {
        return Err(Error::Degenerate {
            what: "DLT rays (nearly) parallel",
            condition,
        });
    }
    // N is symmetric positive definite here: Cholesky.
    match n.cholesky() {
        Some(ch) => Ok(ch.inverse()),
        None => Err(Error::Degenerate {
            what: "DLT normal matrix not positive definite",
            condition,
        }),
    }
}

/// Linear least-squares intersection, inhomogeneous 3-unknown form (normal equations).
///
/// # Errors
/// [`Error::TooFewViews`] for fewer than 2 views, [`Error::NonFinite`], and
/// [`Error::Degenerate`] when the condition number of the design matrix exceeds
/// [`DLT_MAX_CONDITION`] (parallel rays, all centres on one ray).
pub fn dlt(views: &[View]) -> Result<Vec3, Error> {
    check_views(views)?;
    let (n, rhs) = normal_equations(views);
    let inv = checked_inverse(&n)?;
    Ok(inv * rhs)
}

/// Classic homogeneous DLT: the right singular vector of the 2n×4 matrix `[a | −b]` belonging
/// to its smallest singular value (SVD of the stacked matrix, not of its normal matrix, so the
/// condition number is not squared).
///
/// # Errors
/// As [`dlt`]; also [`Error::Degenerate`] when the null space has dimension > 1 (ratio of the
/// extreme non-null singular values above [`DLT_MAX_CONDITION`]) or the solution is at infinity.
pub fn dlt_homogeneous(views: &[View]) -> Result<Vec3, Error> {
    check_views(views)?;
    let mut a = DMatrix::<f64>::zeros(2 * views.len(), 4);
    for (i, view) in views.iter().enumerate() {
        for (k, (row, b)) in rows(view).into_iter().enumerate() {
            a.set_row(2 * i + k, &RowVector4::new(row.x, row.y, row.z, -b));
        }
    }
    let svd = a.svd(false, true);
    let Some(v_t) = svd.v_t else {
        return Err(Error::Degenerate {
            what: "homogeneous DLT: SVD failed",
            condition: f64::INFINITY,
        });
    };
    let s = &svd.singular_values;
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&i, &j| s[i].total_cmp(&s[j]));
    // The second-smallest singular value near 0 means a family of solutions.
    let (s1, s3) = (s[order[1]], s[order[s.len() - 1]]);
    let condition = if s1 > 0.0 { s3 / s1 } else { f64::INFINITY };
    if condition.is_nan() || condition > DLT_MAX_CONDITION {
        return Err(Error::Degenerate {
            what: "homogeneous DLT: null space of dimension > 1",
            condition,
        });
    }
    let h = v_t.row(order[0]);
    if h[3].abs() < DLT_MIN_HOMOGENEOUS_W {
        return Err(Error::Degenerate {
            what: "homogeneous DLT: point at infinity",
            condition: h[3].abs(),
        });
    }
    Ok(Vec3::new(h[0], h[1], h[2]) / h[3])
}

/// First-order covariance (mm²) of [`dlt`]'s point from independent isotropic noise of standard
/// deviation `sigma_normalized` on every normalized coordinate.
///
/// `point` is where the Jacobian is evaluated (normally the [`dlt`] solution of `views`); the
/// derivative is exact for the least-squares solution, residuals included:
/// `∂X/∂u_i = −N⁻¹ (r3·ρ_i + a_i·z_i)` with ρ_i the row residual and z_i the depth.
///
/// # Errors
/// As [`dlt`], and [`Error::NonFinite`] for a non-finite `point` or `sigma_normalized`.
pub fn dlt_covariance(views: &[View], point: &Vec3, sigma_normalized: f64) -> Result<Mat3, Error> {
    let sigmas = vec![sigma_normalized; views.len()];
    dlt_covariance_per_view(views, point, &sigmas)
}

/// As [`dlt_covariance`], with its own isotropic σ (normalized units) for each view, e.g.
/// `pixel_sigma / focal_px` of each camera.
///
/// # Errors
/// As [`dlt_covariance`], and [`Error::LengthMismatch`] when `sigma_per_view.len() != views.len()`.
pub fn dlt_covariance_per_view(
    views: &[View],
    point: &Vec3,
    sigma_per_view: &[f64],
) -> Result<Mat3, Error> {
    check_views(views)?;
    if sigma_per_view.len() != views.len() {
        return Err(Error::LengthMismatch {
            left: views.len(),
            right: sigma_per_view.len(),
        });
    }
    if sigma_per_view.iter().any(|s| !s.is_finite()) || point.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "point or sigma",
        });
    }
    let (n, _) = normal_equations(views);
    let inv = checked_inverse(&n)?;
    let mut cov = Mat3::zeros();
    for (view, sigma) in views.iter().zip(sigma_per_view) {
        let rot = view
            .cam_from_world
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let r3_row = rot.row(2).transpose();
        let depth = r3_row.dot(point) + view.cam_from_world.translation.vector.z;
        for (a, b) in rows(view) {
            let residual = a.dot(point) - b;
            let col = -(inv * (r3_row * residual + a * depth));
            cov += col * col.transpose() * (sigma * sigma);
        }
    }
    Ok(cov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn extreme_eigenvalues_nominal() {
        // A = Q diag(5, 2, 1e-4) Qᵀ for a fixed rotation Q: the closed form must return 5, 1e-4.
        let q = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0).into_inner();
        let a = q * Mat3::from_diagonal(&Vec3::new(5.0, 2.0, 1e-4)) * q.transpose();
        let (lmax, lmin) = extreme_eigenvalues(&a);
        // Absolute error a few ε·λmax ≈ 1e-15.
        assert_relative_eq!(lmax, 5.0, epsilon = 1e-13);
        assert_relative_eq!(lmin, 1e-4, epsilon = 1e-13);
        let (lmax, lmin) = extreme_eigenvalues(&(Mat3::identity() * 3.0));
        assert_relative_eq!(lmax, 3.0);
        assert_relative_eq!(lmin, 3.0);
    }
}
