//! How a grid run is scheduled: the task (Philox stream) of each chunk of draws, the
//! adaptive stopping rule (GUM-S1 §7.9), progress counted in grid points, and which engine
//! draws.

use crate::kernel::Isa;
use crate::kernel::accumulate::Acc3;
use crate::model::Adaptive;
use crashrig_stats::Moments;
use crashrig_stats::progress::{Cancelled, Counter, Monitor};
use nalgebra::Vector3;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Draws per work chunk (and per RNG stream). Fixed, so results do not depend on the thread
/// count.
pub(crate) const CHUNK: usize = 4096;

/// Which engine draws: the vectorised engine at an instruction-set level, or (tests only) the
/// former ChaCha8 + ziggurat loops (`grid::legacy`, `Chain::draw_into`, `fixed::run_chunk_fixed`),
/// the statistical cross-check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Engine {
    /// Philox normals, blocks of 64 draws, compiled for the level.
    Simd(Isa),
    /// The former engine (different random numbers, the same distribution).
    #[cfg(test)]
    Legacy,
}

/// Progress of a grid run in grid points: a point counts when its last chunk of draws is done
/// (`chunk_done`, runs split into `chunks` tasks per point) or when it is finished whole
/// (`point_done`, adaptive runs); `finish` reports the total (points that drew nothing).
/// Without a monitor every call is a no-op and nothing is allocated.
///
/// Cancellation: every unit of work (a chunk, or an adaptive point) first asks [`Self::stop`],
/// which polls the monitor and remembers a cancellation, and is skipped when it says so; the
/// run then ends with [`Self::cancelled`] before using what it computed.
pub(crate) struct PointTicks<'a> {
    counter: Counter<'a>,
    /// Chunks still running per point (only with a monitor and more than one chunk).
    left: Vec<AtomicUsize>,
    /// A unit saw the monitor cancel the run.
    stopped: AtomicBool,
}

impl<'a> PointTicks<'a> {
    pub(crate) fn new(monitor: Option<&'a dyn Monitor>, points: usize, chunks: usize) -> Self {
        let counter = Counter::monitored(monitor, points);
        let left = if counter.is_reporting() && chunks > 1 {
            (0..points).map(|_| AtomicUsize::new(chunks)).collect()
        } else {
            Vec::new()
        };
        Self {
            counter,
            left,
            stopped: AtomicBool::new(false),
        }
    }

    /// Whether the next unit of work is to be skipped: the run was cancelled.
    #[inline]
    pub(crate) fn stop(&self) -> bool {
        if self.stopped.load(Ordering::Relaxed) {
            return true;
        }
        let stop = self.counter.check().is_err();
        if stop {
            self.stopped.store(true, Ordering::Relaxed);
        }
        stop
    }

    /// [`Cancelled`] when a unit was skipped ([`Self::stop`]): the run's sums are incomplete.
    pub(crate) fn cancelled(&self) -> Result<(), Cancelled> {
        if self.stopped.load(Ordering::Relaxed) {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }

    /// One chunk of point `p` is done.
    pub(crate) fn chunk_done(&self, p: usize) {
        if !self.counter.is_reporting() {
            return;
        }
        match self.left.get(p) {
            Some(left) => {
                if left.fetch_sub(1, Ordering::Relaxed) == 1 {
                    self.counter.add(1);
                }
            }
            None => self.counter.add(1),
        }
    }

    /// One point is done.
    pub(crate) fn point_done(&self) {
        self.counter.add(1);
    }

    /// The run is done.
    pub(crate) fn finish(&self) {
        self.counter.finish();
    }
}

/// Smallest number of batches before the adaptive rule may stop (JCGM 101 §7.9.4 needs h ≥ 2;
/// 4 keeps the standard deviation of the batch values from being met by chance).
pub const ADAPTIVE_MIN_BATCHES: usize = 4;

/// Adaptive draws at one point: batches of `adaptive.batch` draws (batch `b` drawn by
/// `draw(b, m, acc)`) until, after at least [`ADAPTIVE_MIN_BATCHES`] batches,
/// [`adaptive_stable`] holds, or until `max_samples`. Returns all the draws and whether the
/// tolerance was met.
pub(crate) fn adaptive_draws(
    point: &Vector3<f64>,
    adaptive: &Adaptive,
    mut draw: impl FnMut(usize, usize, &mut Acc3),
) -> (Acc3, bool) {
    let mut total = Acc3::new(*point);
    // Per batch: the mean coordinate (x, y, z) and the σ (x, y, z).
    let mut batches = Moments::<6>::new();
    let mut b = 0usize;
    loop {
        let m = adaptive
            .batch
            .min(adaptive.max_samples.saturating_sub(b * adaptive.batch));
        if m < 2 {
            return (total, false);
        }
        let mut acc = Acc3::new(*point);
        draw(b, m, &mut acc);
        total.merge(&acc);
        let (mean, s) = (acc.mean(), acc.std_dev());
        batches.push(&[mean.x, mean.y, mean.z, s.x, s.y, s.z]);
        b += 1;
        if b >= ADAPTIVE_MIN_BATCHES && adaptive_stable(&batches, &total.std_dev(), adaptive) {
            return (total, true);
        }
        if b * adaptive.batch >= adaptive.max_samples {
            return (total, false);
        }
    }
}

/// The stopping test of JCGM 101 §7.9.4 (k) per axis: with `h` batches and `s` the standard
/// deviation (n − 1) of a per-batch value, `2·s/√h ≤ δ` for the batch means (the estimate y)
/// and for the batch σ (its standard uncertainty u(y)) of x, y and z; δ of each axis from
/// `adaptive.tolerance` at `pooled_sigma` (σ of all the draws so far, §7.9.4 i–j). The
/// coverage-interval endpoints are not tested (the grid keeps no quantiles).
pub(crate) fn adaptive_stable(
    batches: &Moments<6>,
    pooled_sigma: &Vector3<f64>,
    adaptive: &Adaptive,
) -> bool {
    let h = batches.count() as f64;
    if h < 2.0 {
        return false;
    }
    let s = batches.std_dev();
    (0..3).all(|axis| {
        let delta = adaptive.tolerance.delta_mm(pooled_sigma[axis]);
        let mean_ok = 2.0 * s[axis] / h.sqrt() <= delta;
        let sigma_ok = 2.0 * s[axis + 3] / h.sqrt() <= delta;
        mean_ok && sigma_ok
    })
}

/// The task number of chunk (or adaptive batch) `chunk` of grid point `point`: `p·2²⁴ + k`,
/// the stream of its draws (aimed and fixed paths).
#[inline]
pub(crate) fn task_index(point: usize, chunk: usize) -> u64 {
    ((point as u64) << 24) | chunk as u64
}

/// The task of a map's shared chain draws (correlated mode): replicate `j` of every grid point
/// takes its chain normals from draw `j` of this stream — one rig error per crash test, common
/// to every point it measures. Above every grid task `p·2²⁴ + k` (p < 2⁴⁰).
pub(crate) const CHAIN_TASK: u64 = u64::MAX;
