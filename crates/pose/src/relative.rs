//! Relative orientation: 5-point essential matrix (Stewénius–Engels–Nistér, [`essential_5point`])
//! in seeded LO-RANSAC, cheirality, Levenberg–Marquardt on the Sampson error over rotation × the
//! sphere of translation directions, with the first-order covariance; metric scale from a given
//! base length.
//!
//! The local optimisation of LO-RANSAC re-estimates E from all current inliers with the linear
//! 8-point algorithm (Longuet-Higgins 1981, with the essential-matrix projection of Hartley &
//! Zisserman §9.6), then LM refines the final pose.

use crate::fivept::essential_5point;
use crate::lm::{self, Problem};
use crate::ransac::{Consensus, Estimator, RansacOptions, lo_ransac};
use crate::{Degeneracy, Error, Projector};
use crashrig_geometry::{Rigid3, Rot3, Vec3, so3};
use nalgebra::{Matrix3, SMatrix, SVector, Translation3, Vector2};

/// 5-vector: the relative-pose tangent `[ω (3); δt (2)]`.
pub type Vec5 = SVector<f64, 5>;
/// 5×5 covariance in the relative-pose tangent.
pub type Mat5 = SMatrix<f64, 5, 5>;

/// A refined relative pose `b_from_a` with unit translation, and its first-order uncertainty.
///
/// Tangent (5): `R ← Exp(ω)·R` (left, rad) and `t ← normalize(t + B·δ)` with `B` the
/// orthonormal basis of the plane ⟂ t from [`tangent_basis`] (unitless: radians of direction).
/// The covariance is `σ₀²·(JᵀJ)⁻¹` with `σ₀² = Σr²/(m − 5)`, residuals in normalized units.
#[derive(Debug, Clone, PartialEq)]
pub struct RelativeRefinement {
    /// Rotation and unit translation of `b_from_a` (`x_b = R·x_a + t`, |t| = 1).
    pub b_from_a: Rigid3,
    /// Number of correspondences used (m, repeats counted).
    pub n_observations: usize,
    /// Sum of squared Sampson errors, normalized units².
    pub cost: f64,
    /// A-posteriori σ of one Sampson residual, normalized units (× focal ≈ px).
    pub sigma0: f64,
    /// 5×5 covariance in the tangent described above.
    pub covariance: Mat5,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
}

/// Result of [`estimate_relative_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct RelativePose {
    /// Refinement on the final inliers.
    pub refinement: RelativeRefinement,
    /// Indices of the inlier correspondences (increasing).
    pub inliers: Vec<usize>,
    /// RANSAC hypotheses drawn.
    pub ransac_iterations: usize,
}

/// Orthonormal basis (3×2) of the plane perpendicular to the unit vector `t`, a smooth
/// deterministic function of `t` away from `t ∥ e_k` for the chosen helper axis.
pub fn tangent_basis(t: &Vec3) -> SMatrix<f64, 3, 2> {
    // Helper axis: the coordinate axis least aligned with t.
    let a = t.abs();
    let helper = if a.x <= a.y && a.x <= a.z {
        Vec3::x()
    } else if a.y <= a.z {
        Vec3::y()
    } else {
        Vec3::z()
    };
    let b1 = t.cross(&helper).normalize();
    let b2 = t.cross(&b1);
    SMatrix::<f64, 3, 2>::from_columns(&[b1, b2])
}

/// Essential matrix `E = [t]×·R` of `b_from_a` (`x_bᵀ·E·x_a = 0`).
pub fn essential_from_pose(b_from_a: &Rigid3) -> Matrix3<f64> {
    so3::hat(&b_from_a.translation.vector) * b_from_a.rotation.to_rotation_matrix().matrix()
}

/// Sampson error of `x_bᵀ E x_a = 0` for normalized image points (normalized units).
pub fn sampson_error(e: &Matrix3<f64>, xa: &Vector2<f64>, xb: &Vector2<f64>) -> f64 {
    let a = Vec3::new(xa.x, xa.y, 1.0);
    let b = Vec3::new(xb.x, xb.y, 1.0);
    let ea = e * a;
    let etb = e.transpose() * b;
    let num = b.dot(&ea);
    let den = ea.x * ea.x + ea.y * ea.y + etb.x * etb.x + etb.y * etb.y;
    if den > 0.0 {
        num / den.sqrt()
    } else {
        num.abs() * f64::INFINITY
    }
}

/// Essential matrices from ≥ 8 correspondences (normalized coordinates) by the linear
/// 8-point algorithm, projected onto the essential manifold (singular values 1, 1, 0).
pub fn essential_8point(xa: &[Vector2<f64>], xb: &[Vector2<f64>]) -> Option<Matrix3<f64>> {
    if xa.len() < 8 || xa.len() != xb.len() {
        return None;
    }
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (a, b) in xa.iter().zip(xb) {
        let a = Vec3::new(a.x, a.y, 1.0);
        let b = Vec3::new(b.x, b.y, 1.0);
        let row = SVector::<f64, 9>::from_fn(|k, _| b[k / 3] * a[k % 3]);
        ata += row * row.transpose();
    }
    let eig = ata.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let e = Matrix3::from_fn(|i, j| v[3 * i + j]);
    let svd = e.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let e = u * Matrix3::from_diagonal(&Vec3::new(1.0, 1.0, 0.0)) * vt;
    e.iter().all(|x| x.is_finite()).then_some(e)
}

/// The four `b_from_a` poses (unit translation) of an essential matrix.
pub fn poses_from_essential(e: &Matrix3<f64>) -> Option<[Rigid3; 4]> {
    let svd = e.svd(true, true);
    let (mut u, mut vt) = (svd.u?, svd.v_t?);
    if u.determinant() < 0.0 {
        u = -u;
    }
    if vt.determinant() < 0.0 {
        vt = -vt;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let r1 = Rot3::from_matrix_unchecked(u * w * vt);
    let r2 = Rot3::from_matrix_unchecked(u * w.transpose() * vt);
    let t: Vec3 = u.column(2).into();
    let mk = |r: &Rot3, t: Vec3| {
        Rigid3::from_parts(
            Translation3::from(t),
            crashrig_geometry::quat::unit_quaternion_from_rotation(r),
        )
    };
    Some([mk(&r1, t), mk(&r1, -t), mk(&r2, t), mk(&r2, -t)])
}

/// Depths `(z_a, z_b)` of the midpoint triangulation of one correspondence, `None` for
/// parallel rays.
pub fn triangulate_depths(
    b_from_a: &Rigid3,
    xa: &Vector2<f64>,
    xb: &Vector2<f64>,
) -> Option<(f64, f64)> {
    // x_b = R x_a + t with x_a = λa·fa, x_b = λb·fb: solve λa·(R fa) − λb·fb = −t (least squares).
    let fa = b_from_a.rotation * Vec3::new(xa.x, xa.y, 1.0);
    let fb = Vec3::new(xb.x, xb.y, 1.0);
    let t = b_from_a.translation.vector;
    let m = SMatrix::<f64, 3, 2>::from_columns(&[fa, -fb]);
    let mtm = m.transpose() * m;
    let sol = mtm.try_inverse()? * (m.transpose() * (-t));
    let (la, lb) = (sol[0], sol[1]);
    (la.is_finite() && lb.is_finite()).then_some((la, lb))
}

/// Number of correspondences in `idx` triangulated in front of both cameras.
fn cheirality_count(
    pose: &Rigid3,
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    idx: &[usize],
) -> usize {
    idx.iter()
        .filter(|&&i| {
            triangulate_depths(pose, &xa[i], &xb[i]).is_some_and(|(a, b)| a > 0.0 && b > 0.0)
        })
        .count()
}

/// Of the four decompositions of `e`, the pose with most points in front of both cameras.
pub fn pose_with_cheirality(
    e: &Matrix3<f64>,
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    idx: &[usize],
) -> Option<(Rigid3, usize)> {
    poses_from_essential(e)?
        .into_iter()
        .map(|p| {
            let c = cheirality_count(&p, xa, xb, idx);
            (p, c)
        })
        .max_by_key(|(_, c)| *c)
}

#[derive(Clone)]
struct State {
    r: Rot3,
    t: Vec3,
}

struct SampsonProblem<'a> {
    xa: &'a [Vector2<f64>],
    xb: &'a [Vector2<f64>],
    idx: &'a [usize],
}

/// Central-difference step in the tangent (rad): balances truncation and rounding errors for
/// residuals of order 1e-3 (normalized units).
const FD_STEP: f64 = 1e-7;

impl SampsonProblem<'_> {
    fn residuals(&self, s: &State) -> Result<Vec<f64>, usize> {
        let e = so3::hat(&s.t) * s.r.matrix();
        self.idx
            .iter()
            .map(|&i| {
                let r = sampson_error(&e, &self.xa[i], &self.xb[i]);
                if r.is_finite() { Ok(r) } else { Err(i) }
            })
            .collect()
    }
}

impl Problem<5> for SampsonProblem<'_> {
    type State = State;

    fn normal_equations(&self, s: &State) -> Result<(Mat5, Vec5, f64), usize> {
        // Jacobian by central differences in the 5-dimensional tangent.
        let r0 = self.residuals(s)?;
        let mut jac = vec![Vec5::zeros(); r0.len()];
        for k in 0..5 {
            let mut d = Vec5::zeros();
            d[k] = FD_STEP;
            let rp = self.residuals(&self.retract(s, &d))?;
            let rm = self.residuals(&self.retract(s, &(-d)))?;
            for (i, (p, m)) in rp.iter().zip(&rm).enumerate() {
                jac[i][k] = (p - m) / (2.0 * FD_STEP);
            }
        }
        let mut jtj = Mat5::zeros();
        let mut jtr = Vec5::zeros();
        for (row, r) in jac.iter().zip(&r0) {
            jtj += row * row.transpose();
            jtr += row * *r;
        }
        let cost = r0.iter().map(|r| r * r).sum();
        Ok((jtj, jtr, cost))
    }

    fn cost(&self, s: &State) -> Result<f64, usize> {
        Ok(self.residuals(s)?.iter().map(|r| r * r).sum())
    }

    fn retract(&self, s: &State, d: &Vec5) -> State {
        let w = Vec3::new(d[0], d[1], d[2]);
        let b = tangent_basis(&s.t);
        State {
            r: so3::exp(&w) * s.r,
            t: (s.t + b * nalgebra::Vector2::new(d[3], d[4])).normalize(),
        }
    }
}

/// Refines `init` (`b_from_a`, its translation is normalized) by Levenberg–Marquardt on the
/// Sampson error of the correspondences `indices` (repeats allowed: a bootstrap resample), in
/// normalized image coordinates, and returns it with its first-order covariance.
pub fn refine_relative_pose(
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    indices: &[usize],
    init: &Rigid3,
) -> Result<RelativeRefinement, Error> {
    check_pairs(xa, xb)?;
    if let Some(&bad) = indices.iter().find(|&&i| i >= xa.len()) {
        return Err(Error::IndexOutOfRange {
            index: bad,
            len: xa.len(),
        });
    }
    refine_unchecked(xa, xb, indices, init, lm::MAX_ITERATIONS)
}

fn refine_unchecked(
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    indices: &[usize],
    init: &Rigid3,
    max_iterations: usize,
) -> Result<RelativeRefinement, Error> {
    let m = indices.len();
    if m < 6 {
        return Err(Error::TooFewCorrespondences {
            needed: 6,
            found: m,
        });
    }
    let mut d = indices.to_vec();
    d.sort_unstable();
    d.dedup();
    if d.len() < 5 {
        return Err(Error::Degenerate {
            what: Degeneracy::TooFewDistinct,
        });
    }
    let t = init.translation.vector;
    if t.norm().is_nan() || t.norm() <= 0.0 {
        return Err(Error::Degenerate {
            what: Degeneracy::SingularNormalEquations,
        });
    }
    let problem = SampsonProblem {
        xa,
        xb,
        idx: indices,
    };
    let start = State {
        r: init.rotation.to_rotation_matrix(),
        t: t.normalize(),
    };
    let out = lm::solve(&problem, start, max_iterations).map_err(|f| match f {
        lm::Failure::Undefined(index) => Error::Projection { index },
        lm::Failure::Diverged(iterations) => Error::Diverged { iterations },
    })?;
    let inv = lm::inverse_if_regular(&out.jtj).ok_or(Error::Degenerate {
        what: Degeneracy::SingularNormalEquations,
    })?;
    let sigma0_sq = out.cost / (m - 5) as f64;
    Ok(RelativeRefinement {
        b_from_a: Rigid3::from_parts(
            Translation3::from(out.state.t),
            crashrig_geometry::quat::unit_quaternion_from_rotation(&out.state.r),
        ),
        n_observations: m,
        cost: out.cost,
        sigma0: sigma0_sq.sqrt(),
        covariance: inv * sigma0_sq,
        iterations: out.iterations,
    })
}

fn check_pairs(xa: &[Vector2<f64>], xb: &[Vector2<f64>]) -> Result<(), Error> {
    if xa.len() != xb.len() {
        return Err(Error::LengthMismatch {
            left: xa.len(),
            right: xb.len(),
        });
    }
    for (index, (a, b)) in xa.iter().zip(xb).enumerate() {
        if !(a.iter().chain(b.iter()).all(|v| v.is_finite())) {
            return Err(Error::NotFinite { index });
        }
    }
    Ok(())
}

/// Normalized image coordinates of `pixels` through `camera` (distortion removed).
pub fn normalize_pixels<C: Projector>(
    camera: &C,
    pixels: &[Vector2<f64>],
) -> Result<Vec<Vector2<f64>>, Error> {
    pixels
        .iter()
        .enumerate()
        .map(|(index, x)| {
            if !x.iter().all(|v| v.is_finite()) {
                return Err(Error::NotFinite { index });
            }
            camera.normalized(x).ok_or(Error::Unprojection { index })
        })
        .collect()
}

/// Above this fraction of the essential-matrix inliers also explained by a pure rotation the
/// pair has no usable parallax (COLMAP uses the same 0.8 for its homography-inlier ratio).
pub const MAX_ROTATION_ONLY_RATIO: f64 = 0.8;

/// Fraction of `idx` explained (transfer error below `th`, normalized units) by the best pure
/// rotation `x_b ~ R·x_a` (orthogonal Procrustes on the bearings).
pub fn rotation_only_ratio(
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    idx: &[usize],
    th: f64,
) -> f64 {
    if idx.is_empty() {
        return 0.0;
    }
    let fa: Vec<Vec3> = idx
        .iter()
        .map(|&i| Vec3::new(xa[i].x, xa[i].y, 1.0).normalize())
        .collect();
    let fb: Vec<Vec3> = idx
        .iter()
        .map(|&i| Vec3::new(xb[i].x, xb[i].y, 1.0).normalize())
        .collect();
    let mut h = Matrix3::zeros();
    for (a, b) in fa.iter().zip(&fb) {
        h += b * a.transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return 0.0;
    };
    let d = (u * vt).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vec3::new(1.0, 1.0, d)) * vt;
    let explained = idx
        .iter()
        .filter(|&&i| {
            let p = r * Vec3::new(xa[i].x, xa[i].y, 1.0);
            p.z > 0.0 && (Vector2::new(p.x / p.z, p.y / p.z) - xb[i]).norm() < th
        })
        .count();
    explained as f64 / idx.len() as f64
}

/// MSAC score and inliers of an essential matrix; `th` in normalized units.
fn score(e: &Matrix3<f64>, xa: &[Vector2<f64>], xb: &[Vector2<f64>], th: f64) -> (f64, Vec<usize>) {
    let th2 = th * th;
    let mut s = 0.0;
    let mut inl = Vec::new();
    for (i, (a, b)) in xa.iter().zip(xb).enumerate() {
        let r = sampson_error(e, a, b);
        let r2 = r * r;
        if r2 < th2 {
            s += r2;
            inl.push(i);
        } else {
            s += th2;
        }
    }
    (s, inl)
}

/// The essential matrix as an [`Estimator`] of the LO-RANSAC driver: the 5-point solver, MSAC
/// on the Sampson error (normalized units), the linear 8-point algorithm on the inliers as the
/// local optimisation.
struct EssentialMatrix<'a> {
    xa: &'a [Vector2<f64>],
    xb: &'a [Vector2<f64>],
    th: f64,
}

impl Estimator for EssentialMatrix<'_> {
    type Model = Matrix3<f64>;
    const SAMPLE: usize = 5;

    fn len(&self) -> usize {
        self.xa.len()
    }

    fn minimal(&self, s: &[usize]) -> Vec<Matrix3<f64>> {
        let sa: [Vector2<f64>; 5] = std::array::from_fn(|k| self.xa[s[k]]);
        let sb: [Vector2<f64>; 5] = std::array::from_fn(|k| self.xb[s[k]]);
        essential_5point(&sa, &sb)
    }

    fn score(&self, e: &Matrix3<f64>) -> (f64, Vec<usize>) {
        score(e, self.xa, self.xb, self.th)
    }

    fn local_optimize(&self, _e: &Matrix3<f64>, inliers: &[usize]) -> Option<Matrix3<f64>> {
        if inliers.len() <= 8 {
            return None;
        }
        let la: Vec<Vector2<f64>> = inliers.iter().map(|&i| self.xa[i]).collect();
        let lb: Vec<Vector2<f64>> = inliers.iter().map(|&i| self.xb[i]).collect();
        essential_8point(&la, &lb)
    }
}

/// Estimates `b_from_a` (unit translation) from normalized image correspondences
/// `xa[i] ↔ xb[i]`: 5-point hypotheses in a seeded LO-RANSAC scored by the Sampson error
/// (threshold `options.max_error_px / focal_px`), cheirality to pick among the four
/// decompositions, then Levenberg–Marquardt on the inliers with the first-order covariance.
///
/// Fails with [`Degeneracy::NoParallax`] when more than [`MAX_ROTATION_ONLY_RATIO`] of the
/// inliers are also explained by a pure rotation (zero or negligible baseline).
pub fn estimate_relative_pose(
    xa: &[Vector2<f64>],
    xb: &[Vector2<f64>],
    focal_px: f64,
    options: &RansacOptions,
) -> Result<RelativePose, Error> {
    check_pairs(xa, xb)?;
    let n = xa.len();
    let needed = options.min_inliers.max(8);
    if n < needed {
        return Err(Error::TooFewCorrespondences { needed, found: n });
    }
    let th = options.max_error_px / focal_px;
    let Consensus {
        model: e,
        inliers,
        iterations,
    } = lo_ransac(&EssentialMatrix { xa, xb, th }, options, needed)?;
    let (pose, _) = pose_with_cheirality(&e, xa, xb, &inliers).ok_or(Error::Degenerate {
        what: Degeneracy::SingularNormalEquations,
    })?;
    let r = refine_unchecked(xa, xb, &inliers, &pose, lm::MAX_ITERATIONS)?;
    let e = essential_from_pose(&r.b_from_a);
    let (_, inliers) = score(&e, xa, xb, th);
    // Keep only inliers in front of both cameras.
    let inliers: Vec<usize> = inliers
        .into_iter()
        .filter(|&i| {
            triangulate_depths(&r.b_from_a, &xa[i], &xb[i]).is_some_and(|(a, b)| a > 0.0 && b > 0.0)
        })
        .collect();
    if inliers.len() < needed {
        return Err(Error::NoConsensus {
            needed,
            best: inliers.len(),
            iterations,
        });
    }
    if rotation_only_ratio(xa, xb, &inliers, th) > MAX_ROTATION_ONLY_RATIO {
        return Err(Error::Degenerate {
            what: Degeneracy::NoParallax,
        });
    }
    let refinement = refine_unchecked(xa, xb, &inliers, &r.b_from_a, lm::MAX_ITERATIONS)?;
    Ok(RelativePose {
        refinement,
        inliers,
        ransac_iterations: iterations,
    })
}
