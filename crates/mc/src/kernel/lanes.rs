//! Lane forms (blocks of [`LANES`] draws in structure-of-arrays form) shared by the grid and
//! chain kernels: the pose-noise factor `δ = L·ε` ([`NoiseFactor`]), the perturbed rotations
//! and rays by their Taylor series (tangent `R̄·Exp(w)` and ω φ κ + δ, exact to < 3·10⁻¹⁸ for
//! θ² < [`SMALL_ANGLE_SQ`]), and the per-lane DLT normal equations ([`Normals3`]). Plain loops
//! over lanes with correctly rounded operations only, so every instruction-set level gives the
//! same bits.

#![allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays are the point (they vectorise)

use super::accumulate::LaneSums;
use super::normal::{LANES, Lane};
#[cfg(doc)]
use super::scalar::SMALL_ANGLE_SQ;
use nalgebra::{Matrix6, Vector3};

/// Lower-triangular factor `L` of a pose's 6×6 noise covariance (order x y z mm, then the
/// three rotation components rad): `δ = L·ε`, ε standard normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NoiseFactor {
    l: [[f64; 6]; 6],
    diagonal: bool,
}

impl NoiseFactor {
    /// Independent per-axis σ (today's model): `L = diag(σ_position, σ_rotation)`.
    pub(crate) fn from_sigma(position: &Vector3<f64>, rotation: &Vector3<f64>) -> Self {
        let mut l = [[0.0; 6]; 6];
        for i in 0..3 {
            l[i][i] = position[i];
            l[i + 3][i + 3] = rotation[i];
        }
        NoiseFactor { l, diagonal: true }
    }

    /// A general factor: the lower triangle of `l` (the strict upper triangle is ignored).
    /// Uses the diagonal fast path when the strict lower triangle is zero.
    pub(crate) fn from_lower(l: &Matrix6<f64>) -> Self {
        let mut f = [[0.0; 6]; 6];
        let mut diagonal = true;
        for i in 0..6 {
            for k in 0..=i {
                f[i][k] = l[(i, k)];
                diagonal &= k == i || f[i][k] == 0.0;
            }
        }
        NoiseFactor { l: f, diagonal }
    }

    /// True when the factor is diagonal (independent components).
    pub(crate) fn is_diagonal(&self) -> bool {
        self.diagonal
    }

    /// The factor as a matrix.
    #[cfg(test)]
    pub(crate) fn matrix(&self) -> Matrix6<f64> {
        Matrix6::from_fn(|i, k| self.l[i][k])
    }

    /// The same factor without the diagonal shortcut (tests: both paths agree bit for bit).
    #[cfg(test)]
    pub(crate) fn without_shortcut(mut self) -> Self {
        self.diagonal = false;
        self
    }

    /// `δ = L·ε` of lane `d` (the same operations as [`Self::apply`], so the same bits),
    /// written out: a loop over the triangle (`k ≤ i`) inside the caller's lane loop kept
    /// LLVM from vectorising the lane loop (a nested loop whose trip count varies).
    #[inline(always)]
    pub(crate) fn delta_lane<const DIAGONAL: bool>(&self, e: &[Lane; 6], d: usize) -> [f64; 6] {
        let l = &self.l;
        let [e0, e1, e2, e3, e4, e5] = [e[0][d], e[1][d], e[2][d], e[3][d], e[4][d], e[5][d]];
        if DIAGONAL {
            return [
                l[0][0] * e0,
                l[1][1] * e1,
                l[2][2] * e2,
                l[3][3] * e3,
                l[4][4] * e4,
                l[5][5] * e5,
            ];
        }
        // Row i: ((l_i0·e0 + l_i1·e1) + …) + l_ii·e_i, each step one fused multiply-add.
        let f = |k: f64, e: f64, s: f64| k.mul_add(e, s);
        [
            l[0][0] * e0,
            f(l[1][1], e1, l[1][0] * e0),
            f(l[2][2], e2, f(l[2][1], e1, l[2][0] * e0)),
            f(l[3][3], e3, f(l[3][2], e2, f(l[3][1], e1, l[3][0] * e0))),
            f(
                l[4][4],
                e4,
                f(l[4][3], e3, f(l[4][2], e2, f(l[4][1], e1, l[4][0] * e0))),
            ),
            f(
                l[5][5],
                e5,
                f(
                    l[5][4],
                    e4,
                    f(l[5][3], e3, f(l[5][2], e2, f(l[5][1], e1, l[5][0] * e0))),
                ),
            ),
        ]
    }

    /// `δ = L·ε` per lane; `e` holds the six normal rows. Row `i` is `Σ_{k ≤ i} L_ik ε_k`
    /// summed in k order by fused multiply-adds (with a diagonal factor the other terms are
    /// zeros, so both forms give the same bits for non-zero σ).
    #[inline(always)]
    pub(crate) fn apply(&self, e: &[Lane; 6], out: &mut [Lane; 6]) {
        if self.diagonal {
            for i in 0..6 {
                let li = self.l[i][i];
                for d in 0..LANES {
                    out[i][d] = li * e[i][d];
                }
            }
        } else {
            // Term by term over the whole row (the lane loop innermost, so it vectorises):
            // per lane the same products added in the same k order as `delta_lane`.
            for i in 0..6 {
                let li = &self.l[i];
                let row = &mut out[i];
                for d in 0..LANES {
                    row[d] = li[0] * e[0][d];
                }
                for k in 1..=i {
                    for d in 0..LANES {
                        row[d] = li[k].mul_add(e[k][d], row[d]);
                    }
                }
            }
        }
    }
}

/// Per-lane 3×3 DLT normal equations (upper triangle) and right-hand side.
#[derive(Debug, Clone)]
pub(crate) struct Normals3 {
    n: [Lane; 6],
    r: [Lane; 3],
}

impl Normals3 {
    pub(crate) fn new() -> Self {
        Normals3 {
            n: [[0.0; LANES]; 6],
            r: [[0.0; LANES]; 3],
        }
    }

    #[inline(always)]
    pub(crate) fn clear(&mut self) {
        for row in self.n.iter_mut().chain(self.r.iter_mut()) {
            *row = [0.0; LANES];
        }
    }

    /// Adds to lane `l` the ray through `c` with unit direction `d`: `I − ddᵀ`, `(I − ddᵀ)c`.
    #[inline(always)]
    pub(crate) fn add_ray_lane(&mut self, l: usize, d: [f64; 3], c: [f64; 3]) {
        let [dx, dy, dz] = d;
        let [cx, cy, cz] = c;
        let dc = dx.mul_add(cx, dy.mul_add(cy, dz * cz));
        self.n[0][l] += (-dx).mul_add(dx, 1.0);
        self.n[1][l] = (-dx).mul_add(dy, self.n[1][l]);
        self.n[2][l] = (-dx).mul_add(dz, self.n[2][l]);
        self.n[3][l] += (-dy).mul_add(dy, 1.0);
        self.n[4][l] = (-dy).mul_add(dz, self.n[4][l]);
        self.n[5][l] += (-dz).mul_add(dz, 1.0);
        self.r[0][l] += (-dx).mul_add(dc, cx);
        self.r[1][l] += (-dy).mul_add(dc, cy);
        self.r[2][l] += (-dz).mul_add(dc, cz);
    }

    /// Adds to lane `l` two DLT rows `a`, `b` (`q·(X − c) = 0`) of a view with centre `c`:
    /// `qqᵀ` to the matrix and `q (q·c)` to the right-hand side, by fused multiply-adds.
    #[inline(always)]
    pub(crate) fn add_rows_lane(&mut self, l: usize, a: [f64; 3], b: [f64; 3], c: [f64; 3]) {
        let [cx, cy, cz] = c;
        for [q0, q1, q2] in [a, b] {
            let qc = q0.mul_add(cx, q1.mul_add(cy, q2 * cz));
            self.n[0][l] = q0.mul_add(q0, self.n[0][l]);
            self.n[1][l] = q0.mul_add(q1, self.n[1][l]);
            self.n[2][l] = q0.mul_add(q2, self.n[2][l]);
            self.n[3][l] = q1.mul_add(q1, self.n[3][l]);
            self.n[4][l] = q1.mul_add(q2, self.n[4][l]);
            self.n[5][l] = q2.mul_add(q2, self.n[5][l]);
            self.r[0][l] = q0.mul_add(qc, self.r[0][l]);
            self.r[1][l] = q1.mul_add(qc, self.r[1][l]);
            self.r[2][l] = q2.mul_add(qc, self.r[2][l]);
        }
    }

    /// Solves every lane ([`Self::solve`]) and adds the points to `sums` as deviations from
    /// `shift` ([`LaneSums::add`]), in one pass: the same operations, so the same bits.
    #[inline(always)]
    pub(crate) fn solve_into(&self, sums: &mut LaneSums<LANES>, shift: &Vector3<f64>) {
        for l in 0..LANES {
            let x = self.solve_lane(l);
            sums.add_lane(l, x, shift);
        }
        sums.count(LANES);
    }

    /// Solves every lane by cofactors (NaN for a singular lane).
    #[inline(always)]
    pub(crate) fn solve(&self, out: &mut [Lane; 3]) {
        for l in 0..LANES {
            let x = self.solve_lane(l);
            for i in 0..3 {
                out[i][l] = x[i];
            }
        }
    }

    /// Lane `l` solved by cofactors (NaN when singular).
    #[inline(always)]
    pub(crate) fn solve_lane(&self, l: usize) -> [f64; 3] {
        {
            let [a, b, c, d, e, f] = [
                self.n[0][l],
                self.n[1][l],
                self.n[2][l],
                self.n[3][l],
                self.n[4][l],
                self.n[5][l],
            ];
            let c00 = d.mul_add(f, -(e * e));
            let c01 = c.mul_add(e, -(b * f));
            let c02 = b.mul_add(e, -(c * d));
            let c11 = a.mul_add(f, -(c * c));
            let c12 = b.mul_add(c, -(a * e));
            let c22 = a.mul_add(d, -(b * b));
            let inv = 1.0 / a.mul_add(c00, b.mul_add(c01, c * c02));
            let (r0, r1, r2) = (self.r[0][l], self.r[1][l], self.r[2][l]);
            [
                c00.mul_add(r0, c01.mul_add(r1, c02 * r2)) * inv,
                c01.mul_add(r0, c11.mul_add(r1, c12 * r2)) * inv,
                c02.mul_add(r0, c12.mul_add(r1, c22 * r2)) * inv,
            ]
        }
    }
}

/// `(sin θ/θ, (1 − cos θ)/θ²)` for θ² = t, Taylor series (t < [`SMALL_ANGLE_SQ`]).
#[inline(always)]
pub(crate) fn sinc_cosc_series(t: f64) -> (f64, f64) {
    const S: [f64; 3] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0];
    const C: [f64; 4] = [0.5, -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0];
    let s = t.mul_add(t.mul_add(t.mul_add(S[2], S[1]), S[0]), 1.0);
    let c = t.mul_add(t.mul_add(t.mul_add(C[3], C[2]), C[1]), C[0]);
    (s, c)
}

/// `(sin δ, cos δ)` for a small δ (δ² < [`SMALL_ANGLE_SQ`]), Taylor series.
#[inline(always)]
pub(crate) fn sin_cos_series(x: f64) -> (f64, f64) {
    let t = x * x;
    let (s, c) = sinc_cosc_series(t);
    (x * s, 1.0 - t * c)
}

#[inline(always)]
pub(crate) fn keep_max(m: &mut f64, t: f64) {
    *m = if t > *m { t } else { *m };
}

/// Ray `R̄·Exp(w)·e₃` and θ² = |w|² (Taylor form of `Exp`).
#[inline(always)]
pub(crate) fn tangent_dir(r: &[f64; 9], w: [f64; 3]) -> ([f64; 3], f64) {
    let [wx, wy, wz] = w;
    let t = wx * wx + wy * wy + wz * wz;
    let (s, c) = sinc_cosc_series(t);
    // Exp(w)e₃ = e₃ + s (w × e₃) + c w × (w × e₃).
    let v0 = s * wy + c * wx * wz;
    let v1 = c * wy * wz - s * wx;
    let v2 = 1.0 - c * (wx * wx + wy * wy);
    let dir =
        std::array::from_fn(|i| r[3 * i].mul_add(v0, r[3 * i + 1].mul_add(v1, r[3 * i + 2] * v2)));
    (dir, t)
}

/// Rotation `R̄·Exp(w)` (row-major) and θ² = |w|² (Taylor form of `Exp`).
#[inline(always)]
pub(crate) fn tangent_rot(r: &[f64; 9], w: [f64; 3]) -> ([f64; 9], f64) {
    let [wx, wy, wz] = w;
    let t = wx * wx + wy * wy + wz * wz;
    let (s, c) = sinc_cosc_series(t);
    // Exp(w) = I + s[w]× + c(wwᵀ − tI).
    let e = [
        1.0 + c * (wx * wx - t),
        c * wx * wy - s * wz,
        s * wy + c * wx * wz,
        s * wz + c * wx * wy,
        1.0 + c * (wy * wy - t),
        c * wy * wz - s * wx,
        c * wx * wz - s * wy,
        s * wx + c * wy * wz,
        1.0 + c * (wz * wz - t),
    ];
    let rot = std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        r[3 * i].mul_add(
            e[j],
            r[3 * i + 1].mul_add(e[3 + j], r[3 * i + 2] * e[6 + j]),
        )
    });
    (rot, t)
}

/// The two DLT rows `a = R·(−1, 0, x)`, `b = R·(0, −1, y)` of a view turned to
/// `R = R̄·Exp(w)` (`r` = R̄ row-major) with normalized coordinates `(x, y)`, and θ² = |w|²,
/// without forming R: `Exp(w)·q = cos θ·q + sinc θ·(w × q) + cosc θ·(w·q)·w` (Taylor forms of
/// the coefficients, as [`tangent_rot`]).
#[inline(always)]
pub(crate) fn tangent_rows(r: &[f64; 9], w: [f64; 3], x: f64, y: f64) -> ([f64; 3], [f64; 3], f64) {
    let [wx, wy, wz] = w;
    let t = wx.mul_add(wx, wy.mul_add(wy, wz * wz));
    let (s, c) = sinc_cosc_series(t);
    let k = (-c).mul_add(t, 1.0);
    // q_a = (−1, 0, x): w × q_a = (wy·x, −wz − wx·x, wy), w·q_a = wz·x − wx.
    let ca = c * wz.mul_add(x, -wx);
    let va = [
        s.mul_add(wy * x, ca.mul_add(wx, -k)),
        s.mul_add(-(wx.mul_add(x, wz)), ca * wy),
        s.mul_add(wy, ca.mul_add(wz, k * x)),
    ];
    // q_b = (0, −1, y): w × q_b = (wy·y + wz, −wx·y, −wx), w·q_b = wz·y − wy.
    let cb = c * wz.mul_add(y, -wy);
    let vb = [
        s.mul_add(wy.mul_add(y, wz), cb * wx),
        s.mul_add(-(wx * y), cb.mul_add(wy, -k)),
        s.mul_add(-wx, cb.mul_add(wz, k * y)),
    ];
    let turn = |v: [f64; 3]| {
        std::array::from_fn(|i| {
            r[3 * i].mul_add(v[0], r[3 * i + 1].mul_add(v[1], r[3 * i + 2] * v[2]))
        })
    };
    (turn(va), turn(vb), t)
}

/// Sines and cosines of the nominal ω, φ, κ of an observer (or of a chain link).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Trig {
    pub(crate) s: [f64; 3],
    pub(crate) c: [f64; 3],
}

/// `sin`, `cos` of `nominal + δ` per angle by the addition theorem (δ small).
#[inline(always)]
pub(crate) fn perturbed_trig(nom: &Trig, d: [f64; 3]) -> ([f64; 3], [f64; 3], f64) {
    let mut s = [0.0; 3];
    let mut c = [0.0; 3];
    let mut t = 0.0;
    for k in 0..3 {
        let (sd, cd) = sin_cos_series(d[k]);
        s[k] = nom.s[k] * cd + nom.c[k] * sd;
        c[k] = nom.c[k] * cd - nom.s[k] * sd;
        keep_max(&mut t, d[k] * d[k]);
    }
    (s, c, t)
}

/// Ray of `Rx(ω)Ry(φ)Rz(κ)` (third column) at the nominal angles plus `w`, and the largest
/// squared offset.
#[inline(always)]
pub(crate) fn euler_dir(nom: &Trig, w: [f64; 3]) -> ([f64; 3], f64) {
    let (s, c, t) = perturbed_trig(nom, w);
    ([s[1], -(s[0] * c[1]), c[0] * c[1]], t)
}

/// `Rx(ω)Ry(φ)Rz(κ)` (row-major) at the nominal angles plus `w`, and the largest squared
/// offset.
#[inline(always)]
pub(crate) fn euler_rot(nom: &Trig, w: [f64; 3]) -> ([f64; 9], f64) {
    let (s, c, t) = perturbed_trig(nom, w);
    let (so, co, sp, cp, sk, ck) = (s[0], c[0], s[1], c[1], s[2], c[2]);
    let m = [
        cp * ck,
        -(cp * sk),
        sp,
        co * sk + so * sp * ck,
        co * ck - so * sp * sk,
        -(so * cp),
        so * sk - co * sp * ck,
        so * ck + co * sp * sk,
        co * cp,
    ];
    (m, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normal rows with distinct, irregular values (no two products alike).
    fn rows() -> [Lane; 6] {
        std::array::from_fn(|i| {
            std::array::from_fn(|d| ((i * 64 + d) as f64 * 0.618_033_988_7).sin() * 3.1)
        })
    }

    #[test]
    fn apply_and_delta_lane_give_identical_bits() {
        // The narrow shape (`apply`, term by term over the row) and the wide one
        // (`delta_lane`, lane by lane) must round identically, for a full factor (every
        // entry of the lower triangle non-zero) and a diagonal one.
        let e = rows();
        let full = Matrix6::from_fn(|i, k| {
            if k <= i {
                0.3 + 0.7 * ((i * 6 + k) as f64).cos()
            } else {
                0.0
            }
        });
        let diag = Matrix6::from_diagonal(&nalgebra::Vector6::new(1.5, 1.4, 1.6, 2e-4, 3e-4, 1e-4));
        for (f, diagonal) in [(full, false), (diag, true)] {
            let n = NoiseFactor::from_lower(&f);
            assert_eq!(n.is_diagonal(), diagonal);
            let mut out = [[0.0; LANES]; 6];
            n.apply(&e, &mut out);
            for d in 0..LANES {
                let lane = if diagonal {
                    n.delta_lane::<true>(&e, d)
                } else {
                    n.delta_lane::<false>(&e, d)
                };
                for i in 0..6 {
                    assert_eq!(out[i][d].to_bits(), lane[i].to_bits(), "row {i} lane {d}");
                }
            }
            // And the general form on the diagonal factor gives the same bits too.
            let mut general = [[0.0; LANES]; 6];
            n.without_shortcut().apply(&e, &mut general);
            if diagonal {
                assert_eq!(general, out);
            }
        }
    }
}
