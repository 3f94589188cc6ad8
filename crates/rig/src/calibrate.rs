//! The whole calibration of a sequence: links, statistics with and without outliers, drift,
//! the tangent covariance of one epoch's link and of the mean, and the rig-constrained
//! refinement (floored at the uncertainty of the mean).

use crate::drift::{DriftReport, drift_report};
use crate::refine::{RefineOptions, Refinement, refine};
use crate::robust::{OutlierReport, flag_outliers};
use crate::sem::{SemEstimate, sem_covariance, sem_iid};
use crate::stats::{LinkStatistics, link_statistics};
use crate::{Epoch, Error, Link, links_of};
use crashrig_geometry::{Rigid3, UncertainPose, Vec6};
use crashrig_stats::progress::{Monitor, Part};

/// Relative size, against the coordinates of the sequence, of a base spread at numerical zero
/// (10⁻¹⁰: ~10⁶ ulps; a measured spread is many orders of magnitude larger).
pub const ZERO_SPREAD_RELATIVE: f64 = 1e-10;
/// A rotation spread at numerical zero (rad).
pub const ZERO_SPREAD_RAD: f64 = 1e-10;

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateOptions {
    /// Largest lag of the autocorrelation report.
    pub max_lag: usize,
    /// Run the rig-constrained refinement (`None`: skip it).
    pub refine: Option<RefineOptions>,
    /// Accept a sequence whose links are identical (a rig-constrained bundle) instead of
    /// refusing it with [`Error::RigConstrained`]; its spread and SEM are then zero and no
    /// autocorrelation analysis is done.
    pub accept_rig_constrained: bool,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        Self {
            max_lag: 10,
            refine: Some(RefineOptions::default()),
            accept_rig_constrained: false,
        }
    }
}

/// Everything the calibration of one sequence reports.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The scale used (mm per model unit).
    pub mm_per_unit: f64,
    /// Per-epoch links, in input order.
    pub links: Vec<Link>,
    /// Statistics over all epochs.
    pub all: LinkStatistics,
    /// Robust scores and outlier flags.
    pub outliers: OutlierReport,
    /// Statistics over the epochs not flagged (`None` when fewer than two remain).
    pub without_outliers: Option<LinkStatistics>,
    /// Autocorrelation and effective-n report of ω φ κ and the base (`None` for fewer than
    /// three epochs, or for a spread at numerical zero).
    pub drift: Option<DriftReport>,
    /// The spread of one epoch's link: mean link (Karcher rotation, mean centre) with the
    /// covariance (n − 1) of the tangent residuals (mm, rad) — `covariance_tangent`.
    pub epoch_spread: UncertainPose,
    /// Tangent residual of each epoch's link about [`Calibration::epoch_spread`]'s nominal.
    pub residuals: Vec<Vec6>,
    /// The uncertainty of the mean link and its rule ([`crate::sem`]).
    pub sem: SemEstimate,
    /// The mean link with the uncertainty of the mean (`sem_covariance_tangent`).
    pub link: UncertainPose,
    /// True when every epoch gives the same link (accepted only with
    /// [`CalibrateOptions::accept_rig_constrained`]).
    pub rig_constrained: bool,
    /// Rig-constrained refinement over all epochs (`None` when not requested), its covariance
    /// floored at [`Calibration::sem`].
    pub refined: Option<Refinement>,
    /// Rig-constrained refinement over the epochs not flagged (`None` when not requested,
    /// when no epoch is flagged, or when fewer than two remain), floored likewise at the
    /// uncertainty of their mean.
    pub refined_without_outliers: Option<Refinement>,
}

/// The spread of `links` as an uncertain pose (mean and n − 1 tangent covariance) with the
/// residuals of each link about the mean.
///
/// # Errors
/// [`Error::TooFewEpochs`] below two links; [`Error::Geometry`] when the rotations have no
/// mean.
pub fn epoch_spread(links: &[Link]) -> Result<(UncertainPose, Vec<Vec6>), Error> {
    if links.len() < 2 {
        return Err(Error::TooFewEpochs {
            what: "link statistics",
            needed: 2,
            found: links.len(),
        });
    }
    let samples: Vec<Rigid3> = links.iter().map(|l| l.a_from_b).collect();
    let spread = UncertainPose::from_samples(&samples)?;
    let residuals = samples.iter().map(|p| spread.tangent_of(p)).collect();
    Ok((spread, residuals))
}

/// True when the spread is at numerical zero: base σ ≤ [`ZERO_SPREAD_RELATIVE`] times the
/// largest coordinate of the sequence (camera A's centres and the base, mm, at least 1 mm)
/// and rotation σ ≤ [`ZERO_SPREAD_RAD`] on every axis. Returns (zero?, base σ, rotation σ).
fn zero_spread(epochs: &[Epoch], mm_per_unit: f64, spread: &UncertainPose) -> (bool, f64, f64) {
    let magnitude = epochs
        .iter()
        .map(|e| e.a_from_world.translation.vector.norm() * mm_per_unit)
        .fold(spread.center().norm().max(1.0), f64::max);
    let s_mm = spread.sigma_position().max();
    let s_rad = spread.sigma_rotation().max();
    (
        s_mm <= ZERO_SPREAD_RELATIVE * magnitude && s_rad <= ZERO_SPREAD_RAD,
        s_mm,
        s_rad,
    )
}

/// The spread, residuals and uncertainty of the mean of `links`.
fn spread_and_sem(
    links: &[Link],
    zero: bool,
) -> Result<(UncertainPose, Vec<Vec6>, SemEstimate), Error> {
    let (spread, residuals) = epoch_spread(links)?;
    let sem = if zero {
        sem_iid(&spread.covariance, links.len())
    } else {
        sem_covariance(&residuals, &spread.covariance)
    };
    Ok((spread, residuals, sem))
}

/// Calibrates the rig from `epochs` (poses in model units, `mm_per_unit` to mm).
///
/// `monitor` (optional) follows the refinements (the slow part): `(weighting rounds done,
/// rounds)` over the refinement of all epochs and, when epochs are flagged, the one without
/// them (see [`crate::refine::refine`]), and may cancel between rounds; the result is the same
/// with and without it.
///
/// # Errors
/// [`Error::TooFewEpochs`] for fewer than two epochs, [`Error::RigConstrained`] when every
/// epoch gives the same link and [`CalibrateOptions::accept_rig_constrained`] is false, the
/// errors of [`links_of`], [`link_statistics`] and [`crate::refine::refine`], and
/// [`Error::Cancelled`].
pub fn calibrate(
    epochs: &[Epoch],
    mm_per_unit: f64,
    options: &CalibrateOptions,
    monitor: Option<&dyn Monitor>,
) -> Result<Calibration, Error> {
    let links = links_of(epochs, mm_per_unit)?;
    let all = link_statistics(&links)?;
    let (spread, _) = epoch_spread(&links)?;
    let (zero, spread_mm, spread_rad) = zero_spread(epochs, mm_per_unit, &spread);
    if zero && !options.accept_rig_constrained {
        return Err(Error::RigConstrained {
            n_epochs: links.len(),
            spread_mm,
            spread_rad,
        });
    }
    let (epoch_spread, residuals, sem) = spread_and_sem(&links, zero)?;
    let outliers = flag_outliers(&links)?;
    let kept: Vec<Link> = links
        .iter()
        .zip(&outliers.outlier)
        .filter(|(_, o)| !**o)
        .map(|(l, _)| l.clone())
        .collect();
    let without_outliers = if kept.len() >= 2 {
        Some(link_statistics(&kept)?)
    } else {
        None
    };
    // No autocorrelation analysis of rounding noise.
    let drift = if links.len() >= 3 && !zero {
        Some(drift_report(&links, options.max_lag)?)
    } else {
        None
    };
    let n_flagged = outliers.outlier.iter().filter(|o| **o).count();
    // Progress: refinement k of `parts` covers rounds k·R … (k + 1)·R of parts·R.
    let parts = if n_flagged > 0 && kept.len() >= 2 {
        2
    } else {
        1
    };
    let first = monitor.map(|m| Part::new(m, 0, parts));
    let second = monitor.map(|m| Part::new(m, 1, parts));
    let refined = match &options.refine {
        Some(o) => Some(
            refine(
                epochs,
                mm_per_unit,
                o,
                first.as_ref().map(|m| m as &dyn Monitor),
            )?
            .floored(&sem.covariance),
        ),
        None => None,
    };
    let refined_without_outliers = match &options.refine {
        Some(o) if n_flagged > 0 && kept.len() >= 2 => {
            let kept_epochs: Vec<Epoch> = epochs
                .iter()
                .zip(&outliers.outlier)
                .filter(|(_, o)| !**o)
                .map(|(e, _)| e.clone())
                .collect();
            let (_, _, kept_sem) = spread_and_sem(&kept, zero)?;
            Some(
                refine(
                    &kept_epochs,
                    mm_per_unit,
                    o,
                    second.as_ref().map(|m| m as &dyn Monitor),
                )?
                .floored(&kept_sem.covariance),
            )
        }
        _ => None,
    };
    let link = UncertainPose {
        b_from_a: epoch_spread.b_from_a,
        covariance: sem.covariance,
    };
    Ok(Calibration {
        mm_per_unit,
        links,
        all,
        outliers,
        without_outliers,
        drift,
        epoch_spread,
        residuals,
        sem,
        link,
        rig_constrained: zero,
        refined,
        refined_without_outliers,
    })
}
