//! The tie link of a third camera, the library of `crashrig bootstrap`: correspondences from a
//! COLMAP database and model, bootstrapped (the resampling engine is `crashrig_bootstrap`).
//!
//! The pose of image B relative to image A (`A_from_B`) and its uncertainty by resampling
//! correspondences with replacement (the paper's §2.3.1, §3.2):
//! - [`Method::Absolute`]: B is resected from its observations of the model's 3-D points (P3P
//!   LO-RANSAC + Levenberg–Marquardt through B's camera model); A's pose is the model's.
//! - [`Method::Relative`]: the essential matrix from the A–B matches (5-point LO-RANSAC + LM on
//!   the Sampson error), undistorted through each image's camera; the base length is the
//!   distance of the model's projection centres (or [`TieConfig::base_mm`]) and is held fixed,
//!   so the base σ comes from the direction and rotation only.
//!
//! Two resampling modes ([`Resample`]):
//! - [`Resample::Inliers`] (default): each replicate resamples the full-sample RANSAC inliers and
//!   re-runs the LM refinement warm-started from the full-sample pose. Cheap; it does not
//!   bootstrap the inlier selection.
//! - [`Resample::AllMatches`]: each replicate resamples **all** candidate correspondences (B's
//!   observations of 3-D points, or every raw match of the `matches` table) and re-runs the
//!   whole LO-RANSAC + LM, so the variability of the inlier selection is in the spread (the
//!   paper's procedure). The RANSAC seed of a replicate is a hash of the run's seed and the
//!   replicate's indices, so results do not depend on the thread count.
//!
//! Reported: the full-sample estimate (base = B's centre in A's axes, mm; ω φ κ of `R_A_from_B`,
//! degrees), per-parameter bootstrap σ (n − 1, wrap-safe), percentile and BCa intervals (the
//! acceleration from the leave-one-out over the inliers with the warm-started LM, in both
//! modes), the first-order σ, and the contract's `covariance_tangent`: the
//! covariance of the replicates in the tangent of [`crashrig_geometry::UncertainPose`] (centre
//! in A's axes, rotation `log(R̄ᵀ·R)` about B's axes, about the replicates' mean).
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```no_run
//! use crashrig_tie::{self as tie, Method, Resample, TieConfig};
//!
//! let config = TieConfig {
//!     database: "tie/database.db".into(),
//!     model: "tie/sparse/0".into(),
//!     image_a: "in/0001.png".into(),
//!     image_b: "third/0001.png".into(),
//!     method: Method::Absolute,
//!     resample: Resample::AllMatches,
//!     mm_per_unit: 1000.0,
//!     ..TieConfig::default()
//! };
//! let result = tie::bootstrap(&config, None)?;
//! // The link A_from_B with its 6×6 covariance (mm, rad) for the Monte Carlo chain:
//! let link = result.link;
//! println!("{}", result.text_report());
//! # Ok::<(), crashrig_tie::Error>(())
//! ```

#![deny(missing_docs)]
#![warn(unnameable_types)]

mod correspondences;
mod error;

use crate::correspondences::{MatchSet, ModelImage, TieSource};
pub use crate::error::Error;
use crashrig_bootstrap as boot;
use crashrig_geometry::angles::{unwrap_about, wrapped_stats};
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3};
use crashrig_pose::{
    Projector, RansacOptions, estimate_absolute_pose, estimate_relative_pose,
    link_covariance_absolute, link_covariance_relative, link_parameters, normalize_pixels,
    refine_absolute_pose, refine_relative_pose, scaled_a_from_b,
};
use crashrig_stats::progress::{Monitor, Offset};
use nalgebra::Vector2;
use serde::Serialize;
use std::path::PathBuf;

/// Confidence level of the reported intervals.
const LEVEL: f64 = 0.95;
/// Parameter names, in the order of `link_parameters` (also the histogram file names).
pub const PARAMS: [&str; 6] = ["x", "y", "z", "omega", "phi", "kappa"];
/// Axis labels of the histograms and the text report.
const LABELS: [&str; 6] = [
    "base x [mm]",
    "base y [mm]",
    "base z [mm]",
    "omega [deg]",
    "phi [deg]",
    "kappa [deg]",
];
/// Header of [`TieResult::replicates_csv`].
pub const REPLICATES_CSV_HEADER: &str =
    "replicate,x_mm,y_mm,z_mm,omega_deg,phi_deg,kappa_deg,tx_deg,ty_deg,tz_deg";

impl Error {
    /// The error of a failed [`bootstrap_link`] on the correspondences of `path`, described by
    /// `what` (a cancellation stays [`Error::Cancelled`]).
    fn estimation(e: Error, path: &std::path::Path, what: impl FnOnce() -> String) -> Self {
        match e {
            Error::Cancelled(c) => Self::Cancelled(c),
            e => Self::Estimation {
                path: path.to_path_buf(),
                message: format!("{}: {e}", what()),
            },
        }
    }
}

/// How B is posed relative to A.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Resection of B from its observations of the model's 3-D points.
    #[default]
    Absolute,
    /// Essential matrix from the A–B matches, scale from the model.
    Relative,
}

impl Method {
    /// `"absolute"` or `"relative"` (the CLI and JSON spelling).
    pub fn name(self) -> &'static str {
        match self {
            Method::Absolute => "absolute",
            Method::Relative => "relative",
        }
    }

    /// Parses [`Method::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "absolute" => Some(Method::Absolute),
            "relative" => Some(Method::Relative),
            _ => None,
        }
    }
}

/// What each bootstrap replicate resamples (issue 12 item 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Resample {
    /// The full-sample RANSAC inliers; LM warm-started from the full-sample pose.
    #[default]
    Inliers,
    /// All candidate correspondences; LO-RANSAC + LM re-run in every replicate.
    AllMatches,
}

impl Resample {
    /// `"inliers"` or `"matches"` (the CLI `--resample` value and the JSON `resampled` field).
    pub fn name(self) -> &'static str {
        match self {
            Resample::Inliers => "inliers",
            Resample::AllMatches => "matches",
        }
    }

    /// Parses [`Resample::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "inliers" => Some(Resample::Inliers),
            "matches" => Some(Resample::AllMatches),
            _ => None,
        }
    }
}

/// Everything `crashrig bootstrap` takes.
#[derive(Debug, Clone, PartialEq)]
pub struct TieConfig {
    /// COLMAP database with the matches.
    pub database: PathBuf,
    /// COLMAP model directory.
    pub model: PathBuf,
    /// Name of image A (the reference).
    pub image_a: String,
    /// Name of image B (reported relative to A).
    pub image_b: String,
    /// Absolute or relative orientation.
    pub method: Method,
    /// Bootstrap replicates (≥ 2).
    pub iterations: usize,
    /// Seed of the resampling and of every RANSAC run.
    pub seed: u64,
    /// Millimetres per model unit.
    pub mm_per_unit: f64,
    /// RANSAC inlier threshold, px (reprojection error, or Sampson error × focal).
    pub max_error_px: f64,
    /// Relative method: the base length (mm) instead of the model's projection centres.
    pub base_mm: Option<f64>,
    /// What each replicate resamples.
    pub resample: Resample,
}

impl Default for TieConfig {
    /// Paths and image names empty; absolute, 500 replicates, seed 1, 1 mm per unit, 4 px,
    /// inlier resampling.
    fn default() -> Self {
        TieConfig {
            database: PathBuf::new(),
            model: PathBuf::new(),
            image_a: String::new(),
            image_b: String::new(),
            method: Method::Absolute,
            iterations: 500,
            seed: 1,
            mm_per_unit: 1.0,
            max_error_px: 4.0,
            base_mm: None,
            resample: Resample::Inliers,
        }
    }
}

/// Resection input: B's observations of 3-D points (mm) and A's fixed pose.
#[derive(Debug, Clone)]
pub struct AbsoluteInput<C> {
    /// B's camera.
    pub camera_b: C,
    /// B's pixels.
    pub pixels_b: Vec<Vector2<f64>>,
    /// The observed points, mm.
    pub points_mm: Vec<Vec3>,
    /// A's pose (mm), held fixed.
    pub a_from_world: Rigid3,
}

/// Relative-orientation input: matched pixels and the base length (mm).
#[derive(Debug, Clone)]
pub struct RelativeInput<C> {
    /// A's camera.
    pub camera_a: C,
    /// B's camera.
    pub camera_b: C,
    /// A's pixels.
    pub pixels_a: Vec<Vector2<f64>>,
    /// B's pixels (same order).
    pub pixels_b: Vec<Vector2<f64>>,
    /// Base length, mm (held fixed).
    pub base_mm: f64,
}

/// Full-sample estimate, replicates and first-order covariance of the link `A_from_B` (mm).
#[derive(Debug, Clone)]
pub struct LinkBootstrap {
    /// Correspondences given to the full-sample RANSAC.
    pub n_candidates: usize,
    /// Its inliers.
    pub n_inliers: usize,
    /// What each replicate resampled.
    pub resample: Resample,
    /// The full-sample `A_from_B` (mm).
    pub estimate: Rigid3,
    /// The replicates' `A_from_B` (mm) and failures.
    pub replicates: boot::Replicates<Rigid3, String>,
    /// Leave-one-out values (empty when not asked for).
    pub jackknife: Vec<Result<Rigid3, String>>,
    /// First-order covariance of `[x, y, z (mm), ω, φ, κ (rad)]` from the estimator.
    pub first_order: Mat6,
}

impl LinkBootstrap {
    /// Number of items each replicate resampled.
    pub fn n_resampled(&self) -> usize {
        match self.resample {
            Resample::Inliers => self.n_inliers,
            Resample::AllMatches => self.n_candidates,
        }
    }
}

/// A RANSAC seed for one replicate that depends only on the run's seed and the replicate's
/// resampled indices (FNV-1a then SplitMix64), so it is the same on any thread.
fn replicate_seed(seed: u64, idx: &[usize]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325 ^ seed;
    for &i in idx {
        h ^= i as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    let mut z = h.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn seeded(ransac: &RansacOptions, idx: &[usize]) -> RansacOptions {
    RansacOptions {
        seed: replicate_seed(ransac.seed, idx),
        ..*ransac
    }
}

/// The correspondences of one tie bootstrap: B resected against the model's points, or the
/// relative orientation of A and B.
#[derive(Debug, Clone)]
pub enum LinkInput<C> {
    /// Resection of B ([`Method::Absolute`]).
    Absolute(AbsoluteInput<C>),
    /// Relative orientation A–B ([`Method::Relative`]).
    Relative(RelativeInput<C>),
}

/// How [`bootstrap_link`] resamples. No `Default`: it holds a seed and a replicate count.
#[derive(Debug, Clone, Copy)]
pub struct LinkBootstrapOptions {
    /// Number of replicates.
    pub iterations: usize,
    /// Seed of the resampling (replicate `r` uses `crashrig_stats::stream(seed, r)`).
    pub seed: u64,
    /// The full-sample (and, with [`Resample::AllMatches`], per-replicate) RANSAC.
    pub ransac: RansacOptions,
    /// What each replicate resamples.
    pub resample: Resample,
    /// Also the leave-one-out values over the inliers (the BCa acceleration); without them
    /// [`LinkBootstrap::jackknife`] is empty.
    pub jackknife: bool,
}

/// The full-sample estimate of the link `A_from_B`, then `options.iterations` bootstrap
/// replicates of it and, if asked, the leave-one-out values (the paper's §2.3.1).
///
/// `monitor` (optional) gets `(replicates + leave-one-out values done, iterations + n)` (n: the
/// inliers of the jackknife, 0 without it) and may cancel between replicates; the result is the
/// same with and without it.
///
/// # Errors
/// [`Error`]: the full-sample estimation failed, the engine refused the run, or the call
/// was cancelled.
pub fn bootstrap_link<C: Projector + Sync>(
    input: &LinkInput<C>,
    options: &LinkBootstrapOptions,
    monitor: Option<&dyn Monitor>,
) -> Result<LinkBootstrap, Error> {
    match input {
        LinkInput::Absolute(a) => bootstrap_absolute(a, options, monitor),
        LinkInput::Relative(r) => bootstrap_relative(r, options, monitor),
    }
}

/// Resection of B, then the bootstrap of the link.
fn bootstrap_absolute<C: Projector + Sync>(
    input: &AbsoluteInput<C>,
    options: &LinkBootstrapOptions,
    monitor: Option<&dyn Monitor>,
) -> Result<LinkBootstrap, Error> {
    let ransac = &options.ransac;
    let est = estimate_absolute_pose(&input.camera_b, &input.pixels_b, &input.points_mm, ransac)
        .map_err(Error::Resection)?;
    let inliers = est.inliers;
    let full = est.refinement;
    let a_from_world = input.a_from_world;
    let link = |b_from_world: &Rigid3| a_from_world * b_from_world.inverse();
    let warm = |idx: &[usize]| -> Result<Rigid3, String> {
        let sel: Vec<usize> = idx.iter().map(|&i| inliers[i]).collect();
        refine_absolute_pose(
            &input.camera_b,
            &input.pixels_b,
            &input.points_mm,
            &sel,
            &full.cam_from_world,
        )
        .map(|r| link(&r.cam_from_world))
        .map_err(|e| e.to_string())
    };
    let rerun = |idx: &[usize]| -> Result<Rigid3, String> {
        let px: Vec<Vector2<f64>> = idx.iter().map(|&i| input.pixels_b[i]).collect();
        let pt: Vec<Vec3> = idx.iter().map(|&i| input.points_mm[i]).collect();
        estimate_absolute_pose(&input.camera_b, &px, &pt, &seeded(ransac, idx))
            .map(|r| link(&r.refinement.cam_from_world))
            .map_err(|e| e.to_string())
    };
    let n_candidates = input.pixels_b.len();
    let (replicates, jackknife) = resample_both(
        (n_candidates, &rerun),
        (inliers.len(), &warm),
        options,
        monitor,
    )?;
    Ok(LinkBootstrap {
        n_candidates,
        n_inliers: inliers.len(),
        resample: options.resample,
        estimate: link(&full.cam_from_world),
        replicates,
        jackknife,
        first_order: link_covariance_absolute(
            &a_from_world,
            &full.cam_from_world,
            &full.covariance,
        ),
    })
}

/// A per-replicate estimator over the indices of the items it resamples.
type Estimate<'a> = &'a (dyn Fn(&[usize]) -> Result<Rigid3, String> + Sync);

/// The replicates and, if asked, the jackknife of one bootstrap. `Inliers` resamples the
/// inliers with the warm-started refit `warm`; `AllMatches` resamples all candidates and reruns
/// the estimator (`rerun`). The BCa acceleration comes from the leave-one-out over the inliers
/// with `warm` in both modes (a RANSAC per left-out candidate would cost n full estimations).
#[allow(clippy::type_complexity)]
fn resample_both(
    (n_candidates, rerun): (usize, Estimate<'_>),
    (n_inliers, warm): (usize, Estimate<'_>),
    options: &LinkBootstrapOptions,
    monitor: Option<&dyn Monitor>,
) -> Result<
    (
        boot::Replicates<Rigid3, String>,
        Vec<Result<Rigid3, String>>,
    ),
    Error,
> {
    let (iterations, seed) = (options.iterations, options.seed);
    // Progress over the replicates, then the leave-one-out values: (done, iterations + n).
    let n_jackknife = if options.jackknife { n_inliers } else { 0 };
    let total = iterations + n_jackknife;
    let on_replicates = monitor.map(|m| Offset::new(m, 0, total));
    let on_jackknife = monitor.map(|m| Offset::new(m, iterations, total));
    let (on_replicates, on_jackknife) = (
        on_replicates.as_ref().map(|m| m as &dyn Monitor),
        on_jackknife.as_ref().map(|m| m as &dyn Monitor),
    );
    let replicates = match options.resample {
        Resample::Inliers => boot::run(n_inliers, iterations, seed, warm, on_replicates)?,
        Resample::AllMatches => boot::run(n_candidates, iterations, seed, rerun, on_replicates)?,
    };
    let jackknife = if options.jackknife {
        boot::jackknife(n_inliers, warm, on_jackknife)?
    } else {
        Vec::new()
    };
    Ok((replicates, jackknife))
}

/// Relative orientation A–B, then the bootstrap of the link.
fn bootstrap_relative<C: Projector + Sync>(
    input: &RelativeInput<C>,
    options: &LinkBootstrapOptions,
    monitor: Option<&dyn Monitor>,
) -> Result<LinkBootstrap, Error> {
    let ransac = &options.ransac;
    let xa = normalize_pixels(&input.camera_a, &input.pixels_a)
        .map_err(|source| Error::Undistort { image: 'A', source })?;
    let xb = normalize_pixels(&input.camera_b, &input.pixels_b)
        .map_err(|source| Error::Undistort { image: 'B', source })?;
    let focal = 0.5 * (input.camera_a.focal_px() + input.camera_b.focal_px());
    let est =
        estimate_relative_pose(&xa, &xb, focal, ransac).map_err(Error::RelativeOrientation)?;
    let inliers = est.inliers;
    let full = est.refinement;
    let base = input.base_mm;
    let link = |b_from_a: &Rigid3| scaled_a_from_b(b_from_a, base);
    let warm = |idx: &[usize]| -> Result<Rigid3, String> {
        let sel: Vec<usize> = idx.iter().map(|&i| inliers[i]).collect();
        refine_relative_pose(&xa, &xb, &sel, &full.b_from_a)
            .map(|r| link(&r.b_from_a))
            .map_err(|e| e.to_string())
    };
    let rerun = |idx: &[usize]| -> Result<Rigid3, String> {
        let sa: Vec<Vector2<f64>> = idx.iter().map(|&i| xa[i]).collect();
        let sb: Vec<Vector2<f64>> = idx.iter().map(|&i| xb[i]).collect();
        estimate_relative_pose(&sa, &sb, focal, &seeded(ransac, idx))
            .map(|r| link(&r.refinement.b_from_a))
            .map_err(|e| e.to_string())
    };
    let n_candidates = input.pixels_a.len();
    let (replicates, jackknife) = resample_both(
        (n_candidates, &rerun),
        (inliers.len(), &warm),
        options,
        monitor,
    )?;
    Ok(LinkBootstrap {
        n_candidates,
        n_inliers: inliers.len(),
        resample: options.resample,
        estimate: link(&full.b_from_a),
        replicates,
        jackknife,
        first_order: link_covariance_relative(&full.b_from_a, base, &full.covariance),
    })
}

/// Per-parameter summary in output units (mm, degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSummary {
    /// Full-sample estimate.
    pub estimate: f64,
    /// Bootstrap σ (n − 1; wrap-safe for angles).
    pub sigma: f64,
    /// Mean of the replicates (angles unwrapped about the estimate).
    pub mean: f64,
    /// `mean − estimate`.
    pub bias: f64,
    /// 95 % percentile interval.
    pub ci95: [f64; 2],
    /// 95 % BCa interval (`None` when undefined or without jackknife).
    pub ci95_bca: Option<[f64; 2]>,
    /// First-order σ from the estimator's covariance.
    pub first_order_sigma: f64,
    /// Replicate values, unwrapped about the estimate for angles (for the histograms).
    pub values: Vec<f64>,
}

/// Summaries of the six link parameters `[x, y, z, ω, φ, κ]`.
pub fn summarize(lb: &LinkBootstrap) -> Result<Vec<ParamSummary>, Error> {
    let n_ok = lb.replicates.values.len();
    if n_ok < 2 {
        return Err(Error::Replicates {
            message: format!(
                "only {n_ok} of {} bootstrap replicates succeeded; first failure: {}",
                lb.replicates.replicates,
                lb.replicates
                    .failures
                    .first()
                    .map_or("none", |f| f.error.as_str())
            ),
        });
    }
    let rep: Vec<[f64; 6]> = lb.replicates.values_only().map(link_parameters).collect();
    let jk_ok: Option<Vec<[f64; 6]>> = if lb.jackknife.is_empty() {
        None
    } else {
        lb.jackknife
            .iter()
            .map(|r| r.as_ref().ok().map(link_parameters))
            .collect()
    };
    let estimate = link_parameters(&lb.estimate);
    let rerr = |e: boot::Error| Error::Replicates {
        message: format!("summarising the replicates: {e}"),
    };
    let mut out = Vec::with_capacity(6);
    for j in 0..6 {
        let raw: Vec<f64> = rep.iter().map(|v| v[j]).collect();
        let angle = j >= 3;
        let est = estimate[j];
        // Angles: unwrap about the full-sample estimate so ω ≈ 180° stays continuous.
        let values = if angle {
            unwrap_about(&raw, est)
        } else {
            raw.clone()
        };
        let sigma = if angle {
            wrapped_stats(&raw)
                .map_err(|e| Error::Replicates {
                    message: format!("summarising the replicates: {e}"),
                })?
                .sigma
        } else {
            boot::sigma(&values).map_err(rerr)?
        };
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let ci = boot::percentile_interval(&values, LEVEL).map_err(rerr)?;
        let bca = jk_ok.as_ref().and_then(|jk| {
            let jv: Vec<f64> = jk.iter().map(|v| v[j]).collect();
            let jv = if angle { unwrap_about(&jv, est) } else { jv };
            boot::bca_interval(&values, est, &jv, LEVEL).ok()
        });
        let k = if angle { 1f64.to_degrees() } else { 1.0 };
        out.push(ParamSummary {
            estimate: est * k,
            sigma: sigma * k,
            mean: mean * k,
            bias: (mean - est) * k,
            ci95: [ci.lo * k, ci.hi * k],
            ci95_bca: bca.map(|c| [c.lo * k, c.hi * k]),
            first_order_sigma: lb.first_order[(j, j)].sqrt() * k,
            values: values.iter().map(|v| v * k).collect(),
        });
    }
    Ok(out)
}

/// The result of [`bootstrap`]: typed values; [`TieResult::to_json`] and
/// [`TieResult::text_report`] are made from them.
#[derive(Debug, Clone)]
pub struct TieResult {
    /// How B was posed.
    pub method: Method,
    /// What each replicate resampled.
    pub resample: Resample,
    /// Replicates asked for.
    pub iterations: usize,
    /// Seed of the run.
    pub seed: u64,
    /// Millimetres per model unit.
    pub mm_per_unit: f64,
    /// Correspondences given to the full-sample RANSAC.
    pub n_candidates: usize,
    /// Inliers of the full-sample RANSAC.
    pub n_inliers: usize,
    /// Items each replicate resampled (`n_inliers` or `n_candidates`).
    pub n_resampled: usize,
    /// B relative to A: the full-sample `A_from_B` (mm) with the covariance of the replicates
    /// in the contract's tangent (mm, **rad**; about the replicates' mean).
    pub link: UncertainPose,
    /// The replicates' mean (Karcher rotation mean, mean centre): the origin of the tangent
    /// residuals of [`TieResult::replicates_csv`].
    pub replicate_mean: Rigid3,
    /// Every successful replicate's `A_from_B` (mm), in replicate order.
    pub replicates: Vec<Rigid3>,
    /// The replicate index of each entry of `replicates`.
    pub replicate_index: Vec<usize>,
    /// Failed replicates: (replicate index, error).
    pub failures: Vec<(usize, String)>,
    /// Summaries of x, y, z (mm), ω, φ, κ (deg).
    pub params: Vec<ParamSummary>,
}

#[derive(Debug, Serialize)]
struct Ci {
    base_mm: [[f64; 2]; 3],
    angles_deg: [[f64; 2]; 3],
}

#[derive(Debug, Serialize)]
struct FirstOrder {
    base_sigma_mm: [f64; 3],
    angles_sigma_deg: [f64; 3],
}

#[derive(Debug, Serialize)]
struct Means {
    base_mm: [f64; 3],
    angles_deg: [f64; 3],
}

#[derive(Debug, Serialize)]
struct FailureJson<'a> {
    replicate: usize,
    error: &'a str,
}

#[derive(Debug, Serialize)]
struct Output<'a> {
    method: &'static str,
    iterations: usize,
    n_correspondences: usize,
    failed_iterations: usize,
    base_mm: [f64; 3],
    base_sigma_mm: [f64; 3],
    angles_deg: [f64; 3],
    angles_sigma_deg: [f64; 3],
    ci95: Ci,
    // Extensions.
    seed: u64,
    mm_per_unit: f64,
    n_candidates: usize,
    ci95_bca: Option<Ci>,
    first_order: FirstOrder,
    bootstrap_mean: Means,
    bootstrap_bias: Means,
    failures: Vec<FailureJson<'a>>,
    resampled: &'static str,
    n_resampled: usize,
    covariance_tangent: [[f64; 6]; 6],
}

impl TieResult {
    /// Builds the result from a finished bootstrap.
    pub fn from_bootstrap(
        config: &TieConfig,
        lb: &LinkBootstrap,
        params: Vec<ParamSummary>,
    ) -> Result<Self, Error> {
        let replicates: Vec<Rigid3> = lb.replicates.values_only().copied().collect();
        let spread = UncertainPose::from_samples(&replicates).map_err(|e| Error::Replicates {
            message: format!("covariance of the replicates: {e}"),
        })?;
        let link =
            UncertainPose::new(lb.estimate, spread.covariance).map_err(|e| Error::Replicates {
                message: format!("covariance of the replicates: {e}"),
            })?;
        Ok(TieResult {
            method: config.method,
            resample: lb.resample,
            iterations: config.iterations,
            seed: config.seed,
            mm_per_unit: config.mm_per_unit,
            n_candidates: lb.n_candidates,
            n_inliers: lb.n_inliers,
            n_resampled: lb.n_resampled(),
            link,
            replicate_mean: spread.b_from_a,
            replicates,
            replicate_index: lb.replicates.values.iter().map(|(i, _)| *i).collect(),
            failures: lb
                .replicates
                .failures
                .iter()
                .map(|f| (f.replicate, f.error.clone()))
                .collect(),
            params,
        })
    }

    /// The `covariance_tangent` of the contract: mm², mm·deg, deg².
    pub fn covariance_tangent_deg(&self) -> Mat6 {
        self.link.covariance_deg()
    }

    /// Warnings for stderr (failed replicates).
    pub fn warnings(&self) -> Vec<String> {
        match self.failures.first() {
            None => Vec::new(),
            Some((r, e)) => vec![format!(
                "{} of {} bootstrap replicates failed (first: replicate {r}: {e})",
                self.failures.len(),
                self.iterations
            )],
        }
    }

    fn output(&self) -> Output<'_> {
        let s = &self.params;
        let pick = |f: &dyn Fn(&ParamSummary) -> f64, off: usize| -> [f64; 3] {
            [f(&s[off]), f(&s[off + 1]), f(&s[off + 2])]
        };
        let ci = |off: usize| [s[off].ci95, s[off + 1].ci95, s[off + 2].ci95];
        let bca = |off: usize| -> Option<[[f64; 2]; 3]> {
            Some([s[off].ci95_bca?, s[off + 1].ci95_bca?, s[off + 2].ci95_bca?])
        };
        let c = self.covariance_tangent_deg();
        Output {
            method: self.method.name(),
            iterations: self.iterations,
            n_correspondences: self.n_inliers,
            failed_iterations: self.failures.len(),
            base_mm: pick(&|p| p.estimate, 0),
            base_sigma_mm: pick(&|p| p.sigma, 0),
            angles_deg: pick(&|p| p.estimate, 3),
            angles_sigma_deg: pick(&|p| p.sigma, 3),
            ci95: Ci {
                base_mm: ci(0),
                angles_deg: ci(3),
            },
            seed: self.seed,
            mm_per_unit: self.mm_per_unit,
            n_candidates: self.n_candidates,
            ci95_bca: bca(0).zip(bca(3)).map(|(b, g)| Ci {
                base_mm: b,
                angles_deg: g,
            }),
            first_order: FirstOrder {
                base_sigma_mm: pick(&|p| p.first_order_sigma, 0),
                angles_sigma_deg: pick(&|p| p.first_order_sigma, 3),
            },
            bootstrap_mean: Means {
                base_mm: pick(&|p| p.mean, 0),
                angles_deg: pick(&|p| p.mean, 3),
            },
            bootstrap_bias: Means {
                base_mm: pick(&|p| p.bias, 0),
                angles_deg: pick(&|p| p.bias, 3),
            },
            failures: self
                .failures
                .iter()
                .map(|(r, e)| FailureJson {
                    replicate: *r,
                    error: e,
                })
                .collect(),
            resampled: self.resample.name(),
            n_resampled: self.n_resampled,
            covariance_tangent: std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)])),
        }
    }

    /// Exactly what `crashrig bootstrap --json` prints.
    pub fn to_json(&self) -> serde_json::Value {
        // Serialising plain numbers, strings and arrays cannot fail; non-finite numbers
        // become null.
        serde_json::to_value(self.output()).unwrap_or(serde_json::Value::Null)
    }

    /// What `crashrig bootstrap` prints without `--json`.
    pub fn text_report(&self) -> String {
        use std::fmt::Write;
        let mut t = String::new();
        let resampled = match self.resample {
            Resample::Inliers => format!(
                "resampled: the {} RANSAC inliers (LM warm-started per replicate; the inlier \
                 selection is not bootstrapped)",
                self.n_inliers
            ),
            Resample::AllMatches => format!(
                "resampled: all {} candidate correspondences (LO-RANSAC + LM re-run per replicate)",
                self.n_candidates
            ),
        };
        let _ = writeln!(
            t,
            "B relative to A ({}), {} correspondences ({} candidates), {} replicates, {} failed, seed {}",
            self.method.name(),
            self.n_inliers,
            self.n_candidates,
            self.iterations,
            self.failures.len(),
            self.seed
        );
        let _ = writeln!(t, "{resampled}");
        let _ = writeln!(
            t,
            "{:<14} {:>14} {:>12} {:>12} {:>26}",
            "parameter", "estimate", "σ bootstrap", "σ 1st order", "95 % percentile interval"
        );
        for (j, p) in self.params.iter().enumerate() {
            let _ = writeln!(
                t,
                "{:<14} {:>14.4} {:>12.5} {:>12.5}   [{:.4}, {:.4}]",
                LABELS[j], p.estimate, p.sigma, p.first_order_sigma, p.ci95[0], p.ci95[1]
            );
        }
        let sp = self.link.sigma_position();
        let sr = self.link.sigma_rotation().map(f64::to_degrees);
        let _ = writeln!(
            t,
            "tangent σ (covariance_tangent): centre {:.5} {:.5} {:.5} mm, rotation about B's axes {:.5} {:.5} {:.5}°",
            sp.x, sp.y, sp.z, sr.x, sr.y, sr.z
        );
        t
    }

    /// Every successful replicate as CSV with the header [`REPLICATES_CSV_HEADER`]: the
    /// replicate index, the base (mm) and ω φ κ (deg) of its `A_from_B`, and its rotation
    /// tangent `log(R̄ᵀ·R)` about B's axes (deg) relative to the replicates' mean
    /// ([`TieResult::replicate_mean`]). The sample covariance (n − 1) of the columns
    /// `x_mm, y_mm, z_mm, tx_deg, ty_deg, tz_deg` is `covariance_tangent`.
    pub fn replicates_csv(&self) -> String {
        use std::fmt::Write;
        let mut t = String::with_capacity(128 * (self.replicates.len() + 1));
        t.push_str(REPLICATES_CSV_HEADER);
        t.push('\n');
        let mean = UncertainPose::certain(self.replicate_mean);
        for (r, p) in self.replicate_index.iter().zip(&self.replicates) {
            let q = link_parameters(p);
            let tan = mean.tangent_of(p);
            let d = f64::to_degrees;
            let _ = writeln!(
                t,
                "{r},{},{},{},{},{},{},{},{},{}",
                q[0],
                q[1],
                q[2],
                d(q[3]),
                d(q[4]),
                d(q[5]),
                d(tan[3]),
                d(tan[4]),
                d(tan[5])
            );
        }
        t
    }

    /// Writes what `crashrig bootstrap --plots DIR --replicates FILE` writes (each optional):
    /// the histograms ([`TieResult::plots`]) as the directory `plots`, replaced as a whole
    /// ([`crashrig_outdir::write_dir`]: an existing one may hold only these files, and a kill
    /// leaves old, none or new, never a mix), and the replicates
    /// ([`TieResult::replicates_csv`]) to `replicates` atomically
    /// ([`crashrig_outdir::write_file`]; a `replicates` inside `plots` is swapped in with the
    /// plots). The command and the Python module both call it.
    ///
    /// # Errors
    /// [`Error::Write`] naming the file or folder, and [`TieResult::plots`]'s errors.
    pub fn write_files(
        &self,
        plots: Option<&std::path::Path>,
        replicates: Option<&std::path::Path>,
    ) -> Result<(), Error> {
        let csv = || self.replicates_csv().into_bytes();
        let mut replicates_left = replicates;
        if let Some(dir) = plots {
            let mut files = self.plots()?;
            // A replicates file inside the plot directory is one of its files, swapped in with
            // them.
            let inside = replicates
                .filter(|r| r.parent() == Some(dir))
                .and_then(|r| r.file_name()?.to_str());
            if let Some(name) = inside {
                files.push((name.to_string(), csv()));
                replicates_left = None;
            }
            crashrig_outdir::write_dir(dir, &files)?;
        }
        if let Some(path) = replicates_left {
            crashrig_outdir::write_file(path, &csv())?;
        }
        Ok(())
    }

    /// The histograms of the six parameters (Figures 8–9): `(file name, bytes)` for
    /// `bootstrap_{x,y,z,omega,phi,kappa}.{png,svg}`.
    pub fn plots(&self) -> Result<Vec<(String, Vec<u8>)>, Error> {
        use crashrig_plot::{Format, histogram};
        let mut out = Vec::with_capacity(12);
        for (j, p) in self.params.iter().enumerate() {
            for (fmt, ext) in [(Format::Png, "png"), (Format::Svg, "svg")] {
                let bytes = histogram(
                    &p.values,
                    &[p.mean - p.sigma, p.mean + p.sigma],
                    &format!(
                        "{} over {} replicates (lines: mean ± σ)",
                        LABELS[j],
                        p.values.len()
                    ),
                    LABELS[j],
                    fmt,
                )
                .map_err(|e| Error::Replicates {
                    message: format!("plotting the {} histogram: {e}", PARAMS[j]),
                })?;
                out.push((format!("bootstrap_{}.{ext}", PARAMS[j]), bytes));
            }
        }
        Ok(out)
    }
}

fn check_config(c: &TieConfig) -> Result<(), Error> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(c.mm_per_unit) {
        return Err(Error::Option {
            option: "--mm-per-unit",
            message: format!(
                "--mm-per-unit must be a positive number, got {}",
                c.mm_per_unit
            ),
        });
    }
    if c.iterations < 2 {
        return Err(Error::Option {
            option: "--iterations",
            message: format!("--iterations must be at least 2, got {}", c.iterations),
        });
    }
    if !positive(c.max_error_px) {
        return Err(Error::Option {
            option: "--max-error-px",
            message: format!(
                "--max-error-px must be a positive number, got {}",
                c.max_error_px
            ),
        });
    }
    if let Some(b) = c.base_mm
        && !positive(b)
    {
        return Err(Error::Option {
            option: "--base-mm",
            message: format!("--base-mm must be a positive number, got {b}"),
        });
    }
    Ok(())
}

/// The tie bootstrap as `crashrig bootstrap` runs it: reads the model and database, extracts
/// the correspondences, estimates B relative to A on the full sample, bootstraps
/// `config.iterations` replicates (with the jackknife for BCa) and summarises.
///
/// `monitor` (optional) gets `(done, total)` over the replicates and then the jackknife's
/// leave-one-out values (see [`bootstrap_link`]) and may cancel; the result is the same with
/// and without it.
///
/// # Errors
/// Every [`Error`]; [`Error::Cancelled`] when `monitor` cancelled the run.
pub fn bootstrap(config: &TieConfig, monitor: Option<&dyn Monitor>) -> Result<TieResult, Error> {
    check_config(config)?;
    let src = TieSource::open(
        &config.model,
        &config.database,
        &config.image_a,
        &config.image_b,
        config.mm_per_unit,
    )?;
    let mut ransac = RansacOptions::new(config.seed);
    ransac.max_error_px = config.max_error_px;
    let options = LinkBootstrapOptions {
        iterations: config.iterations,
        seed: config.seed,
        ransac,
        resample: config.resample,
        jackknife: true,
    };
    let lb = match config.method {
        Method::Absolute => {
            let c = src.absolute(config.mm_per_unit)?;
            let n = c.pixels_b.len();
            let input = LinkInput::Absolute(AbsoluteInput {
                camera_b: c.b.camera.clone(),
                pixels_b: c.pixels_b,
                points_mm: c.points_mm,
                a_from_world: c.a.cam_from_world,
            });
            bootstrap_link(&input, &options, monitor).map_err(|e| {
                Error::estimation(e, &config.model, || {
                    format!(
                        "image {:?} ({n} observations of 3-D points)",
                        config.image_b
                    )
                })
            })?
        }
        Method::Relative => {
            let set = match config.resample {
                Resample::Inliers => MatchSet::Verified,
                Resample::AllMatches => MatchSet::Raw,
            };
            let m = src.matches(set)?;
            let base_mm = match config.base_mm {
                Some(b) => b,
                None => {
                    let d = m.model_base_mm;
                    if d.is_nan() || d <= 0.0 {
                        return Err(Error::Model {
                            path: config.model.clone(),
                            message: format!(
                                "images {:?} and {:?} have the same projection centre; give --base-mm",
                                config.image_a, config.image_b
                            ),
                        });
                    }
                    d
                }
            };
            let what = match set {
                MatchSet::Verified => "verified matches",
                MatchSet::Raw => "candidate matches",
            };
            let n = m.pixels_a.len();
            let ModelImage { camera: cam_a, .. } = m.a;
            let input = LinkInput::Relative(RelativeInput {
                camera_a: cam_a,
                camera_b: m.b.camera,
                pixels_a: m.pixels_a,
                pixels_b: m.pixels_b,
                base_mm,
            });
            bootstrap_link(&input, &options, monitor).map_err(|e| {
                Error::estimation(e, &config.database, || {
                    format!("{n} {what} {:?}-{:?}", config.image_a, config.image_b)
                })
            })?
        }
    };
    let params = summarize(&lb)?;
    TieResult::from_bootstrap(config, &lb, params)
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
