//! The JSON documents of the study crate as serde structs: `calibrate --json`
//! ([`CalibrationDocument`], built by [`crate::calibration::CalibrationResult::document`]) and a
//! study's `results.json` ([`StudyDocument`], built by
//! [`crate::StudyResult::document`]).
//!
//! Both are written through their `to_json` value, whose object keys serde_json sorts; the fields
//! of this module are declared in that order (alphabetical), so serialising
//! [`CalibrationDocument`] directly gives the same bytes too ([`StudyDocument`] also holds the
//! grid and measure summaries of other modules, declared in their own order). A non-finite
//! number is `null`. Every field is documented for users in `docs/CALIBRATE.md` and
//! `docs/REFERENCE.md`.
//!
//! # Example
//! ```
//! use crashrig_study::contract::ScaleDocument;
//! let s = ScaleDocument::source("mm_per_unit");
//! assert_eq!(serde_json::to_string(&s).unwrap(), r#"{"source":"mm_per_unit"}"#);
//! ```

use crashrig_geometry::Mat6;
use crashrig_grid::summary::GridSummary;
use crashrig_measure::output::Summary as MeasureSummary;
use serde::Serialize;

/// A 6×6 covariance (mm, rad) in the contract's units (mm, deg) as rows.
pub fn covariance_deg_rows(c: &Mat6) -> Vec<[f64; 6]> {
    let k = [
        1.0,
        1.0,
        1.0,
        180.0 / std::f64::consts::PI,
        180.0 / std::f64::consts::PI,
        180.0 / std::f64::consts::PI,
    ];
    (0..6)
        .map(|i| std::array::from_fn(|j| c[(i, j)] * k[i] * k[j]))
        .collect()
}

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

/// A study's `results.json`: `calibration` and `tie` exactly as `calibrate --json` and
/// `bootstrap --json` print them, the propagation, each layout's summary and, with
/// `[measure]`, the measured sequence.
#[derive(Debug, Clone, Serialize)]
pub struct StudyDocument {
    /// The calibration.
    pub calibration: CalibrationDocument,
    /// The calibration's quality values the report judges it by (the split-half check and the
    /// reprojection residuals per camera).
    pub calibration_quality: CalibrationQualityDocument,
    /// One entry per layout.
    pub layouts: Vec<LayoutDocument>,
    /// The measured sequence (absent without `[measure]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measure: Option<MeasureDocument>,
    /// The chain's propagation.
    pub propagation: PropagationDocument,
    /// Grid draws per point.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
    /// The tie as `bootstrap --json` prints it ([`crate::tie::TieResult::to_json`]; `null`
    /// without a tie).
    pub tie: Option<serde_json::Value>,
}

/// [`StudyDocument::calibration_quality`]: [`crate::calibration::SplitHalf`] and
/// [`crate::calibration::Reprojection`] as the report shows them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationQualityDocument {
    /// Per camera (A first): the reprojection residuals of the calibration model.
    pub reprojection: Vec<ReprojectionDocument>,
    /// The split-half check (`null` below 4 epochs).
    pub split_half: Option<SplitHalfDocument>,
}

/// One entry of [`CalibrationQualityDocument::reprojection`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReprojectionDocument {
    /// Images of the camera with a pose.
    pub images: usize,
    /// Largest residual length, px (`null` without observations).
    pub max_px: f64,
    /// Median residual length, px (`null` without observations).
    pub median_px: f64,
    /// Observations of a 3-D point.
    pub observations: usize,
    /// `A` or `B`.
    pub role: String,
    /// The camera selector.
    pub selector: String,
    /// σ per image axis, px (`null` without observations).
    pub sigma_px: f64,
}

/// [`CalibrationQualityDocument::split_half`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SplitHalfDocument {
    /// Every |z| ≤ `bound_z`: the halves agree.
    pub agree: bool,
    /// The agreement bound on |difference| / σ.
    pub bound_z: f64,
    /// Second half's mean link minus the first's (x y z mm, θx θy θz deg; tangent about the
    /// first).
    pub difference: [f64; 6],
    /// The largest |difference| / σ.
    pub max_z: f64,
    /// Epochs of the first half.
    pub n_first: usize,
    /// Epochs of the second half.
    pub n_second: usize,
    /// The axes' names (`x y z θx θy θz`).
    pub order: [&'static str; 6],
    /// σ of the difference (mm, deg).
    pub sigma: [f64; 6],
    /// |difference| / σ per axis.
    pub z: [f64; 6],
}

/// [`StudyDocument::propagation`].
#[derive(Debug, Clone, Serialize)]
pub struct PropagationDocument {
    /// The propagated cameras.
    pub cameras: Vec<ChainCameraDocument>,
    /// `tangent`.
    pub rotation_noise: &'static str,
    /// Chain draws.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
}

/// One camera of [`PropagationDocument::cameras`]: Monte Carlo statistics of its world pose.
#[derive(Debug, Clone, Serialize)]
pub struct ChainCameraDocument {
    /// Nominal ω φ κ, deg.
    pub angles_deg: [f64; 3],
    /// σ of ω φ κ, deg.
    pub angles_sigma_deg: [f64; 3],
    /// ω φ κ near the singularity (|φ| → 90°).
    pub angles_singular: bool,
    /// Tangent covariance, mm and deg.
    pub covariance_tangent: Vec<[f64; 6]>,
    /// First-order propagation of the same inputs.
    pub linear: LinearDocument,
    /// `outward`, `inward` or `tie`.
    pub name: &'static str,
    /// Nominal position, mm.
    pub position_mm: [f64; 3],
    /// σ of the position, mm.
    pub position_sigma_mm: [f64; 3],
    /// σ of the tangent rotation, deg.
    pub tangent_sigma_deg: [f64; 3],
}

/// [`ChainCameraDocument::linear`].
#[derive(Debug, Clone, Serialize)]
pub struct LinearDocument {
    /// σ of ω φ κ, deg (`null` at the singularity).
    pub angles_sigma_deg: Option<[f64; 3]>,
    /// Tangent covariance, mm and deg.
    pub covariance_tangent: Vec<[f64; 6]>,
    /// σ of the position, mm.
    pub position_sigma_mm: [f64; 3],
    /// σ of the tangent rotation, deg.
    pub tangent_sigma_deg: [f64; 3],
}

/// One entry of [`StudyDocument::layouts`].
#[derive(Debug, Clone, Serialize)]
pub struct LayoutDocument {
    /// The Monte Carlo ran with correlated observers.
    pub correlated: bool,
    /// The layout's description.
    pub description: String,
    /// Its output directory (`grid/<slug>`).
    pub dir: String,
    /// The layout's name.
    pub name: String,
    /// The observers with their resolved σ.
    pub observers: Vec<ObserverDocument>,
    /// The one-at-a-time sensitivity.
    pub sensitivity: Vec<Sensitivity>,
    /// The grid summary.
    pub summary: GridSummary,
    /// The layout's answer on the report's first screen (worst-direction σ; not-measurable
    /// points counted apart).
    pub verdict: LayoutVerdict,
}

/// One entry of [`LayoutDocument::observers`].
#[derive(Debug, Clone, Serialize)]
pub struct ObserverDocument {
    /// Tangent covariance, mm and deg.
    pub covariance_tangent: Vec<[f64; 6]>,
    /// The chain camera it is (`null` for a given σ).
    pub from: Option<&'static str>,
    /// The observer's name.
    pub name: String,
    /// Its position, mm.
    pub position_mm: [f64; 3],
    /// σ of its tangent rotation, deg.
    pub sigma_angles_deg: [f64; 3],
    /// σ of its position, mm.
    pub sigma_position_mm: [f64; 3],
}

/// The one-at-a-time sensitivity of a layout to one input.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    /// Fraction below the threshold with that input's σ halved.
    pub fraction_below_threshold: f64,
    /// Worst-direction σ (mm) at the layout's hot spot
    /// ([`HotSpot`]) with that input's σ halved (`None` when nothing is
    /// measurable).
    pub hot_spot_sigma_worst_mm: Option<f64>,
    /// The input whose σ is halved (`outward`, `link` (calibration), `tie`, or an observer's
    /// name for a given σ).
    pub input: String,
    /// Median σ_max (mm) with that input's σ halved.
    pub median_sigma_max_mm: f64,
    /// Median worst-direction σ (mm, over the measurable points) with that input's σ halved
    /// (`None` when nothing is measurable).
    pub median_sigma_worst_mm: Option<f64>,
}

/// One layout's answer (fields in `results.json`'s sorted key order).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LayoutVerdict {
    /// Bounding box of the measurable points at or above the threshold, `[[x_lo, x_hi],
    /// [y_lo, y_hi], [z_lo, z_hi]]` (mm, vehicle); `None` when every measurable point is below.
    pub above_threshold_box_mm: Option<[[f64; 2]; 3]>,
    /// The input whose halved σ lowers the median worst-direction σ most (`None` without
    /// sensitivity runs).
    pub dominant_input: Option<DominantInput>,
    /// Share of all grid points that are measurable.
    pub fraction_measurable: f64,
    /// Of the measurable points, the share whose worst-direction σ is below the threshold
    /// (0 when none is measurable).
    pub fraction_below_threshold_of_measurable: f64,
    /// The measurable point with the largest worst-direction σ and why it is worst (`None`
    /// when no point is measurable).
    pub hot_spot: Option<HotSpot>,
    /// Median worst-direction σ over the measurable points (mm; `None` when none is).
    pub median_sigma_worst_mm: Option<f64>,
    /// Grid points.
    pub points: usize,
    /// Measurable points whose worst-direction σ is at or above the threshold.
    pub points_above_threshold: usize,
    /// Measurable points whose worst-direction σ is below the threshold.
    pub points_below_threshold: usize,
    /// Points seen by two or more cameras whose rays meet at less than the smallest
    /// intersection angle (not measurable).
    pub points_degenerate: usize,
    /// Points with a worst-direction σ (seen by two or more cameras, not degenerate).
    pub points_measurable: usize,
    /// Points seen by fewer than two cameras (not measurable).
    pub points_seen_by_fewer_than_two: usize,
    /// Every point is measurable and below the threshold in every direction.
    pub reached: bool,
    /// Always `worst_direction`: the σ every number here is.
    pub sigma: &'static str,
    /// The threshold (mm).
    pub threshold_mm: f64,
}

/// [`LayoutVerdict::hot_spot`]: the worst measurable point and what makes it worst.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HotSpot {
    /// The input whose halved σ lowers the σ at this point most, with that σ (`None` without
    /// sensitivity runs).
    pub dominant_input: Option<DominantInput>,
    /// The largest angle (deg) between the lines of sight of two cameras that see the point:
    /// the error along the rays grows as 1 / sin(angle).
    pub intersection_angle_deg: f64,
    /// The median of that angle over the measurable points (deg), for comparison.
    pub median_intersection_angle_deg: f64,
    /// Cameras that see the point.
    pub observers_seen: usize,
    /// The point (mm, vehicle).
    pub point_mm: [f64; 3],
    /// Its worst-direction σ (mm).
    pub sigma_worst_mm: f64,
}

/// An input of the one-at-a-time sensitivity and its effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DominantInput {
    /// `outward`, `link`, `tie` or `observer <name>`.
    pub input: String,
    /// The worst-direction σ (mm) with that input's σ halved: the median over the grid
    /// ([`LayoutVerdict::dominant_input`]) or the σ at the hot spot ([`HotSpot::dominant_input`]).
    pub sigma_worst_halved_mm: f64,
    /// The same without halving (mm).
    pub sigma_worst_mm: f64,
}

/// [`StudyDocument::measure`].
#[derive(Debug, Clone, Serialize)]
pub struct MeasureDocument {
    /// A's bundle covariance (`a_covariance = "bundle"`), without its matrices.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub a_covariance: Option<ACovarianceSummary>,
    /// `measure`.
    pub dir: &'static str,
    /// The numbers of `measure/summary.json`.
    pub summary: MeasureSummary,
}

/// [`MeasureDocument::a_covariance`]: the numbers of `measure/a_covariance.json` (what
/// `crashrig covariance --out` writes) and σ per epoch; the per-epoch and joint matrices are in
/// that file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ACovarianceSummary {
    /// Control points observed.
    pub control_points: usize,
    /// Per epoch: centre and σ of A's pose.
    pub epoch_sigmas: Vec<crashrig_covariance::contract::EpochSigmas>,
    /// `measure/a_covariance.json`.
    pub file: &'static str,
    /// Frames (pose unknowns) in the system.
    pub frames: usize,
    /// Which intrinsics were marginalised.
    pub intrinsics: &'static str,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// Observations used.
    pub observations: usize,
    /// Unknowns.
    pub parameters: usize,
    /// The pixel σ used, px.
    pub pixel_sigma_px: f64,
    /// Points of the model left out.
    pub points_left_out: usize,
    /// Redundancy.
    pub redundancy: i64,
    /// The a-posteriori σ̂₀, px.
    pub sigma0_px: Option<f64>,
}
