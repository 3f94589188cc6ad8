//! The measurement: nominal forward intersection per (epoch, marker) and the Monte Carlo with
//! the physical correlation structure.
//!
//! # The model of one Monte Carlo replicate `r`
//! - the link `A_from_B` and the tie `B_from_C` are drawn **once per replicate** (they are
//!   fixed, systematic errors during a test): `δ_link ~ N(0, Σ_link)`, `δ_tie ~ N(0, Σ_tie)`;
//! - camera A's world pose is drawn **per epoch**: `δ_A(e) ~ N(0, Σ_A(e))`, independently
//!   between epochs; or, with a joint covariance ([`measure`], a `crashrig
//!   covariance` result's `"joint"`), all measured epochs of a replicate together,
//!   `(δ_A(e₁), …, δ_A(eₘ)) = L·ε` with `L·Lᵀ` the joint covariance of the measured epochs
//!   (shared control points and intrinsics correlate them; displacements depend on it);
//! - every observation gets its own pixel noise `N(0, σ_px²)` on each image axis.
//!
//! All perturbations act as the contract's tangent perturbation ([`UncertainPose::perturbed`]):
//! `C = C̄ + δ_xyz` in the parent's axes, `R = R̄·Exp(δθ)` about the child's own axes. Then
//! `world_from_B = world_from_A · A_from_B`, `world_from_C = world_from_B · B_from_C`, and the
//! marker is intersected by the same linear least squares (DLT) as
//! [`crashrig_geometry::triangulate::dlt`].
//!
//! Pixel noise reaches the normalized ray through the lens to first order: `δn = J⁻¹·δpx`,
//! `J = ∂px/∂n` of the camera model at the undistorted observation (exact Jacobian). The
//! neglected term is of relative size `σ_px/f` (≈ 10⁻⁴ for 0.3 px at f = 2000 px) and saves the
//! Newton undistortion in every draw.
//!
//! # Determinism and memory
//! Replicates are processed in blocks of [`BLOCK`]. Block `b`'s link and tie draws come from
//! `stream(seed, b)`; epoch `e`'s draws in block `b` (its pose, then its observations' pixel
//! noise, replicate by replicate) from `stream(seed, (e + 1)·2³² + b)`. Every task that needs
//! epoch `e`'s positions in block `b` (its own rows, the reference epoch, a velocity neighbour)
//! recomputes them from that stream, so they are identical wherever they are computed. With a
//! joint covariance, A's poses of block `b` come from `stream(seed, u64::MAX − 2⁴⁰ − b)`
//! instead (6m normals per replicate, then `L·ε`; the epoch streams then carry only the pixel
//! noise), and the factor `L` is computed once per measurement. Epochs
//! are split into runs of [`RUN`] epochs processed in parallel; each run owns its rows'
//! streaming accumulators and feeds them in replicate order, so the result is bit-identical
//! for any thread count. Memory is O(rows + threads·RUN·markers·BLOCK), independent of the
//! number of draws. With scale bars ([`crate::length`]), each chunk's positions also feed
//! every bar's distance moments, one task per bar in replicate order (memory O(bars·epochs)).

mod filtered;
mod moments;
mod positions;
mod prepare;
mod result;
mod settings;
mod streams;

pub(crate) use moments::{Acc, Accs, Draws};
pub use result::{
    Flags, MeasuredEpoch, Measurement, REPROJECTION_OUTLIER_ROBUST_SIGMAS, Row, ShareStats,
    SkippedEpoch, SyncShare, robust_reprojection_limit,
};
pub use settings::{MAX_DRAWS, MAX_SAMPLES, MAX_SYNC_SIGMA_MS, Settings};

use crate::Error;
use crate::filter::Cfc;
use crate::input::{JointA, Observation};
use crate::kinematics::{self, Run, RunAcc, Scratch};
use crate::length::{self, BarAcc, BarPrep, ScaleBars};
use crashrig_camera::Camera;
use crashrig_geometry::{UncertainPose, Vec3};
use crashrig_stats::progress::{Cancelled, Counter, Monitor, Part};
use crashrig_stats::{StreamRng, stream};
use filtered::{FeedRun, KinWork, assemble_kinematics};
use moments::{AllMoments, given_moments, shard_part};
use positions::{epoch_positions, finite};
use prepare::{
    ATrack, EpochPrep, LinkPrep, bar_preps, group_observations, measured_epochs, prep_epoch,
    velocity_pair,
};
use rayon::prelude::*;
use result::{assemble, sync_share};
use settings::{check_draws, check_settings};
use std::collections::{BTreeSet, HashMap};
use streams::{JointFactor, epoch_stream, joint_draws, joint_factor, link_draws};

/// Replicates per block (fixed: the streams depend on it, the thread count does not).
pub const BLOCK: usize = 256;

/// Epochs per parallel task.
pub const RUN: usize = 8;

/// The rig: the calibrated link, the optional tie, and the inward cameras' intrinsics.
#[derive(Debug, Clone)]
pub struct Rig {
    /// `A_from_B` (translation = B's centre in A's axes, mm) with the uncertainty of the
    /// calibrated mean link (mm, rad).
    pub a_from_b: UncertainPose,
    /// Camera B's intrinsics (COLMAP model and pixel convention).
    pub camera_b: Camera,
    /// The tied-in camera C: `B_from_C` with its uncertainty, and its intrinsics.
    pub c: Option<(UncertainPose, Camera)>,
}

/// One epoch of the sequence with camera A's uncertain world pose.
#[derive(Debug, Clone)]
pub struct Epoch {
    /// Epoch key (A's image name without the prefix).
    pub key: String,
    /// Epoch name (the key without its extension); the outputs use it.
    pub name: String,
    /// `world_from_A` (mm) with its tangent covariance (mm, rad; centre in world axes,
    /// rotation about A's own axes).
    pub world_from_a: UncertainPose,
}

/// Measures every observed (epoch, marker): nominal DLT position, reprojection check, and the
/// Monte Carlo σ of position, displacement from the reference epoch and (with a frame rate)
/// velocity. See the module doc for the model and the streams.
///
/// `epochs` must be in sequence order (as [`crate::sequence::a_sequence`] returns them).
/// Observations whose epoch (key or name) is not in `epochs` are skipped and reported in
/// [`Measurement::skipped`].
///
/// With `joint`, camera A's poses of one replicate are drawn **jointly** from it (the
/// epochs' joint covariance, e.g. a `crashrig covariance` result's `"joint"`): the marginal
/// of the measured epochs is factored once, `L·Lᵀ = Σ`, and every replicate draws
/// `(δ_A(e₁), …, δ_A(eₘ)) = L·ε`. Each epoch's own covariance (`Epoch::world_from_a`) is not
/// used for drawing then. `None`: each epoch's own covariance, epoch by epoch.
///
/// # Errors
/// [`Error::Setting`] for settings out of range or an unknown reference epoch;
/// [`Error::Input`] when no observation has a posed epoch, an observation names camera C
/// without a tie or a pixel cannot be undistorted; [`Error::Sequence`] when (with a frame
/// rate) an epoch name has no frame number or frame numbers do not increase along the
/// sequence. [`Error::in_files`] names the file each is about.
/// With `scale_bars` ([`crate::length`]), the distance of every bar's two markers is taken
/// in each replicate too, and [`Measurement::length_check`] holds the bars' errors, σ and
/// verdicts.
///
/// With `joint`: [`Error::Json`] naming the joint's file when a measured epoch is not in
/// it or its matrix is not positive semi-definite.
pub fn measure(
    epochs: &[Epoch],
    joint: Option<&JointA>,
    rig: &Rig,
    observations: &[Observation],
    scale_bars: Option<&ScaleBars>,
    settings: &Settings,
) -> Result<Measurement, Error> {
    let whole = Draws::Shard(crashrig_outdir::shard::Shard::whole());
    let input = Input {
        epochs,
        joint,
        rig,
        observations,
        scale_bars,
    };
    measure_parts(&input, settings, whole, None).map(|(m, _)| m)
}

/// What a measurement measures: the epochs with A's poses (and their joint covariance), the
/// rig, the observations and the scale bars ([`measure`]'s arguments).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Input<'a> {
    pub epochs: &'a [Epoch],
    pub joint: Option<&'a JointA>,
    pub rig: &'a Rig,
    pub observations: &'a [Observation],
    pub scale_bars: Option<&'a ScaleBars>,
}

/// [`measure`] with the moments drawn for one shard's markers or given
/// ([`Draws`]), and the accumulators per pass (the measurement, then — with a trigger offset
/// — the one without it; a shard's hold only its markers, and its measurement's other rows
/// are empty). The replicates drawn are reported, chunk by chunk, to `monitor` (two equal
/// parts with a sync σ: the run with and the run without it), which may stop the run between
/// chunks with [`Error::Cancelled`]; the result does not depend on it.
/// The scale bars are measured in the first pass only (a trigger offset moves B and C
/// rigidly together: a distance does not see it).
pub(crate) fn measure_parts(
    input: &Input<'_>,
    settings: &Settings,
    draws: Draws<'_>,
    monitor: Option<&dyn Monitor>,
) -> Result<(Measurement, Vec<Accs>), Error> {
    let parts = if settings.sync_sigma_ms > 0.0 { 2 } else { 1 };
    let part = |i| monitor.map(|m| Part::new(m, i, parts));
    let first = part(0);
    let ticks = Counter::monitored(first.as_ref().map(|p| p as _), settings.samples);
    let (mut m, accs) = measure_once(input, settings, draws, 0, &ticks)?;
    let mut all = vec![accs];
    if settings.sync_sigma_ms > 0.0 {
        let without = Settings {
            sync_sigma_ms: 0.0,
            ..settings.clone()
        };
        let second = part(1);
        let ticks = Counter::monitored(second.as_ref().map(|p| p as _), settings.samples);
        let no_bars = Input {
            scale_bars: None,
            ..*input
        };
        let (m0, accs0) = measure_once(&no_bars, &without, draws, 1, &ticks)?;
        m.sync_share = Some(sync_share(&m, &m0, settings.sync_sigma_ms));
        all.push(accs0);
    }
    Ok((m, all))
}

fn measure_once(
    input: &Input<'_>,
    settings: &Settings,
    draws: Draws<'_>,
    pass: usize,
    ticks: &Counter<'_>,
) -> Result<(Measurement, Accs), Error> {
    let Input {
        epochs,
        rig,
        observations,
        scale_bars,
        ..
    } = *input;
    check_settings(settings)?;
    check_draws(observations.len(), settings.samples)?;
    crate::input::check_in_image(observations, &rig.camera_b, rig.c.as_ref().map(|(_, c)| c))?;
    let groups = group_observations(epochs, rig, observations)?;
    let (measured, reference_epoch) = measured_epochs(epochs, &groups, settings)?;
    let marker_idx: HashMap<&str, usize> = groups
        .markers
        .iter()
        .enumerate()
        .map(|(i, m)| (m.as_str(), i))
        .collect();

    // Per-epoch preparation (nominal intersections).
    let mut preps: Vec<EpochPrep> = Vec::with_capacity(groups.by_epoch.len());
    for (k, (&e, by_marker)) in groups.by_epoch.iter().enumerate() {
        let mut prep = prep_epoch(&epochs[e], rig, by_marker, &marker_idx, settings)?;
        prep.time_s = measured[k].time_s;
        preps.push(prep);
    }

    let reprojection_limit_px = settings.max_reprojection_px.or_else(|| {
        let all: Vec<f64> = preps
            .iter()
            .flat_map(|p| p.slots.iter().filter_map(|s| s.reprojection_px))
            .collect();
        robust_reprojection_limit(&all)
    });
    let filter = match (settings.cfc, settings.frame_rate_hz) {
        (Some(spec), Some(hz)) => Some(Cfc::new(spec.class, spec.standard, hz)?),
        _ => None,
    };
    let kin_runs = filter.as_ref().map(|_| {
        let frames: Vec<u64> = measured.iter().map(|m| m.frame.unwrap_or(0)).collect();
        let has = |e: usize, mk: usize| {
            let d = |k: usize| preps[k].slot_of[mk].is_some_and(|s| preps[k].slots[s].drawable());
            d(e) && d(reference_epoch)
        };
        kinematics::runs(groups.markers.len(), &frames, has)
    });
    let bars = scale_bars.map_or_else(Vec::new, |b| bar_preps(&b.bars, &marker_idx, &preps));
    let mut work = Work {
        preps,
        reference: reference_epoch,
        filter: filter.as_ref(),
        kin_runs: kin_runs.as_deref(),
        bars: &bars,
        n_markers: groups.markers.len(),
        measured: groups.by_epoch.keys().copied().collect(),
    };
    let (moments, part) = draw_moments(&mut work, input, settings, draws, pass, ticks)?;
    let preps = work.preps;
    let rows = assemble(
        &preps,
        &moments.rows,
        settings,
        reference_epoch,
        reprojection_limit_px,
    );
    let kinematics = filter
        .as_ref()
        .zip(kin_runs.as_deref())
        .map(|(filter, runs)| {
            let k = KinWork { filter, runs };
            assemble_kinematics(&preps, &k, &moments.runs, reference_epoch, rows.len())
        });
    let m = Measurement {
        epochs: measured,
        markers: groups.markers,
        rows,
        reference_epoch,
        skipped: groups
            .skipped
            .into_iter()
            .map(|(epoch, observations)| SkippedEpoch {
                epoch: epoch.to_string(),
                observations,
            })
            .collect(),
        samples: settings.samples,
        reprojection_limit_px,
        kinematics,
        sync_share: None,
        length_check: scale_bars.map(|b| length::assemble(b, &bars, &moments.bars)),
    };
    Ok((m, part))
}

/// A measurement prepared for its Monte Carlo.
struct Work<'a> {
    /// The measured epochs' views and nominal intersections.
    preps: Vec<EpochPrep>,
    /// The reference epoch of the displacements.
    reference: usize,
    /// The kinematics' filter (with `cfc`).
    filter: Option<&'a Cfc>,
    /// Every marker's kinematic runs (with `cfc`).
    kin_runs: Option<&'a [Vec<Run>]>,
    /// The scale bars.
    bars: &'a [BarPrep],
    /// Markers of the measurement.
    n_markers: usize,
    /// The measured epochs (indices into the input's epochs).
    measured: Vec<usize>,
}

/// The moments of `work`, drawn here (for a shard's markers and bars) or taken from a shard
/// set ([`Draws`]), and the part a shard writes.
fn draw_moments(
    work: &mut Work<'_>,
    input: &Input<'_>,
    settings: &Settings,
    draws: Draws<'_>,
    pass: usize,
    ticks: &Counter<'_>,
) -> Result<(AllMoments, Accs), Error> {
    let shard = match draws {
        Draws::Given(given) => {
            let given = given.get(pass).ok_or_else(|| {
                Error::Input("the shards hold no moments of the run without the offset".into())
            })?;
            let kin = work.filter.zip(work.kin_runs);
            let kin = kin.map(|(filter, runs)| KinWork { filter, runs });
            return Ok((
                given_moments(&work.preps, kin.as_ref(), work.bars, given)?,
                Accs::default(),
            ));
        }
        Draws::Shard(shard) => shard,
    };
    let mine = shard.range(work.n_markers);
    let my_bars = shard.range(work.bars.len());
    // A shard draws its markers and the markers of its bars (a bar needs both positions).
    let bar_markers: BTreeSet<usize> = work.bars[my_bars.clone()]
        .iter()
        .flat_map(|b| b.markers.iter().flatten().copied())
        .collect();
    for slot in work.preps.iter_mut().flat_map(|p| p.slots.iter_mut()) {
        slot.drawn = mine.contains(&slot.marker) || bar_markers.contains(&slot.marker);
    }
    // Only this shard's markers' runs are filtered.
    let my_runs: Option<Vec<Vec<Run>>> = work.kin_runs.map(|runs| {
        let keep = |(m, r): (usize, &Vec<Run>)| {
            if mine.contains(&m) {
                r.clone()
            } else {
                Vec::new()
            }
        };
        runs.iter().enumerate().map(keep).collect()
    });
    let my_work = work
        .filter
        .zip(my_runs.as_deref())
        .map(|(filter, runs)| KinWork { filter, runs });
    let a_factor = input
        .joint
        .map(|j| joint_factor(j, input.epochs, &work.measured))
        .transpose()?;
    let track = match settings.frame_rate_hz {
        Some(hz) if settings.sync_sigma_ms > 0.0 => {
            ATrack::new(input.epochs, hz, settings.frame_times.as_ref())
        }
        _ => None,
    };
    let link = LinkPrep::new(input.rig);
    let moments = run_monte_carlo(
        &work.preps,
        &link,
        a_factor.as_ref(),
        settings,
        work.reference,
        track.as_ref(),
        my_work.as_ref(),
        (work.bars, my_bars.clone()),
        ticks,
    )?;
    let part = shard_part(&work.preps, work.kin_runs, &moments, &mine, my_bars);
    Ok((moments, part))
}

/// Replicates per chunk: a block's replicates are drawn chunk by chunk, every epoch's stream
/// continuing where the previous chunk stopped, so the scratch is O(epochs · slots · CHUNK).
const CHUNK: usize = 32;

/// The Monte Carlo: per-(epoch, slot) accumulators and, with kinematics, per-(marker, run)
/// accumulators of the filtered series.
///
/// Block by block, chunk by chunk: every epoch's positions of the chunk's replicates are drawn
/// once (in parallel over epochs), then the rows' moments are fed (in parallel over runs of
/// [`RUN`] epochs) and every marker's runs filtered and differentiated replicate by replicate
/// (in parallel over markers). Each accumulator is fed by one task in replicate order, so the
/// result does not depend on the thread count.
#[allow(clippy::too_many_arguments)]
fn run_monte_carlo(
    preps: &[EpochPrep],
    link: &LinkPrep,
    a_factor: Option<&JointFactor>,
    settings: &Settings,
    reference: usize,
    track: Option<&ATrack>,
    kin: Option<&KinWork<'_>>,
    (bars, my_bars): (&[BarPrep], std::ops::Range<usize>),
    ticks: &Counter<'_>,
) -> Result<AllMoments, Cancelled> {
    let n_epochs = preps.len();
    let with_velocity = settings.frame_rate_hz.is_some();
    let mut accs: Vec<Vec<Acc>> = preps
        .iter()
        .map(|p| vec![Acc::default(); p.slots.len()])
        .collect();
    let mut kin_accs: Vec<Vec<RunAcc>> = kin.map_or_else(Vec::new, |k| {
        k.runs
            .iter()
            .map(|rs| rs.iter().map(|r| RunAcc::new(r.len)).collect())
            .collect()
    });
    let mut bar_accs: Vec<BarAcc> = bars.iter().map(|b| BarAcc::new(b.epochs.len())).collect();
    let n_blocks = settings.samples.div_ceil(BLOCK);
    let seed = settings.seed;
    let sync_s = settings.sync_sigma_ms / 1000.0;
    let mut bufs: Vec<Vec<Vec3>> = vec![Vec::new(); n_epochs];
    for b in 0..n_blocks {
        let len = BLOCK.min(settings.samples - b * BLOCK);
        let links = link_draws(link, seed, b, len, sync_s);
        let a_joint = a_factor.map(|l| joint_draws(l, seed, b, len));
        let mut rngs: Vec<StreamRng> = (0..n_epochs)
            .map(|e| stream(seed, epoch_stream(e, b)))
            .collect();
        for c0 in (0..len).step_by(CHUNK) {
            ticks.check()?;
            let chunk = &links[c0..(c0 + CHUNK).min(len)];
            let m = chunk.len();
            bufs.par_iter_mut()
                .zip(rngs.par_iter_mut())
                .enumerate()
                .for_each(|(e, (buf, rng))| {
                    let a = a_joint.as_ref().map(|d| &d[e][c0..c0 + m]);
                    epoch_positions(&preps[e], rng, chunk, a, track, buf)
                });
            let bufs = &bufs;
            let pos = |e: usize, marker: usize, r: usize| -> Option<Vec3> {
                let s = preps[e].slot_of[marker]?;
                let x = bufs[e][s * m + r];
                finite(&x).then_some(x)
            };
            accs.par_chunks_mut(RUN)
                .enumerate()
                .for_each(|(k, run_accs)| {
                    for (i, accs_e) in run_accs.iter_mut().enumerate() {
                        let e = k * RUN + i;
                        feed_rows(preps, e, accs_e, reference, with_velocity, m, &pos);
                    }
                });
            if let Some(kin) = kin {
                kin_accs
                    .par_iter_mut()
                    .zip(kin.runs.par_iter())
                    .for_each_init(Scratch::default, |scratch, (racc, runs)| {
                        for (run, acc) in runs.iter().zip(racc) {
                            crate::simd::vectorized(FeedRun {
                                filter: kin.filter,
                                run,
                                acc,
                                preps,
                                bufs,
                                reference,
                                m,
                                scratch,
                            });
                        }
                    });
            }
            // Each bar's moments are fed by one task, replicate by replicate.
            bar_accs[my_bars.clone()]
                .par_iter_mut()
                .zip(bars[my_bars.clone()].par_iter())
                .for_each_init(Vec::new, |d, (acc, bar)| acc.feed(bar, bufs, m, d));
            ticks.add(m);
        }
    }
    Ok(AllMoments {
        rows: accs,
        runs: kin_accs,
        bars: bar_accs,
    })
}

/// Feeds the position, displacement and velocity moments of epoch `e`'s rows with the `m`
/// replicates of a chunk.
fn feed_rows(
    preps: &[EpochPrep],
    e: usize,
    accs: &mut [Acc],
    reference: usize,
    with_velocity: bool,
    m: usize,
    pos: &(impl Fn(usize, usize, usize) -> Option<Vec3> + Sync),
) {
    for (s, slot) in preps[e].slots.iter().enumerate() {
        if !slot.drawable() {
            continue;
        }
        let acc = &mut accs[s];
        let mk = slot.marker;
        let vpair = if with_velocity {
            velocity_pair(e, mk, preps)
        } else {
            None
        };
        for r in 0..m {
            let Some(x) = pos(e, mk, r) else { continue };
            acc.pos.push_vec(&x);
            if let Some(xr) = pos(reference, mk, r) {
                acc.disp.push_vec(&(x - xr));
            }
            if let Some((p, n)) = vpair
                && let (Some(xp), Some(xn)) = (pos(p, mk, r), pos(n, mk, r))
            {
                let dt = preps[n].time_s.unwrap_or(0.0) - preps[p].time_s.unwrap_or(0.0);
                acc.vel.push_vec(&((xn - xp) / dt));
            }
        }
    }
}
