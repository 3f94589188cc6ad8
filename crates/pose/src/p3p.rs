//! Minimal absolute-pose solver: Grunert's P3P and a 3-point rigid alignment.
//!
//! Reference: J. A. Grunert (1841), in the formulation reviewed by R. M. Haralick, C.-N. Lee,
//! K. Ottenberg and M. Nölle, "Review and analysis of solutions of the three point perspective
//! pose estimation problem", IJCV 13(3), 1994, §2.1: with `s₂ = u·s₁`, `s₃ = v·s₁` the three
//! laws of cosines reduce to a quartic in `v`.

use crashrig_geometry::{Rigid3, Vec3};
use nalgebra::{DMatrix, Matrix3, Rotation3, Translation3};

/// Real roots of `c[0]·x^d + … + c[d]` (highest degree first) from the eigenvalues of the
/// companion matrix, polished by two Newton steps. Leading coefficients that vanish relative to
/// the largest one lower the degree.
pub(crate) fn real_roots(coeffs: &[f64]) -> Vec<f64> {
    let scale = coeffs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return Vec::new();
    }
    let first = coeffs
        .iter()
        .position(|c| c.abs() > 1e-14 * scale)
        .unwrap_or(coeffs.len());
    let c = &coeffs[first..];
    let d = c.len().saturating_sub(1);
    if d == 0 {
        return Vec::new();
    }
    let mut comp = DMatrix::<f64>::zeros(d, d);
    for j in 0..d {
        comp[(0, j)] = -c[j + 1] / c[0];
    }
    for i in 1..d {
        comp[(i, i - 1)] = 1.0;
    }
    let eval = |x: f64| {
        let (mut p, mut dp) = (0.0, 0.0);
        for &a in c {
            dp = dp * x + p;
            p = p * x + a;
        }
        (p, dp)
    };
    comp.complex_eigenvalues()
        .iter()
        .filter(|z| z.im.abs() <= 1e-6 * (1.0 + z.re.abs()))
        .map(|z| {
            let mut x = z.re;
            for _ in 0..2 {
                let (p, dp) = eval(x);
                if dp != 0.0 {
                    x -= p / dp;
                }
            }
            x
        })
        .filter(|x| x.is_finite())
        .collect()
}

/// Rigid transform `b_from_a` with `b_i ≈ R·a_i + t` (Kabsch/Horn, SVD of the cross
/// covariance; exact for consistent data, any number ≥ 3 of non-collinear points).
pub(crate) fn rigid_from_points(a: &[Vec3], b: &[Vec3]) -> Option<Rigid3> {
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vec3>() / n;
    let cb = b.iter().sum::<Vec3>() / n;
    let mut h = Matrix3::zeros();
    for (p, q) in a.iter().zip(b) {
        h += (q - cb) * (p - ca).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let d = (u * vt).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vec3::new(1.0, 1.0, d)) * vt;
    if !r.iter().all(|v| v.is_finite()) {
        return None;
    }
    let rot = Rotation3::from_matrix_unchecked(r);
    let t = cb - rot * ca;
    Some(Rigid3::from_parts(
        Translation3::from(t),
        crashrig_geometry::quat::unit_quaternion_from_rotation(&rot),
    ))
}

/// All `cam_from_world` poses (up to four) that map the three world `points` onto the three
/// unit `bearings` (camera frame). Empty for degenerate input (collinear or coincident points).
pub fn p3p(bearings: &[Vec3; 3], points: &[Vec3; 3]) -> Vec<Rigid3> {
    let [j1, j2, j3] = bearings.map(|b| b.normalize());
    let [p1, p2, p3] = *points;
    let a2 = (p2 - p3).norm_squared();
    let b2 = (p1 - p3).norm_squared();
    let c2 = (p1 - p2).norm_squared();
    let cross = (p2 - p1).cross(&(p3 - p1)).norm();
    if b2 == 0.0 || cross <= 1e-12 * (a2 + b2 + c2) || !cross.is_finite() {
        return Vec::new();
    }
    let ca = j2.dot(&j3);
    let cb = j1.dot(&j3);
    let cg = j1.dot(&j2);
    let (ca2, cb2, cg2) = (ca * ca, cb * cb, cg * cg);
    let amc = (a2 - c2) / b2;
    let apc = (a2 + c2) / b2;
    let q4 = (amc - 1.0).powi(2) - 4.0 * c2 / b2 * ca2;
    let q3 = 4.0 * (amc * (1.0 - amc) * cb - (1.0 - apc) * ca * cg + 2.0 * c2 / b2 * ca2 * cb);
    let q2 = 2.0
        * (amc * amc - 1.0 + 2.0 * amc * amc * cb2 + 2.0 * (b2 - c2) / b2 * ca2
            - 4.0 * apc * ca * cb * cg
            + 2.0 * (b2 - a2) / b2 * cg2);
    let q1 = 4.0 * (-amc * (1.0 + amc) * cb + 2.0 * a2 / b2 * cg2 * cb - (1.0 - apc) * ca * cg);
    let q0 = (1.0 + amc).powi(2) - 4.0 * a2 / b2 * cg2;
    let mut out = Vec::with_capacity(4);
    let world = [p1, p2, p3];
    for v in real_roots(&[q4, q3, q2, q1, q0]) {
        let den = 2.0 * (cg - v * ca);
        if den.abs() < 1e-14 {
            continue;
        }
        let u = ((-1.0 + amc) * v * v - 2.0 * amc * cb * v + 1.0 + amc) / den;
        let s1sq = b2 / (1.0 + v * v - 2.0 * v * cb);
        if s1sq.is_nan() || s1sq <= 0.0 || u <= 0.0 || v <= 0.0 {
            continue;
        }
        let s1 = s1sq.sqrt();
        let cam = [j1 * s1, j2 * (u * s1), j3 * (v * s1)];
        if let Some(pose) = rigid_from_points(&world, &cam) {
            out.push(pose);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn real_roots_nominal_known_quartic() {
        // (x − 1)(x + 2)(x − 3)(x² + 1) has real roots 1, −2, 3.
        // Expanded: x⁵ − 2x⁴ − 4x³ + 4x² − 5x + 6.
        let mut r = real_roots(&[1.0, -2.0, -4.0, 4.0, -5.0, 6.0]);
        r.sort_by(f64::total_cmp);
        assert_eq!(r.len(), 3);
        // Newton-polished roots of a well-conditioned polynomial: a few ulps.
        assert_relative_eq!(r[0], -2.0, epsilon = 1e-12);
        assert_relative_eq!(r[1], 1.0, epsilon = 1e-12);
        assert_relative_eq!(r[2], 3.0, epsilon = 1e-12);
        // Vanishing leading coefficient lowers the degree: 0·x² + 2x − 4.
        assert_eq!(real_roots(&[0.0, 2.0, -4.0]), vec![2.0]);
        assert!(real_roots(&[0.0, 0.0]).is_empty());
    }

    #[test]
    fn p3p_rejects_collinear_points() {
        let b = [
            Vec3::z(),
            Vec3::new(0.1, 0.0, 1.0),
            Vec3::new(0.2, 0.0, 1.0),
        ];
        let p = [
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(1.0, 0.0, 5.0),
            Vec3::new(2.0, 0.0, 5.0),
        ];
        assert!(p3p(&b, &p).is_empty());
    }
}
