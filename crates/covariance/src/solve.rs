//! The information matrix reduced to the poses and intrinsics (points eliminated by the
//! Schur complement, one 3×3 block at a time), its factorisation and the pose covariances.

use crate::Error;
use crate::jacobian::project;
use crate::problem::{PointKind, Problem};
use faer::Mat;
use faer::linalg::solvers::Solve;
use std::path::Path;

/// The rank test's relative tolerance: the reduced system, Jacobi-scaled (unit diagonal), is
/// numerically singular when its smallest eigenvalue is below `max(RANK_TOLERANCE, n·ε)` times
/// its largest (`n` unknowns, `ε` the double-precision epsilon, as numpy's `matrix_rank`).
/// Well-posed real bundles measured 2·10⁻¹¹ … 3·10⁻⁷ (`docs/COVARIANCE.md`); numerically
/// singular ones 1.5·10⁻¹⁵ and below. At this bound the rounding error of the covariance,
/// about `ε` over the ratio, is still below 0.3 %.
pub const RANK_TOLERANCE: f64 = 1e-13;

/// Iterations of the power and inverse iterations of the rank test (each stops earlier once
/// its estimate changes by less than [`ITERATION_CONVERGED`] relative).
const MAX_ITERATIONS: usize = 60;

/// Relative change of an eigenvalue estimate at which its iteration stops.
const ITERATION_CONVERGED: f64 = 1e-4;

/// A component of the undetermined direction (unit vector in Jacobi-scaled unknowns) at least
/// this fraction of its largest is named in the error.
const DIRECTION_SHARE: f64 = 0.25;

/// Unknowns named in the error at most (the rest is counted).
const DIRECTION_NAMED: usize = 6;

/// Eigenvalues of a point's 3×3 block below this fraction of its largest are treated as zero
/// (a point at infinity along that direction: it is absorbed, not inverted).
const POINT_EIGEN_FLOOR: f64 = 1e-12;

/// Scratch of one eliminated point: its weighted Jacobian rows (`rows` of them), the point's
/// three columns and, per column block it touches (a frame's pose, a camera's free intrinsics;
/// `blocks[k] = (offset in the reduced system, width, first local column)`), its columns.
#[derive(Default)]
struct PointRows {
    rows: usize,
    /// `rows × 3`, row-major.
    jp: Vec<f64>,
    /// `rows × cols`, row-major.
    jc: Vec<f64>,
    cols: usize,
    blocks: Vec<(usize, usize, usize)>,
}

impl PointRows {
    fn clear(&mut self) {
        self.rows = 0;
        self.cols = 0;
        self.jp.clear();
        self.jc.clear();
        self.blocks.clear();
    }

    /// The first local column of the block at `offset` (`width` wide), added when new.
    fn block(&mut self, offset: usize, width: usize) -> usize {
        if let Some(b) = self.blocks.iter().find(|b| b.0 == offset) {
            return b.2;
        }
        let first = self.cols;
        self.blocks.push((offset, width, first));
        self.cols += width;
        first
    }
}

/// One observation of an eliminated point: the first local column of its frame block and of
/// its camera's intrinsics block, the number of free intrinsics, where its `[du, dv]` per
/// active parameter (pose, then intrinsics) start in the point's shared list of them, and its
/// 2×3 point Jacobian.
type ObsRow = (usize, usize, usize, usize, [[f64; 3]; 2]);

/// The reduced information matrix `S = U − W V⁻¹ Wᵀ` over frames (6 each) and free
/// intrinsics, for pixel weight `1/σ²`.
///
/// Each eliminated point's share is formed as `YᵀY`, `Y = (I − Q Qᵀ)·J_c`, with `J_c` its
/// weighted Jacobian rows over the frames and intrinsics and `Q` an orthonormal basis of the
/// range of its point columns (from their SVD; directions below 10⁻⁶ of the largest singular
/// value — eigenvalues of `V` below 10⁻¹² of the largest — are not eliminated, as a point near
/// infinity). In exact arithmetic `YᵀY = U − W V⁻¹ Wᵀ`; in floating point the difference of
/// the two large terms loses what the point absorbs (issue 47: a point close to a camera centre,
/// a weak depth), while `Y` is formed from the Jacobian itself, never squaring its
/// conditioning.
pub(crate) fn reduced_information(p: &Problem, pixel_sigma: f64) -> Mat<f64> {
    let n = p.n_reduced;
    let w = 1.0 / pixel_sigma;
    // Row-major n×n; only the upper triangle (row ≤ column) is accumulated, then mirrored.
    let mut s = vec![0.0; n * n];
    let mut pt_rows = PointRows::default();
    // Per observation: the columns of J restricted to the active parameters (index, [du, dv]),
    // in increasing index order (pose block first, then the camera's intrinsics).
    let mut active: Vec<(usize, [f64; 2])> = Vec::with_capacity(32);
    let mut y: Vec<f64> = Vec::new();
    let mut z: Vec<f64> = Vec::new();
    let mut global: Vec<usize> = Vec::new();
    // One point's observations and their `[du, dv]` (buffers reused across points).
    let mut obs_rows: Vec<ObsRow> = Vec::new();
    let mut obs_j: Vec<[f64; 2]> = Vec::new();
    for pt in &p.points {
        pt_rows.clear();
        // First pass: the column blocks of this point (frames, then cameras, in order seen).
        obs_rows.clear();
        obs_j.clear();
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
            if pt.kind == PointKind::Fixed {
                // U: direct information of this observation (upper triangle).
                let wgt = w * w;
                for &(a, ja) in &active {
                    let row = &mut s[a * n..(a + 1) * n];
                    for &(b, jb) in &active {
                        if b >= a {
                            row[b] += wgt * (ja[0] * jb[0] + ja[1] * jb[1]);
                        }
                    }
                }
                continue;
            }
            let pose = pt_rows.block(f0, 6);
            let intr = if cam.free.is_empty() {
                usize::MAX
            } else {
                pt_rows.block(cam.offset, cam.free.len())
            };
            let jp = [
                [pr.d_point[(0, 0)], pr.d_point[(0, 1)], pr.d_point[(0, 2)]],
                [pr.d_point[(1, 0)], pr.d_point[(1, 1)], pr.d_point[(1, 2)]],
            ];
            obs_rows.push((pose, intr, cam.free.len(), obs_j.len(), jp));
            obs_j.extend(active.iter().map(|x| x.1));
        }
        if pt.kind == PointKind::Fixed {
            continue;
        }
        // Second pass: the weighted rows (two per observation, three for a prior).
        let cols = pt_rows.cols;
        let prior = matches!(pt.kind, PointKind::Prior(_));
        let rows = 2 * obs_rows.len() + if prior { 3 } else { 0 };
        pt_rows.rows = rows;
        pt_rows.jp.resize(rows * 3, 0.0);
        pt_rows.jc.resize(rows * cols, 0.0);
        for (k, &(pose, intr, nf, j0, jp)) in obs_rows.iter().enumerate() {
            let jc = &obs_j[j0..j0 + 6 + nf];
            for r in 0..2 {
                let row = 2 * k + r;
                for (dst, j) in pt_rows.jp[row * 3..row * 3 + 3].iter_mut().zip(jp[r]) {
                    *dst = w * j;
                }
                let out = &mut pt_rows.jc[row * cols..(row + 1) * cols];
                for c in 0..6 {
                    out[pose + c] = w * jc[c][r];
                }
                for c in 0..nf {
                    out[intr + c] = w * jc[6 + c][r];
                }
            }
        }
        if let PointKind::Prior(sigma) = pt.kind {
            for c in 0..3 {
                pt_rows.jp[(rows - 3 + c) * 3 + c] = 1.0 / sigma;
            }
        }
        add_point_share(&mut s, n, &pt_rows, &mut y, &mut z, &mut global);
    }
    Mat::from_fn(
        n,
        n,
        |i, j| if i <= j { s[i * n + j] } else { s[j * n + i] },
    )
}

/// Adds one eliminated point's share `YᵀY` (`Y = (I − Q Qᵀ)·J_c`) to the upper triangle of
/// the row-major `n×n` reduced system `s` (see [`reduced_information`]); `y`, `z` and `global`
/// are scratch buffers reused across points.
fn add_point_share(
    s: &mut [f64],
    n: usize,
    pt_rows: &PointRows,
    y: &mut Vec<f64>,
    z: &mut Vec<f64>,
    global: &mut Vec<usize>,
) {
    let (rows, cols) = (pt_rows.rows, pt_rows.cols);
    // Q: the left singular vectors of the point columns above the floor.
    let jp = nalgebra::DMatrix::from_row_slice(rows, 3, &pt_rows.jp);
    let svd = jp.svd(true, false);
    let Some(u) = svd.u else { return };
    let top = svd.singular_values.max();
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| {
            let sv = svd.singular_values[k];
            top > 0.0 && sv * sv > POINT_EIGEN_FLOOR * top * top
        })
        .collect();
    // Z = Qᵀ J_c (keep × cols), Y = J_c − Q Z (rows × cols).
    z.clear();
    z.resize(keep.len() * cols, 0.0);
    for (q, &k) in keep.iter().enumerate() {
        let zq = &mut z[q * cols..(q + 1) * cols];
        for r in 0..rows {
            let uq = u[(r, k)];
            let jr = &pt_rows.jc[r * cols..(r + 1) * cols];
            for (zc, jc) in zq.iter_mut().zip(jr) {
                *zc += uq * jc;
            }
        }
    }
    // Yᵀ (cols × rows), so that each entry of YᵀY is a contiguous dot product.
    y.clear();
    y.resize(cols * rows, 0.0);
    for r in 0..rows {
        for c in 0..cols {
            let mut v = pt_rows.jc[r * cols + c];
            for (q, &k) in keep.iter().enumerate() {
                v -= u[(r, k)] * z[q * cols + c];
            }
            y[c * rows + r] = v;
        }
    }
    // S += YᵀY (upper triangle of the reduced system).
    global.clear();
    global.resize(cols, 0);
    for &(offset, width, first) in &pt_rows.blocks {
        for c in 0..width {
            global[first + c] = offset + c;
        }
    }
    // Four entries of a row at a time, each its own sum over the rows in row order (the bits of
    // one `sum` per entry; the four independent sums keep the CPU's adders busy).
    let mut bs: Vec<usize> = Vec::with_capacity(cols);
    for a in 0..cols {
        let ga = global[a];
        bs.clear();
        bs.extend((0..cols).filter(|&b| {
            let gb = global[b];
            !(gb < ga || (ga == gb && b != a))
        }));
        let ya = &y[a * rows..(a + 1) * rows];
        let col = |b: usize| &y[b * rows..(b + 1) * rows];
        let mut quads = bs.chunks_exact(4);
        for q in quads.by_ref() {
            let (y0, y1, y2, y3) = (col(q[0]), col(q[1]), col(q[2]), col(q[3]));
            let mut acc = [-0.0f64; 4];
            for r in 0..rows {
                let p = ya[r];
                acc[0] += p * y0[r];
                acc[1] += p * y1[r];
                acc[2] += p * y2[r];
                acc[3] += p * y3[r];
            }
            for (&b, v) in q.iter().zip(acc) {
                s[ga * n + global[b]] += v;
            }
        }
        for &b in quads.remainder() {
            s[ga * n + global[b]] += ya.iter().zip(col(b)).map(|(p, q)| p * q).sum::<f64>();
        }
    }
}

/// The relative tolerance of the rank test for `n` unknowns ([`RANK_TOLERANCE`]).
pub(crate) fn rank_tolerance(n: usize) -> f64 {
    RANK_TOLERANCE.max(n as f64 * f64::EPSILON)
}

/// The columns `cols` of `S⁻¹`, or [`Error::Singular`] naming the parameters that the
/// observations and control points leave undetermined: a zero diagonal, or a smallest
/// eigenvalue of the Jacobi-scaled system below [`rank_tolerance`] times its largest (then the
/// error names the unknowns of the undetermined direction).
pub(crate) fn inverse_columns(
    p: &Problem,
    s: &Mat<f64>,
    cols: &[usize],
    model: &Path,
) -> Result<Mat<f64>, Error> {
    let n = s.nrows();
    let mut d = vec![0.0; n];
    for (k, dk) in d.iter_mut().enumerate() {
        let v = s[(k, k)];
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Singular {
                model: model.to_path_buf(),
                problem: format!(
                    "{} is not determined (no information)",
                    parameter_name(p, k)
                ),
            });
        }
        *dk = 1.0 / v.sqrt();
    }
    let scaled = Mat::<f64>::from_fn(n, n, |i, j| s[(i, j)] * d[i] * d[j]);
    let tol = rank_tolerance(n);
    let largest = largest_eigenvalue(&scaled);
    let llt = match scaled.llt(faer::Side::Lower) {
        Ok(llt) => llt,
        Err(_) => {
            let problem = match null_direction(&scaled, largest, tol) {
                Some(v) => direction_message(p, &v, None, tol),
                None => {
                    let k = first_small_pivot(&scaled, tol * largest).unwrap_or(0);
                    format!(
                        "{} is not determined (a gauge freedom or a degenerate configuration)",
                        parameter_name(p, k)
                    )
                }
            };
            return Err(Error::Singular {
                model: model.to_path_buf(),
                problem,
            });
        }
    };
    let (smallest, v) = smallest_eigenpair(n, |x| llt.solve(x), tol * largest);
    // `!(a >= b)` also refuses a NaN estimate.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(smallest >= tol * largest) {
        return Err(Error::Singular {
            model: model.to_path_buf(),
            problem: direction_message(p, &v, Some(smallest / largest), tol),
        });
    }
    let mut e = Mat::<f64>::zeros(n, cols.len());
    for (j, &c) in cols.iter().enumerate() {
        e[(c, j)] = d[c];
    }
    let x = llt.solve(&e);
    Ok(Mat::from_fn(n, cols.len(), |i, j| x[(i, j)] * d[i]))
}

/// A fixed start vector for the iterations: entries in (−1, 1) from a hash of the index (no
/// symmetry that could make it orthogonal to the direction sought), unit length.
fn start_vector(n: usize) -> Mat<f64> {
    let mut x = Mat::<f64>::from_fn(n, 1, |k, _| {
        let mut z = (k as u64)
            .wrapping_add(1)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64 - 1.0
    });
    let norm = x.norm_l2();
    x /= faer::Scale(norm);
    x
}

/// The largest eigenvalue of the symmetric positive semi-definite `m` by power iteration: a
/// lower bound that converges to it (at least the largest diagonal entry).
fn largest_eigenvalue(m: &Mat<f64>) -> f64 {
    let n = m.nrows();
    let diag = (0..n).map(|k| m[(k, k)]).fold(0.0, f64::max);
    let mut x = start_vector(n);
    let mut estimate = 0.0_f64;
    for _ in 0..MAX_ITERATIONS {
        let y = m * &x;
        let norm = y.norm_l2();
        if !(norm.is_finite() && norm > 0.0) {
            break;
        }
        x = y / faer::Scale(norm);
        let done = (norm - estimate).abs() <= ITERATION_CONVERGED * norm;
        estimate = norm;
        if done {
            break;
        }
    }
    estimate.max(diag)
}

/// The smallest eigenvalue of a symmetric positive definite matrix given by its `solve`
/// (`x ↦ M⁻¹x`), and its unit eigenvector, by inverse iteration. Each estimate `1/‖M⁻¹x‖`
/// (`x` unit) is an upper bound of the smallest eigenvalue, so the iteration stops as soon as
/// one falls below `enough` (the matrix is then certainly that close to singular), when it
/// has converged, or after [`MAX_ITERATIONS`]. A solve that overflows gives 0.
fn smallest_eigenpair(
    n: usize,
    solve: impl Fn(&Mat<f64>) -> Mat<f64>,
    enough: f64,
) -> (f64, Mat<f64>) {
    let mut x = start_vector(n);
    let mut estimate = f64::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let y = solve(&x);
        let norm = y.norm_l2();
        if !(norm.is_finite() && norm > 0.0) {
            return (0.0, x);
        }
        x = y / faer::Scale(norm);
        let lambda = 1.0 / norm;
        let done = lambda < enough || (estimate - lambda).abs() <= ITERATION_CONVERGED * lambda;
        estimate = lambda;
        if done {
            break;
        }
    }
    (estimate, x)
}

/// The undetermined direction of a scaled system that Cholesky refused (rounding made it
/// slightly indefinite): the eigenvector of its smallest eigenvalue, found on the system
/// shifted by the smallest multiple of `largest·tol` (× 10² steps) that factorises. `None`
/// when no shift up to 10⁻² of the largest eigenvalue does.
fn null_direction(scaled: &Mat<f64>, largest: f64, tol: f64) -> Option<Mat<f64>> {
    let n = scaled.nrows();
    let mut shift = tol * largest;
    while shift <= 1e-2 * largest {
        let shifted = Mat::<f64>::from_fn(n, n, |i, j| {
            scaled[(i, j)] + if i == j { shift } else { 0.0 }
        });
        if let Ok(llt) = shifted.llt(faer::Side::Lower) {
            return Some(smallest_eigenpair(n, |x| llt.solve(x), 0.0).1);
        }
        shift *= 1e2;
    }
    None
}

/// The error text for an undetermined direction `v` (unit, Jacobi-scaled unknowns): the
/// unknowns it moves, grouped by frame and camera, with the eigenvalue ratio (`None`: the
/// factorisation failed) and a hint.
fn direction_message(p: &Problem, v: &Mat<f64>, ratio: Option<f64>, tol: f64) -> String {
    let n = v.nrows();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| v[(b, 0)].abs().total_cmp(&v[(a, 0)].abs()).then(a.cmp(&b)));
    let top = v[(order[0], 0)].abs();
    let named: Vec<usize> = order
        .iter()
        .copied()
        .take_while(|&k| v[(k, 0)].abs() >= DIRECTION_SHARE * top)
        .collect();
    let more = named.len().saturating_sub(DIRECTION_NAMED);
    let named = &named[..named.len().min(DIRECTION_NAMED)];
    // Blocks (a frame's pose or a camera's intrinsics) in order of their largest component.
    let mut blocks: Vec<(Block, Vec<usize>)> = Vec::new();
    for &k in named {
        let b = block(p, k);
        match blocks.iter_mut().find(|(bb, _)| *bb == b) {
            Some((_, ks)) => ks.push(k),
            None => blocks.push((b, vec![k])),
        }
    }
    let parts: Vec<String> = blocks.iter().map(|(b, ks)| block_text(p, *b, ks)).collect();
    let one = named.len() == 1 && more == 0;
    let what = match parts.as_slice() {
        [only] => only.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
        [] => "a parameter".into(),
    };
    let more = if more > 0 {
        format!(" and {more} more unknown(s)")
    } else {
        String::new()
    };
    let verb = if one {
        "is not determined".to_string()
    } else {
        "are not determined: one combination of them is free".to_string()
    };
    let size = match ratio {
        Some(r) => format!(
            "the Jacobi-scaled reduced system's smallest eigenvalue is {r:.1e} of its largest, \
             below the rank tolerance {tol:.0e}"
        ),
        None => "the Jacobi-scaled reduced system is not positive definite".into(),
    };
    let hint = if blocks.iter().any(|(b, _)| matches!(b, Block::Camera(_))) {
        "; try --intrinsics colmap or fixed"
    } else {
        "; a degenerate configuration: an image whose points are too few or nearly on one \
         line, or images that share one centre"
    };
    format!("{what}{more} {verb} ({size}{hint})")
}

/// The frame or camera an unknown of the reduced system belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Block {
    Frame(usize),
    Camera(usize),
    Other,
}

fn block(p: &Problem, k: usize) -> Block {
    if k < 6 * p.frames.len() {
        return Block::Frame(k / 6);
    }
    p.cameras
        .iter()
        .position(|c| k >= c.offset && k < c.offset + c.free.len())
        .map_or(Block::Other, Block::Camera)
}

const POSE_AXES: [&str; 6] = [
    "position x",
    "position y",
    "position z",
    "rotation about x",
    "rotation about y",
    "rotation about z",
];

/// "the pose (position x, rotation about z) of the frame of image `…`", "intrinsics `f`, `k` of
/// camera 1 (SIMPLE_RADIAL)".
fn block_text(p: &Problem, b: Block, ks: &[usize]) -> String {
    match b {
        Block::Frame(f) => format!(
            "the pose ({}) of the frame of image `{}`",
            ks.iter()
                .map(|k| POSE_AXES[k % 6])
                .collect::<Vec<_>>()
                .join(", "),
            p.frames[f].label
        ),
        Block::Camera(c) => {
            let cam = &p.cameras[c];
            let names: Vec<String> = ks
                .iter()
                .map(|k| {
                    format!(
                        "`{}`",
                        cam.camera.model.param_names()[cam.free[k - cam.offset]]
                    )
                })
                .collect();
            format!(
                "intrinsic{} {} of camera {} ({})",
                if names.len() > 1 { "s" } else { "" },
                names.join(", "),
                cam.camera_id,
                cam.camera.model
            )
        }
        Block::Other => ks
            .iter()
            .map(|k| format!("parameter {k}"))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The first pivot of an unpivoted Cholesky that falls below `limit` (for the message when
/// no other way finds the undetermined direction).
// `!(piv > limit)` also catches a NaN pivot.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn first_small_pivot(m: &Mat<f64>, limit: f64) -> Option<usize> {
    let n = m.nrows();
    let mut a = m.clone();
    for k in 0..n {
        let piv = a[(k, k)];
        if !(piv > limit) {
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
    if k < 6 * p.frames.len() {
        return format!(
            "the pose ({}) of the frame of image `{}`",
            POSE_AXES[k % 6],
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{ring_scene, with_line_image};
    use crate::{ControlPoints, Intrinsics};
    use crashrig_colmap::CameraSelector;

    /// `Q·diag(λ)·Qᵀ` with a fixed orthogonal `Q` (Householder reflections of hashed vectors).
    fn with_eigenvalues(lambda: &[f64]) -> Mat<f64> {
        let n = lambda.len();
        let mut q = Mat::<f64>::identity(n, n);
        for r in 0..3 {
            let mut v = start_vector(n + r).subrows(r, n).to_owned();
            let norm = v.norm_l2();
            v /= faer::Scale(norm);
            let h = Mat::<f64>::identity(n, n) - (&v * v.transpose()) * faer::Scale(2.0);
            q = &q * &h;
        }
        let d = Mat::<f64>::from_fn(n, n, |i, j| if i == j { lambda[i] } else { 0.0 });
        &q * &d * q.transpose()
    }

    /// The power and inverse iterations against known spectra: a well separated smallest
    /// eigenvalue is found to 10⁻⁴, a clustered one (10 % apart) is never under-estimated and
    /// is over-estimated by at most 1 %, one at the rounding level (10⁻¹⁶ of the largest) is
    /// put below the rank tolerance; the largest is found to 10⁻³.
    #[test]
    fn iterations_find_the_extreme_eigenvalues() {
        for (lambda, tol) in [
            (vec![1e-9, 1e-3, 0.1, 0.5, 1.0, 2.0, 3.0, 5.0], 1e-4),
            (vec![1e-6, 1.1e-6, 0.2, 0.7, 1.3, 2.0, 4.0, 4.4], 1e-2),
        ] {
            let m = with_eigenvalues(&lambda);
            let n = lambda.len();
            let llt = m.llt(faer::Side::Lower).unwrap();
            let (small, v) = smallest_eigenpair(n, |x| llt.solve(x), 0.0);
            let (lo, hi) = (lambda[0], lambda[n - 1]);
            // Rounding of M (~ε·‖M‖ = 10⁻¹⁵) is below 10⁻⁶ of λ_min here.
            assert!(
                small >= lo * (1.0 - 1e-6) && small <= lo * (1.0 + tol),
                "{small} vs {lo}"
            );
            // The eigenvector: ‖M v‖ ≈ λ_min.
            let mv = (&m * &v).norm_l2();
            assert!(mv <= lo * (1.0 + 10.0 * tol), "{mv} vs {lo}");
            let big = largest_eigenvalue(&m);
            assert!(
                big <= hi * (1.0 + 1e-12) && big >= hi * (1.0 - 1e-3),
                "{big} vs {hi}"
            );
        }
        let lambda = [5e-16, 1e-3, 0.1, 0.5, 1.0, 2.0, 3.0, 5.0];
        let m = with_eigenvalues(&lambda);
        let limit = rank_tolerance(lambda.len()) * largest_eigenvalue(&m);
        match m.llt(faer::Side::Lower) {
            Ok(llt) => {
                let (small, _) = smallest_eigenpair(lambda.len(), |x| llt.solve(x), limit);
                assert!(small < limit, "{small} vs {limit}");
            }
            // Rounding made it indefinite: refused all the same.
            Err(_) => assert!(null_direction(&m, 5.0, 1e-13).is_some()),
        }
    }

    /// Issue 36: the old guard (every pivot of the Jacobi-scaled Cholesky factor above 10⁻¹¹)
    /// passes a numerically singular system — the line image at an offset of 10⁻⁶, whose
    /// smallest eigenvalue is ~10⁻¹⁶ of the largest — while the rank test refuses it.
    #[test]
    fn the_rank_test_refuses_what_the_old_pivot_guard_passed() {
        let scene = with_line_image(&ring_scene(4, 0.3), 1e-6);
        let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
        let p = crate::problem::build(
            &scene.model,
            &CameraSelector::parse("cam_out/"),
            &control,
            1000.0,
            Intrinsics::All,
        )
        .unwrap();
        let s = reduced_information(&p, 0.5);
        let n = s.nrows();
        let scaled = Mat::<f64>::from_fn(n, n, |i, j| s[(i, j)] / (s[(i, i)] * s[(j, j)]).sqrt());
        let llt = scaled.llt(faer::Side::Lower).expect("Cholesky succeeds");
        let l = llt.L();
        let smallest_pivot = (0..n)
            .map(|k| l[(k, k)] * l[(k, k)])
            .fold(f64::INFINITY, f64::min);
        assert!(smallest_pivot > 1e-11, "{smallest_pivot}");
        let e = inverse_columns(&p, &s, &[0], Path::new("m")).unwrap_err();
        assert!(e.to_string().contains("cam_out/9999.png"), "{e}");
    }
}
