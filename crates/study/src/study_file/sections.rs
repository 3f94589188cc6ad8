//! The typed sections of a validated study file.

use crashrig_geometry::{Mat6, UncertainPose, Vec3};
use std::path::PathBuf;

/// How the calibration sequence is scaled to mm.
#[derive(Debug, Clone, PartialEq)]
pub enum StudyScale {
    /// A scale bar: two point3D ids a known distance apart.
    ScaleBar {
        /// The two point3D ids.
        points: [u64; 2],
        /// Their distance (mm).
        length_mm: f64,
    },
    /// A fixed factor (mm per model unit).
    MmPerUnit(f64),
}

/// `[calibration]`: the rig link `A_from_B` from a sequence, as `crashrig calibrate` takes it.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationSection {
    /// COLMAP model directory (absolute after reading).
    pub model: PathBuf,
    /// Outward camera A: image-name prefix or camera id.
    pub camera_a: String,
    /// Inward camera B: image-name prefix or camera id.
    pub camera_b: String,
    /// Scale.
    pub scale: StudyScale,
    /// Largest lag of the autocorrelation check (default 10).
    pub max_lag: usize,
    /// Rig-constrained refinement (default true).
    pub refine: bool,
    /// Accept a model adjusted with a rig constraint (default false; see `calibrate
    /// --accept-rig-constrained`).
    pub accept_rig_constrained: bool,
}

/// Bootstrap method of the tie.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TieMethod {
    /// B resected from its observations of the model's 3-D points.
    Absolute,
    /// Essential matrix from the verified A–B matches, scale from the model.
    Relative,
}

/// What the tie bootstrap resamples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TieResample {
    /// The verified inliers only (default).
    Inliers,
    /// All matches (paper §2.3.1).
    AllMatches,
}

/// `[tie]`: a third camera tied to the inward camera by matching, as `crashrig bootstrap`
/// takes it. `image_a` is an image of the inward camera B, `image_b` one of the tied camera.
#[derive(Debug, Clone, PartialEq)]
pub struct TieSection {
    /// COLMAP database.
    pub database: PathBuf,
    /// COLMAP model directory.
    pub model: PathBuf,
    /// Image of the inward camera (the tie's reference A).
    pub image_a: String,
    /// Image of the tied camera.
    pub image_b: String,
    /// Method.
    pub method: TieMethod,
    /// Bootstrap replicates (default 500).
    pub iterations: usize,
    /// mm per model unit (default 1).
    pub mm_per_unit: f64,
    /// RANSAC inlier threshold (px, default 4).
    pub max_error_px: f64,
    /// Known base length (mm) for `relative` (default: from the model).
    pub base_mm: Option<f64>,
    /// What is resampled (default inliers).
    pub resample: TieResample,
}

/// Where an observer's pose noise comes from.
// A handful per study, never in a hot loop: boxing the matrix would only add indirection.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum ObserverNoise {
    /// The propagated world covariance of a chain camera (`from = "inward"` or `"tie"`).
    From(ChainCamera),
    /// A given covariance (mm, rad), centre in vehicle axes, rotation about its own axes.
    Given(Mat6),
}

/// The cameras of the study's chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainCamera {
    /// Camera A (world pose from `[outward]`).
    Outward,
    /// Camera B (A_from_B from `[calibration]`).
    Inward,
    /// The tied camera C (B_from_C from `[tie]`).
    Tie,
}

impl ChainCamera {
    /// Name used in the study file, the chain and `results.json`.
    pub fn name(self) -> &'static str {
        match self {
            ChainCamera::Outward => "outward",
            ChainCamera::Inward => "inward",
            ChainCamera::Tie => "tie",
        }
    }
}

/// An observer of a layout: an interior camera that aims at every grid point (the paper's
/// re-aiming, `aim = "point"`) or is bolted in place with a real lens (`aim = "fixed"`).
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    /// Label.
    pub name: String,
    /// Projection centre in the vehicle frame (mm).
    pub position_mm: Vec3,
    /// Its noise.
    pub noise: ObserverNoise,
    /// `aim = "fixed"`: orientation, lens and pixel noise (`None`: aimed at every point).
    pub fixed: Option<Box<crashrig_mc::FixedCamera>>,
}

/// A regularly spaced axis `[start, stop, count]` (mm).
pub type AxisSpec = [f64; 3];

/// `[[layout]]`: one arrangement of interior cameras over a grid, in the vehicle frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Name (file-name safe form used for `DIR/grid/<slug>/`).
    pub name: String,
    /// Free text shown in the report.
    pub description: String,
    /// x axis (mm): start, stop, count.
    pub x_mm: (f64, f64, usize),
    /// y axis (mm).
    pub y_mm: (f64, f64, usize),
    /// z axis (mm).
    pub z_mm: (f64, f64, usize),
    /// Threshold on σ_max (mm).
    pub threshold_mm: f64,
    /// Pixel noise σ (px) and focal length (px), optional.
    pub pixel: Option<(f64, f64)>,
    /// `correlated` as written: `Some(true)` draws the `from` observers jointly from one chain
    /// draw (the physical, rigid-body model), `Some(false)` independently; `None` (key absent)
    /// is the default [`crate::run_study`] resolves against the chain's nominal poses: jointly
    /// when at least two aimed `from` observers stand at their chain cameras, else
    /// independently.
    pub correlated: Option<bool>,
    /// At least two observers.
    pub observers: Vec<Observer>,
}

impl Layout {
    /// A file-name safe form of the name.
    pub fn slug(&self) -> String {
        let s: String = self
            .name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c.to_ascii_lowercase()
                } else {
                    '_'
                }
            })
            .collect();
        s.trim_matches('_').to_string()
    }
}

/// Camera A's per-epoch pose uncertainty in `[measure]`.
#[derive(Debug, Clone, PartialEq)]
pub enum MeasureANoise {
    /// `sigma_a_position_mm` (world axes, mm) and `sigma_a_angles_deg` (tangent, deg); zero
    /// when absent.
    Sigmas(Vec3, Vec3),
    /// `a_covariance`: a JSON file as `crashrig measure --a-covariance` takes it.
    File(PathBuf),
    /// `a_control_points` (with `a_model`, `a_pixel_sigma_px`, `a_intrinsics`): computed from
    /// the bundle by `crashrig_covariance::run` as a typed step of the study.
    Bundle(ABundle),
}

/// Camera A's covariance from the bundle (`[measure] a_control_points`): what `crashrig
/// covariance` takes; camera A and the scale are the section's `camera_a` and `mm_per_unit`.
#[derive(Debug, Clone, PartialEq)]
pub struct ABundle {
    /// `a_model`: the COLMAP model with A's epochs and the lab's points (default: `model`).
    pub model: PathBuf,
    /// `a_control_points`: the control-point CSV (`point3D_id`, optional `sigma_mm`).
    pub control_points: PathBuf,
    /// `a_pixel_sigma_px`: the pixel σ (px); `None`: the model's σ̂₀.
    pub pixel_sigma_px: Option<f64>,
    /// `a_intrinsics`: which intrinsics are marginalised (default `all`).
    pub intrinsics: crashrig_covariance::Intrinsics,
}

/// `[measure]`: a crash-test sequence measured with the study's calibrated link (and tie), as
/// `crashrig measure` takes it (paths relative to the study file, absolute after reading).
#[derive(Debug, Clone, PartialEq)]
pub struct MeasureSection {
    /// COLMAP model of the sequence (camera A registered against the lab per epoch).
    pub model: PathBuf,
    /// Camera A: image-name prefix or camera id (its images are the epochs).
    pub camera_a: String,
    /// Inward camera B: camera id or image-name prefix (intrinsics).
    pub camera_b: String,
    /// Tied-in camera C (needs `[tie]`): camera id or image-name prefix.
    pub camera_c: Option<String>,
    /// Marker observations CSV `epoch,camera,marker,u_px,v_px`.
    pub observations: PathBuf,
    /// Model units → mm (default 1).
    pub mm_per_unit: Option<f64>,
    /// A's per-epoch uncertainty.
    pub a_noise: MeasureANoise,
    /// σ of each pixel coordinate (px, default 0.5); with `pixel_sigma_px = "estimate"` the
    /// default, against which the check compares before its estimate replaces it.
    pub pixel_sigma_px: f64,
    /// `pixel_sigma_px = "estimate"`: the Monte Carlo uses the pixel σ check's estimate
    /// (needs camera C).
    pub pixel_sigma_from: crashrig_measure::pixel_check::PixelSigmaFrom,
    /// Replicates per row (default: the study's `samples`, or `--samples`).
    pub samples: Option<usize>,
    /// Reference epoch of the displacements (default: the first measured epoch).
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz): times and velocities; with `frame_times` the rate of their mean
    /// interval.
    pub frame_rate_hz: Option<f64>,
    /// `frame_times`: each frame's time from the camera's clock (CSV `epoch,time_s`, read when
    /// the study file is), the time axis instead of `frame_rate_hz`.
    pub frame_times: Option<crashrig_measure::input::FrameTimes>,
    /// Rows whose σ_max exceeds this are flagged (mm, default 5).
    pub threshold_mm: f64,
    /// Reprojection residual limit (px; default the robust limit of the sequence).
    pub max_reprojection_px: Option<f64>,
    /// `cfc` / `cfc_standard`: the CFC filter of the kinematics (needs `frame_rate_hz`; checked
    /// against it when the file is read); `None`: no kinematics.
    pub cfc: Option<crashrig_measure::filter::CfcSpec>,
    /// `sync_sigma_ms`: σ of camera A's trigger offset against the inward cameras (ms, default
    /// 0; > 0 needs `frame_rate_hz`).
    pub sync_sigma_ms: f64,
    /// `scale_bars`: the scale-bar CSV of the length check (as `measure --scale-bars`), if any.
    pub scale_bars: Option<PathBuf>,
    /// `mpe_mm`: the maximum permissible error of a bar's length (mm; needs `scale_bars`).
    pub mpe_mm: Option<f64>,
}

/// A validated study.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// The study file (as given).
    pub path: PathBuf,
    /// Its text (for line numbers of later errors).
    pub text: String,
    /// Master seed (default 1; `--seed` overrides).
    pub seed: u64,
    /// Monte Carlo draws per grid point (default 2000; `--samples` overrides).
    pub samples: usize,
    /// Monte Carlo draws of the chain propagation (default 200 000).
    pub chain_samples: usize,
    /// The rig calibration.
    pub calibration: CalibrationSection,
    /// The tie, if any.
    pub tie: Option<TieSection>,
    /// The outward camera's world pose `world_from_A` with its covariance (mm, rad).
    pub outward: UncertainPose,
    /// The layouts.
    pub layouts: Vec<Layout>,
    /// `reference = "kaminski2023"`: the report compares with the paper's published values.
    pub reference: Option<String>,
    /// `[measure]`: a test sequence to measure with the calibrated link, if any.
    pub measure: Option<MeasureSection>,
    /// Plausibility warnings found on reading (units are never guessed: a length or σ that
    /// looks typed in metres; [`units`](super::units)), one line each naming the file, line, key
    /// and unit, without the `warning: ` prefix. The study's warnings and its report repeat them.
    pub warnings: Vec<String>,
}
