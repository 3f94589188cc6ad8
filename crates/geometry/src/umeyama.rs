//! Least-squares similarity (or rigid) alignment of point sets, Umeyama (1991).

use crate::tolerance::UMEYAMA_MIN_SINGULAR_RATIO;
use crate::{Error, Mat3, Rigid3, Rot3, Vec3};

/// A similarity `dst = scale·R·src + t` (scale dimensionless, t in mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sim3 {
    /// Scale factor s > 0 (1 for a rigid alignment).
    pub scale: f64,
    /// Rotation R (dst_from_src).
    pub rotation: Rot3,
    /// Translation t (mm, in the dst frame).
    pub translation: Vec3,
}

impl Sim3 {
    /// Apply to a point: `s·R·p + t`.
    pub fn transform_point(&self, p: &Vec3) -> Vec3 {
        self.rotation * p * self.scale + self.translation
    }

    /// The rigid part `(R, t)`, ignoring the scale.
    pub fn rigid(&self) -> Rigid3 {
        crate::quat::rigid_from_rotation(&self.rotation, &self.translation)
    }
}

/// Align `src` onto `dst` (same length, paired by index): minimises `Σ |dst_i − (s R src_i + t)|²`.
///
/// `R` is always a proper rotation (det +1): when the best orthogonal map is a reflection the
/// direction of the smallest singular value is flipped (Umeyama's `S` matrix).
///
/// # Errors
/// [`Error::LengthMismatch`], [`Error::TooFewPoints`] (< 3), [`Error::NonFinite`], and
/// [`Error::Degenerate`] for coincident or collinear points.
pub fn align(src: &[Vec3], dst: &[Vec3], with_scale: bool) -> Result<Sim3, Error> {
    if src.len() != dst.len() {
        return Err(Error::LengthMismatch {
            left: src.len(),
            right: dst.len(),
        });
    }
    if src.len() < 3 {
        return Err(Error::TooFewPoints {
            needed: 3,
            found: src.len(),
        });
    }
    if src
        .iter()
        .chain(dst)
        .any(|p| p.iter().any(|v| !v.is_finite()))
    {
        return Err(Error::NonFinite { what: "point" });
    }
    let n = src.len() as f64;
    let mu_s: Vec3 = src.iter().sum::<Vec3>() / n;
    let mu_d: Vec3 = dst.iter().sum::<Vec3>() / n;
    let mut cov = Mat3::zeros();
    let mut var_s = 0.0;
    for (s, d) in src.iter().zip(dst) {
        let (ds, dd) = (s - mu_s, d - mu_d);
        cov += dd * ds.transpose();
        var_s += ds.norm_squared();
    }
    cov /= n;
    var_s /= n;
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(Error::Degenerate {
            what: "Umeyama SVD failed",
            condition: f64::INFINITY,
        });
    };
    let sv = svd.singular_values;
    let mut sorted = [sv[0], sv[1], sv[2]];
    sorted.sort_by(|a, b| b.total_cmp(a));
    let ratio = if sorted[0] > 0.0 {
        sorted[1] / sorted[0]
    } else {
        0.0
    };
    if ratio < UMEYAMA_MIN_SINGULAR_RATIO {
        return Err(Error::Degenerate {
            what: "Umeyama: points coincident or collinear",
            condition: ratio,
        });
    }
    let mut diag = Vec3::new(1.0, 1.0, 1.0);
    if (u * v_t).determinant() < 0.0 {
        diag[sv.imin()] = -1.0;
    }
    let r = u * Mat3::from_diagonal(&diag) * v_t;
    let scale = if with_scale {
        sv.dot(&diag) / var_s
    } else {
        1.0
    };
    let rotation = Rot3::from_matrix_unchecked(r);
    Ok(Sim3 {
        scale,
        rotation,
        translation: mu_d - rotation * mu_s * scale,
    })
}
