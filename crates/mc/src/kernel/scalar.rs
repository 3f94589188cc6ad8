//! Per-draw kernels: inlined fixed-size math, no allocation and no `Result` in the loop.
//!
//! Forward intersection is the inhomogeneous linear least-squares DLT in normalized image
//! coordinates: each view adds the rows `a = x·c₃ − c₁`, `b = y·c₃ − c₂` (cᵢ = columns of the
//! perturbed `R_world_from_cam`, i.e. the rows of `R_cam_from_world`) with right-hand sides
//! `a·C`, `b·C`; the 3×3 normal equations `Σ(aaᵀ + bbᵀ) X = Σ(a aᵀ + b bᵀ) C` are solved by
//! cofactors. At the principal point (x = y = 0) `aaᵀ + bbᵀ = I − ddᵀ` with `d = c₃` the unit
//! ray, so the DLT is exactly the least-squares point closest to all rays (midpoint method).

use nalgebra::{Matrix3, Vector3};

/// Squared angle below which `sin θ/θ` and `(1 − cos θ)/θ²` use their Taylor series
/// (truncation error below θ⁸/9! ≈ 3e-18 for θ² < 1e-3).
pub(crate) const SMALL_ANGLE_SQ: f64 = 1e-3;

/// `(sin θ/θ, (1 − cos θ)/θ²)` for `θ² = t`.
#[inline(always)]
pub(crate) fn sinc_cosc(t: f64) -> (f64, f64) {
    if t < SMALL_ANGLE_SQ {
        let s = 1.0 - t / 6.0 * (1.0 - t / 20.0 * (1.0 - t / 42.0));
        let c = 0.5 * (1.0 - t / 12.0 * (1.0 - t / 30.0 * (1.0 - t / 56.0)));
        (s, c)
    } else {
        let th = t.sqrt();
        (th.sin() / th, (1.0 - th.cos()) / t)
    }
}

/// `Exp(w)·e₃` (the optical axis after a small rotation `w` about the camera axes).
#[inline(always)]
pub(crate) fn exp_e3(w: &Vector3<f64>) -> Vector3<f64> {
    let t = w.norm_squared();
    let (s, c) = sinc_cosc(t);
    // Exp(w)e₃ = e₃ + s (w × e₃) + c w × (w × e₃), w × e₃ = (w_y, −w_x, 0),
    // w × (w × e₃) = (w_x w_z, w_y w_z, w_z² − θ²).
    Vector3::new(
        s * w.y + c * w.x * w.z,
        -s * w.x + c * w.y * w.z,
        1.0 + c * (w.z * w.z - t),
    )
}

/// `Exp(w)` as a matrix (Rodrigues).
#[inline(always)]
pub(crate) fn exp_matrix(w: &Vector3<f64>) -> Matrix3<f64> {
    let t = w.norm_squared();
    let (s, c) = sinc_cosc(t);
    let k = w.cross_matrix();
    Matrix3::identity() + k * s + k * k * c
}

/// `log(R)` for a rotation close to the identity (angle < π/2), as a rotation vector.
#[inline(always)]
pub(crate) fn log_near_identity(r: &Matrix3<f64>) -> Vector3<f64> {
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) * 0.5;
    let s = v.norm();
    let cos = 0.5 * (r.trace() - 1.0);
    if s < 1e-8 {
        // θ/sin θ = 1 + θ²/6 + …, θ ≈ s.
        v * (1.0 + s * s / 6.0)
    } else {
        v * (s.atan2(cos) / s)
    }
}

/// Rotation `Rx(ω)·Ry(φ)·Rz(κ)` as a matrix.
#[inline(always)]
pub(crate) fn rot_opk(a: &Vector3<f64>) -> Matrix3<f64> {
    let (so, co) = a.x.sin_cos();
    let (sp, cp) = a.y.sin_cos();
    let (sk, ck) = a.z.sin_cos();
    Matrix3::new(
        cp * ck,
        -cp * sk,
        sp,
        co * sk + so * sp * ck,
        co * ck - so * sp * sk,
        -so * cp,
        so * sk - co * sp * ck,
        so * ck + co * sp * sk,
        co * cp,
    )
}

/// Third column of `Rx(ω)·Ry(φ)·Rz(κ)` (independent of κ).
#[inline(always)]
pub(crate) fn opk_e3(a: &Vector3<f64>) -> Vector3<f64> {
    let (so, co) = a.x.sin_cos();
    let (sp, cp) = a.y.sin_cos();
    Vector3::new(sp, -so * cp, co * cp)
}

/// Accumulator of the 3×3 DLT normal equations (upper triangle) and right-hand side.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Normal3 {
    n: [f64; 6],
    r: [f64; 3],
}

impl Normal3 {
    /// Adds one row `a·X = a·c`.
    #[inline(always)]
    pub(crate) fn add_row(&mut self, a: &Vector3<f64>, c: &Vector3<f64>) {
        let ac = a.dot(c);
        self.n[0] += a.x * a.x;
        self.n[1] += a.x * a.y;
        self.n[2] += a.x * a.z;
        self.n[3] += a.y * a.y;
        self.n[4] += a.y * a.z;
        self.n[5] += a.z * a.z;
        self.r[0] += a.x * ac;
        self.r[1] += a.y * ac;
        self.r[2] += a.z * ac;
    }

    /// Adds the two DLT rows ([`crashrig_geometry::triangulate::dlt_rows`]) of a view with
    /// rotation `r` (`R_world_from_cam`), centre `c` and normalized observation `(x, y)`.
    #[inline(always)]
    pub(crate) fn add_view(&mut self, r: &Matrix3<f64>, c: &Vector3<f64>, x: f64, y: f64) {
        let [a, b] = crashrig_geometry::triangulate::dlt_rows(r, x, y);
        self.add_row(&a, c);
        self.add_row(&b, c);
    }

    /// Adds a ray through `c` with unit direction `d` (both rows of a principal-point view):
    /// `I − ddᵀ` and `(I − ddᵀ)c`.
    #[inline(always)]
    pub(crate) fn add_ray(&mut self, d: &Vector3<f64>, c: &Vector3<f64>) {
        let dc = d.dot(c);
        self.n[0] += 1.0 - d.x * d.x;
        self.n[1] -= d.x * d.y;
        self.n[2] -= d.x * d.z;
        self.n[3] += 1.0 - d.y * d.y;
        self.n[4] -= d.y * d.z;
        self.n[5] += 1.0 - d.z * d.z;
        self.r[0] += c.x - d.x * dc;
        self.r[1] += c.y - d.y * dc;
        self.r[2] += c.z - d.z * dc;
    }

    /// Solves `N X = r` by cofactors; NaN when `N` is singular.
    #[inline(always)]
    pub(crate) fn solve(&self) -> Vector3<f64> {
        let [a, b, c, d, e, f] = self.n;
        // N = [[a b c] [b d e] [c e f]]
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let c11 = a * f - c * c;
        let c12 = b * c - a * e;
        let c22 = a * d - b * b;
        let det = a * c00 + b * c01 + c * c02;
        let inv = 1.0 / det;
        let [r0, r1, r2] = self.r;
        Vector3::new(
            (c00 * r0 + c01 * r1 + c02 * r2) * inv,
            (c01 * r0 + c11 * r1 + c12 * r2) * inv,
            (c02 * r0 + c12 * r1 + c22 * r2) * inv,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use crashrig_geometry::{opk, so3};

    #[test]
    fn exp_e3_nominal_matches_geometry() {
        for w in [
            Vector3::new(1e-4, -2e-4, 3e-4),
            Vector3::new(0.02, 0.01, -0.015),
            Vector3::new(0.3, -0.2, 0.5),
        ] {
            let expect = so3::exp(&w) * Vector3::z();
            let got = exp_e3(&w);
            // Both are exact formulas; differences are rounding only.
            assert_relative_eq!(got, expect, epsilon = 1e-15);
            assert_relative_eq!(exp_matrix(&w), *so3::exp(&w).matrix(), epsilon = 1e-15);
            assert_relative_eq!(log_near_identity(&exp_matrix(&w)), w, epsilon = 1e-14);
        }
    }

    #[test]
    fn sinc_cosc_branches_agree_at_switch() {
        let t = SMALL_ANGLE_SQ;
        let th = t.sqrt();
        let (s, c) = sinc_cosc(t * (1.0 - 1e-12));
        // Series truncation error is below 3e-18 here; the closed form loses ~1e-13 to
        // cancellation in 1 − cos θ at θ ≈ 0.03.
        assert_relative_eq!(s, th.sin() / th, epsilon = 1e-15);
        assert_relative_eq!(c, (1.0 - th.cos()) / t, epsilon = 1e-12);
    }

    #[test]
    fn rot_opk_nominal_matches_geometry() {
        let a = Vector3::new(0.3, -1.1, 2.5);
        let g = opk::rotation_from_opk(a.x, a.y, a.z);
        assert_relative_eq!(rot_opk(&a), *g.matrix(), epsilon = 1e-15);
        assert_relative_eq!(
            opk_e3(&a),
            g.matrix().column(2).into_owned(),
            epsilon = 1e-15
        );
    }

    #[test]
    fn normal3_nominal_two_rays_meet() {
        // Rays from (−1,0,0) and (1,0,0) towards (0,2,0.5) meet there.
        let p = Vector3::new(0.0, 2.0, 0.5);
        let mut n = Normal3::default();
        for c in [Vector3::new(-1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0)] {
            n.add_ray(&(p - c).normalize(), &c);
        }
        assert_relative_eq!(n.solve(), p, epsilon = 1e-14);
        // The same with the two DLT rows of each view at the principal point.
        let mut m = Normal3::default();
        for c in [Vector3::new(-1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0)] {
            let r = crashrig_geometry::look_at::world_from_cam_look_at(&c, &p).unwrap();
            m.add_row(&-r.matrix().column(0).into_owned(), &c);
            m.add_row(&-r.matrix().column(1).into_owned(), &c);
        }
        assert_relative_eq!(m.solve(), p, epsilon = 1e-14);
    }
}
