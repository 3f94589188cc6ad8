//! Means of rotations: chordal (closed form) and Karcher (geodesic, iterative); projection onto SO(3).

use crate::tolerance::CHORDAL_MIN_SINGULAR_RATIO;
use crate::{Error, Mat3, Rot3, Vec3, so3};

/// Chordal L2 mean: the rotation closest in Frobenius norm to `Σ R`, via SVD with the
/// determinant fixed to +1.
///
/// # Errors
/// [`Error::TooFewSamples`] for an empty slice, [`Error::NonFinite`] for NaN input,
/// [`Error::Degenerate`] when `Σ R` is (nearly) rank ≤ 1 and the projection is not unique.
pub fn chordal_mean(rs: &[Rot3]) -> Result<Rot3, Error> {
    if rs.is_empty() {
        return Err(Error::TooFewSamples {
            needed: 1,
            found: 0,
        });
    }
    let sum: Mat3 = rs.iter().map(|r| r.matrix()).sum();
    if sum.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what: "rotation" });
    }
    project_to_so3(&sum, "chordal mean: sum of rotations has rank < 2")
}

/// Nearest rotation to `m` in the Frobenius norm (SVD, determinant fixed to +1), e.g. to
/// re-orthonormalise a matrix that drifted or to project a linear estimate onto SO(3).
///
/// # Errors
/// [`Error::NonFinite`] for NaN/∞ entries, [`Error::Degenerate`] when `m` has rank < 2.
pub fn nearest_rotation(m: &Mat3) -> Result<Rot3, Error> {
    if m.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what: "matrix" });
    }
    project_to_so3(m, "nearest rotation: matrix has rank < 2")
}

/// Nearest rotation to `m` (Frobenius), with the determinant fixed to +1.
fn project_to_so3(m: &Mat3, what: &'static str) -> Result<Rot3, Error> {
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(Error::Degenerate {
            what,
            condition: f64::INFINITY,
        });
    };
    let mut s: Vec<f64> = svd.singular_values.iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    let ratio = if s[0] > 0.0 { s[1] / s[0] } else { 0.0 };
    if ratio < CHORDAL_MIN_SINGULAR_RATIO {
        return Err(Error::Degenerate {
            what,
            condition: ratio,
        });
    }
    let d = (u * v_t).determinant().signum();
    // Flip the direction belonging to the smallest singular value.
    let imin = svd.singular_values.imin();
    let mut diag = Vec3::new(1.0, 1.0, 1.0);
    diag[imin] = d;
    Ok(Rot3::from_matrix_unchecked(
        u * Mat3::from_diagonal(&diag) * v_t,
    ))
}

/// Karcher (geodesic L2) mean, started at the chordal mean.
///
/// Iterates `R̄ ← R̄·Exp(mean_i Log(R̄ᵀ R_i))` until the step is below `tol` (rad).
///
/// # Errors
/// Those of [`chordal_mean`], and [`Error::NoConvergence`] after `max_iter` steps.
pub fn karcher_mean(rs: &[Rot3], tol: f64, max_iter: usize) -> Result<Rot3, Error> {
    let mut mean = chordal_mean(rs)?;
    let n = rs.len() as f64;
    let mut step = f64::INFINITY;
    for _ in 0..max_iter {
        let inv = mean.inverse();
        let delta: Vec3 = rs.iter().map(|r| so3::log(&(inv * r))).sum::<Vec3>() / n;
        mean = renormalize(&(mean * so3::exp(&delta)));
        step = delta.norm();
        if step < tol {
            return Ok(mean);
        }
    }
    Err(Error::NoConvergence {
        iterations: max_iter,
        last_step: step,
    })
}

/// Re-orthonormalise a product of rotations (keeps drift from accumulating).
fn renormalize(r: &Rot3) -> Rot3 {
    crate::quat::unit_quaternion_from_rotation(r).to_rotation_matrix()
}
