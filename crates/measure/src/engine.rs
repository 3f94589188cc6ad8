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

use crate::Error;
use crate::filter::{Cfc, CfcSpec};
use crate::input::{Inward, JointA, Observation};
use crate::kinematics::{
    self, Differences, KinRow, Kinematics, LANES, Lanes, Run, RunAcc, Scratch,
};
use crate::length::{self, BarAcc, BarEpochPrep, BarPrep, LengthCheck, ScaleBars};
use crate::sequence::frame_number;
use crashrig_camera::Camera;
use crashrig_geometry::triangulate::{self, View};
use crashrig_geometry::{Mat3, Mat6, UncertainPose, Vec3, Vec6, so3};
use crashrig_stats::progress::{Cancelled, Counter, Monitor, Part};
use crashrig_stats::summary::median;
use crashrig_stats::{Moments, StreamRng, stream};
use nalgebra::{DMatrix, Matrix2, Vector2, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};

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

/// Settings of a measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Monte Carlo replicates per row (≥ 2).
    pub samples: usize,
    /// Master seed.
    pub seed: u64,
    /// σ of each pixel coordinate (px, ≥ 0).
    pub pixel_sigma_px: f64,
    /// Reference epoch of the displacements (key or name); `None`: the first measured epoch.
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz) for velocities; `None`: no velocities. With
    /// [`Settings::frame_times`], the rate of their mean interval (the CFC filter's).
    pub frame_rate_hz: Option<f64>,
    /// Each frame's time from the camera's clock (`--frame-times`): the epochs' times and
    /// frame numbers (the index in the file) instead of `frame / frame_rate_hz`; needs
    /// [`Settings::frame_rate_hz`] (the rate of the mean interval).
    pub frame_times: Option<crate::input::FrameTimes>,
    /// Rows with σ_max above this (mm) are flagged.
    pub threshold_mm: f64,
    /// Rows whose largest reprojection residual exceeds this (px) are flagged; `None`: the
    /// robust limit of the sequence, [`robust_reprojection_limit`].
    pub max_reprojection_px: Option<f64>,
    /// CFC filter of the kinematics ([`crate::kinematics`]; needs a frame rate); `None`: no
    /// kinematics.
    pub cfc: Option<CfcSpec>,
    /// σ of camera A's trigger offset against the inward cameras (ms, ≥ 0; needs a frame
    /// rate): drawn once per replicate, A's pose interpolated to the shifted time. 0: none.
    pub sync_sigma_ms: f64,
}

/// The largest `--sync-sigma-ms` accepted (ms): an offset of a second is not a trigger offset.
pub const MAX_SYNC_SIGMA_MS: f64 = 1000.0;

/// Modified-z limit of the reprojection check: a residual is an outlier when it exceeds the
/// median of the sequence's residuals by more than this many robust σ (1.4826·MAD).
pub const REPROJECTION_OUTLIER_ROBUST_SIGMAS: f64 = 5.0;

/// The default reprojection limit: `median + 5 · 1.4826 · MAD` of the residuals of all rows
/// with a position. Residuals come from pixel noise *and* from the link, tie and A errors
/// (which make the rays miss each other), so a limit in units of the pixel σ alone would flag
/// good rows; the robust limit flags rows that disagree with the rest of the sequence (a
/// mislabelled or mis-detected marker). `None` for fewer than 3 residuals.
pub fn robust_reprojection_limit(residuals: &[f64]) -> Option<f64> {
    let v: Vec<f64> = residuals
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .collect();
    if v.len() < 3 {
        return None;
    }
    let med = median(&v)?;
    let dev: Vec<f64> = v.iter().map(|r| (r - med).abs()).collect();
    let mad = median(&dev)?;
    Some(med + REPROJECTION_OUTLIER_ROBUST_SIGMAS * 1.4826 * mad)
}

/// Why a row is flagged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Flags {
    /// Fewer than two cameras saw the marker in this epoch (no position).
    pub fewer_than_two_views: bool,
    /// The rays are (nearly) parallel: the intersection failed (no position).
    pub degenerate: bool,
    /// σ_max exceeds the threshold.
    pub sigma_above_threshold: bool,
    /// The largest reprojection residual exceeds the limit.
    pub reprojection_outlier: bool,
}

impl Flags {
    /// The flag names that are set, in a fixed order.
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.fewer_than_two_views {
            v.push("fewer_than_two_views");
        }
        if self.degenerate {
            v.push("degenerate");
        }
        if self.sigma_above_threshold {
            v.push("sigma_above_threshold");
        }
        if self.reprojection_outlier {
            v.push("reprojection_outlier");
        }
        v
    }

    /// True when any flag is set.
    pub fn any(&self) -> bool {
        !self.names().is_empty()
    }
}

/// One (epoch, marker) row of the result. Positions are in the model's world frame (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Index into [`Measurement::epochs`].
    pub epoch: usize,
    /// Index into [`Measurement::markers`].
    pub marker: usize,
    /// Number of cameras that saw the marker in this epoch.
    pub n_views: usize,
    /// Nominal intersection (mm).
    pub position_mm: Option<Vec3>,
    /// Monte Carlo σ of the position (mm, n − 1).
    pub sigma_mm: Option<Vec3>,
    /// Monte Carlo covariance of the position (mm²).
    pub covariance_mm2: Option<Mat3>,
    /// Nominal displacement from the reference epoch (mm).
    pub displacement_mm: Option<Vec3>,
    /// Its Monte Carlo σ (mm).
    pub displacement_sigma_mm: Option<Vec3>,
    /// Nominal velocity by finite differences (mm/s).
    pub velocity_mm_s: Option<Vec3>,
    /// Its Monte Carlo σ (mm/s).
    pub velocity_sigma_mm_s: Option<Vec3>,
    /// Largest reprojection residual of the nominal intersection over its views (px).
    pub reprojection_px: Option<f64>,
    /// Monte Carlo draws that produced a position (= samples unless a draw was degenerate).
    pub draws: u64,
    /// Flags.
    pub flags: Flags,
}

impl Row {
    /// max(σx, σy, σz) (mm).
    pub fn sigma_max_mm(&self) -> Option<f64> {
        self.sigma_mm.map(|s| s.max())
    }
}

/// A measured epoch.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredEpoch {
    /// Epoch key.
    pub key: String,
    /// Epoch name.
    pub name: String,
    /// Frame number (last digits of the name), if any.
    pub frame: Option<u64>,
    /// `frame / frame_rate` (s), with a frame rate.
    pub time_s: Option<f64>,
}

/// Observations of an epoch that the model does not pose (skipped).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedEpoch {
    /// The epoch as the observations spell it.
    pub epoch: String,
    /// How many observations were skipped.
    pub observations: usize,
}

/// The result of [`measure`].
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Measured epochs in sequence order (those with observations and a pose of A).
    pub epochs: Vec<MeasuredEpoch>,
    /// Marker names, sorted.
    pub markers: Vec<String>,
    /// One row per observed (epoch, marker), epoch-major, markers in order.
    pub rows: Vec<Row>,
    /// Index of the reference epoch of the displacements.
    pub reference_epoch: usize,
    /// Epochs of the observations without a pose of camera A.
    pub skipped: Vec<SkippedEpoch>,
    /// Monte Carlo replicates per row.
    pub samples: usize,
    /// The reprojection limit used for the flags (px; given or robust), `None` when no row
    /// has a position or the robust limit had too few residuals.
    pub reprojection_limit_px: Option<f64>,
    /// The filtered kinematics (with [`Settings::cfc`]).
    pub kinematics: Option<Kinematics>,
    /// How much of the variance the trigger offset contributes (with
    /// [`Settings::sync_sigma_ms`] > 0).
    pub sync_share: Option<SyncShare>,
    /// The length check of the scale bars ([`crate::length`]; with scale bars).
    pub length_check: Option<LengthCheck>,
}

/// The share of the variance that camera A's trigger offset contributes: the measurement is
/// repeated without the offset on the same random numbers (the offsets have their own
/// streams), and each row's share is `1 − Σσ₀² / Σσ²` (traces over the three axes; clamped at
/// 0 where Monte Carlo noise makes it negative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncShare {
    /// The offset's σ (ms).
    pub sigma_ms: f64,
    /// Position σ.
    pub position: Option<ShareStats>,
    /// Raw displacement σ.
    pub displacement: Option<ShareStats>,
    /// Raw velocity σ.
    pub velocity: Option<ShareStats>,
    /// Filtered displacement σ (with kinematics).
    pub filtered_displacement: Option<ShareStats>,
    /// Filtered velocity σ (with kinematics).
    pub filtered_velocity: Option<ShareStats>,
    /// Acceleration σ (with kinematics).
    pub acceleration: Option<ShareStats>,
}

/// Median and largest share over the rows (fractions 0…1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShareStats {
    /// Median share.
    pub median: f64,
    /// Largest share.
    pub max: f64,
    /// Rows with the quantity.
    pub rows: usize,
}

impl ShareStats {
    /// The statistics of the per-row shares of `pairs` (σ with, σ without the offset).
    fn of(pairs: impl Iterator<Item = (Option<Vec3>, Option<Vec3>)>) -> Option<ShareStats> {
        let v: Vec<f64> = pairs
            .filter_map(|(with, without)| {
                let (w, o) = (with?.norm_squared(), without?.norm_squared());
                (w > 0.0).then(|| (1.0 - o / w).max(0.0))
            })
            .collect();
        let max = v.iter().copied().fold(0.0, f64::max);
        Some(ShareStats {
            // The shares are finite (≥ 0 and ≤ 1), so `None` only for no share at all.
            median: median(&v)?,
            max,
            rows: v.len(),
        })
    }
}

impl Measurement {
    /// Fraction of rows with σ_max below `threshold_mm` (rows without σ count as not below).
    pub fn fraction_below(&self, threshold_mm: f64) -> f64 {
        let n = self.rows.len().max(1) as f64;
        self.rows
            .iter()
            .filter(|r| r.sigma_max_mm().is_some_and(|s| s < threshold_mm))
            .count() as f64
            / n
    }
}

/// One view of a marker prepared for the draws.
#[derive(Debug, Clone, Copy)]
struct ViewPrep {
    cam: usize,
    n0: Vector2<f64>,
    /// `σ_px · J⁻¹`: normalized perturbation per unit normal.
    m: Matrix2<f64>,
}

#[derive(Debug, Clone)]
struct Slot {
    marker: usize,
    n_views: usize,
    views: Vec<ViewPrep>,
    nominal: Option<Vec3>,
    reprojection_px: Option<f64>,
    degenerate: bool,
    /// Intersected in the draws (false: a marker of another shard, whose pixel noise is drawn
    /// and dropped so that the epoch's stream stays aligned).
    drawn: bool,
}

impl Slot {
    fn drawable(&self) -> bool {
        self.nominal.is_some()
    }
}

#[derive(Debug, Clone)]
struct EpochPrep {
    r_wa: Mat3,
    c_a: Vec3,
    l_a: Mat6,
    slots: Vec<Slot>,
    /// marker index → slot index.
    slot_of: Vec<Option<usize>>,
    time_s: Option<f64>,
}

#[derive(Debug, Clone, Copy)]
struct LinkDraw {
    r_ab: Mat3,
    c_ab: Vec3,
    r_bc: Mat3,
    c_bc: Vec3,
    /// A's trigger offset in this replicate (s; 0 without `sync_sigma_ms`).
    sync_s: f64,
}

/// Camera A's nominal poses along the sequence, for the poses between frames (trigger offset):
/// the centre is interpolated linearly, the rotation by slerp `R_k·Exp(s·Log(R_kᵀR_{k+1}))`;
/// before the first and after the last pose the end interval is extended.
#[derive(Debug, Clone)]
struct ATrack {
    times: Vec<f64>,
    r: Vec<Mat3>,
    c: Vec<Vec3>,
    /// `Log(R_kᵀ·R_{k+1})`.
    w: Vec<Vec3>,
}

impl ATrack {
    /// The track of the epochs with a frame number (times `frame / hz`, increasing).
    fn new(epochs: &[Epoch], hz: f64) -> Option<ATrack> {
        let mut t = ATrack {
            times: Vec::new(),
            r: Vec::new(),
            c: Vec::new(),
            w: Vec::new(),
        };
        for e in epochs {
            let Some(f) = frame_number(&e.name) else {
                continue;
            };
            let time = f as f64 / hz;
            if t.times.last().is_some_and(|&last| last >= time) {
                continue;
            }
            t.times.push(time);
            t.r.push(e.world_from_a.rotation().into_inner());
            t.c.push(e.world_from_a.center());
        }
        if t.times.len() < 2 {
            return None;
        }
        t.w =
            t.r.windows(2)
                .map(|p| {
                    so3::log(&crashrig_geometry::Rot3::from_matrix_unchecked(
                        p[0].transpose() * p[1],
                    ))
                })
                .collect();
        Some(t)
    }

    /// `world_from_A` (rotation, centre) at time `t` (s).
    fn at(&self, t: f64) -> (Mat3, Vec3) {
        let n = self.times.len();
        let k = self
            .times
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(n - 2);
        let s = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
        let r = self.r[k] * so3::exp(&(self.w[k] * s)).into_inner();
        (r, self.c[k] + (self.c[k + 1] - self.c[k]) * s)
    }
}

#[derive(Debug, Clone, Copy)]
struct LinkPrep {
    r_ab: Mat3,
    c_ab: Vec3,
    l_ab: Mat6,
    c: Option<(Mat3, Vec3, Mat6)>,
}

impl LinkPrep {
    /// The link's and the tie's nominal rotation, centre and covariance factor.
    fn new(rig: &Rig) -> LinkPrep {
        LinkPrep {
            r_ab: rig.a_from_b.rotation().into_inner(),
            c_ab: rig.a_from_b.center(),
            l_ab: rig.a_from_b.factor(),
            c: rig
                .c
                .as_ref()
                .map(|(p, _)| (p.rotation().into_inner(), p.center(), p.factor())),
        }
    }
}

/// A row's streaming moments of position, displacement and velocity.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Acc {
    pub pos: Moments<3>,
    pub disp: Moments<3>,
    pub vel: Moments<3>,
}

/// The Monte Carlo's accumulators of some markers ([`crate::shard`]): the rows' moments by
/// (measured epoch, marker) and the kinematic runs' moments by (marker, first epoch).
#[derive(Debug, Clone, Default)]
pub(crate) struct Accs {
    pub rows: BTreeMap<(usize, usize), Acc>,
    pub runs: BTreeMap<(usize, usize), RunAcc>,
    /// The scale bars' moments by bar index ([`crate::length`]).
    pub bars: BTreeMap<usize, BarAcc>,
}

/// Where the Monte Carlo's moments come from.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Draws<'a> {
    /// Drawn here, for the markers of this shard (`Shard::whole()`: every marker).
    Shard(crashrig_outdir::shard::Shard),
    /// Given, per pass (the measurement, then the one without the trigger offset): the union
    /// of a shard set's accumulators.
    Given(&'a [Accs]),
}

fn normals6(rng: &mut StreamRng) -> Vec6 {
    Vec6::from_fn(|_, _| rng.sample(StandardNormal))
}

/// Draws `R̄·Exp(δθ)`, `C̄ + δC` with `δ = L·ε`.
fn perturb(r: &Mat3, c: &Vec3, l: &Mat6, rng: &mut StreamRng) -> (Mat3, Vec3) {
    apply(r, c, &(l * normals6(rng)))
}

/// `R̄·Exp(δθ)`, `C̄ + δC`.
fn apply(r: &Mat3, c: &Vec3, d: &Vec6) -> (Mat3, Vec3) {
    let dr = so3::exp(&Vector3::new(d[3], d[4], d[5])).into_inner();
    (r * dr, c + Vector3::new(d[0], d[1], d[2]))
}

/// Stream index of A's joint draws in block `b` (apart from the link, epoch and sync streams).
fn joint_stream(b: usize) -> u64 {
    u64::MAX - (1 << 40) - b as u64
}

/// A factor `L` of A's joint covariance (`L·Lᵀ = Σ`), [`joint_factor`]'s result.
#[derive(Debug, Clone)]
struct JointFactor {
    l: DMatrix<f64>,
    /// `L` is lower triangular (a Cholesky factor; else `V·√Λ`, a full matrix).
    lower: bool,
}

/// Rows of `L` multiplied per call in [`joint_draws`] (8 epochs): the product of a row block
/// stops at the block's last column, so the triangle's zeros are not multiplied.
const JOINT_ROWS: usize = 48;

/// A's joint draws of the `len` replicates of block `block`: `out[e][r]` = `δ_A` of measured
/// epoch `e` in replicate `r` (`L·ε`, one 6m-vector `ε` per replicate, in replicate order).
///
/// A lower-triangular `L` is multiplied by row blocks of [`JOINT_ROWS`], each only over the
/// columns up to its last row: about half the work of the full product, with its bits — every
/// element is the same general matrix product (the same kernel, the same blocks of the inner
/// dimension from column 0) with the exact zeros above the diagonal left out, and a zero term
/// adds nothing (`joint_draws_triangle_is_the_full_product_bit_for_bit`).
fn joint_draws(factor: &JointFactor, seed: u64, block: usize, len: usize) -> Vec<Vec<Vec6>> {
    let mut rng = stream(seed, joint_stream(block));
    let l = &factor.l;
    let n = l.nrows();
    let mut eps = DMatrix::<f64>::zeros(n, len);
    for r in 0..len {
        for k in 0..n {
            eps[(k, r)] = rng.sample(StandardNormal);
        }
    }
    let d = if factor.lower {
        let mut d = DMatrix::<f64>::zeros(n, len);
        for r0 in (0..n).step_by(JOINT_ROWS) {
            let r1 = (r0 + JOINT_ROWS).min(n);
            d.rows_mut(r0, r1 - r0)
                .copy_from(&(l.view((r0, 0), (r1 - r0, r1)) * eps.rows(0, r1)));
        }
        d
    } else {
        l * eps
    };
    (0..n / 6)
        .map(|e| {
            (0..len)
                .map(|r| Vec6::from_fn(|i, _| d[(6 * e + i, r)]))
                .collect()
        })
        .collect()
}

/// The factor `L` (`L·Lᵀ = Σ`) of the joint covariance of the measured epochs `measured`
/// (indices into `epochs`): the sub-matrix of their blocks (the marginal of the Gaussian),
/// Cholesky when it is positive definite, else `V·√Λ` of its eigen-decomposition (a
/// semi-definite matrix, e.g. epochs whose errors are fully correlated).
///
/// # Errors
/// [`Error::Json`] naming `joint.epochs` when a measured epoch is not in the joint matrix,
/// `joint.covariance_tangent` when the matrix is not positive semi-definite.
fn joint_factor(
    joint: &JointA,
    epochs: &[Epoch],
    measured: &[usize],
) -> Result<JointFactor, Error> {
    let index: HashMap<&str, usize> = joint
        .epochs
        .iter()
        .enumerate()
        .map(|(k, n)| (n.as_str(), k))
        .collect();
    let mut blocks = Vec::with_capacity(measured.len());
    for &e in measured {
        let ep = &epochs[e];
        let k = index
            .get(ep.name.as_str())
            .or_else(|| index.get(ep.key.as_str()))
            .ok_or_else(|| Error::Json {
                path: joint.path.clone(),
                key: "joint.epochs".into(),
                problem: format!(
                    "the measured epoch `{}` is not in the joint covariance",
                    ep.name
                ),
            })?;
        blocks.push(*k);
    }
    let n = 6 * blocks.len();
    let sub = DMatrix::from_fn(n, n, |i, j| {
        joint.covariance[(6 * blocks[i / 6] + i % 6, 6 * blocks[j / 6] + j % 6)]
    });
    if let Some(c) = sub.clone().cholesky() {
        return Ok(JointFactor {
            l: c.unpack(),
            lower: true,
        });
    }
    let eig = sub.symmetric_eigen();
    let tol = crashrig_geometry::uncertain::COVARIANCE_RELATIVE_TOLERANCE * joint.covariance.amax();
    let min = eig.eigenvalues.min();
    if min < -tol {
        return Err(Error::Json {
            path: joint.path.clone(),
            key: "joint.covariance_tangent".into(),
            problem: format!(
                "not positive semi-definite (smallest eigenvalue {min:e}, library units mm and rad)"
            ),
        });
    }
    // Eigenvalues within rounding of zero (the usual numerical-rank tolerance n·ε·λmax) are
    // zero: a fully correlated set of epochs then shares its draw exactly.
    let floor = n as f64 * f64::EPSILON * eig.eigenvalues.max();
    let root = eig
        .eigenvalues
        .map(|l| if l > floor { l.sqrt() } else { 0.0 });
    Ok(JointFactor {
        l: &eig.eigenvectors * DMatrix::from_diagonal(&root),
        lower: false,
    })
}

/// Stream index of epoch `e` in block `b`.
fn epoch_stream(e: usize, b: usize) -> u64 {
    ((e as u64 + 1) << 32) | b as u64
}

/// Stream index of the trigger offsets of block `b` (far above every epoch stream, so the
/// other draws are the same with and without an offset).
fn sync_stream(b: usize) -> u64 {
    u64::MAX - b as u64
}

fn link_draws(
    link: &LinkPrep,
    seed: u64,
    block: usize,
    len: usize,
    sync_sigma_s: f64,
) -> Vec<LinkDraw> {
    let mut rng = stream(seed, block as u64);
    let mut sync_rng = (sync_sigma_s > 0.0).then(|| stream(seed, sync_stream(block)));
    (0..len)
        .map(|_| {
            let (r_ab, c_ab) = perturb(&link.r_ab, &link.c_ab, &link.l_ab, &mut rng);
            let (r_bc, c_bc) = match &link.c {
                Some((r, c, l)) => perturb(r, c, l, &mut rng),
                None => (Mat3::identity(), Vec3::zeros()),
            };
            let sync_s = sync_rng.as_mut().map_or(0.0, |r| {
                let z: f64 = r.sample(StandardNormal);
                sync_sigma_s * z
            });
            LinkDraw {
                r_ab,
                c_ab,
                r_bc,
                c_bc,
                sync_s,
            }
        })
        .collect()
}

/// Linear least-squares intersection of rays given as (world_from_cam rotation, centre,
/// normalized observation): the DLT rows `(u·c₃ − c₁)·X = (u·c₃ − c₁)·C` with `cᵢ` the columns
/// of `R_world_from_cam` (the rows of `R_cam_from_world`), as [`triangulate::dlt`].
#[inline]
fn intersect<'a>(views: impl Iterator<Item = (&'a Mat3, &'a Vec3, Vector2<f64>)>) -> Option<Vec3> {
    let mut n = Mat3::zeros();
    let mut rhs = Vec3::zeros();
    for (r, c, uv) in views {
        let c1 = r.column(0);
        let c2 = r.column(1);
        let c3 = r.column(2);
        let a1: Vec3 = c3 * uv.x - c1;
        let a2: Vec3 = c3 * uv.y - c2;
        n += a1 * a1.transpose() + a2 * a2.transpose();
        rhs += a1 * a1.dot(c) + a2 * a2.dot(c);
    }
    n.try_inverse().map(|inv| inv * rhs)
}

/// Positions of an epoch's slots for the replicates `links` (the next ones of its stream
/// `rng`): `out[slot·len + r]` (NaN where the slot has no position or a draw is degenerate).
/// `a_joint`: A's joint draws of these replicates (else A is drawn from `rng`).
fn epoch_positions(
    ep: &EpochPrep,
    rng: &mut StreamRng,
    links: &[LinkDraw],
    a_joint: Option<&[Vec6]>,
    track: Option<&ATrack>,
    out: &mut Vec<Vec3>,
) {
    let len = links.len();
    out.clear();
    out.resize(ep.slots.len() * len, Vec3::repeat(f64::NAN));
    for (r, link) in links.iter().enumerate() {
        let (r0, c0) = match (track, ep.time_s) {
            (Some(track), Some(t)) if link.sync_s != 0.0 => track.at(t + link.sync_s),
            _ => (ep.r_wa, ep.c_a),
        };
        let (r_wa, c_a) = match a_joint {
            Some(d) => apply(&r0, &c0, &d[r]),
            None => perturb(&r0, &c0, &ep.l_a, rng),
        };
        let r_wb = r_wa * link.r_ab;
        let c_b = c_a + r_wa * link.c_ab;
        let r_wc = r_wb * link.r_bc;
        let c_c = c_b + r_wb * link.c_bc;
        let cams = [(r_wb, c_b), (r_wc, c_c)];
        for (s, slot) in ep.slots.iter().enumerate() {
            if !slot.drawable() {
                continue;
            }
            let mut noisy = [Vector2::zeros(); 2];
            for (k, v) in slot.views.iter().enumerate() {
                let eps = Vector2::new(rng.sample(StandardNormal), rng.sample(StandardNormal));
                noisy[k] = v.n0 + v.m * eps;
            }
            if !slot.drawn {
                continue;
            }
            let x = intersect(
                slot.views
                    .iter()
                    .zip(noisy)
                    .map(|(v, uv)| (&cams[v.cam].0, &cams[v.cam].1, uv)),
            );
            if let Some(x) = x.filter(|x| x.iter().all(|v| v.is_finite())) {
                out[s * len + r] = x;
            }
        }
    }
}

#[inline(always)]
fn finite(x: &Vec3) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// How epoch `e` differentiates in time: `(previous epoch, next epoch)` whose difference gives
/// the velocity of a marker (central where both neighbours measured it, one-sided otherwise).
fn velocity_pair(e: usize, marker: usize, preps: &[EpochPrep]) -> Option<(usize, usize)> {
    let has = |k: usize| preps[k].slot_of[marker].is_some_and(|s| preps[k].slots[s].drawable());
    let prev = (e > 0 && has(e - 1)).then(|| e - 1);
    let next = (e + 1 < preps.len() && has(e + 1)).then_some(e + 1);
    match (prev, next) {
        (Some(p), Some(n)) => Some((p, n)),
        (Some(p), None) if has(e) => Some((p, e)),
        (None, Some(n)) if has(e) => Some((e, n)),
        _ => None,
    }
}

/// Largest number of Monte Carlo replicates per row (`--samples`, `[measure] samples`).
pub const MAX_SAMPLES: usize = 10_000_000;

/// Largest number of row draws of one measure run: observation rows × replicates (the same
/// bound as a grid's points × samples), checked before the replicates start.
pub const MAX_DRAWS: u64 = 10_000_000_000;

/// Refuses a run whose `rows × samples` exceeds [`MAX_DRAWS`] (it would run for hours).
fn check_draws(rows: usize, samples: usize) -> Result<(), Error> {
    let draws = rows as u64 * samples as u64;
    if draws > MAX_DRAWS {
        return Err(Error::Setting {
            name: "--samples",
            problem: format!(
                "{samples} replicates × {rows} observation rows = {draws} draws exceeds the limit of {MAX_DRAWS}; use fewer --samples"
            ),
        });
    }
    Ok(())
}

fn check_settings(s: &Settings) -> Result<(), Error> {
    let bad = |name, problem: String| Err(Error::Setting { name, problem });
    if !(2..=MAX_SAMPLES).contains(&s.samples) {
        return bad(
            "--samples",
            format!("{} (from 2 to {})", s.samples, MAX_SAMPLES),
        );
    }
    if !(s.pixel_sigma_px.is_finite() && s.pixel_sigma_px >= 0.0) {
        return bad(
            "--pixel-sigma-px",
            format!("{} (a number ≥ 0)", s.pixel_sigma_px),
        );
    }
    if !(s.threshold_mm.is_finite() && s.threshold_mm > 0.0) {
        return bad(
            "--threshold-mm",
            format!("{} (a number > 0)", s.threshold_mm),
        );
    }
    if let Some(p) = s.max_reprojection_px
        && !(p.is_finite() && p > 0.0)
    {
        return bad("--max-reprojection-px", format!("{p} (a number > 0)"));
    }
    if let Some(f) = s.frame_rate_hz
        && !(f.is_finite() && f > 0.0)
    {
        return bad("--frame-rate-hz", format!("{f} (a number > 0)"));
    }
    if !(s.sync_sigma_ms.is_finite() && (0.0..=MAX_SYNC_SIGMA_MS).contains(&s.sync_sigma_ms)) {
        return bad(
            "--sync-sigma-ms",
            format!(
                "{} (a number from 0 to {MAX_SYNC_SIGMA_MS} ms)",
                s.sync_sigma_ms
            ),
        );
    }
    if s.sync_sigma_ms > 0.0 && s.frame_rate_hz.is_none() {
        return bad(
            "--sync-sigma-ms",
            "needs --frame-rate-hz (the offset shifts A's pose in time)".into(),
        );
    }
    match (s.cfc, s.frame_rate_hz) {
        (Some(spec), None) => bad(
            "--cfc",
            format!(
                "CFC {} needs --frame-rate-hz (the filter's sampling rate)",
                spec.class
            ),
        ),
        (Some(spec), Some(hz)) => Cfc::new(spec.class, spec.standard, hz).map(|_| ()),
        _ => Ok(()),
    }
}

/// Prepares a view: the undistorted normalized observation and `J⁻¹·L` (`L·Lᵀ` = the
/// observation's own Σ, else `σ·I` with `σ` = `sigma`).
fn prep_view(
    camera: &Camera,
    cam: usize,
    obs: &Observation,
    sigma: f64,
) -> Result<ViewPrep, Error> {
    let fail = |what: String| {
        Error::Input(format!(
            "observation on line {} (epoch `{}`, camera {}, marker `{}`): {what}",
            obs.line,
            obs.epoch,
            obs.camera.letter(),
            obs.marker
        ))
    };
    let und = camera
        .cam_from_img(&obs.pixel)
        .map_err(|e| fail(format!("the pixel cannot be undistorted: {e}")))?;
    let n0 = und.normalized;
    let j = camera
        .dx_img_from_cam_point(&Vector3::new(n0.x, n0.y, 1.0))
        .map_err(|e| fail(format!("the lens Jacobian is undefined: {e:?}")))?;
    let j2 = Matrix2::new(j[(0, 0)], j[(0, 1)], j[(1, 0)], j[(1, 1)]);
    let inv = j2
        .try_inverse()
        .ok_or_else(|| fail("the lens Jacobian is singular".into()))?;
    // The observation's own Σ = L·Lᵀ (draw L·ε), else σ on each axis as ever (same bits).
    let m = match &obs.sigma {
        Some(s) => inv * s.factor(),
        None => inv * sigma,
    };
    Ok(ViewPrep { cam, n0, m })
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

fn sync_share(m: &Measurement, m0: &Measurement, sigma_ms: f64) -> SyncShare {
    let rows = || m.rows.iter().zip(&m0.rows);
    let kin = m.kinematics.as_ref().zip(m0.kinematics.as_ref());
    let kin_share = |f: fn(&KinRow) -> Option<Vec3>| {
        kin.and_then(|(k, k0)| {
            ShareStats::of(k.rows.iter().zip(&k0.rows).map(|(a, b)| (f(a), f(b))))
        })
    };
    SyncShare {
        sigma_ms,
        position: ShareStats::of(rows().map(|(a, b)| (a.sigma_mm, b.sigma_mm))),
        displacement: ShareStats::of(
            rows().map(|(a, b)| (a.displacement_sigma_mm, b.displacement_sigma_mm)),
        ),
        velocity: ShareStats::of(
            rows().map(|(a, b)| (a.velocity_sigma_mm_s, b.velocity_sigma_mm_s)),
        ),
        filtered_displacement: kin_share(|k| k.displacement_sigma_mm),
        filtered_velocity: kin_share(|k| k.velocity_sigma_m_s),
        acceleration: kin_share(|k| k.acceleration_sigma_m_s2),
    }
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

/// The Monte Carlo's moments of every row, kinematic run and scale bar.
struct AllMoments {
    rows: Vec<Vec<Acc>>,
    runs: Vec<Vec<RunAcc>>,
    bars: Vec<BarAcc>,
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
        Some(hz) if settings.sync_sigma_ms > 0.0 => ATrack::new(input.epochs, hz),
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

/// Every scale bar prepared for the draws: its markers' indices (`None`: a marker seen only
/// in epochs without a pose of A) and the measured epochs in which both have a position.
fn bar_preps(
    bars: &[length::ScaleBar],
    marker_idx: &HashMap<&str, usize>,
    preps: &[EpochPrep],
) -> Vec<BarPrep> {
    bars.iter()
        .map(|bar| {
            let markers = [
                marker_idx.get(bar.marker_1.as_str()).copied(),
                marker_idx.get(bar.marker_2.as_str()).copied(),
            ];
            let mut epochs = Vec::new();
            if let [Some(m1), Some(m2)] = markers {
                for (e, p) in preps.iter().enumerate() {
                    let at = |m: usize| {
                        let s = p.slot_of[m]?;
                        p.slots[s].nominal.map(|x| (s, x))
                    };
                    if let (Some((s1, x1)), Some((s2, x2))) = (at(m1), at(m2)) {
                        epochs.push(BarEpochPrep {
                            e,
                            s1,
                            s2,
                            nominal_mm: (x1 - x2).norm(),
                        });
                    }
                }
            }
            BarPrep::new(markers, epochs)
        })
        .collect()
}

/// The accumulators of the rows and kinematic runs of the markers `mine` and of the scale
/// bars `my_bars` (a shard's).
fn shard_part(
    preps: &[EpochPrep],
    kin_runs: Option<&[Vec<Run>]>,
    moments: &AllMoments,
    mine: &std::ops::Range<usize>,
    my_bars: std::ops::Range<usize>,
) -> Accs {
    let mut part = Accs::default();
    for (e, p) in preps.iter().enumerate() {
        for (s, slot) in p.slots.iter().enumerate() {
            if mine.contains(&slot.marker) {
                part.rows.insert((e, slot.marker), moments.rows[e][s]);
            }
        }
    }
    for (runs, racc) in kin_runs.into_iter().flatten().zip(&moments.runs) {
        for (run, acc) in runs.iter().zip(racc) {
            part.runs.insert((run.marker, run.start), acc.clone());
        }
    }
    for b in my_bars {
        part.bars.insert(b, moments.bars[b].clone());
    }
    part
}

/// The accumulators of every row and run, from the union of a shard set's ([`Draws::Given`]).
///
/// # Errors
/// [`Error::Input`] naming the first row or run that no shard holds, or a run whose length
/// differs (the shards come from other inputs).
fn given_moments(
    preps: &[EpochPrep],
    kin: Option<&KinWork<'_>>,
    bars: &[BarPrep],
    given: &Accs,
) -> Result<AllMoments, Error> {
    let mut accs = Vec::with_capacity(preps.len());
    for (e, p) in preps.iter().enumerate() {
        let row = |slot: &Slot| {
            given.rows.get(&(e, slot.marker)).copied().ok_or_else(|| {
                Error::Input(format!(
                    "no shard holds the moments of measured epoch {e}, marker {}",
                    slot.marker
                ))
            })
        };
        accs.push(p.slots.iter().map(row).collect::<Result<Vec<_>, _>>()?);
    }
    let runs = kin.map_or(&[][..], |k| k.runs);
    let (n_rows, n_runs) = (
        accs.iter().map(Vec::len).sum(),
        runs.iter().map(Vec::len).sum(),
    );
    if (given.rows.len(), given.runs.len()) != (n_rows, n_runs) {
        return Err(Error::Input(format!(
            "the shards hold the moments of {} rows and {} kinematic runs, the run has {n_rows} and {n_runs}",
            given.rows.len(),
            given.runs.len()
        )));
    }
    let mut kin_accs = Vec::new();
    for runs in runs {
        let mut racc = Vec::with_capacity(runs.len());
        for run in runs {
            match given.runs.get(&(run.marker, run.start)) {
                Some(acc) if acc.m.len() == run.len => racc.push(acc.clone()),
                _ => {
                    return Err(Error::Input(format!(
                        "no shard holds the moments of marker {}'s kinematic run of {} epochs from measured epoch {}",
                        run.marker, run.len, run.start
                    )));
                }
            }
        }
        kin_accs.push(racc);
    }
    let mut bar_accs = Vec::with_capacity(bars.len());
    for (b, bar) in bars.iter().enumerate() {
        match given.bars.get(&b) {
            Some(acc) if acc.dist.len() == bar.epochs.len() => bar_accs.push(acc.clone()),
            _ => {
                return Err(Error::Input(format!(
                    "no shard holds the moments of scale bar {b} over {} epochs",
                    bar.epochs.len()
                )));
            }
        }
    }
    if given.bars.len() != bars.len() {
        return Err(Error::Input(format!(
            "the shards hold the moments of {} scale bars, the run has {}",
            given.bars.len(),
            bars.len()
        )));
    }
    Ok(AllMoments {
        rows: accs,
        runs: kin_accs,
        bars: bar_accs,
    })
}

/// One epoch's observations: marker → camera → observation.
type ByMarker<'a> = BTreeMap<&'a str, BTreeMap<Inward, &'a Observation>>;

/// The observations grouped by posed epoch (index into the epochs), the skipped epochs with
/// their observation counts, and the markers in order.
struct Groups<'a> {
    by_epoch: BTreeMap<usize, ByMarker<'a>>,
    skipped: BTreeMap<&'a str, usize>,
    markers: Vec<String>,
}

/// Groups the observations by epoch, marker and camera.
fn group_observations<'a>(
    epochs: &[Epoch],
    rig: &Rig,
    observations: &'a [Observation],
) -> Result<Groups<'a>, Error> {
    let mut lookup: HashMap<&str, usize> = HashMap::new();
    for (i, e) in epochs.iter().enumerate() {
        lookup.insert(e.key.as_str(), i);
        lookup.insert(e.name.as_str(), i);
    }
    let mut by_epoch: BTreeMap<usize, ByMarker<'a>> = BTreeMap::new();
    let mut skipped: BTreeMap<&str, usize> = BTreeMap::new();
    let mut markers: BTreeSet<&str> = BTreeSet::new();
    for obs in observations {
        if obs.camera == Inward::C && rig.c.is_none() {
            return Err(Error::Input(format!(
                "observation on line {} is from camera C, but no camera C is configured",
                obs.line
            )));
        }
        match lookup.get(obs.epoch.as_str()) {
            Some(&e) => {
                markers.insert(obs.marker.as_str());
                by_epoch
                    .entry(e)
                    .or_default()
                    .entry(obs.marker.as_str())
                    .or_default()
                    .insert(obs.camera, obs);
            }
            None => *skipped.entry(obs.epoch.as_str()).or_default() += 1,
        }
    }
    if by_epoch.is_empty() {
        return Err(Error::Input(format!(
            "no observation belongs to an epoch with a pose of camera A ({} epochs skipped)",
            skipped.len()
        )));
    }
    Ok(Groups {
        by_epoch,
        skipped,
        markers: markers.into_iter().map(String::from).collect(),
    })
}

/// The measured epochs in sequence order with their times (with a frame rate), and the index
/// of the reference epoch.
fn measured_epochs(
    epochs: &[Epoch],
    groups: &Groups<'_>,
    settings: &Settings,
) -> Result<(Vec<MeasuredEpoch>, usize), Error> {
    let mut measured: Vec<MeasuredEpoch> = Vec::new();
    for &e in groups.by_epoch.keys() {
        let ep = &epochs[e];
        let frame = frame_number(&ep.name);
        let time_s = match settings.frame_rate_hz {
            Some(hz) => {
                let f = frame.ok_or_else(|| {
                    Error::Sequence(format!(
                        "epoch `{}` has no frame number (digits in its name), needed for velocities",
                        ep.name
                    ))
                })?;
                Some(f as f64 / hz)
            }
            None => None,
        };
        if let (Some(t), Some(last)) = (time_s, measured.last())
            && last.time_s.is_some_and(|lt| lt >= t)
        {
            return Err(Error::Sequence(format!(
                "frame numbers do not increase along the sequence: epoch `{}` follows `{}` (zero-pad the image names)",
                ep.name, last.name
            )));
        }
        measured.push(MeasuredEpoch {
            key: ep.key.clone(),
            name: ep.name.clone(),
            frame,
            time_s,
        });
    }
    let reference_epoch = match &settings.reference_epoch {
        None => 0,
        Some(r) => measured
            .iter()
            .position(|m| &m.key == r || &m.name == r)
            .ok_or_else(|| Error::Setting {
                name: "--reference-epoch",
                problem: format!("`{r}` is not a measured epoch"),
            })?,
    };
    Ok((measured, reference_epoch))
}

/// One epoch prepared for the draws: its views, the nominal intersections and their
/// reprojection residuals (`time_s` is left to the caller).
fn prep_epoch(
    ep: &Epoch,
    rig: &Rig,
    by_marker: &ByMarker<'_>,
    marker_idx: &HashMap<&str, usize>,
    settings: &Settings,
) -> Result<EpochPrep, Error> {
    let cameras: Vec<&Camera> = std::iter::once(&rig.camera_b)
        .chain(rig.c.as_ref().map(|(_, c)| c))
        .collect();
    let world_from_b = ep.world_from_a.b_from_a * rig.a_from_b.b_from_a;
    let world_from_c = rig.c.as_ref().map(|(p, _)| world_from_b * p.b_from_a);
    let cam_from_world = [
        Some(world_from_b.inverse()),
        world_from_c.map(|w| w.inverse()),
    ];
    let mut slots = Vec::with_capacity(by_marker.len());
    let mut slot_of = vec![None; marker_idx.len()];
    for (&marker, by_cam) in by_marker {
        let mut views = Vec::with_capacity(by_cam.len());
        for (&cam, &obs) in by_cam {
            let ci = usize::from(cam == Inward::C);
            views.push(prep_view(cameras[ci], ci, obs, settings.pixel_sigma_px)?);
        }
        let n_views = views.len();
        let mut nominal = None;
        let mut degenerate = false;
        let mut reprojection_px = None;
        if n_views >= 2 {
            let dlt_views: Vec<View> = views
                .iter()
                .map(|v| View {
                    cam_from_world: cam_from_world[v.cam].expect("camera present"),
                    normalized: v.n0,
                })
                .collect();
            match triangulate::dlt(&dlt_views) {
                Ok(x) => {
                    nominal = Some(x);
                    let mut worst = 0.0_f64;
                    for (&cam, &obs) in by_cam {
                        let ci = usize::from(cam == Inward::C);
                        let p =
                            cam_from_world[ci].expect("camera present") * nalgebra::Point3::from(x);
                        let res = match cameras[ci].img_from_cam(&p.coords) {
                            Ok(px) => (px - obs.pixel).norm(),
                            Err(_) => f64::INFINITY,
                        };
                        worst = worst.max(res);
                    }
                    reprojection_px = Some(worst);
                }
                Err(_) => degenerate = true,
            }
        }
        slot_of[marker_idx[marker]] = Some(slots.len());
        slots.push(Slot {
            marker: marker_idx[marker],
            n_views,
            views,
            nominal,
            reprojection_px,
            degenerate,
            drawn: true,
        });
    }
    Ok(EpochPrep {
        r_wa: ep.world_from_a.rotation().into_inner(),
        c_a: ep.world_from_a.center(),
        l_a: ep.world_from_a.factor(),
        slots,
        slot_of,
        time_s: None,
    })
}

/// The kinematic rows: the nominal runs filtered and differentiated, σ from the replicates.
fn assemble_kinematics(
    preps: &[EpochPrep],
    kin: &KinWork<'_>,
    accs: &[Vec<RunAcc>],
    reference: usize,
    n_rows: usize,
) -> Kinematics {
    // Row index of (epoch, slot): rows are epoch-major in slot order.
    let mut offsets = Vec::with_capacity(preps.len());
    let mut n = 0;
    for p in preps {
        offsets.push(n);
        n += p.slots.len();
    }
    let mut rows = vec![KinRow::default(); n_rows];
    let mut scratch = Scratch::<Vec3>::default();
    let mut with = 0;
    for (runs, racc) in kin.runs.iter().zip(accs) {
        for (run, acc) in runs.iter().zip(racc) {
            let mk = run.marker;
            let nominal = |e: usize| {
                preps[e].slot_of[mk]
                    .and_then(|s| preps[e].slots[s].nominal)
                    .unwrap_or_else(|| Vec3::repeat(f64::NAN))
            };
            let xr = nominal(reference);
            let d: Vec<Vec3> = (run.start..run.start + run.len)
                .map(|e| nominal(e) - xr)
                .collect();
            scratch.filter_and_differentiate(kin.filter, &d);
            for i in 0..run.len {
                let e = run.start + i;
                let Some(s) = preps[e].slot_of[mk] else {
                    continue;
                };
                let [d, v, a] = &acc.m[i];
                rows[offsets[e] + s] = KinRow {
                    displacement_mm: Some(scratch.f[i]),
                    displacement_sigma_mm: d.std_dev(acc.n),
                    velocity_m_s: Some(scratch.v[i]),
                    velocity_sigma_m_s: v.std_dev(acc.n),
                    acceleration_m_s2: Some(scratch.a[i]),
                    acceleration_sigma_m_s2: a.std_dev(acc.n),
                };
                with += 1;
            }
        }
    }
    Kinematics {
        filter: *kin.filter,
        rows,
        rows_with_kinematics: with,
        runs: kin.runs.iter().map(Vec::len).sum(),
    }
}

/// Replicates per chunk: a block's replicates are drawn chunk by chunk, every epoch's stream
/// continuing where the previous chunk stopped, so the scratch is O(epochs · slots · CHUNK).
const CHUNK: usize = 32;

/// The kinematics work of the Monte Carlo: the filter and every marker's runs.
struct KinWork<'a> {
    filter: &'a Cfc,
    runs: &'a [Vec<Run>],
}

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

/// Filters one run of one marker in each of the `m` replicates of a chunk and feeds its
/// moments (a replicate with a failed intersection in the run, or at the reference epoch, is
/// left out). [`LANES`] replicates at a time: their displacement series are gathered side by
/// side ([`Lanes`]; `bufs[e]` holds the chunk's replicates of a slot contiguously), filtered
/// together — each replicate with exactly the arithmetic of its own record — and their
/// velocity and acceleration taken at each epoch as the moments are fed. Every accumulator
/// still takes the replicates in replicate order, so the moments have the bits of a
/// replicate-by-replicate loop.
/// The job the vector level runs (`crate::simd`; a struct rather than a closure: its
/// `with_simd` is `#[inline(always)]`, so the whole body is compiled for the level).
struct FeedRun<'a> {
    filter: &'a Cfc,
    run: &'a Run,
    acc: &'a mut RunAcc,
    preps: &'a [EpochPrep],
    bufs: &'a [Vec<Vec3>],
    reference: usize,
    m: usize,
    scratch: &'a mut Scratch<Lanes>,
}

impl pulp::WithSimd for FeedRun<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let FeedRun {
            filter,
            run,
            acc,
            preps,
            bufs,
            reference,
            m,
            scratch,
        } = self;
        let slot = |e: usize| preps[e].slot_of[run.marker].expect("a run's epochs see its marker");
        let rs = slot(reference);
        let diff = Differences::new(1.0 / filter.frame_rate_hz());
        let (len, groups) = (run.len, m.div_ceil(LANES));
        let xr = &bufs[reference][rs * m..rs * m + m];
        // One pass over the chunk's positions (each epoch's replicates are contiguous): group `g`
        // of replicates `g·LANES…` at run epoch `i` goes to `d[g·len + i]`.
        // Every taken lane of `d` is overwritten below; a lane past `m` in the last group keeps
        // whatever it held (it is filtered alongside but never fed), so `d` is only resized.
        let mut d = std::mem::take(&mut scratch.d);
        d.resize(groups * len, Lanes([0.0; 3 * LANES]));
        // The epochs' slots first, in a loop of independent lookups (the CPU overlaps their cache
        // misses), then the gather reads each epoch's replicates at a known address.
        let mut slots = std::mem::take(&mut scratch.slots);
        slots.clear();
        slots.extend((run.start..run.start + len).map(slot));
        let mut taken = std::mem::take(&mut scratch.taken);
        taken.clear();
        taken.resize(m, true);
        for (i, &s) in slots.iter().enumerate() {
            let e = run.start + i;
            for (r, (x, xr)) in bufs[e][s * m..s * m + m].iter().zip(xr).enumerate() {
                let dx = x - xr;
                taken[r] &= finite(&dx);
                d[(r / LANES) * len + i].set_lane(r % LANES, &dx);
            }
        }
        for g in 0..groups {
            let (r0, lanes) = (g * LANES, LANES.min(m - g * LANES));
            let taken = &taken[r0..r0 + lanes];
            scratch.filter(filter, &d[g * len..(g + 1) * len]);
            let mut inv_n = [0.0; LANES];
            for l in 0..lanes {
                if taken[l] {
                    acc.n += 1;
                    inv_n[l] = 1.0 / acc.n as f64;
                }
            }
            let f = &scratch.f;
            for (i, q) in acc.m.iter_mut().enumerate() {
                let (v, a) = (diff.velocity(f, i), diff.acceleration(f, i));
                for l in (0..lanes).filter(|&l| taken[l]) {
                    q[0].push(&f[i].lane(l), inv_n[l]);
                    q[1].push(&v.lane(l), inv_n[l]);
                    q[2].push(&a.lane(l), inv_n[l]);
                }
            }
        }
        scratch.d = d;
        scratch.slots = slots;
        scratch.taken = taken;
    }
}

fn sigma_of(m: &Moments<3>) -> Option<Vec3> {
    (m.count() >= 2).then(|| m.std_dev())
}

fn assemble(
    preps: &[EpochPrep],
    accs: &[Vec<Acc>],
    settings: &Settings,
    reference: usize,
    reprojection_limit_px: Option<f64>,
) -> Vec<Row> {
    let mut rows = Vec::new();
    for (e, ep) in preps.iter().enumerate() {
        for (s, slot) in ep.slots.iter().enumerate() {
            let acc = &accs[e][s];
            let m = slot.marker;
            let nominal_of = |k: usize| preps[k].slot_of[m].and_then(|s| preps[k].slots[s].nominal);
            let displacement_mm = match (slot.nominal, nominal_of(reference)) {
                (Some(x), Some(xr)) => Some(x - xr),
                _ => None,
            };
            let velocity_mm_s = if settings.frame_rate_hz.is_some() {
                velocity_pair(e, m, preps).and_then(|(p, n)| {
                    let dt = preps[n].time_s? - preps[p].time_s?;
                    Some((nominal_of(n)? - nominal_of(p)?) / dt)
                })
            } else {
                None
            };
            let sigma_mm = if slot.drawable() {
                sigma_of(&acc.pos)
            } else {
                None
            };
            let flags = Flags {
                fewer_than_two_views: slot.n_views < 2,
                degenerate: slot.degenerate,
                sigma_above_threshold: sigma_mm.is_some_and(|s| s.max() > settings.threshold_mm),
                reprojection_outlier: match (slot.reprojection_px, reprojection_limit_px) {
                    (Some(r), Some(l)) => r > l,
                    (Some(r), None) => !r.is_finite(),
                    _ => false,
                },
            };
            rows.push(Row {
                epoch: e,
                marker: m,
                n_views: slot.n_views,
                position_mm: slot.nominal,
                sigma_mm,
                covariance_mm2: sigma_mm.map(|_| acc.pos.covariance()),
                displacement_mm,
                displacement_sigma_mm: displacement_mm.and_then(|_| {
                    if e == reference {
                        Some(Vec3::zeros())
                    } else {
                        sigma_of(&acc.disp)
                    }
                }),
                velocity_mm_s,
                velocity_sigma_mm_s: velocity_mm_s.and_then(|_| sigma_of(&acc.vel)),
                reprojection_px: slot.reprojection_px,
                draws: acc.pos.count(),
                flags,
            });
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_geometry::{Rigid3, quat};

    #[test]
    fn draws_bound_is_rows_times_samples() {
        // 1000 rows × 10⁷ replicates = 10¹⁰ draws: at the limit, accepted; one row more is not.
        assert!(check_draws(1000, 10_000_000).is_ok());
        let err = check_draws(1001, 10_000_000).unwrap_err().to_string();
        assert!(
            err.contains("--samples") && err.contains("10010000000 draws"),
            "{err}"
        );
    }

    #[test]
    fn intersect_matches_geometry_dlt() {
        // Three cameras around a point, observations slightly off (residuals ≠ 0): the lean
        // solver of the draws must give the geometry crate's DLT solution.
        let cams: Vec<Rigid3> = [(0.1, -0.2, 0.05), (-0.3, 0.4, 0.2), (0.2, 0.1, -0.3)]
            .iter()
            .enumerate()
            .map(|(i, &(a, b, c))| {
                let r = so3::exp(&Vector3::new(a, b, c));
                let centre = Vec3::new(300.0 * i as f64, -100.0, -2000.0 + 50.0 * i as f64);
                quat::rigid_from_rotation(&r, &centre) // world_from_cam
            })
            .collect();
        let x = Vec3::new(120.0, 40.0, 500.0);
        let noise = [(1e-3, -2e-3), (-5e-4, 1e-3), (2e-3, 4e-4)];
        let views: Vec<View> = cams
            .iter()
            .zip(noise)
            .map(|(w, (du, dv))| {
                let p = w.inverse() * nalgebra::Point3::from(x);
                View {
                    cam_from_world: w.inverse(),
                    normalized: Vector2::new(p.x / p.z + du, p.y / p.z + dv),
                }
            })
            .collect();
        let expected = triangulate::dlt(&views).unwrap();
        let mats: Vec<(Mat3, Vec3)> = cams
            .iter()
            .map(|w| {
                (
                    w.rotation.to_rotation_matrix().into_inner(),
                    w.translation.vector,
                )
            })
            .collect();
        let got = intersect(
            mats.iter()
                .zip(&views)
                .map(|((r, c), v)| (r, c, v.normalized)),
        )
        .unwrap();
        assert!(
            (got - expected).norm() < 1e-9 * expected.norm(),
            "{got} vs {expected}"
        );
        assert!((got - x).norm() > 1e-3, "the noise must move the solution");
    }

    #[test]
    fn robust_limit_known_answer() {
        // median 3, |dev| = 2 1 0 1 2 → MAD 1: limit 3 + 5·1.4826.
        let l = robust_reprojection_limit(&[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert!((l - (3.0 + 5.0 * 1.4826)).abs() < 1e-12);
        assert_eq!(robust_reprojection_limit(&[1.0, f64::INFINITY]), None);
    }

    /// The joint draws reproduce the joint covariance: every entry of the sample covariance
    /// of 40 blocks (10 240 replicates) of 3 epochs × 6 axes is within 4.5 standard errors
    /// of the matrix, `SE(sᵢⱼ) = √((ΣᵢᵢΣⱼⱼ + Σᵢⱼ²)/(n − 1))`, the marginals (diagonal
    /// blocks) and the between-epoch blocks alike (171 entries: a false alarm at 4.5 SE has
    /// probability ~1e-3 for some seed; this seed is fixed).
    #[test]
    fn joint_draws_reproduce_the_joint_covariance() {
        let n = 18;
        // A random-looking SPD matrix with strong between-epoch correlation: B·Bᵀ + 0.1·I
        // with B's entries from a fixed formula.
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.4);
        let sigma = &b * b.transpose() + DMatrix::identity(n, n) * 0.1;
        let l = JointFactor {
            l: sigma.clone().cholesky().unwrap().unpack(),
            lower: true,
        };
        let blocks = 40;
        let mut draws: Vec<Vec<Vec6>> = vec![Vec::new(); 3];
        for blk in 0..blocks {
            for (e, d) in joint_draws(&l, 5, blk, BLOCK).into_iter().enumerate() {
                draws[e].extend(d);
            }
        }
        let count = blocks * BLOCK;
        let x = DMatrix::from_fn(n, count, |k, r| draws[k / 6][r][k % 6]);
        let mean = x.column_mean();
        let c = DMatrix::from_fn(n, n, |i, j| {
            (0..count)
                .map(|r| (x[(i, r)] - mean[i]) * (x[(j, r)] - mean[j]))
                .sum::<f64>()
                / (count - 1) as f64
        });
        for i in 0..n {
            for j in 0..=i {
                let se = ((sigma[(i, i)] * sigma[(j, j)] + sigma[(i, j)].powi(2))
                    / (count - 1) as f64)
                    .sqrt();
                let z = (c[(i, j)] - sigma[(i, j)]) / se;
                assert!(
                    z.abs() < 4.5,
                    "({i}, {j}): {} vs {} (z {z})",
                    c[(i, j)],
                    sigma[(i, j)]
                );
            }
        }
        // Bit-identical on a second call (one stream per block).
        assert_eq!(joint_draws(&l, 5, 3, 7), joint_draws(&l, 5, 3, 7));
    }

    /// The triangular product gives the full product's bits: a Cholesky factor of 100 epochs
    /// (600 rows: several row blocks, and an inner dimension beyond the product kernel's
    /// blocks of it), once as lower triangular and once as a general matrix, the same draws.
    #[test]
    fn joint_draws_triangle_is_the_full_product_bit_for_bit() {
        let n = 600;
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.4);
        let sigma = &b * b.transpose() + DMatrix::identity(n, n) * 0.1;
        let l = sigma.cholesky().unwrap().unpack();
        let tri = JointFactor {
            l: l.clone(),
            lower: true,
        };
        let full = JointFactor { l, lower: false };
        let (a, f) = (joint_draws(&tri, 9, 2, 5), joint_draws(&full, 9, 2, 5));
        assert_eq!(a.len(), 100);
        for (a, f) in a.iter().flatten().zip(f.iter().flatten()) {
            for (x, y) in a.iter().zip(f.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        assert!(a[99][4].norm() > 0.0, "the last epoch is drawn");
    }
}
