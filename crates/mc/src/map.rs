//! How the draws of a map are scheduled: every grid path (aimed observers, fixed lenses, any
//! mix) describes a point by a [`MapPath`] — its observers ready for the block kernel and
//! what it needs to report the point — and this module runs the draws.
//!
//! # Tasks, and the chain shared by the points
//! The selected points are taken in windows of [`WINDOW`] points (each point is prepared once
//! per window, so memory does not grow with the map beyond the results), the points a window
//! draws in groups of up to [`GROUP`] ([`CHAIN_GROUP`] in correlated mode), and the draws in
//! chunks of [`CHUNK`] replicates: a task
//! is (group, chunk). In correlated mode a task draws the chain once per block of 64
//! replicates and shares it between the points of its group (`block::run_group`): replicate
//! `j` of every point takes draw `j` of the chain stream (`schedule::CHAIN_TASK`) — one rig
//! error per crash test, common to all the points it measures. A point's own normals come
//! from its task `p·2²⁴ + k` (`schedule::task_index`, p its index in the whole grid). So a
//! point's draws depend on (seed, p, j) only — not on the group, the window, the shard, the
//! thread count or the instruction set — and each point's chunks are merged in chunk order.
//!
//! The adaptive rule runs each point on its own (batches until stable), with the same streams
//! (batch `b` is task `p·2²⁴ + b`, its replicates `b·batch ..`).

use crate::block::{GroupSink, LaneSink, PointKernel, run_group};
use crate::chain::Chain;
use crate::error::Error;
use crate::kernel::accumulate::Acc3;
use crate::model::Adaptive;
use crate::options::Draws;
use crate::result::PointStats;
use crate::schedule::{CHUNK, Engine, PointTicks, adaptive_draws, task_index};
use nalgebra::Vector3;
use rayon::prelude::*;

/// Points drawn together by one task without a chain.
pub(crate) const GROUP: usize = 16;

/// Points drawn together by one task in correlated mode, sharing each block's chain draw: the
/// chain's normals and composition (≈ 15 cycles per point-draw of the real-study map in groups
/// of 16) are spread over four times as many points. Without a chain a larger group only
/// enlarges each task's per-lane sums, and was measured slower (`docs/performance.md`,
/// issue 39).
pub(crate) const CHAIN_GROUP: usize = 64;

/// Points prepared at a time.
pub(crate) const WINDOW: usize = 1024;

/// One point as a grid path prepared it: its observers for the block kernel, and what the path
/// needs to report it (`extra`).
pub(crate) struct Planned<'a, T> {
    pub(crate) kernel: PointKernel<'a>,
    pub(crate) extra: T,
}

impl<T> Planned<'_, T> {
    /// Whether the point is drawn: at least two observers see it.
    fn drawn(&self) -> bool {
        self.kernel.observers.len() >= 2
    }
}

/// A grid path: how to prepare and to report one of its points (local index `p` of the run's
/// points).
pub(crate) trait MapPath<'a>: Sync {
    /// What the path keeps per point to report it.
    type Extra: Send + Sync;

    /// Point `p` prepared.
    fn plan(&self, p: usize) -> Result<Planned<'a, Self::Extra>, Error>;

    /// The statistics of point `p` from its draws (`None`: it was not drawn).
    fn finish(
        &self,
        p: usize,
        planned: &Planned<'a, Self::Extra>,
        draws: Option<&Acc3>,
    ) -> PointStats;

    /// The former engine's `m` draws of task `task` (tests: the statistical cross-check).
    #[cfg(test)]
    fn legacy(&self, extra: &Self::Extra, seed: u64, task: u64, m: usize, acc: &mut Acc3);
}

/// The settings of a run shared by its tasks.
pub(crate) struct MapRun<'r> {
    /// The chain, in correlated mode.
    pub(crate) chain: Option<&'r Chain>,
    pub(crate) seed: u64,
    pub(crate) engine: Engine,
    pub(crate) ticks: &'r PointTicks<'r>,
    /// Grid index of the first of the run's points (they are consecutive).
    pub(crate) first: usize,
}

/// `m` replicates from `replicate0` of the points `kernels` (each with its own task) into
/// `sink` (see `block::run_group`).
pub(crate) fn draw_into<S: GroupSink>(
    run: &MapRun<'_>,
    kernels: &[(&PointKernel<'_>, u64)],
    replicate0: u64,
    m: usize,
    sink: &mut S,
) {
    match run.engine {
        Engine::Simd(isa) => {
            let key = crate::kernel::philox::key_of_seed(run.seed);
            crate::kernel::simd::dispatch(
                isa,
                #[inline(always)]
                |width| run_group(kernels, run.chain, key, replicate0, m, sink, width),
            );
        }
        #[cfg(test)]
        Engine::Legacy => unreachable!("the legacy engine draws through MapPath::legacy"),
    }
}

/// [`draw_into`] the per-lane sums of each point about `shifts`: their sums, in order.
pub(crate) fn draw_points(
    run: &MapRun<'_>,
    kernels: &[(&PointKernel<'_>, u64)],
    shifts: &[Vector3<f64>],
    replicate0: u64,
    m: usize,
) -> Vec<Acc3> {
    let mut sink = LaneSink::new(shifts.iter().copied());
    draw_into(run, kernels, replicate0, m, &mut sink);
    sink.finish()
}

/// [`run_samples`] or [`run_adaptive`], as `draws` says.
pub(crate) fn run_draws<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    points: &[Vector3<f64>],
    draws: &Draws,
) -> Result<Vec<PointStats>, Error> {
    match draws {
        Draws::Samples(samples) => run_samples(path, run, points, *samples),
        Draws::Adaptive(adaptive) => run_adaptive(path, run, points, adaptive),
    }
}

/// The run's `points` with `samples` draws each (see the module docs).
pub(crate) fn run_samples<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    points: &[Vector3<f64>],
    samples: usize,
) -> Result<Vec<PointStats>, Error> {
    let chunks = samples.div_ceil(CHUNK);
    let mut out = Vec::with_capacity(points.len());
    for start in (0..points.len()).step_by(WINDOW) {
        let end = (start + WINDOW).min(points.len());
        let plans: Vec<Planned<'a, P::Extra>> = (start..end)
            .into_par_iter()
            .map(|p| path.plan(p))
            .collect::<Result<_, _>>()?;
        let drawn: Vec<usize> = (0..plans.len()).filter(|&i| plans[i].drawn()).collect();
        let group = if run.chain.is_some() {
            CHAIN_GROUP
        } else {
            GROUP
        };
        let groups: Vec<&[usize]> = drawn.chunks(group).collect();
        let mut sums: Vec<Acc3> = points[start..end].iter().map(|p| Acc3::new(*p)).collect();
        crate::kernel::ordered::map_fold_in_order(
            groups.len() * chunks,
            |t| {
                let (group, k) = (groups[t / chunks], t % chunks);
                if run.ticks.stop() {
                    return Vec::new();
                }
                let m = CHUNK.min(samples - k * CHUNK);
                let task = |i: usize| task_index(run.first + start + i, k);
                let parts = chunk_of_group(path, run, &plans, group, &task, k, m, &points[start..]);
                for &i in group {
                    run.ticks.chunk_done(start + i);
                }
                parts
            },
            |t, parts| {
                for (&i, part) in groups[t / chunks].iter().zip(&parts) {
                    sums[i].merge(part);
                }
            },
        );
        run.ticks.cancelled()?;
        out.par_extend(
            plans
                .par_iter()
                .zip(&sums)
                .enumerate()
                .map(|(i, (pl, s))| path.finish(start + i, pl, pl.drawn().then_some(s))),
        );
    }
    Ok(out)
}

/// Chunk `k` (`m` replicates) of the points `group` (indices into `plans`, whose points are
/// `points`; `task(i)` their streams).
#[allow(clippy::too_many_arguments)]
fn chunk_of_group<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    plans: &[Planned<'a, P::Extra>],
    group: &[usize],
    task: &dyn Fn(usize) -> u64,
    k: usize,
    m: usize,
    points: &[Vector3<f64>],
) -> Vec<Acc3> {
    #[cfg(test)]
    if run.engine == Engine::Legacy {
        return group
            .iter()
            .map(|&i| {
                let mut acc = Acc3::new(points[i]);
                path.legacy(&plans[i].extra, run.seed, task(i), m, &mut acc);
                acc
            })
            .collect();
    }
    #[cfg(not(test))]
    let _ = path;
    let kernels: Vec<_> = group.iter().map(|&i| (&plans[i].kernel, task(i))).collect();
    let shifts: Vec<_> = group.iter().map(|&i| points[i]).collect();
    draw_points(run, &kernels, &shifts, (k * CHUNK) as u64, m)
}

/// The run's `points` under the adaptive rule, each point on its own (see the module docs).
pub(crate) fn run_adaptive<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    points: &[Vector3<f64>],
    adaptive: &Adaptive,
) -> Result<Vec<PointStats>, Error> {
    let mut out = Vec::with_capacity(points.len());
    for start in (0..points.len()).step_by(WINDOW) {
        let end = (start + WINDOW).min(points.len());
        let stats: Vec<PointStats> = (start..end)
            .into_par_iter()
            .map(|p| {
                let planned = path.plan(p)?;
                if !planned.drawn() || run.ticks.stop() {
                    // Nothing to draw (or the run was cancelled, and this is discarded):
                    // `converged` is true so that only points that stopped at `max_samples`
                    // are unconverged.
                    return Ok(PointStats {
                        converged: Some(true),
                        ..path.finish(p, &planned, None)
                    });
                }
                let point = points[p];
                let (total, converged) = adaptive_draws(&point, adaptive, |b, m, acc| {
                    let part =
                        batch_of_point(path, run, &planned, run.first + p, b, adaptive, m, point);
                    acc.merge(&part);
                });
                run.ticks.point_done();
                Ok(PointStats {
                    converged: Some(converged),
                    ..path.finish(p, &planned, Some(&total))
                })
            })
            .collect::<Result<_, Error>>()?;
        run.ticks.cancelled()?;
        out.extend(stats);
    }
    Ok(out)
}

/// Batch `b` (`m` replicates) of the adaptive rule at grid point `index`.
#[allow(clippy::too_many_arguments)]
fn batch_of_point<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    planned: &Planned<'a, P::Extra>,
    index: usize,
    b: usize,
    adaptive: &Adaptive,
    m: usize,
    point: Vector3<f64>,
) -> Acc3 {
    let task = task_index(index, b);
    #[cfg(test)]
    if run.engine == Engine::Legacy {
        let mut acc = Acc3::new(point);
        path.legacy(&planned.extra, run.seed, task, m, &mut acc);
        return acc;
    }
    #[cfg(not(test))]
    let _ = path;
    let replicate0 = (b * adaptive.batch) as u64;
    draw_points(run, &[(&planned.kernel, task)], &[point], replicate0, m).remove(0)
}
