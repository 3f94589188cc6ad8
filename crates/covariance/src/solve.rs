//! The information matrix reduced to the poses and intrinsics (points eliminated by the
//! Schur complement, one 3×3 block at a time), its factorisation and the pose covariances.

use crate::Error;
use crate::jacobian::project;
use crate::problem::{PointKind, Problem};
use crashrig_geometry::Vec3;
use faer::Mat;
use faer::linalg::solvers::Solve;
use nalgebra::{Matrix3, SymmetricEigen};
use std::path::Path;

/// A pivot of the Jacobi-scaled Cholesky factor below this (squared) means the parameter is
/// not determined: in exact arithmetic a gauge freedom gives a zero pivot; a well-posed
/// bundle gives pivots of 1e-6 and above (the squared inverse condition of one parameter
/// against all others).
const SINGULAR_PIVOT: f64 = 1e-11;

/// Eigenvalues of a point's 3×3 block below this fraction of its largest are treated as zero
/// (a point at infinity along that direction: it is absorbed, not inverted).
const POINT_EIGEN_FLOOR: f64 = 1e-12;

/// One block of a point's cross information: `offset` of the first parameter in the reduced
/// system, and `W` (rows × 3).
struct Cross {
    offset: usize,
    w: Vec<[f64; 3]>,
}

impl Cross {
    fn add(
        crosses: &mut Vec<Cross>,
        offset: usize,
        rows: &[[f64; 2]],
        jp: &[[f64; 3]; 2],
        wgt: f64,
    ) {
        let idx = match crosses.iter().position(|c| c.offset == offset) {
            Some(i) => i,
            None => {
                crosses.push(Cross {
                    offset,
                    w: vec![[0.0; 3]; rows.len()],
                });
                crosses.len() - 1
            }
        };
        let c = &mut crosses[idx];
        for (a, col) in rows.iter().enumerate() {
            for (k, w) in c.w[a].iter_mut().enumerate().take(3) {
                *w += wgt * (col[0] * jp[0][k] + col[1] * jp[1][k]);
            }
        }
    }
}

/// The reduced information matrix `S = U − W V⁻¹ Wᵀ` over frames (6 each) and free
/// intrinsics, for pixel weight `1/σ²`.
pub(crate) fn reduced_information(p: &Problem, pixel_sigma: f64) -> Mat<f64> {
    let n = p.n_reduced;
    let wgt = 1.0 / (pixel_sigma * pixel_sigma);
    // Row-major n×n; only the upper triangle (row ≤ column) is accumulated, then mirrored.
    let mut s = vec![0.0; n * n];
    let mut crosses: Vec<Cross> = Vec::new();
    // Per observation: the columns of J restricted to the active parameters (index, [du, dv]),
    // in increasing index order (pose block first, then the camera's intrinsics).
    let mut active: Vec<(usize, [f64; 2])> = Vec::with_capacity(32);
    for pt in &p.points {
        crosses.clear();
        let mut v = Matrix3::<f64>::zeros();
        for o in &p.obs[pt.start..pt.end] {
            let im = &p.images[o.image];
            let cam = &p.cameras[im.camera];
            let fr = &p.frames[im.frame];
            // The model's estimate projected at build time, so this cannot fail.
            let Ok(pr) = project(
                &cam.camera,
                &im.sensor_from_rig,
                &fr.rig_from_world,
                &pt.xyz,
            ) else {
                continue;
            };
            active.clear();
            let f0 = 6 * im.frame;
            for k in 0..6 {
                active.push((f0 + k, [pr.d_pose[(0, k)], pr.d_pose[(1, k)]]));
            }
            for (j, &k) in cam.free.iter().enumerate() {
                active.push((cam.offset + j, [pr.d_params[(0, k)], pr.d_params[(1, k)]]));
            }
            // U: direct information of this observation (upper triangle).
            for &(a, ja) in &active {
                let row = &mut s[a * n..(a + 1) * n];
                for &(b, jb) in &active {
                    if b >= a {
                        row[b] += wgt * (ja[0] * jb[0] + ja[1] * jb[1]);
                    }
                }
            }
            if pt.kind == PointKind::Fixed {
                continue;
            }
            let jp = [
                [pr.d_point[(0, 0)], pr.d_point[(0, 1)], pr.d_point[(0, 2)]],
                [pr.d_point[(1, 0)], pr.d_point[(1, 1)], pr.d_point[(1, 2)]],
            ];
            v += wgt * pr.d_point.transpose() * pr.d_point;
            let pose_cols: Vec<[f64; 2]> = active[..6].iter().map(|x| x.1).collect();
            Cross::add(&mut crosses, f0, &pose_cols, &jp, wgt);
            if !cam.free.is_empty() {
                let cols: Vec<[f64; 2]> = active[6..].iter().map(|x| x.1).collect();
                Cross::add(&mut crosses, cam.offset, &cols, &jp, wgt);
            }
        }
        if pt.kind == PointKind::Fixed {
            continue;
        }
        if let PointKind::Prior(sigma) = pt.kind {
            v += Matrix3::identity() / (sigma * sigma);
        }
        let v_inv = pseudo_inverse(&v);
        // S −= W_c V⁻¹ W_dᵀ over every pair of blocks of this point (upper triangle: blocks
        // never overlap, so c.offset ≤ d.offset puts every entry on or above the diagonal).
        for c in &crosses {
            for (a, wa) in c.w.iter().enumerate() {
                let t = v_inv * Vec3::from(*wa);
                let row = &mut s[(c.offset + a) * n..(c.offset + a + 1) * n];
                for d in crosses.iter().filter(|d| d.offset >= c.offset) {
                    let start = if d.offset == c.offset { a } else { 0 };
                    for (b, wb) in d.w.iter().enumerate().skip(start) {
                        row[d.offset + b] -= t.x * wb[0] + t.y * wb[1] + t.z * wb[2];
                    }
                }
            }
        }
    }
    Mat::from_fn(
        n,
        n,
        |i, j| if i <= j { s[i * n + j] } else { s[j * n + i] },
    )
}

/// The inverse on the range of a symmetric positive semi-definite 3×3 block.
fn pseudo_inverse(v: &Matrix3<f64>) -> Matrix3<f64> {
    let e = SymmetricEigen::new(*v);
    let top = e.eigenvalues.max();
    let mut out = Matrix3::zeros();
    if top <= 0.0 {
        return out;
    }
    for k in 0..3 {
        let l = e.eigenvalues[k];
        if l > POINT_EIGEN_FLOOR * top {
            let u = e.eigenvectors.column(k);
            out += u * u.transpose() / l;
        }
    }
    out
}

/// The columns `cols` of `S⁻¹`, or [`Error::Singular`] naming the first parameter that the
/// observations and control points leave undetermined.
pub(crate) fn inverse_columns(
    p: &Problem,
    s: &Mat<f64>,
    cols: &[usize],
    model: &Path,
) -> Result<Mat<f64>, Error> {
    let n = s.nrows();
    let singular = |k: usize, why: &str| Error::Singular {
        model: model.to_path_buf(),
        problem: format!("{} is not determined ({why})", parameter_name(p, k)),
    };
    let mut d = vec![0.0; n];
    for (k, dk) in d.iter_mut().enumerate() {
        let v = s[(k, k)];
        if !(v.is_finite() && v > 0.0) {
            return Err(singular(k, "no information"));
        }
        *dk = 1.0 / v.sqrt();
    }
    let scaled = Mat::<f64>::from_fn(n, n, |i, j| s[(i, j)] * d[i] * d[j]);
    let llt = scaled.llt(faer::Side::Lower).map_err(|_| {
        let k = first_small_pivot(&scaled).unwrap_or(0);
        singular(k, "a gauge freedom or a degenerate configuration")
    })?;
    let l = llt.L();
    for k in 0..n {
        let piv = l[(k, k)] * l[(k, k)];
        if !(piv.is_finite() && piv > SINGULAR_PIVOT) {
            return Err(singular(k, "a gauge freedom or a degenerate configuration"));
        }
    }
    let mut e = Mat::<f64>::zeros(n, cols.len());
    for (j, &c) in cols.iter().enumerate() {
        e[(c, j)] = d[c];
    }
    let x = llt.solve(&e);
    Ok(Mat::from_fn(n, cols.len(), |i, j| x[(i, j)] * d[i]))
}

/// The first pivot of an unpivoted Cholesky that falls below [`SINGULAR_PIVOT`] (for the
/// message when faer refuses the matrix).
// `!(piv > limit)` also catches a NaN pivot.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn first_small_pivot(m: &Mat<f64>) -> Option<usize> {
    let n = m.nrows();
    let mut a = m.clone();
    for k in 0..n {
        let piv = a[(k, k)];
        if !(piv > SINGULAR_PIVOT) {
            return Some(k);
        }
        let r = piv.sqrt();
        for i in k..n {
            a[(i, k)] /= r;
        }
        for j in k + 1..n {
            let ajk = a[(j, k)];
            for i in j..n {
                let aik = a[(i, k)];
                a[(i, j)] -= aik * ajk;
            }
        }
    }
    None
}

/// A readable name of reduced-system parameter `k`.
pub(crate) fn parameter_name(p: &Problem, k: usize) -> String {
    const POSE: [&str; 6] = [
        "position x",
        "position y",
        "position z",
        "rotation about x",
        "rotation about y",
        "rotation about z",
    ];
    if k < 6 * p.frames.len() {
        return format!(
            "the pose ({}) of the frame of image `{}`",
            POSE[k % 6],
            p.frames[k / 6].label
        );
    }
    for c in &p.cameras {
        if k >= c.offset && k < c.offset + c.free.len() {
            let name = c.camera.model.param_names()[c.free[k - c.offset]];
            return format!(
                "intrinsic `{name}` of camera {} ({}; try --intrinsics colmap or fixed)",
                c.camera_id, c.camera.model
            );
        }
    }
    format!("parameter {k}")
}
