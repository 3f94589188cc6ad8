//! Grid studies with fixed observers (`aim = "fixed"`): cameras bolted in place with a real
//! lens, in any mix with aimed observers.
//!
//! Per grid point, every observer that *sees* the point becomes a [`View`]:
//! - an aimed observer always sees it (the paper's re-aiming): nominal rotation = look-at, the
//!   point at the principal point, pixel noise `N(0, σ_px/focal_px)` in normalized coordinates
//!   from the grid's `pixel_sigma_px`/`focal_px`;
//! - a fixed observer sees it when it lies in front (z > 0 in the camera frame), projects
//!   through its lens inside the image (`0 ≤ u < width`, `0 ≤ v < height`, COLMAP's pixel
//!   convention: the centre of the upper-left pixel is (0.5, 0.5)), and the lens maps the pixel
//!   back to the same ray (undistortion round trip within 1e-9; this rejects points far
//!   outside the field of view that a polynomial distortion folds back into the image).
//!
//! Each draw (per view): the pose error `δ = L·ε` (centre + δ₁₋₃ in world axes, `R̄·Exp(δ₄₋₆)`
//! about the camera's own axes, or ω φ κ + δ₄₋₆ for `euler` noise), the true pixel plus
//! `N(0, σ_px)` per axis, taken back through the lens to normalized coordinates, and the two
//! DLT rows of the perturbed camera; the views' rows are solved together (inhomogeneous DLT).
//! Points seen by fewer than two observers are *not measurable*: NaN σ, `observers_seen < 2`.
//!
//! The draws run on the vectorised block engine ([`crate::block`]: Philox + Box–Muller normals,
//! blocks of 64 draws in lanes, compiled per instruction-set level) with every other grid
//! path: a fixed view is an [`crate::block::Observation::Lens`], whose per-lane normalized
//! coordinates come from [`undistort_lanes`].
//!
//! Undistortion in lanes: the linear predictor `n₀ + J⁻¹·δu` (J = ∂pixel/∂normalized at the
//! true pixel, computed once per point) is exact for lenses without distortion (PINHOLE,
//! SIMPLE_PINHOLE, or distortion parameters all zero). Distorting lenses with a written-out
//! projection ([`FastLens`]: SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV) take exactly
//! [`REFINE_STEPS`] chord-Newton steps per lane on that projection, branch-free; a lane whose
//! last residual is still ≥ [`UNDISTORT_RESIDUAL_PX`] (or not finite) is recomputed by the
//! scalar routine (refinement until the residual is below the bound, then the camera crate's
//! full unprojection) — a fix-up that depends only on that draw's pixel offset, so results do
//! not depend on the block, the thread count or the instruction set. The other distorting
//! models (fisheyes, FOV) undistort every lane with the scalar routine.
//!
//! Determinism: as the aimed path, (point p, chunk k) is task `p·2²⁴ + k`
//! ([`crate::grid::task_index`]) and chunks merge in index order. `CRASHRIG_ISA=legacy` runs
//! the former scalar loop (ChaCha8 + ziggurat, [`run_chunk_fixed`]) as a benchmark baseline.

use crate::accumulate::Acc3;
use crate::block::{NoiseFactor, Observation, ObserverSpec, Prepared};
use crate::chain::Chain;
use crate::grid::{GridResult, PointStats};
use crate::kernel::{Normal3, exp_matrix, rot_opk};
use crate::normal::{LANES, Lane};
use crate::scenario::{Adaptive, Aim, Grid, Observer, PixelNoise, RotationNoise};
use crate::simd::Engine;
use crate::{CHUNK, Error, FastNormal};
use crashrig_camera::{Camera as Lens, ModelId};
use crashrig_stats::stream;
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector2, Vector3, Vector6};
use rayon::prelude::*;

/// The undistortion in the draw loop stops when the refined ray reprojects within this many
/// pixels of the observed pixel.
pub const UNDISTORT_RESIDUAL_PX: f64 = 1e-7;

/// Largest number of chord-Newton refinements of the scalar undistortion before the fallback.
const MAX_REFINE: usize = 8;

/// Chord-Newton steps of the undistortion in lanes (every lane takes all of them). Two
/// suffice for pixel σ of a few pixels: the predictor's error is second order in the pixel
/// offset and each step multiplies it by the relative change of the lens Jacobian over the
/// offset (≈ 10⁻⁴ for 0.5 px at 1000 px focal length).
pub(crate) const REFINE_STEPS: usize = 2;

/// Relative tolerance of the visibility round trip (pixel → ray → same ray).
const ROUND_TRIP_TOL: f64 = 1e-9;

/// Normals per view and draw: 6 pose + 2 pixel.
const NORMALS_PER_VIEW: usize = 8;

/// One observer as seen from one grid point, ready for the draw loop.
#[derive(Debug, Clone, Copy)]
pub(crate) struct View<'a> {
    /// Nominal projection centre (world, mm).
    c: Vector3<f64>,
    /// Nominal `R_world_from_cam`.
    r: Matrix3<f64>,
    /// ω φ κ of `r` (base of `euler` noise).
    opk: Vector3<f64>,
    /// Lower factor of the pose-noise covariance (mm, rad): `δ = L·ε`.
    l: Matrix6<f64>,
    /// The diagonal of `l` when `l` is diagonal (independent σ): `δ = σ∘ε`.
    diag: Option<Vector6<f64>>,
    /// `euler` rotation noise (else tangent).
    euler: bool,
    /// Exact normalized coordinates of the true point.
    n0: Vector2<f64>,
    /// The true pixel (COLMAP convention; unused for aimed views).
    u0: Vector2<f64>,
    /// ∂normalized/∂pixel at the true pixel.
    jinv: Matrix2<f64>,
    /// σ of each image coordinate (px).
    sigma_px: f64,
    /// The lens when it distorts (the predictor needs refining), else `None`.
    lens: Option<&'a Lens>,
    /// Its written-out projection, for the models that have one.
    fast: Option<FastLens>,
    /// The full lens (for the fallback unprojection), `None` for aimed views.
    full_lens: Option<&'a Lens>,
    /// Chain camera whose joint draw this view takes (correlated mode).
    source: Option<usize>,
}

/// What the fixed path needs from a prepared [`crate::GridStudy`].
pub(crate) struct Setup<'a> {
    /// The grid.
    pub(crate) grid: &'a Grid,
    /// Resolved pose-noise covariance of each observer (mm, rad; rotation block in the
    /// meaning of its `kinds` entry).
    pub(crate) covariance: &'a [Matrix6<f64>],
    /// Rotation-noise meaning of each observer's covariance.
    pub(crate) kinds: &'a [RotationNoise],
    /// The grid's pixel noise (aimed observers).
    pub(crate) pixel: Option<PixelNoise>,
    /// The chain, in correlated mode.
    pub(crate) chain: Option<&'a Chain>,
}

/// How many draws per point.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Draws<'a> {
    /// A fixed number.
    Samples(usize),
    /// GUM-S1 adaptive stopping.
    Adaptive(&'a Adaptive),
}

/// The projection of the radial-tangential lenses (SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV)
/// written out for the draw loop: normalized (x, y) ↦ pixel, COLMAP's formulas
/// (`sensor/models.h`), no validation and no `Result` (the lens was validated when read).
/// Tested against `crashrig_camera::Camera::img_from_cam` (`fixed_fast_lens_matches_camera_crate`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FastLens {
    f: [f64; 2],
    c: [f64; 2],
    /// k1 k2 k3 (numerator), k4 k5 k6 (denominator), p1 p2.
    k: [f64; 6],
    p: [f64; 2],
}

impl FastLens {
    /// The fast form of `lens`, if its model has one.
    pub(crate) fn of(lens: &Lens) -> Option<FastLens> {
        use ModelId as M;
        let q = &lens.params;
        let (f, c, k, p) = match lens.model {
            M::SimpleRadial => (
                [q[0], q[0]],
                [q[1], q[2]],
                [q[3], 0.0, 0.0, 0.0, 0.0, 0.0],
                [0.0; 2],
            ),
            M::Radial => (
                [q[0], q[0]],
                [q[1], q[2]],
                [q[3], q[4], 0.0, 0.0, 0.0, 0.0],
                [0.0; 2],
            ),
            M::OpenCv => (
                [q[0], q[1]],
                [q[2], q[3]],
                [q[4], q[5], 0.0, 0.0, 0.0, 0.0],
                [q[6], q[7]],
            ),
            M::FullOpenCv => (
                [q[0], q[1]],
                [q[2], q[3]],
                [q[4], q[5], q[8], q[9], q[10], q[11]],
                [q[6], q[7]],
            ),
            _ => return None,
        };
        Some(FastLens { f, c, k, p })
    }

    /// Pixel (COLMAP convention) of normalized coordinates `n`.
    #[inline(always)]
    pub(crate) fn img_from_normalized(&self, n: Vector2<f64>) -> Vector2<f64> {
        let (u, v) = self.img_from_xy(n.x, n.y);
        Vector2::new(u, v)
    }

    /// [`FastLens::img_from_normalized`] on plain numbers (the lane loop).
    #[inline(always)]
    pub(crate) fn img_from_xy(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let [k1, k2, k3, k4, k5, k6] = self.k;
        let [p1, p2] = self.p;
        let radial =
            (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)));
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + 2.0 * p2 * x * y + p1 * (r2 + 2.0 * y * y);
        (self.f[0] * xd + self.c[0], self.f[1] * yd + self.c[1])
    }
}

/// True when the lens maps normalized coordinates to pixels linearly (no distortion term).
fn is_linear(lens: &Lens) -> bool {
    use ModelId as M;
    let extra = match lens.model {
        M::SimplePinhole | M::Pinhole => return true,
        M::SimpleRadial | M::Radial => &lens.params[3..],
        M::OpenCv | M::FullOpenCv => &lens.params[4..],
        _ => return false,
    };
    extra.iter().all(|k| *k == 0.0)
}

/// Lower factor `L` (`L·Lᵀ = Σ`) of an observer's pose-noise covariance (mm, rad; order δC,
/// δθ): `crashrig_geometry::uncertain::psd_factor` (for independent σ it is `diag(σ)`
/// exactly).
fn factor_of(covariance: &Matrix6<f64>) -> Matrix6<f64> {
    crashrig_geometry::uncertain::psd_factor(covariance)
}

fn is_diagonal(l: &Matrix6<f64>) -> bool {
    (0..6).all(|i| (0..6).all(|j| i == j || l[(i, j)] == 0.0))
}

/// Where a fixed camera at `center` sees world point `x`: the true pixel, the exact
/// normalized coordinates and `∂normalized/∂pixel`; `None` when it does not see it.
pub(crate) fn sight(
    fixed: &crate::scenario::FixedCamera,
    center: &Vector3<f64>,
    x: &Vector3<f64>,
) -> Option<(Vector2<f64>, Vector2<f64>, Matrix2<f64>)> {
    let p = fixed.cam_from_world(center, x);
    if p.z.is_nan() || p.z <= 0.0 {
        return None;
    }
    let lens = &fixed.lens;
    let u = lens.img_from_cam(&p).ok()?;
    if !(u.x >= 0.0 && u.x < lens.width as f64 && u.y >= 0.0 && u.y < lens.height as f64) {
        return None;
    }
    let n0 = Vector2::new(p.x / p.z, p.y / p.z);
    let back = lens.cam_from_img(&u).ok()?.normalized;
    if (back - n0).norm() > ROUND_TRIP_TOL * (1.0 + n0.norm()) {
        return None;
    }
    let j = lens
        .dx_img_from_cam_point(&Vector3::new(n0.x, n0.y, 1.0))
        .ok()?;
    let jinv = j.fixed_view::<2, 2>(0, 0).into_owned().try_inverse()?;
    Some((u, n0, jinv))
}

/// Signed margin (px) of world point `x` inside fixed camera's image: `min(u, w − u, v, h − v)`
/// where the camera sees the point, `−(w + h)` where it does not (behind, outside the lens's
/// domain, folded back). Its zero contour on a plane is the camera's field-of-view footprint.
pub fn footprint_margin_px(observer: &Observer, x: &Vector3<f64>) -> Option<f64> {
    let Aim::Fixed(f) = &observer.aim else {
        return None;
    };
    let (w, h) = (f.lens.width as f64, f.lens.height as f64);
    let p = f.cam_from_world(&observer.position_mm, x);
    let outside = -(w + h);
    if p.z.is_nan() || p.z <= 0.0 {
        return Some(outside);
    }
    let Ok(u) = f.lens.img_from_cam(&p) else {
        return Some(outside);
    };
    let n0 = Vector2::new(p.x / p.z, p.y / p.z);
    let folded = match f.lens.cam_from_img(&u) {
        Ok(b) => (b.normalized - n0).norm() > ROUND_TRIP_TOL * (1.0 + n0.norm()),
        Err(_) => true,
    };
    if folded {
        return Some(outside);
    }
    Some(u.x.min(w - u.x).min(u.y).min(h - u.y).max(outside))
}

/// The views of every observer that sees `point`.
pub(crate) fn views<'a>(setup: &Setup<'a>, point: &Vector3<f64>) -> Result<Vec<View<'a>>, Error> {
    let mut out = Vec::with_capacity(setup.grid.observers.len());
    for ((o, s), kind) in setup
        .grid
        .observers
        .iter()
        .zip(setup.covariance)
        .zip(setup.kinds)
    {
        let source = match (setup.chain, o.sigma) {
            (Some(_), crate::scenario::ObserverSigma::From(i)) => Some(i),
            _ => None,
        };
        let l = factor_of(s);
        // A chain draw is always a tangent (body-axis) rotation error.
        let euler = *kind == RotationNoise::Euler && source.is_none();
        match &o.aim {
            Aim::Point => {
                let r = crashrig_geometry::look_at::world_from_cam_look_at(&o.position_mm, point)?;
                let a = crashrig_geometry::opk::opk_from_rotation(&r);
                let (sigma_px, focal) =
                    setup.pixel.map_or((0.0, 1.0), |p| (p.sigma_px, p.focal_px));
                out.push(View {
                    c: o.position_mm,
                    r: r.into_inner(),
                    opk: Vector3::new(a.omega, a.phi, a.kappa),
                    l,
                    diag: is_diagonal(&l).then(|| l.diagonal()),
                    euler,
                    n0: Vector2::zeros(),
                    u0: Vector2::zeros(),
                    jinv: Matrix2::identity() / focal,
                    sigma_px,
                    lens: None,
                    fast: None,
                    full_lens: None,
                    source,
                });
            }
            Aim::Fixed(f) => {
                let Some((u0, n0, jinv)) = sight(f, &o.position_mm, point) else {
                    continue;
                };
                out.push(View {
                    c: o.position_mm,
                    r: f.rotation,
                    opk: f.angles_rad,
                    l,
                    diag: is_diagonal(&l).then(|| l.diagonal()),
                    euler,
                    n0,
                    u0,
                    jinv,
                    sigma_px: f.pixel_sigma_px,
                    lens: (!is_linear(&f.lens)).then_some(&f.lens),
                    fast: FastLens::of(&f.lens),
                    full_lens: Some(&f.lens),
                    source,
                });
            }
        }
    }
    Ok(out)
}

/// Normalized coordinates of the observed pixel `u0 + du` (undistorted through the lens).
#[inline(always)]
fn undistort(v: &View<'_>, du: Vector2<f64>) -> Vector2<f64> {
    let mut n = v.n0 + v.jinv * du;
    let Some(lens) = v.lens else {
        return n;
    };
    let target = v.u0 + du;
    for _ in 0..MAX_REFINE {
        let p = match v.fast {
            Some(fast) => fast.img_from_normalized(n),
            None => match lens.img_from_cam(&Vector3::new(n.x, n.y, 1.0)) {
                Ok(p) => p,
                Err(_) => break,
            },
        };
        let res = p - target;
        if res.norm_squared() < UNDISTORT_RESIDUAL_PX * UNDISTORT_RESIDUAL_PX {
            return n;
        }
        n -= v.jinv * res;
    }
    // Not refined (never seen for σ of a few pixels): the lens's own unprojection.
    match v.full_lens.map(|l| l.cam_from_img(&target)) {
        Some(Ok(u)) => u.normalized,
        _ => n,
    }
}

/// Normalized coordinates of the observed pixels `u0 + σ_px·(ex, ey)` of view `v` in lanes
/// (see the module docs): the predictor, [`REFINE_STEPS`] chord-Newton steps on the
/// [`FastLens`] projection, and the scalar [`undistort`] for the lanes `< b` that did not
/// converge. Plain loops over lanes with `+ − × ÷` only (vectorised by the caller's
/// instruction-set level, the same bits on every level).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays vectorise
pub(crate) fn undistort_lanes(
    v: &View<'_>,
    ex: &Lane,
    ey: &Lane,
    x: &mut Lane,
    y: &mut Lane,
    b: usize,
) {
    let s = v.sigma_px;
    let j = [
        v.jinv[(0, 0)],
        v.jinv[(0, 1)],
        v.jinv[(1, 0)],
        v.jinv[(1, 1)],
    ];
    let (n0, n1) = (v.n0.x, v.n0.y);
    for l in 0..LANES {
        let (du, dv) = (s * ex[l], s * ey[l]);
        x[l] = n0 + (j[0] * du + j[1] * dv);
        y[l] = n1 + (j[2] * du + j[3] * dv);
    }
    if v.lens.is_none() {
        return;
    }
    let scalar = |l: usize, x: &mut Lane, y: &mut Lane| {
        let n = undistort(v, Vector2::new(s * ex[l], s * ey[l]));
        x[l] = n.x;
        y[l] = n.y;
    };
    let Some(fast) = v.fast else {
        for l in 0..b {
            scalar(l, x, y);
        }
        return;
    };
    let (t0, t1) = (v.u0.x, v.u0.y);
    let mut res2 = [0.0; LANES];
    for _ in 0..REFINE_STEPS {
        for l in 0..LANES {
            let (du, dv) = (s * ex[l], s * ey[l]);
            let (p0, p1) = fast.img_from_xy(x[l], y[l]);
            let (r0, r1) = (p0 - (t0 + du), p1 - (t1 + dv));
            x[l] -= j[0] * r0 + j[1] * r1;
            y[l] -= j[2] * r0 + j[3] * r1;
            res2[l] = r0 * r0 + r1 * r1;
        }
    }
    for l in 0..b {
        // The last step's residual (before its update) bounds the result's from above.
        let r2 = res2[l];
        if r2 >= UNDISTORT_RESIDUAL_PX * UNDISTORT_RESIDUAL_PX || r2.is_nan() {
            scalar(l, x, y);
        }
    }
}

/// The block engine's description of view `v` (`chain`: correlated mode; `pixel`: σ of the
/// aimed views' normalized coordinates).
fn spec<'a>(v: &'a View<'a>, chain: Option<&Chain>, pixel: Option<f64>) -> ObserverSpec<'a> {
    let source = v.source.filter(|_| chain.is_some());
    ObserverSpec {
        c: v.c,
        r: v.r,
        opk: v.opk,
        noise: NoiseFactor::from_lower(&v.l),
        tangent: !v.euler,
        source,
        chain_to_own: match (source, chain) {
            (Some(i), Some(chain)) => v.r.transpose() * chain.nominal()[i].rotation,
            _ => Matrix3::identity(),
        },
        observation: match v.full_lens {
            Some(_) => Observation::Lens(v),
            None => pixel.map_or(Observation::Ray, Observation::Normalized),
        },
    }
}

/// Adds the two DLT rows of view `v` perturbed by `dpose` (δC mm, δθ rad) and `du` (px),
/// with the rotation `rot` already perturbed.
#[inline(always)]
fn add_rows(n: &mut Normal3, rot: &Matrix3<f64>, c: &Vector3<f64>, x: Vector2<f64>) {
    let c1 = rot.column(0).into_owned();
    let c2 = rot.column(1).into_owned();
    let c3 = rot.column(2).into_owned();
    n.add_row(&(c3 * x.x - c1), c);
    n.add_row(&(c3 * x.y - c2), c);
}

/// The perturbed rotation and centre of view `v` for the pose error `d` (independent noise).
#[inline(always)]
fn perturbed_pose(v: &View<'_>, d: &Vector6<f64>) -> (Matrix3<f64>, Vector3<f64>) {
    let c = v.c + Vector3::new(d[0], d[1], d[2]);
    let w = Vector3::new(d[3], d[4], d[5]);
    let r = if v.euler {
        rot_opk(&(v.opk + w))
    } else {
        v.r * exp_matrix(&w)
    };
    (r, c)
}

/// The two DLT rows of view `v` with tangent pose error `d` and observation `x`, without
/// forming the perturbed rotation: `a = R̄·Exp(w)·(−1, 0, x)`, `b = R̄·Exp(w)·(0, −1, y)`, with
/// `Exp(w)·q = q + s (w × q) + c w × (w × q)` (Rodrigues; exact, as `exp_matrix`).
#[inline(always)]
fn add_rows_tangent(n: &mut Normal3, v: &View<'_>, d: &Vector6<f64>, x: Vector2<f64>) {
    let c = v.c + Vector3::new(d[0], d[1], d[2]);
    let w = Vector3::new(d[3], d[4], d[5]);
    let (s, cc) = crate::kernel::sinc_cosc(w.norm_squared());
    let rot = |q: Vector3<f64>| {
        let wq = w.cross(&q);
        v.r * (q + wq * s + w.cross(&wq) * cc)
    };
    n.add_row(&rot(Vector3::new(-1.0, 0.0, x.x)), &c);
    n.add_row(&rot(Vector3::new(0.0, -1.0, x.y)), &c);
}

/// The intersected point for explicit perturbations: per view 6 pose values (mm, rad) and 2
/// pixel offsets (px). The same model as the draw loop.
#[cfg(test)]
pub(crate) fn intersect_perturbed(views: &[View<'_>], delta: &[f64]) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, v) in views.iter().enumerate() {
        let d = &delta[NORMALS_PER_VIEW * j..NORMALS_PER_VIEW * (j + 1)];
        let delta = Vector6::from_column_slice(&d[..6]);
        let x = undistort(v, Vector2::new(d[6], d[7]));
        if v.euler {
            let (r, c) = perturbed_pose(v, &delta);
            add_rows(&mut n, &r, &c, x);
        } else {
            add_rows_tangent(&mut n, v, &delta, x);
        }
    }
    n.solve()
}

/// The former scalar engine of the fixed path (`CRASHRIG_ISA=legacy`, the benchmark
/// baseline): `m` draws of one grid point into `acc`: blocks of [`LANES`] draws, the normals of
/// a block drawn row by row (row `8j + k`: view j's pose component k < 6, pixel axis k − 6), no
/// allocation except the per-call block buffer, no `Result` in the loop.
#[inline(never)]
pub(crate) fn run_chunk_fixed<R: rand::Rng>(
    views: &[View<'_>],
    chain: Option<&Chain>,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let nd = FastNormal::new();
    let rows = NORMALS_PER_VIEW * views.len();
    let mut e = vec![[0.0f64; LANES]; rows];
    let mut eps = vec![0.0; chain.map_or(0, |c| 6 * c.len())];
    let mut drawn = chain.map_or_else(Vec::new, |c| c.nominal().to_vec());
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        for row in e.iter_mut() {
            nd.fill(rng, row);
        }
        #[allow(clippy::needless_range_loop)] // lane d indexes the 8 normal rows of each view
        for d in 0..b {
            if let Some(chain) = chain {
                chain.draw_into(rng, &mut eps, &mut drawn);
            }
            let mut n = Normal3::default();
            for (j, v) in views.iter().enumerate() {
                let k = NORMALS_PER_VIEW * j;
                let (r, c) = match (v.source, chain) {
                    (Some(i), Some(chain)) => {
                        // The chain camera's error as a rigid body: the same centre shift and
                        // the same world-frame rotation.
                        let nom = &chain.nominal()[i];
                        let dr = drawn[i].rotation * nom.rotation.transpose();
                        (dr * v.r, v.c + (drawn[i].position_mm - nom.position_mm))
                    }
                    _ => {
                        let eps6 = Vector6::from_fn(|q, _| e[k + q][d]);
                        let delta = match v.diag {
                            Some(sd) => sd.component_mul(&eps6),
                            None => v.l * eps6,
                        };
                        let du = Vector2::new(e[k + 6][d], e[k + 7][d]) * v.sigma_px;
                        let x = undistort(v, du);
                        if v.euler {
                            let (r, c) = perturbed_pose(v, &delta);
                            add_rows(&mut n, &r, &c, x);
                        } else {
                            add_rows_tangent(&mut n, v, &delta, x);
                        }
                        continue;
                    }
                };
                let du = Vector2::new(e[k + 6][d], e[k + 7][d]) * v.sigma_px;
                add_rows(&mut n, &r, &c, undistort(v, du));
            }
            acc.push(&n.solve());
        }
        done += b;
    }
}

/// First-order covariance (mm²) of the intersection of `views` at `point` (observers
/// independent): pose noise through the DLT, pixel noise through the lens's Jacobian.
///
/// With rows `a = x·c₃ − c₁`, `b = y·c₃ − c₂` (zero residual at the nominal) and
/// `A = Σ(aaᵀ + bbᵀ)`: `dX = A⁻¹ Σ_rows [a aᵀ δC − a (δa·(X − C))]`.
pub(crate) fn linear_covariance(views: &[View<'_>], point: &Vector3<f64>) -> Matrix3<f64> {
    let rows = |v: &View<'_>, r: &Matrix3<f64>| {
        let (c1, c2, c3) = (
            r.column(0).into_owned(),
            r.column(1).into_owned(),
            r.column(2).into_owned(),
        );
        [c3 * v.n0.x - c1, c3 * v.n0.y - c2]
    };
    let mut a = Matrix3::zeros();
    for v in views {
        for q in rows(v, &v.r) {
            a += q * q.transpose();
        }
    }
    let Some(ai) = a.try_inverse() else {
        return Matrix3::from_element(f64::NAN);
    };
    let mut cov = Matrix3::zeros();
    for v in views {
        let [ra, rb] = rows(v, &v.r);
        let xc = point - v.c;
        // Pose block (3 × 6): centre, then rotation.
        let mut jp = nalgebra::Matrix3x6::zeros();
        let jc = ai * (ra * ra.transpose() + rb * rb.transpose());
        jp.fixed_view_mut::<3, 3>(0, 0).copy_from(&jc);
        let drs: [Matrix3<f64>; 3] = if v.euler {
            crashrig_geometry::opk::d_rotation_d_opk(v.opk.x, v.opk.y, v.opk.z)
        } else {
            [0, 1, 2].map(|m| v.r * Vector3::ith(m, 1.0).cross_matrix())
        };
        for (m, dr) in drs.iter().enumerate() {
            let [da, db] = rows(v, dr);
            let col = -(ai * (ra * da.dot(&xc) + rb * db.dot(&xc)));
            jp.set_column(3 + m, &col);
        }
        // Pixel block (3 × 2): normalized x, y, then through ∂normalized/∂pixel.
        let c3 = v.r.column(2).into_owned();
        let g = -c3.dot(&xc);
        let jn = nalgebra::Matrix3x2::from_columns(&[ai * ra * g, ai * rb * g]);
        let jpx = jn * v.jinv;
        let sp = v.l * v.l.transpose();
        cov += jp * sp * jp.transpose() + jpx * jpx.transpose() * (v.sigma_px * v.sigma_px);
    }
    cov
}

fn not_measurable(point: &Vector3<f64>, seen: usize) -> PointStats {
    let nan3 = Vector3::from_element(f64::NAN);
    PointStats {
        point: *point,
        count: 0,
        mean_mm: nan3,
        covariance: Matrix3::from_element(f64::NAN),
        sigma_mm: nan3,
        sigma_max_mm: f64::NAN,
        linear_covariance: Matrix3::from_element(f64::NAN),
        observers_seen: seen,
        converged: None,
    }
}

fn finish(point: &Vector3<f64>, views: &[View<'_>], m: &Acc3) -> PointStats {
    let sigma = m.std_dev();
    PointStats {
        point: *point,
        count: m.count(),
        mean_mm: m.mean(),
        covariance: m.covariance(),
        sigma_mm: sigma,
        sigma_max_mm: sigma.max(),
        linear_covariance: linear_covariance(views, point),
        observers_seen: views.len(),
        converged: None,
    }
}

/// The block engine's observers of each point's views (prepared once per point).
struct Block<'a> {
    prep: Vec<Prepared<'a>>,
    rows: usize,
}

/// `m` draws of one point (task `task`) into `acc` with `engine`.
#[allow(clippy::too_many_arguments)]
fn run_chunk(
    views: &[View<'_>],
    block: &Block<'_>,
    chain: Option<&Chain>,
    seed: u64,
    task: u64,
    m: usize,
    acc: &mut Acc3,
    engine: Engine,
) {
    match engine {
        Engine::Simd(isa) => {
            let key = crate::philox::key_of_seed(seed);
            crate::simd::dispatch(
                isa,
                #[inline(always)]
                |width| {
                    let rows = block.rows;
                    crate::block::run_prepared(&block.prep, rows, chain, key, task, m, acc, width)
                },
            );
        }
        Engine::Legacy => {
            let mut rng = stream(seed, task);
            run_chunk_fixed(views, chain, &mut rng, m, acc);
        }
    }
}

/// Runs the grid study with fixed (and aimed) observers.
pub(crate) fn run(
    setup: &Setup<'_>,
    draws: Draws<'_>,
    seed: u64,
    engine: Engine,
    progress: &crate::grid::PointTicks<'_>,
) -> Result<Vec<PointStats>, Error> {
    let points = setup.grid.points();
    let views: Vec<Vec<View<'_>>> = points
        .iter()
        .map(|p| views(setup, p))
        .collect::<Result<_, _>>()?;
    let chain = setup.chain;
    let pixel = setup.pixel.map(|p| p.sigma_normalized());
    let blocks: Vec<Block<'_>> = views
        .iter()
        .map(|vs| {
            let (prep, rows) =
                crate::block::layout(vs.iter().map(|v| spec(v, chain, pixel)), chain);
            Block { prep, rows }
        })
        .collect();
    let task_index = crate::grid::task_index;
    match draws {
        Draws::Samples(samples) => {
            let chunks = samples.div_ceil(CHUNK);
            // Only points seen by at least two observers are drawn; task t = (measurable point
            // t / chunks, chunk t % chunks), each point's chunks merged in order.
            let drawn: Vec<usize> = (0..points.len()).filter(|&p| views[p].len() >= 2).collect();
            let mut sums: Vec<Acc3> = points.iter().map(|p| Acc3::new(*p)).collect();
            crate::ordered::map_fold_in_order(
                drawn.len() * chunks,
                |t| {
                    let (p, k) = (drawn[t / chunks], t % chunks);
                    let m = CHUNK.min(samples - k * CHUNK);
                    let mut acc = Acc3::new(points[p]);
                    let task = task_index(p, k);
                    run_chunk(
                        &views[p], &blocks[p], chain, seed, task, m, &mut acc, engine,
                    );
                    progress.chunk_done(p);
                    acc
                },
                |t, part| sums[drawn[t / chunks]].merge(&part),
            );
            Ok(points
                .iter()
                .zip(&sums)
                .enumerate()
                .map(|(p, (point, m))| {
                    if views[p].len() < 2 {
                        return not_measurable(point, views[p].len());
                    }
                    finish(point, &views[p], m)
                })
                .collect())
        }
        Draws::Adaptive(ad) => Ok(points
            .par_iter()
            .enumerate()
            .map(|(p, point)| {
                if views[p].len() < 2 {
                    // Nothing to draw, nothing left to stabilise: `converged` is true so that
                    // every adaptive row says true/false and only points that stopped at
                    // `max_samples` are unconverged.
                    return PointStats {
                        converged: Some(true),
                        ..not_measurable(point, views[p].len())
                    };
                }
                let (total, converged) = crate::grid::adaptive_draws(point, ad, |b, m, acc| {
                    let task = task_index(p, b);
                    run_chunk(&views[p], &blocks[p], chain, seed, task, m, acc, engine);
                });
                progress.point_done();
                PointStats {
                    converged: Some(converged),
                    ..finish(point, &views[p], &total)
                }
            })
            .collect()),
    }
}

impl PointStats {
    /// Whether at least two observers see the point (else its σ are NaN: not measurable).
    pub fn is_measurable(&self) -> bool {
        self.observers_seen >= 2
    }
}

impl GridResult {
    /// Fraction of points seen by at least two observers.
    pub fn fraction_measurable(&self) -> f64 {
        let n = self.points.len().max(1) as f64;
        self.points.iter().filter(|p| p.is_measurable()).count() as f64 / n
    }
}

#[cfg(test)]
mod tests;
