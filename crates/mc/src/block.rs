//! The vectorised draw loop of the grid study: blocks of [`LANES`] draws in
//! structure-of-arrays form, compiled per instruction-set level by [`crate::kernel::simd`].
//!
//! Per block of replicates: in correlated mode the chain's normals and its composition, once
//! for every point of a group ([`ChainBlock`], the map's common random numbers); then per
//! point its own normals ([`fill_block`], Philox + Box–Muller), per observer its pose
//! perturbation `δ = L·ε` ([`NoiseFactor`]: a lower-triangular 6×6 factor, with a diagonal
//! fast case) or its chain camera's drawn error, its perturbed centre and ray (or DLT rows
//! with pixel noise), summed into per-lane 3×3 normal equations ([`Normals3`]), solved by
//! cofactors, and the points added to per-lane shifted sums. Every path of the study runs
//! here: n observers, tangent and euler noise, full or diagonal factors, pixel noise, fixed
//! lenses, and observers drawn jointly from the chain.
//!
//! Small-angle forms: `Exp(w)` and the sine/cosine of the euler offsets use their Taylor
//! series, exact to < 3·10⁻¹⁸ for θ² < [`SMALL_ANGLE_SQ`]; a lane with a larger angle (never for
//! realistic σ) is recomputed with `sin`/`cos` by the scalar formulas of [`crate::kernel`],
//! lane by lane, so a draw's result never depends on its block.
//!
//! # Observation models
//! Each observer enters a draw through its [`Observation`]: a ray through its centre
//! ([`ray_pass`]: aimed, no pixel noise), normalized coordinates with pixel noise
//! (the two DLT rows, [`Normals3::add_rows_lane`]: aimed, `σ_px/f` per axis), or a fixed
//! camera's lens (the true pixel
//! plus pixel noise undistorted per lane by `crate::view::undistort_lanes`, then
//! the two DLT rows). [`layout`] assigns a point's normal rows for any mix;
//! [`run_group`] is the one kernel of every grid path (scheduled by `crate::map`).
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
    NoiseFactor, Normals3, Trig, euler_dir, euler_rot, keep_max, tangent_dir, tangent_rows,
};
use crate::kernel::normal::{LANES, Lane, fill_block};
use crate::kernel::simd::Width;
use crate::kernel::{Normal3, SMALL_ANGLE_SQ, exp_e3, exp_matrix, opk_e3, rot_opk};
use crate::model::RotationNoise;
use crate::schedule::CHAIN_TASK;
use crate::view::{View, undistort_lanes};
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3};

/// [`ray_pass`] in separate passes over the block (δ, centres, rays, normal equations), for
/// narrow registers ([`Width::Narrow`]): the same operations, so the same bits.
#[inline(always)]
fn ray_stages<const TANGENT: bool>(
    o: &Prepared<'_>,
    e: &[Lane; 6],
    delta: &mut [Lane; 6],
    scratch: &mut StageScratch,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    o.noise.apply(e, delta);
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
    e: &[Lane; 6],
    delta: &mut [Lane; 6],
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    // The observer's constants as local values, loaded once.
    let (c0, r, trig, noise) = (o.c, o.r, o.trig, o.noise);
    for l in 0..LANES {
        let d = lane_delta::<DIAGONAL>(&noise, e, delta, l);
        let c = std::array::from_fn(|i| c0[i] + d[i]);
        let w = [d[3], d[4], d[5]];
        let (dir, t) = if TANGENT {
            tangent_dir(&r, w)
        } else {
            euler_dir(&trig, w)
        };
        keep_max(&mut tmax[l], t);
        ne.add_ray_lane(l, dir, c);
    }
}

/// One observer with image coordinates (`x`, `y` per lane: pixel noise, or a fixed camera's
/// undistorted observation) fused over the block: per lane its `δ` (from the normal rows `e`),
/// the perturbed centre and its two DLT rows ([`view_rows`]) added to the normal equations
/// (the same operations as [`view_stages`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn view_pass<const TANGENT: bool, const DIAGONAL: bool>(
    o: &Prepared<'_>,
    e: &[Lane; 6],
    delta: &mut [Lane; 6],
    x: &Lane,
    y: &Lane,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    // The observer's constants as local values, loaded once.
    let (c0, r, trig, noise) = (o.c, o.r, o.trig, o.noise);
    for l in 0..LANES {
        let d = lane_delta::<DIAGONAL>(&noise, e, delta, l);
        let c = std::array::from_fn(|i| c0[i] + d[i]);
        let (a, b, t) = view_rows::<TANGENT>(&r, &trig, [d[3], d[4], d[5]], x[l], y[l]);
        keep_max(&mut tmax[l], t);
        ne.add_rows_lane(l, a, b, c);
    }
}

/// The two DLT rows of an observer (nominal rotation `r`, its ω φ κ `trig`) turned by `w`
/// (tangent: `R̄·Exp(w)`, [`tangent_rows`]; else ω φ κ + w) at normalized coordinates
/// `(x, y)`, and the largest squared angle.
#[inline(always)]
fn view_rows<const TANGENT: bool>(
    r: &[f64; 9],
    trig: &Trig,
    w: [f64; 3],
    x: f64,
    y: f64,
) -> ([f64; 3], [f64; 3], f64) {
    if TANGENT {
        tangent_rows(r, w, x, y)
    } else {
        let (r, t) = euler_rot(trig, w);
        let row = |obs: f64, col: usize| {
            std::array::from_fn(|i| obs.mul_add(r[3 * i + 2], -r[3 * i + col]))
        };
        (row(x, 0), row(y, 1), t)
    }
}

/// [`view_pass`] in separate passes over the block, for narrow registers.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn view_stages<const TANGENT: bool>(
    o: &Prepared<'_>,
    e: &[Lane; 6],
    delta: &mut [Lane; 6],
    x: &Lane,
    y: &Lane,
    scratch: &mut StageScratch,
    ne: &mut Normals3,
    tmax: &mut Lane,
) {
    o.noise.apply(e, delta);
    let StageScratch { cpos, rows, .. } = scratch;
    for i in 0..3 {
        for l in 0..LANES {
            cpos[i][l] = o.c[i] + delta[i][l];
        }
    }
    for l in 0..LANES {
        let w = [delta[3][l], delta[4][l], delta[5][l]];
        let (a, b, t) = view_rows::<TANGENT>(&o.r, &o.trig, w, x[l], y[l]);
        for k in 0..3 {
            rows[k][l] = a[k];
            rows[3 + k][l] = b[k];
        }
        keep_max(&mut tmax[l], t);
    }
    for l in 0..LANES {
        let q = |k: usize| std::array::from_fn(|i| rows[k + i][l]);
        ne.add_rows_lane(l, q(0), q(3), [cpos[0][l], cpos[1][l], cpos[2][l]]);
    }
}

/// Lane arrays of the staged (narrow) passes.
struct StageScratch {
    cpos: [Lane; 3],
    dir: [Lane; 3],
    /// The two DLT rows (a, then b).
    rows: [Lane; 6],
}

/// `δ = L·ε` of lane `l` from the rows `e`, stored into `delta` for [`exact_lane`].
#[inline(always)]
fn lane_delta<const DIAGONAL: bool>(
    noise: &NoiseFactor,
    e: &[Lane; 6],
    delta: &mut [Lane; 6],
    l: usize,
) -> [f64; 6] {
    let d = noise.delta_lane::<DIAGONAL>(e, l);
    for i in 0..6 {
        delta[i][l] = d[i];
    }
    d
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
// The lens by value: boxing it (clippy's advice for the variant sizes) made the aimed grid's
// command 10 % slower (`four_cameras_z0`, 3 × alternated, user CPU 0.57 s against 0.51 s).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub(crate) enum Observation<'a> {
    /// At the principal point, no pixel noise: the ray form ([`ray_pass`]).
    Ray,
    /// At the principal point with pixel noise of this σ in normalized coordinates (the aimed
    /// observers' `pixel_sigma_px / focal_px`): the two DLT rows.
    Normalized(f64),
    /// Through a real lens (a fixed camera): the true pixel plus `N(0, σ_px)` per axis,
    /// undistorted per lane ([`crate::view::undistort_lanes`]), then the two DLT rows.
    Lens(View<'a>),
}

/// An observer ready for the block kernel.
#[derive(Debug, Clone)]
pub(crate) struct Prepared<'a> {
    c: [f64; 3],
    r: [f64; 9],
    opk: Vector3<f64>,
    trig: Trig,
    noise: NoiseFactor,
    /// First normal row of the pose noise among the point's rows (`None`: drawn jointly from
    /// the chain).
    row: Option<usize>,
    /// First normal row of the pixel noise (unused for [`Observation::Ray`]).
    pixel_row: usize,
    observation: Observation<'a>,
    source: Option<usize>,
    /// Tangent (body-axis) rotation noise, else ω φ κ noise.
    tangent: bool,
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
    /// How its observation enters a draw.
    pub(crate) observation: Observation<'a>,
}

/// The observers of one grid point, ready for the block kernel, and how many normal rows a
/// draw of the point takes from the point's own stream.
#[derive(Debug, Clone)]
pub(crate) struct PointKernel<'a> {
    pub(crate) observers: Vec<Prepared<'a>>,
    pub(crate) rows: usize,
}

/// How the rows of a point's own stream are used: 6 per observer not drawn from the chain, in
/// observer order, then 2 pixel rows per observer with pixel noise (normalized or through a
/// lens). An observer drawn jointly from the chain (`source`, with `chain` given) takes no
/// row: its pose comes from the map's shared chain draw ([`ChainBlock`]).
pub(crate) fn layout<'a>(
    specs: impl IntoIterator<Item = ObserverSpec<'a>>,
    chain: Option<&Chain>,
) -> PointKernel<'a> {
    let mut row = 0;
    let mut observers: Vec<Prepared<'a>> = specs
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
            };
            if source.is_none() {
                row += 6;
            }
            p
        })
        .collect();
    for p in &mut observers {
        if !matches!(p.observation, Observation::Ray) {
            p.pixel_row = row;
            row += 2;
        }
    }
    PointKernel {
        observers,
        rows: row,
    }
}

/// The aimed observers of one grid point (the grid study without fixed observers).
pub(crate) fn prepare<'a>(obs: &[Aimed], ctx: &Ctx) -> PointKernel<'a> {
    layout(
        obs.iter().map(|o| ObserverSpec {
            c: o.c,
            r: o.r,
            opk: o.opk,
            noise: o.noise,
            tangent: o.kind == RotationNoise::Tangent,
            source: o.source,
            observation: ctx.pixel.map_or(Observation::Ray, Observation::Normalized),
        }),
        ctx.chain.as_ref(),
    )
}

/// The chain's part of a block of replicates in correlated mode, drawn once and shared by
/// every point of a map: replicate `j`'s chain normals are draw `j` of the chain stream
/// ([`CHAIN_TASK`]), composed in lanes into each camera's centre error and world-frame
/// rotation error `R·R̄ᵀ` ([`Composer::compose_world`]).
pub(crate) struct ChainBlock {
    e: Vec<Lane>,
    composer: Composer,
}

impl ChainBlock {
    pub(crate) fn new(chain: &Chain) -> Self {
        ChainBlock {
            e: vec![[0.0; LANES]; (6 * chain.len()).next_multiple_of(2)],
            composer: Composer::new(chain),
        }
    }

    /// Draws and composes replicates `replicate0 .. replicate0 + LANES` (the first `b` valid).
    #[inline(always)]
    pub(crate) fn draw(
        &mut self,
        chain: &Chain,
        key: [u32; 2],
        replicate0: u64,
        b: usize,
        width: Width,
    ) {
        fill_block(key, CHAIN_TASK, replicate0, &mut self.e, width);
        self.composer.compose_world(chain, &self.e, b);
    }
}

/// Lane scratch of the block kernel, shared by the points of a task (allocated once per task;
/// size independent of the number of draws and of points).
pub(crate) struct Scratch {
    /// The point's own normal rows.
    e: Vec<Lane>,
    delta: Vec<[Lane; 6]>,
    /// The normalized image coordinates of each observer with pixel noise.
    xy: Vec<[Lane; 2]>,
    stage: StageScratch,
    ne: Normals3,
    tmax: Lane,
    /// The solved points of a block (x, y, z rows).
    pub(crate) xs: [Lane; 3],
}

impl Scratch {
    /// Scratch for points with at most `rows` own normal rows and `observers` observers.
    pub(crate) fn new(rows: usize, observers: usize) -> Self {
        Scratch {
            e: vec![[0.0; LANES]; rows.next_multiple_of(2)],
            delta: vec![[[0.0; LANES]; 6]; observers],
            xy: vec![[[0.0; LANES]; 2]; observers],
            stage: StageScratch {
                cpos: [[0.0; LANES]; 3],
                dir: [[0.0; LANES]; 3],
                rows: [[0.0; LANES]; 6],
            },
            ne: Normals3::new(),
            tmax: [0.0; LANES],
            xs: [[0.0; LANES]; 3],
        }
    }
}

/// What a task does with each point's solved block: the map's per-lane sums
/// ([`LaneSink`]), or the joint statistics of several points (`crate::joint`).
pub(crate) trait GroupSink {
    /// Point `i` of the group has its block in `s` (`s.ne` filled; `all_small`: every lane
    /// inside the series' range), the first `b` lanes valid.
    #[allow(clippy::too_many_arguments)]
    fn point(
        &mut self,
        i: usize,
        kernel: &PointKernel<'_>,
        shared: Option<&ChainBlock>,
        s: &mut Scratch,
        b: usize,
        all_small: bool,
    );

    /// Every point of the group has had the block.
    fn block_done(&mut self, _b: usize) {}
}

/// Per-lane sums of each point of a group (about its grid point): the map's sink.
pub(crate) struct LaneSink {
    sums: Vec<(Vector3<f64>, LaneSums<LANES>)>,
}

impl LaneSink {
    /// Empty sums about each of `shifts`.
    pub(crate) fn new(shifts: impl IntoIterator<Item = Vector3<f64>>) -> Self {
        LaneSink {
            sums: shifts
                .into_iter()
                .map(|s| (s, LaneSums::default()))
                .collect(),
        }
    }

    /// Each point's sums, in order.
    pub(crate) fn finish(&self) -> Vec<Acc3> {
        self.sums.iter().map(|(s, l)| l.reduce(*s)).collect()
    }
}

impl GroupSink for LaneSink {
    #[inline(always)]
    fn point(
        &mut self,
        i: usize,
        kernel: &PointKernel<'_>,
        shared: Option<&ChainBlock>,
        s: &mut Scratch,
        b: usize,
        all_small: bool,
    ) {
        let (shift, lanes) = &mut self.sums[i];
        // A full block with every lane inside the series' range (all of them, for realistic
        // σ): solve and accumulate in one pass.
        if b == LANES && all_small {
            s.ne.solve_into(lanes, shift);
        } else {
            solve_block(kernel, shared, s, b);
            lanes.add(&s.xs, b, shift);
        }
    }
}

/// `m` replicates (`replicate0 ..`, the index of a point's draw: `chunk·CHUNK + d` or
/// `batch·size + d`) of every point of `points` (its kernel and its own stream, a
/// `schedule::task_index`) into `sink`: the kernel of every grid path. Per block of [`LANES`]
/// replicates the chain (correlated mode) is drawn and composed once ([`ChainBlock`]), then
/// each point draws its own normals, its observers' poses and observations, and solves. A
/// point's result depends only on its own stream and the chain draws of its replicates, not on
/// the other points of the group. Must be called inside [`crate::kernel::simd::dispatch`],
/// which gives the level's `width`.
#[inline(always)]
pub(crate) fn run_group<S: GroupSink>(
    points: &[(&PointKernel<'_>, u64)],
    chain: Option<&Chain>,
    key: [u32; 2],
    replicate0: u64,
    m: usize,
    sink: &mut S,
    width: Width,
) {
    let rows = points.iter().map(|p| p.0.rows).max().unwrap_or(0);
    let observers = points
        .iter()
        .map(|p| p.0.observers.len())
        .max()
        .unwrap_or(0);
    let mut s = Scratch::new(rows, observers);
    let mut shared = chain.map(ChainBlock::new);
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        if let (Some(chain), Some(shared)) = (chain, shared.as_mut()) {
            shared.draw(chain, key, replicate0 + done as u64, b, width);
        }
        for (i, &(kernel, task)) in points.iter().enumerate() {
            let all_small = draw_block(kernel, shared.as_ref(), key, task, done, b, &mut s, width);
            sink.point(i, kernel, shared.as_ref(), &mut s, b, all_small);
        }
        sink.block_done(b);
        done += b;
    }
}

/// Solves every lane of the block in `s` into `s.xs`, lanes beyond the series' range by the
/// exact formulas.
#[inline(always)]
pub(crate) fn solve_block(
    kernel: &PointKernel<'_>,
    shared: Option<&ChainBlock>,
    s: &mut Scratch,
    b: usize,
) {
    let shared = shared.map(|c| &c.composer);
    s.ne.solve(&mut s.xs);
    for l in 0..b {
        if s.tmax[l] >= SMALL_ANGLE_SQ {
            let x = exact_lane(&kernel.observers, s, shared, l);
            for i in 0..3 {
                s.xs[i][l] = x[i];
            }
        }
    }
}

/// One block of draws `draw0 .. draw0 + LANES` of one point into the normal equations
/// `s.ne` (the first `b` lanes valid): its own normals, each observer's pose (its own `L·ε`,
/// or its chain camera's draw from `shared`) and observation. Returns whether every lane
/// stayed inside the series' range.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_block(
    kernel: &PointKernel<'_>,
    shared: Option<&ChainBlock>,
    key: [u32; 2],
    task: u64,
    draw0: usize,
    b: usize,
    s: &mut Scratch,
    width: Width,
) -> bool {
    let rows = kernel.rows.next_multiple_of(2);
    fill_block(key, task, draw0 as u64, &mut s.e[..rows], width);
    s.ne.clear();
    s.tmax = [0.0; LANES];
    let shared = shared.map(|c| &c.composer);
    for (j, o) in kernel.observers.iter().enumerate() {
        observer_pass(o, j, s, shared, b, width);
    }
    s.tmax.iter().fold(0u64, |n, &t| {
        n | u64::from(t >= SMALL_ANGLE_SQ || t.is_nan())
    }) == 0
}

/// Observer `j` (`o`) of a block into the normal equations, in the loop shape of `width`: its
/// own pose noise, or (drawn jointly from the chain) its chain camera's error from `shared`.
#[inline(always)]
fn observer_pass(
    o: &Prepared<'_>,
    j: usize,
    s: &mut Scratch,
    shared: Option<&Composer>,
    b: usize,
    width: Width,
) {
    let Scratch {
        e: rows,
        delta,
        xy,
        stage,
        ne,
        tmax,
        ..
    } = s;
    let delta = &mut delta[j];
    let chain = o.source.zip(shared).map(|(i, c)| (&c.v[i], &c.world[i]));
    // An observer not drawn from the chain has its six rows (a fixed-size array: no bounds
    // check in the lane loops, which would keep them from vectorising).
    let e: &[Lane; 6] = match (chain, o.row) {
        (None, Some(r)) => rows[r..r + 6].try_into().expect("six rows"),
        _ => &[[0.0; LANES]; 6],
    };
    if let Observation::Ray = o.observation {
        if let Some((dc, world)) = chain {
            ray_chain_pass(o, dc, world, ne);
            return;
        }
        match (width, o.tangent, o.noise.is_diagonal()) {
            (Width::Wide, true, true) => ray_pass::<true, true>(o, e, delta, ne, tmax),
            (Width::Wide, true, false) => ray_pass::<true, false>(o, e, delta, ne, tmax),
            (Width::Wide, false, true) => ray_pass::<false, true>(o, e, delta, ne, tmax),
            (Width::Wide, false, false) => ray_pass::<false, false>(o, e, delta, ne, tmax),
            (Width::Narrow, true, _) => ray_stages::<true>(o, e, delta, stage, ne, tmax),
            (Width::Narrow, false, _) => ray_stages::<false>(o, e, delta, stage, ne, tmax),
        }
        return;
    }
    // The image coordinates first (they do not depend on the pose).
    let (ex, ey) = (&rows[o.pixel_row], &rows[o.pixel_row + 1]);
    let [px, py] = &mut xy[j];
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
    if let Some((dc, world)) = chain {
        view_chain_pass(o, dc, world, px, py, ne);
        return;
    }
    match (width, o.tangent, o.noise.is_diagonal()) {
        (Width::Wide, true, true) => view_pass::<true, true>(o, e, delta, px, py, ne, tmax),
        (Width::Wide, true, false) => view_pass::<true, false>(o, e, delta, px, py, ne, tmax),
        (Width::Wide, false, true) => view_pass::<false, true>(o, e, delta, px, py, ne, tmax),
        (Width::Wide, false, false) => view_pass::<false, false>(o, e, delta, px, py, ne, tmax),
        (Width::Narrow, true, _) => view_stages::<true>(o, e, delta, px, py, stage, ne, tmax),
        (Width::Narrow, false, _) => view_stages::<false>(o, e, delta, px, py, stage, ne, tmax),
    }
}

/// An observer drawn jointly from the chain, carried by its chain camera as a rigid body: per
/// lane its centre `C̄ + δC` and ray `E·R̄·e₃` (`E = R·R̄_camᵀ` the camera's world-frame
/// rotation error, `dc` and `world` its lanes), added to the normal equations.
#[inline(always)]
fn ray_chain_pass(o: &Prepared<'_>, dc: &[Lane; 6], world: &[Lane; 9], ne: &mut Normals3) {
    let (d0, c0) = ([o.r[2], o.r[5], o.r[8]], o.c);
    for l in 0..LANES {
        let c = std::array::from_fn(|i| c0[i] + dc[i][l]);
        let dir = std::array::from_fn(|i| {
            let (a, b, cc) = (world[3 * i][l], world[3 * i + 1][l], world[3 * i + 2][l]);
            a.mul_add(d0[0], b.mul_add(d0[1], cc * d0[2]))
        });
        ne.add_ray_lane(l, dir, c);
    }
}

/// [`ray_chain_pass`] for an observer with image coordinates (`x`, `y` per lane): its two DLT
/// rows `E·R̄·(−1, 0, x)`, `E·R̄·(0, −1, y)`.
#[inline(always)]
fn view_chain_pass(
    o: &Prepared<'_>,
    dc: &[Lane; 6],
    world: &[Lane; 9],
    x: &Lane,
    y: &Lane,
    ne: &mut Normals3,
) {
    let (r, c0) = (o.r, o.c);
    for l in 0..LANES {
        let c = std::array::from_fn(|i| c0[i] + dc[i][l]);
        let turn = |obs: f64, col: usize| -> [f64; 3] {
            let u: [f64; 3] = std::array::from_fn(|i| obs.mul_add(r[3 * i + 2], -r[3 * i + col]));
            std::array::from_fn(|i| {
                let (e0, e1, e2) = (world[3 * i][l], world[3 * i + 1][l], world[3 * i + 2][l]);
                e0.mul_add(u[0], e1.mul_add(u[1], e2 * u[2]))
            })
        };
        ne.add_rows_lane(l, turn(x[l], 0), turn(y[l], 1), c);
    }
}

/// `E·R̄` (row-major) of lane `l`: `E` the chain camera's world-frame rotation error, `R̄` the
/// observer's nominal rotation.
#[inline(always)]
fn world_rotation(world: &[Lane; 9], l: usize, r: &[f64; 9]) -> [f64; 9] {
    std::array::from_fn(|k| {
        let (a, b) = (k / 3, k % 3);
        let (e0, e1, e2) = (world[3 * a][l], world[3 * a + 1][l], world[3 * a + 2][l]);
        e0.mul_add(r[b], e1.mul_add(r[3 + b], e2 * r[6 + b]))
    })
}

/// Lane `l` recomputed with the exact `sin`/`cos` formulas (an angle beyond the series).
#[inline(never)]
fn exact_lane(
    prep: &[Prepared<'_>],
    s: &Scratch,
    shared: Option<&Composer>,
    l: usize,
) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, p) in prep.iter().enumerate() {
        if let (Some(i), Some(c)) = (p.source, shared) {
            // Drawn from the chain: exact already (the chain's own fall-back).
            let centre = Vector3::from_fn(|k, _| p.c[k] + c.v[i][k][l]);
            let r = Matrix3::from_row_slice(&world_rotation(&c.world[i], l, &p.r));
            match p.observation {
                Observation::Ray => n.add_ray(&r.column(2).into_owned(), &centre),
                _ => n.add_view(&r, &centre, s.xy[j][0][l], s.xy[j][1][l]),
            }
            continue;
        }
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
