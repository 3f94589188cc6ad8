//! The whole calibration of a sequence: links, statistics with and without outliers, drift,
//! and the rig-constrained refinement.

use crate::drift::{DriftReport, drift_report};
use crate::refine::{RefineOptions, Refinement, refine};
use crate::robust::{OutlierReport, flag_outliers};
use crate::stats::{LinkStatistics, link_statistics};
use crate::{Epoch, Error, Link, links_of};

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateOptions {
    /// Largest lag of the autocorrelation report.
    pub max_lag: usize,
    /// Run the rig-constrained refinement (`None`: skip it).
    pub refine: Option<RefineOptions>,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        Self {
            max_lag: 10,
            refine: Some(RefineOptions::default()),
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
    /// Autocorrelation and effective-n report (`None` for fewer than three epochs).
    pub drift: Option<DriftReport>,
    /// Rig-constrained refinement over all epochs (`None` when not requested).
    pub refined: Option<Refinement>,
    /// Rig-constrained refinement over the epochs not flagged (`None` when not requested,
    /// when no epoch is flagged, or when fewer than two remain).
    pub refined_without_outliers: Option<Refinement>,
}

/// Calibrates the rig from `epochs` (poses in model units, `mm_per_unit` to mm).
///
/// # Errors
/// [`Error::TooFewEpochs`] for fewer than two epochs, and the errors of [`links_of`],
/// [`link_statistics`] and [`refine`].
pub fn calibrate(
    epochs: &[Epoch],
    mm_per_unit: f64,
    options: &CalibrateOptions,
) -> Result<Calibration, Error> {
    let links = links_of(epochs, mm_per_unit)?;
    let all = link_statistics(&links)?;
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
    let drift = if links.len() >= 3 {
        Some(drift_report(&links, options.max_lag)?)
    } else {
        None
    };
    let refined = match &options.refine {
        Some(o) => Some(refine(epochs, mm_per_unit, o)?),
        None => None,
    };
    let n_flagged = outliers.outlier.iter().filter(|o| **o).count();
    let refined_without_outliers = match &options.refine {
        Some(o) if n_flagged > 0 && kept.len() >= 2 => {
            let kept_epochs: Vec<Epoch> = epochs
                .iter()
                .zip(&outliers.outlier)
                .filter(|(_, o)| !**o)
                .map(|(e, _)| e.clone())
                .collect();
            Some(refine(&kept_epochs, mm_per_unit, o)?)
        }
        _ => None,
    };
    Ok(Calibration {
        mm_per_unit,
        links,
        all,
        outliers,
        without_outliers,
        drift,
        refined,
        refined_without_outliers,
    })
}
