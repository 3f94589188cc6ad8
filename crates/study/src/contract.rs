//! The JSON document of a study as serde structs: `results.json` ([`StudyDocument`], built by
//! [`crate::StudyResult::document`]). Its `calibration` is `crashrig_calibrate`'s
//! [`CalibrationDocument`] (the `calibrate --json` document) and its `tie` the
//! `bootstrap --json` document of `crashrig_tie`.
//!
//! It is written through its `to_json` value, whose object keys serde_json sorts; the fields
//! of this module are declared in that order (alphabetical), so serialising a document
//! directly gives the same bytes too ([`StudyDocument`] also holds the grid and measure
//! summaries of other crates, declared in their own order). A non-finite number is `null`.
//! Every field is documented for users in `docs/REFERENCE.md`.
//!
//! # Example
//! ```
//! use crashrig_study::contract::covariance_deg_rows;
//! let rows = covariance_deg_rows(&crashrig_geometry::Mat6::identity());
//! assert_eq!(rows[0][0], 1.0);
//! let deg_per_rad = 180.0 / std::f64::consts::PI;
//! assert_eq!(rows[3][3], deg_per_rad * deg_per_rad);
//! ```

use crashrig_calibrate::contract::CalibrationDocument;
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
    /// The tie as `bootstrap --json` prints it ([`crashrig_tie::TieResult::to_json`]; `null`
    /// without a tie).
    pub tie: Option<serde_json::Value>,
}

/// [`StudyDocument::calibration_quality`]: [`crashrig_calibrate::SplitHalf`] and
/// [`crashrig_calibrate::Reprojection`] as the report shows them.
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
