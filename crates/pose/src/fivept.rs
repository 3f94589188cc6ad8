//! Minimal relative-pose solver: the 5-point essential matrix of Stewénius, Engels and Nistér.
//!
//! Reference: H. Stewénius, C. Engels, D. Nistér, "Recent developments on direct relative
//! orientation", ISPRS J. Photogramm. Remote Sens. 60(4), 2006. The essential matrix is
//! `E = x·X + y·Y + z·Z + W` over the null space of the five epipolar constraints; the cubic
//! constraints `det E = 0` and `2·E·Eᵀ·E − tr(E·Eᵀ)·E = 0` give 10 equations in 20 monomials,
//! reduced by Gauss–Jordan elimination to a 10×10 action matrix for multiplication by `x`,
//! whose eigenvectors are the monomial vectors of the (up to 10) solutions.

use crashrig_geometry::Vec3;
use nalgebra::{DMatrix, Matrix3, SMatrix, SVector, Vector2};

/// Monomials `x^i y^j z^k` in matrix column order: the 10 cubics, then the action basis
/// `[x², xy, y², xz, yz, z², x, y, z, 1]`.
const MONOS: [(usize, usize, usize); 20] = [
    (3, 0, 0),
    (2, 1, 0),
    (1, 2, 0),
    (0, 3, 0),
    (2, 0, 1),
    (1, 1, 1),
    (0, 2, 1),
    (1, 0, 2),
    (0, 1, 2),
    (0, 0, 3),
    (2, 0, 0),
    (1, 1, 0),
    (0, 2, 0),
    (1, 0, 1),
    (0, 1, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, 0),
];

/// `INDEX[i][j][k]` = column of `x^i y^j z^k` (20 = not a monomial of degree ≤ 3).
const INDEX: [[[usize; 4]; 4]; 4] = {
    let mut t = [[[20usize; 4]; 4]; 4];
    let mut m = 0;
    while m < 20 {
        let (i, j, k) = MONOS[m];
        t[i][j][k] = m;
        m += 1;
    }
    t
};

/// A polynomial of degree ≤ 3 in x, y, z (coefficients in [`MONOS`] order).
type Poly = [f64; 20];

fn mul(a: &Poly, b: &Poly) -> Poly {
    let mut out = [0.0; 20];
    for (ma, &ca) in a.iter().enumerate() {
        if ca == 0.0 {
            continue;
        }
        let (ai, aj, ak) = MONOS[ma];
        for (mb, &cb) in b.iter().enumerate() {
            if cb == 0.0 {
                continue;
            }
            let (bi, bj, bk) = MONOS[mb];
            let (i, j, k) = (ai + bi, aj + bj, ak + bk);
            // Callers multiply at most three linear factors: the degree never exceeds 3.
            if i + j + k <= 3 {
                out[INDEX[i][j][k]] += ca * cb;
            }
        }
    }
    out
}

fn add(a: &Poly, b: &Poly, s: f64) -> Poly {
    std::array::from_fn(|m| a[m] + s * b[m])
}

/// Up to 10 essential matrices (`x_bᵀ·E·x_a = 0`, normalized coordinates) from exactly five
/// correspondences. Empty for degenerate samples.
pub fn essential_5point(xa: &[Vector2<f64>; 5], xb: &[Vector2<f64>; 5]) -> Vec<Matrix3<f64>> {
    // Null space of the 5×9 constraint matrix: the 4 eigenvectors of AᵀA with the smallest
    // eigenvalues.
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (a, b) in xa.iter().zip(xb) {
        let a = Vec3::new(a.x, a.y, 1.0);
        let b = Vec3::new(b.x, b.y, 1.0);
        let row = SVector::<f64, 9>::from_fn(|k, _| b[k / 3] * a[k % 3]);
        ata += row * row.transpose();
    }
    let eig = ata.symmetric_eigen();
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let basis: Vec<SVector<f64, 9>> = order[..4]
        .iter()
        .map(|&i| eig.eigenvectors.column(i).into_owned())
        .collect();
    // E entries as linear polynomials: x·X + y·Y + z·Z + W.
    let lin = |r: usize, c: usize| -> Poly {
        let mut p = [0.0; 20];
        let k = 3 * r + c;
        p[INDEX[1][0][0]] = basis[0][k];
        p[INDEX[0][1][0]] = basis[1][k];
        p[INDEX[0][0][1]] = basis[2][k];
        p[INDEX[0][0][0]] = basis[3][k];
        p
    };
    let e: [[Poly; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| lin(r, c)));
    let mut rows: Vec<Poly> = Vec::with_capacity(10);
    // det E.
    let minor = |r1: usize, c1: usize, r2: usize, c2: usize| {
        add(
            &mul(&e[r1][c1], &e[r2][c2]),
            &mul(&e[r1][c2], &e[r2][c1]),
            -1.0,
        )
    };
    let det = add(
        &add(
            &mul(&e[0][0], &minor(1, 1, 2, 2)),
            &mul(&e[0][1], &minor(1, 0, 2, 2)),
            -1.0,
        ),
        &mul(&e[0][2], &minor(1, 0, 2, 1)),
        1.0,
    );
    rows.push(det);
    // 2·E·Eᵀ·E − tr(E·Eᵀ)·E.
    let eet: [[Poly; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..3).fold([0.0; 20], |acc, k| add(&acc, &mul(&e[i][k], &e[j][k]), 1.0))
        })
    });
    let tr = add(&add(&eet[0][0], &eet[1][1], 1.0), &eet[2][2], 1.0);
    // Index loops mirror the matrix formula.
    #[allow(clippy::needless_range_loop)]
    for i in 0..3 {
        for j in 0..3 {
            let mut p = (0..3).fold([0.0; 20], |acc, k| {
                add(&acc, &mul(&eet[i][k], &e[k][j]), 2.0)
            });
            p = add(&p, &mul(&tr, &e[i][j]), -1.0);
            rows.push(p);
        }
    }
    // Gauss–Jordan on the 10×20 coefficient matrix (partial pivoting).
    let mut m = DMatrix::<f64>::from_fn(10, 20, |r, c| rows[r][c]);
    let scale = m.amax();
    if scale == 0.0 || !scale.is_finite() {
        return Vec::new();
    }
    for col in 0..10 {
        let (piv, val) = (col..10)
            .map(|r| (r, m[(r, col)].abs()))
            .fold((col, -1.0), |best, x| if x.1 > best.1 { x } else { best });
        if val < 1e-12 * scale {
            return Vec::new();
        }
        m.swap_rows(col, piv);
        let p = m[(col, col)];
        for c in 0..20 {
            m[(col, c)] /= p;
        }
        for r in 0..10 {
            if r != col {
                let f = m[(r, col)];
                if f != 0.0 {
                    for c in 0..20 {
                        m[(r, c)] -= f * m[(col, c)];
                    }
                }
            }
        }
    }
    // Action matrix of multiplication by x on b = [x², xy, y², xz, yz, z², x, y, z, 1].
    // x·b = [x³, x²y, xy², x²z, xyz, xz², x², xy, xz, x]; a cubic c is −(row c of B)·b.
    let mut act = DMatrix::<f64>::zeros(10, 10);
    for (i, cubic) in [0usize, 1, 2, 4, 5, 7].into_iter().enumerate() {
        for j in 0..10 {
            act[(i, j)] = -m[(cubic, 10 + j)];
        }
    }
    for (i, b) in [(6usize, 0usize), (7, 1), (8, 3), (9, 6)] {
        act[(i, b)] = 1.0;
    }
    let mut out = Vec::new();
    for lambda in act.clone().complex_eigenvalues().iter() {
        if lambda.im.abs() > 1e-8 * (1.0 + lambda.re.abs()) {
            continue;
        }
        // Eigenvector: the null vector of (A − λI), from the SVD.
        let shifted = &act - DMatrix::<f64>::identity(10, 10) * lambda.re;
        let svd = shifted.svd(false, true);
        let Some(vt) = svd.v_t else { continue };
        let k = svd.singular_values.imin();
        let v = vt.row(k);
        if v[9].abs() < 1e-14 {
            continue;
        }
        let (x, y, z) = (v[6] / v[9], v[7] / v[9], v[8] / v[9]);
        let ev = basis[0] * x + basis[1] * y + basis[2] * z + basis[3];
        let em = Matrix3::from_fn(|r, c| ev[3 * r + c]);
        let n = em.norm();
        if n > 0.0 && n.is_finite() {
            out.push(em / n);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_table_nominal() {
        for (m, &(i, j, k)) in MONOS.iter().enumerate() {
            assert_eq!(INDEX[i][j][k], m);
        }
        // (x + 2)(y − 1) = xy − x + 2y − 2.
        let mut a = [0.0; 20];
        a[INDEX[1][0][0]] = 1.0;
        a[INDEX[0][0][0]] = 2.0;
        let mut b = [0.0; 20];
        b[INDEX[0][1][0]] = 1.0;
        b[INDEX[0][0][0]] = -1.0;
        let p = mul(&a, &b);
        assert_eq!(p[INDEX[1][1][0]], 1.0);
        assert_eq!(p[INDEX[1][0][0]], -1.0);
        assert_eq!(p[INDEX[0][1][0]], 2.0);
        assert_eq!(p[INDEX[0][0][0]], -2.0);
    }
}
