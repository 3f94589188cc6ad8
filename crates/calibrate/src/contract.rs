//! The `crashrig calibrate --json` document as serde structs ([`CalibrationDocument`], built by
//! [`crate::CalibrationResult::document`]; also `calibration` of a study's `results.json` and
//! its `calibration.json`).
//!
//! It is written through its `to_json` value, whose object keys serde_json sorts; the fields
//! of this module are declared in that order (alphabetical), so serialising
//! [`CalibrationDocument`] directly gives the same bytes too. A non-finite number is `null`.
//! Every field is documented for users in `docs/CALIBRATE.md` and `docs/REFERENCE.md`.
//!
//! # Example
//! ```
//! use crashrig_calibrate::contract::ScaleDocument;
//! let s = ScaleDocument::source("mm_per_unit");
//! assert_eq!(serde_json::to_string(&s).unwrap(), r#"{"source":"mm_per_unit"}"#);
//! ```

use serde::Serialize;

/// A 6×6 covariance in the contract's units (mm, deg), by rows.
pub type CovarianceRows = Vec<Vec<f64>>;

/// `crashrig calibrate --json` (and `calibration` of `results.json`, `calibration.json`): the
/// contract's statistics over all epochs and the extension fields of `docs/CALIBRATE.md`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationDocument {
    /// Mean ω φ κ of `R_A_from_B` over the epochs, deg.
    pub angles_deg: [f64; 3],
    /// σ/√n of ω φ κ, deg.
    pub angles_sem_deg: [f64; 3],
    /// σ of ω φ κ, deg.
    pub angles_sigma_deg: [f64; 3],
    /// The drift report (lag autocorrelations), `null` below three epochs.
    pub autocorrelation: Option<DriftDocument>,
    /// Mean base (B's centre in A's frame), mm.
    pub base_mm: [f64; 3],
    /// σ/√n of the base, mm.
    pub base_sem_mm: [f64; 3],
    /// σ of the base, mm.
    pub base_sigma_mm: [f64; 3],
    /// Camera A's selector.
    pub camera_a: String,
    /// Camera B's selector.
    pub camera_b: String,
    /// Covariance of the six parameters (x y z ω φ κ), mm and deg.
    pub covariance: CovarianceRows,
    /// Tangent covariance of one epoch's link.
    pub covariance_tangent: CovarianceRows,
    /// Effective number of epochs per tangent axis.
    pub effective_n: [f64; 6],
    /// Per epoch: its link and robust z-scores.
    pub epochs: Vec<EpochDocument>,
    /// The mean link `A_from_B`.
    pub link: LinkDocument,
    /// ω φ κ of the SO(3) mean rotation, deg.
    pub mean_rotation_angles_deg: [f64; 3],
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// The model directory.
    pub model: String,
    /// Epochs.
    pub n_epochs: usize,
    /// Epochs flagged as outliers.
    pub n_outliers: usize,
    /// The rule that flags an outlier.
    pub outlier_rule: String,
    /// The robust z threshold.
    pub outlier_threshold: f64,
    /// The threshold per parameter.
    pub outlier_thresholds: [f64; 6],
    /// How the epochs were paired.
    pub pairing: PairingDocument,
    /// The rig-constrained refinement, if run.
    pub refined: Option<RefinedDocument>,
    /// The refinement without the outliers, if run.
    pub refined_without_outliers: Option<RefinedDocument>,
    /// Every epoch gives the same link (accepted for inspection).
    pub rig_constrained: bool,
    /// Where the scale comes from.
    pub scale: ScaleDocument,
    /// Model units → mm (same as `mm_per_unit`).
    pub scale_factor: f64,
    /// The tangent covariance of the mean link (what a chain uses).
    pub sem_covariance_tangent: CovarianceRows,
    /// How the SEM was computed per axis.
    pub sem_detail: SemDetailDocument,
    /// Whether each axis' SEM is reliable (effective n ≥ 10).
    pub sem_reliable: [bool; 6],
    /// The SEM rule.
    pub sem_rule: String,
    /// Warnings of the calibration.
    pub warnings: Vec<String>,
    /// The statistics without the outliers (`null` without outliers or below two epochs).
    pub without_outliers: Option<LinkStatisticsDocument>,
}

/// The statistics of a set of epochs (`without_outliers`; the top-level fields of
/// [`CalibrationDocument`] over all epochs have the same names).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkStatisticsDocument {
    /// Mean ω φ κ, deg.
    pub angles_deg: [f64; 3],
    /// σ/√n of ω φ κ, deg.
    pub angles_sem_deg: [f64; 3],
    /// σ of ω φ κ, deg.
    pub angles_sigma_deg: [f64; 3],
    /// Mean base, mm.
    pub base_mm: [f64; 3],
    /// σ/√n of the base, mm.
    pub base_sem_mm: [f64; 3],
    /// σ of the base, mm.
    pub base_sigma_mm: [f64; 3],
    /// Covariance of x y z ω φ κ, mm and deg.
    pub covariance: CovarianceRows,
    /// ω φ κ of the SO(3) mean rotation, deg.
    pub mean_rotation_angles_deg: [f64; 3],
    /// Epochs.
    pub n_epochs: usize,
}

/// [`CalibrationDocument::autocorrelation`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriftDocument {
    /// Effective n per parameter.
    pub effective_n: [f64; 6],
    /// Autocorrelation per parameter and lag.
    pub lags: [Vec<f64>; 6],
    /// The parameters' names (`x y z omega phi kappa`).
    pub order: [&'static str; 6],
    /// SEM inflation per parameter.
    pub sem_inflation: [f64; 6],
    /// σ/√n likely optimistic per parameter.
    pub sem_optimistic: [bool; 6],
    /// Any parameter optimistic.
    pub warning: bool,
    /// The white-noise band of the lag-1 autocorrelation.
    pub white_noise_band: f64,
}

/// One entry of [`CalibrationDocument::epochs`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EpochDocument {
    /// ω φ κ of the epoch's link, deg.
    pub angles_deg: [f64; 3],
    /// The epoch's base, mm.
    pub base_mm: [f64; 3],
    /// The epoch name.
    pub name: String,
    /// Flagged as an outlier.
    pub outlier: bool,
    /// Robust z-scores of x y z ω φ κ.
    pub z_scores: [f64; 6],
}

/// [`CalibrationDocument::link`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkDocument {
    /// ω φ κ of the mean link, deg.
    pub angles_deg: [f64; 3],
    /// Centre of B in A's frame, mm.
    pub base_mm: [f64; 3],
}

/// [`CalibrationDocument::pairing`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairingDocument {
    /// Epochs paired by frame.
    pub by_frame: usize,
    /// Epochs paired by name.
    pub by_name: usize,
    /// Images of A without a partner.
    pub unpaired_a: Vec<String>,
    /// Images of B without a partner.
    pub unpaired_b: Vec<String>,
    /// Images without a pose.
    pub without_pose: Vec<String>,
}

/// [`CalibrationDocument::scale`]: `source` (`scale_bar`, `mm_per_unit`, `default`) and, for a
/// scale bar, its points, length and model distance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScaleDocument {
    /// The bar's distance in model units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_units: Option<f64>,
    /// The bar's known length, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_mm: Option<f64>,
    /// The bar's two point3D ids.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point_ids: Option<[u64; 2]>,
    /// Where the scale comes from.
    pub source: &'static str,
}

impl ScaleDocument {
    /// A scale without a bar (`mm_per_unit` or `default`).
    pub fn source(source: &'static str) -> Self {
        ScaleDocument {
            distance_units: None,
            length_mm: None,
            point_ids: None,
            source,
        }
    }
}

/// [`CalibrationDocument::sem_detail`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SemDetailDocument {
    /// Autocorrelated per tangent axis.
    pub autocorrelated: [bool; 6],
    /// Drift correlation per axis.
    pub drift_rho: [f64; 6],
    /// Share of the variance from drift per axis.
    pub drift_share: [f64; 6],
    /// Lag-1 autocorrelation per axis.
    pub lag1: [f64; 6],
    /// The tangent axes' names.
    pub order: [&'static str; 6],
    /// Small-sample factor per axis.
    pub small_sample_factor: [f64; 6],
    /// Variance inflation per axis.
    pub variance_inflation: [f64; 6],
}

/// [`CalibrationDocument::refined`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefinedDocument {
    /// ω φ κ, deg.
    pub angles_deg: [f64; 3],
    /// σ of ω φ κ, deg.
    pub angles_sigma_deg: [f64; 3],
    /// Base, mm.
    pub base_mm: [f64; 3],
    /// σ of the base, mm.
    pub base_sigma_mm: [f64; 3],
    /// Covariance of x y z ω φ κ.
    pub covariance: CovarianceRows,
    /// Tangent covariance (raised to the SEM floor).
    pub covariance_tangent: CovarianceRows,
    /// Tangent covariance of the normal equations alone.
    pub covariance_tangent_independent: CovarianceRows,
    /// The floor's factor per axis.
    pub floor_factors: [f64; 6],
    /// Gauss–Newton steps.
    pub iterations: usize,
    /// Unknowns.
    pub n_unknowns: usize,
    /// Redundancy.
    pub redundancy: usize,
    /// σ of the position, mm.
    pub sigma_position_mm: [f64; 3],
    /// σ of the rotation, deg.
    pub sigma_rotation_deg: [f64; 3],
    /// The variance factor.
    pub variance_factor: f64,
    /// What the refinement's covariance is.
    pub what: &'static str,
}
