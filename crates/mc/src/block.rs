//! The vectorised draw loop of the grid study: blocks of [`LANES`] draws in
//! structure-of-arrays form, compiled per instruction-set level by [`crate::kernel::simd`].
//!
//! Per block: the normals of every draw ([`fill_block`], Philox + Box–Muller), then per
//! observer its pose perturbation `δ = L·ε` ([`NoiseFactor`]: a lower-triangular 6×6 factor,
//! with a diagonal fast case), its perturbed centre and ray (or DLT rows with pixel noise),
//! summed into per-lane 3×3 normal equations ([`Normals3`]), solved by cofactors, and the
//! points added to per-lane shifted sums. Every path of the study runs here: n observers,
//! tangent and euler noise, full or diagonal factors, pixel noise, and observers drawn jointly
//! from the chain (their δ comes from the chain composition, per lane, instead of `L·ε`).
//!
//! Small-angle forms: `Exp(w)` and the sine/cosine of the euler offsets use their Taylor
//! series, exact to < 3·10⁻¹⁸ for θ² < [`SMALL_ANGLE_SQ`]; a lane with a larger angle (never for
//! realistic σ) is recomputed with `sin`/`cos` by the scalar formulas of [`crate::kernel`],
//! lane by lane, so a draw's result never depends on its block.
//!
//! # Observation models
//! Each observer enters a draw through its [`Observation`]: a ray through its centre
//! ([`ray_pass`]: aimed, no pixel noise), normalized coordinates with pixel noise
//! ([`Normals3::add_view`]: aimed, `σ_px/f` per axis), or a fixed camera's lens (the true pixel
//! plus pixel noise undistorted per lane by `crate::view::undistort_lanes`, then
//! [`Normals3::add_view`]). [`layout`] assigns the normal rows of any mix; [`run_prepared`] is
//! the one kernel of every grid path (aimed studies enter through [`run_task`], studies with
//! fixed observers through `crate::fixed::run`).
//!
//! # Frames of the perturbation
//! `δ = (δC, w)`: δC shifts the centre in world axes; `w` rotates about the camera's own axes,
//! `R = R̄·Exp(w)`. A rotation error `ω` given in the world frame (`R = Exp(ω)·R̄`) is the same
//! as `w = R̄ᵀω`, one 3×3 product per lane before the ray.

#![allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays are the point (they vectorise)

use crate::chain::Chain;
use crate::chain::lanes::Composer;
use crate::kernel::accumulate::{Acc3, LaneSums};
use crate::kernel::lanes::{
    NoiseFactor, Normals3, Trig, euler_dir, euler_rot, keep_max, tangent_dir, tangent_rot,
};
use crate::kernel::normal::{LANES, Lane, fill_block};
use crate::kernel::simd::Width;
use crate::kernel::{Normal3, SMALL_ANGLE_SQ, exp_e3, exp_matrix, opk_e3, rot_opk};
use crate::model::RotationNoise;
use crate::view::{View, undistort_lanes};
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3};

/// [`ray_pass`] in separate passes over the block (δ, centres, rays, normal equations), for
/// narrow registers ([`Width::Narrow`]): the same operations, so the same bits.
#[inline(always)]
fn ray_stages<const TANGENT: bool>(
    o: &Prepared<'_>,
    e: Option<&[Lane]>,
    delta: &mut [Lane; 6],
    scratch: &mut StageScratch,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    if let Some(e) = e {
        o.noise.apply(e, delta);
    }
    let StageScratch { cpos, dir, .. } = scratch;
    for i in 0..3 {
        for l in 0..LANES {
            cpos[i][l] = o.c[i] + delta[i][l];
        }
    }
    for l in 0..LANES {
        let w = [delta[3][l], delta[4][l], delta[5][l]];
        let (d, t) = if TANGENT {
            tangent_dir(&o.r, w)
        } else {
            euler_dir(&o.trig, w)
        };
        for i in 0..3 {
            dir[i][l] = d[i];
        }
        keep_max(&mut tmax[l], t);
    }
    for l in 0..LANES {
        let d = [dir[0][l], dir[1][l], dir[2][l]];
        ne.add_ray_lane(l, d, [cpos[0][l], cpos[1][l], cpos[2][l]]);
    }
}

/// One aimed observer with a ray observation, fused over the block: per lane its `δ` (from
/// the normal rows `e`, or read from `delta` when drawn from the chain), the perturbed centre
/// and ray, added to the normal equations. `δ` is kept in `delta` for the exact fix-up of a
/// lane beyond the series ([`exact_lane`]). One pass instead of four over the lane arrays
/// (the same operations in the same order as the separate loops had, so the same bits).
#[inline(always)]
fn ray_pass<const TANGENT: bool, const DIAGONAL: bool>(
    o: &Prepared<'_>,
    e: Option<&[Lane]>,
    delta: &mut [Lane; 6],
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    for l in 0..LANES {
        let d = lane_delta::<DIAGONAL>(o, e, delta, l);
        let c = std::array::from_fn(|i| o.c[i] + d[i]);
        let w = [d[3], d[4], d[5]];
        let (dir, t) = if TANGENT {
            tangent_dir(&o.r, w)
        } else {
            euler_dir(&o.trig, w)
        };
        keep_max(&mut tmax[l], t);
        ne.add_ray_lane(l, dir, c);
    }
}

/// One observer with image coordinates (`x`, `y` per lane: pixel noise, or a fixed camera's
/// undistorted observation) fused over the block: per lane its `δ` (from the normal rows `e`,
/// or read from `delta` when drawn from the chain), the perturbed centre and rotation, and its
/// two DLT rows added to the normal equations (the same operations as [`view_stages`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn view_pass<const TANGENT: bool, const DIAGONAL: bool>(
    o: &Prepared<'_>,
    e: Option<&[Lane]>,
    delta: &mut [Lane; 6],
    x: &Lane,
    y: &Lane,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    for l in 0..LANES {
        let d = lane_delta::<DIAGONAL>(o, e, delta, l);
        let c = std::array::from_fn(|i| o.c[i] + d[i]);
        let w = [d[3], d[4], d[5]];
        let (rot, t) = if TANGENT {
            tangent_rot(&o.r, w)
        } else {
            euler_rot(&o.trig, w)
        };
        keep_max(&mut tmax[l], t);
        ne.add_view_lane(l, &rot, c, x[l], y[l]);
    }
}

/// [`view_pass`] in separate passes over the block, for narrow registers.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn view_stages<const TANGENT: bool>(
    o: &Prepared<'_>,
    e: Option<&[Lane]>,
    delta: &mut [Lane; 6],
    x: &Lane,
    y: &Lane,
    scratch: &mut StageScratch,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    if let Some(e) = e {
        o.noise.apply(e, delta);
    }
    let StageScratch { cpos, rot, .. } = scratch;
    for i in 0..3 {
        for l in 0..LANES {
            cpos[i][l] = o.c[i] + delta[i][l];
        }
    }
    for l in 0..LANES {
        let w = [delta[3][l], delta[4][l], delta[5][l]];
        let (r, t) = if TANGENT {
            tangent_rot(&o.r, w)
        } else {
            euler_rot(&o.trig, w)
        };
        for k in 0..9 {
            rot[k][l] = r[k];
        }
        keep_max(&mut tmax[l], t);
    }
    for l in 0..LANES {
        let r = std::array::from_fn(|k| rot[k][l]);
        ne.add_view_lane(l, &r, [cpos[0][l], cpos[1][l], cpos[2][l]], x[l], y[l]);
    }
}

/// Lane arrays of the staged (narrow) passes.
struct StageScratch {
    cpos: [Lane; 3],
    dir: [Lane; 3],
    rot: [Lane; 9],
}

/// `δ` of lane `l`: `L·ε` from the rows `e` (stored into `delta` for [`exact_lane`]), or the
/// chain-drawn `δ` already in `delta`.
#[inline(always)]
fn lane_delta<const DIAGONAL: bool>(
    o: &Prepared<'_>,
    e: Option<&[Lane]>,
    delta: &mut [Lane; 6],
    l: usize,
) -> [f64; 6] {
    match e {
        Some(e) => {
            let d = o.noise.delta_lane::<DIAGONAL>(e, l);
            for i in 0..6 {
                delta[i][l] = d[i];
            }
            d
        }
        None => std::array::from_fn(|i| delta[i][l]),
    }
}

/// One observer aimed at one grid point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Aimed {
    pub(crate) c: Vector3<f64>,
    pub(crate) r: Matrix3<f64>,
    pub(crate) opk: Vector3<f64>,
    #[cfg(test)]
    pub(crate) sp: Vector3<f64>,
    #[cfg(test)]
    pub(crate) sr: Vector3<f64>,
    /// Rotation noise kind (a chain draw is always tangent).
    pub(crate) kind: RotationNoise,
    /// The pose noise as a factor `δ = L·ε` (diagonal fast path when independent).
    pub(crate) noise: NoiseFactor,
    /// The covariance in the observer's own frame (for the first-order map).
    pub(crate) covariance: Matrix6<f64>,
    /// Chain camera whose joint draw this observer takes (correlated mode).
    pub(crate) source: Option<usize>,
    /// Correlated mode: `Lᵀ·R̄`, mapping the chain camera's body-axis rotation error θ to this
    /// observer's own axes, so that its world rotation is `Exp(R̄·θ)·L`.
    pub(crate) chain_to_own: Matrix3<f64>,
}

/// Everything the per-draw kernel needs that is shared by all points.
#[derive(Debug, Clone)]
pub(crate) struct Ctx {
    /// σ of the normalized image coordinates, if pixel noise is on.
    pub(crate) pixel: Option<f64>,
    /// The chain, when at least one observer is drawn jointly from it.
    pub(crate) chain: Option<Chain>,
    /// [`Chain::jacobians`] of that chain (for the first-order map of correlated observers).
    pub(crate) chain_jacobians: Vec<DMatrix<f64>>,
}

/// How an observer's image observation enters a draw.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Observation<'a> {
    /// At the principal point, no pixel noise: the ray form ([`ray_pass`]).
    Ray,
    /// At the principal point with pixel noise of this σ in normalized coordinates (the aimed
    /// observers' `pixel_sigma_px / focal_px`): the two DLT rows.
    Normalized(f64),
    /// Through a real lens (a fixed camera): the true pixel plus `N(0, σ_px)` per axis,
    /// undistorted per lane ([`crate::view::undistort_lanes`]), then the two DLT rows.
    Lens(&'a View<'a>),
}

/// An observer ready for the block kernel.
#[derive(Debug, Clone)]
pub(crate) struct Prepared<'a> {
    c: [f64; 3],
    r: [f64; 9],
    opk: Vector3<f64>,
    trig: Trig,
    noise: NoiseFactor,
    /// First normal row of the pose noise (`None`: drawn jointly from the chain).
    row: Option<usize>,
    /// First normal row of the pixel noise (unused for [`Observation::Ray`]).
    pixel_row: usize,
    observation: Observation<'a>,
    source: Option<usize>,
    /// Tangent (body-axis) rotation noise, else ω φ κ noise.
    tangent: bool,
    /// Correlated mode: maps the chain camera's body-axis θ to this observer's axes.
    chain_to_own: [f64; 9],
}

/// One observer's pose and noise, before the rows of the block are assigned.
pub(crate) struct ObserverSpec<'a> {
    /// Nominal centre (world, mm).
    pub(crate) c: Vector3<f64>,
    /// Nominal `R_world_from_cam`.
    pub(crate) r: Matrix3<f64>,
    /// ω φ κ of `r` (base of euler noise).
    pub(crate) opk: Vector3<f64>,
    /// `δ = L·ε`.
    pub(crate) noise: NoiseFactor,
    /// Tangent (else euler) rotation noise.
    pub(crate) tangent: bool,
    /// Chain camera whose joint draw it takes (correlated mode, with a chain).
    pub(crate) source: Option<usize>,
    /// `R̄ᵀ·R_chain` (correlated mode; identity otherwise).
    pub(crate) chain_to_own: Matrix3<f64>,
    /// How its observation enters a draw.
    pub(crate) observation: Observation<'a>,
}

/// How the rows of a block are used: the chain's (6 per camera, when observers are drawn
/// jointly), then 6 per independent observer in observer order, then 2 pixel rows per
/// observer with pixel noise (normalized or through a lens). Returns the observers and the
/// number of rows.
pub(crate) fn layout<'a>(
    specs: impl IntoIterator<Item = ObserverSpec<'a>>,
    chain: Option<&Chain>,
) -> (Vec<Prepared<'a>>, usize) {
    let mut row = chain.map_or(0, |c| 6 * c.len());
    let mut out: Vec<Prepared<'a>> = specs
        .into_iter()
        .map(|o| {
            let source = o.source.filter(|_| chain.is_some());
            let p = Prepared {
                c: [o.c.x, o.c.y, o.c.z],
                r: std::array::from_fn(|k| o.r[(k / 3, k % 3)]),
                opk: o.opk,
                trig: Trig {
                    s: std::array::from_fn(|k| o.opk[k].sin()),
                    c: std::array::from_fn(|k| o.opk[k].cos()),
                },
                noise: o.noise,
                row: source.is_none().then_some(row),
                pixel_row: 0,
                observation: o.observation,
                source,
                tangent: source.is_some() || o.tangent,
                chain_to_own: std::array::from_fn(|k| o.chain_to_own[(k / 3, k % 3)]),
            };
            if source.is_none() {
                row += 6;
            }
            p
        })
        .collect();
    for p in &mut out {
        if !matches!(p.observation, Observation::Ray) {
            p.pixel_row = row;
            row += 2;
        }
    }
    (out, row)
}

/// The aimed observers of one grid point (the grid study without fixed observers).
fn prepare<'a>(obs: &[Aimed], ctx: &'a Ctx) -> (Vec<Prepared<'a>>, usize) {
    let chain = ctx.chain.as_ref();
    layout(
        obs.iter().map(|o| ObserverSpec {
            c: o.c,
            r: o.r,
            opk: o.opk,
            noise: o.noise,
            tangent: o.kind == RotationNoise::Tangent,
            source: o.source,
            chain_to_own: o.chain_to_own,
            observation: ctx.pixel.map_or(Observation::Ray, Observation::Normalized),
        }),
        chain,
    )
}

/// Per-task scratch of the block kernel (allocated once per task; size independent of the
/// number of draws).
struct Scratch {
    e: Vec<Lane>,
    delta: Vec<[Lane; 6]>,
    /// The normalized image coordinates of each observer with pixel noise.
    xy: Vec<[Lane; 2]>,
    /// The vectorised chain composition (observers drawn jointly from the chain).
    composer: Option<Composer>,
}

/// `m` draws of one grid point (task `task` of the run keyed `key`) into `acc`. Must be
/// called inside [`crate::kernel::simd::dispatch`].
#[inline(always)]
pub(crate) fn run_task(
    obs: &[Aimed],
    ctx: &Ctx,
    key: [u32; 2],
    task: u64,
    m: usize,
    acc: &mut Acc3,
    width: Width,
) {
    let (prep, rows) = prepare(obs, ctx);
    run_prepared(&prep, rows, ctx.chain.as_ref(), key, task, m, acc, width);
}

/// `m` draws of prepared observers ([`layout`]) into `acc`: the kernel of every grid path.
/// Must be called inside [`crate::kernel::simd::dispatch`], which gives the level's `width`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_prepared(
    prep: &[Prepared<'_>],
    rows: usize,
    chain: Option<&Chain>,
    key: [u32; 2],
    task: u64,
    m: usize,
    acc: &mut Acc3,
    width: Width,
) {
    let mut s = Scratch {
        e: vec![[0.0; LANES]; rows.next_multiple_of(2)],
        delta: vec![[[0.0; LANES]; 6]; prep.len()],
        xy: vec![[[0.0; LANES]; 2]; prep.len()],
        composer: chain.map(Composer::new),
    };
    let mut ne = Normals3::new();
    let mut stage = StageScratch {
        cpos: [[0.0; LANES]; 3],
        dir: [[0.0; LANES]; 3],
        rot: [[0.0; LANES]; 9],
    };
    let mut xs = [[0.0; LANES]; 3];
    let mut tmax;
    let shift = acc.shift();
    let mut lanes = LaneSums::<LANES>::default();
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        fill_block(key, task, done as u64, &mut s.e, width);
        if let Some(chain) = chain {
            chain_deltas(chain, prep, &mut s, b);
        }
        ne.clear();
        tmax = [0.0; LANES];
        for (j, o) in prep.iter().enumerate() {
            let delta = &mut s.delta[j];
            let e = o.row.map(|r| &s.e[r..r + 6]);
            let (ne, tmax) = (&mut ne, &mut tmax);
            if let Observation::Ray = o.observation {
                match (width, o.tangent, o.noise.is_diagonal()) {
                    (Width::Wide, true, true) => ray_pass::<true, true>(o, e, delta, ne, tmax),
                    (Width::Wide, true, false) => ray_pass::<true, false>(o, e, delta, ne, tmax),
                    (Width::Wide, false, true) => ray_pass::<false, true>(o, e, delta, ne, tmax),
                    (Width::Wide, false, false) => ray_pass::<false, false>(o, e, delta, ne, tmax),
                    (Width::Narrow, true, _) => {
                        ray_stages::<true>(o, e, delta, &mut stage, ne, tmax)
                    }
                    (Width::Narrow, false, _) => {
                        ray_stages::<false>(o, e, delta, &mut stage, ne, tmax);
                    }
                }
                continue;
            }
            // The image coordinates first (they do not depend on the pose).
            let [ex, ey] = [&s.e[o.pixel_row], &s.e[o.pixel_row + 1]];
            let [px, py] = &mut s.xy[j];
            match &o.observation {
                Observation::Normalized(sn) => {
                    for l in 0..LANES {
                        px[l] = sn * ex[l];
                        py[l] = sn * ey[l];
                    }
                }
                Observation::Lens(v) => undistort_lanes(v, ex, ey, px, py, b),
                Observation::Ray => unreachable!("handled above"),
            }
            let (px, py) = (&*px, &*py);
            match (width, o.tangent, o.noise.is_diagonal()) {
                (Width::Wide, true, true) => view_pass::<true, true>(o, e, delta, px, py, ne, tmax),
                (Width::Wide, true, false) => {
                    view_pass::<true, false>(o, e, delta, px, py, ne, tmax);
                }
                (Width::Wide, false, true) => {
                    view_pass::<false, true>(o, e, delta, px, py, ne, tmax);
                }
                (Width::Wide, false, false) => {
                    view_pass::<false, false>(o, e, delta, px, py, ne, tmax);
                }
                (Width::Narrow, true, _) => {
                    view_stages::<true>(o, e, delta, px, py, &mut stage, ne, tmax);
                }
                (Width::Narrow, false, _) => {
                    view_stages::<false>(o, e, delta, px, py, &mut stage, ne, tmax);
                }
            }
        }
        // A full block with every lane inside the series' range (all of them, for realistic
        // σ): solve and accumulate in one pass.
        let all_small = tmax.iter().fold(true, |ok, &t| ok & (t < SMALL_ANGLE_SQ));
        if b == LANES && all_small {
            ne.solve_into(&mut lanes, &shift);
            done += b;
            continue;
        }
        ne.solve(&mut xs);
        for l in 0..b {
            if tmax[l] >= SMALL_ANGLE_SQ {
                let x = exact_lane(prep, &s, l);
                for i in 0..3 {
                    xs[i][l] = x[i];
                }
            }
        }
        lanes.add(&xs, b, &shift);
        done += b;
    }
    acc.merge(&lanes.reduce(shift));
}

/// δ of the observers drawn jointly from the chain, per lane: the chain composed in lanes
/// ([`Composer`], scalar formulas only for a lane beyond its series),
/// then each observer's centre error and its chain camera's body-axis error turned into the
/// observer's axes (`R·Exp(Rᵀ R̄ θ)`: `w = chain_to_own·θ`).
#[inline(always)]
fn chain_deltas(chain: &Chain, prep: &[Prepared<'_>], s: &mut Scratch, b: usize) {
    let Some(composer) = s.composer.as_mut() else {
        return;
    };
    composer.compose::<false>(chain, &s.e, b);
    for (j, o) in prep.iter().enumerate() {
        if let Some(i) = o.source {
            let (v, th, m) = (&composer.v[i], &composer.th[i], &o.chain_to_own);
            let delta = &mut s.delta[j];
            for l in 0..LANES {
                for k in 0..3 {
                    delta[k][l] = v[k][l];
                    delta[3 + k][l] =
                        m[3 * k] * th[0][l] + m[3 * k + 1] * th[1][l] + m[3 * k + 2] * th[2][l];
                }
            }
        }
    }
}

/// Lane `l` recomputed with the exact `sin`/`cos` formulas (an angle beyond the series).
#[inline(never)]
fn exact_lane(prep: &[Prepared<'_>], s: &Scratch, l: usize) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, p) in prep.iter().enumerate() {
        let d = &s.delta[j];
        let c = Vector3::new(p.c[0] + d[0][l], p.c[1] + d[1][l], p.c[2] + d[2][l]);
        let w = Vector3::new(d[3][l], d[4][l], d[5][l]);
        let r0 = Matrix3::from_row_slice(&p.r);
        if let Observation::Ray = p.observation {
            let dir = if p.tangent {
                r0 * exp_e3(&w)
            } else {
                opk_e3(&(p.opk + w))
            };
            n.add_ray(&dir, &c);
            continue;
        }
        let r: Matrix3<f64> = if p.tangent {
            r0 * exp_matrix(&w)
        } else {
            rot_opk(&(p.opk + w))
        };
        n.add_view(&r, &c, s.xy[j][0][l], s.xy[j][1][l]);
    }
    n.solve()
}
