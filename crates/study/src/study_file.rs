//! The study file (TOML): what `crashrig study` runs.
//!
//! Paths are relative to the study file. Frames (see `docs/REFERENCE.md`, "Study file"):
//! - the **world frame** is the lab frame in which the outward camera A's pose
//!   `world_from_A` is given (`[outward]`); the chain outward → inward (the calibrated link
//!   `A_from_B`) → tie (the bootstrapped link `B_from_C`) is composed in it;
//! - the **vehicle frame** of a `[[layout]]` (x forwards from the trunk opening, y left, z up)
//!   holds the grid and the observers' positions. An observer with `from = "inward"` takes the
//!   propagated world covariance of that chain camera unchanged: the vehicle axes are taken as
//!   parallel to the world axes (the covariance is not rotated).

use crate::Error;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use toml::Spanned;

pub mod units;

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
    /// σ of each pixel coordinate (px, default 0.5).
    pub pixel_sigma_px: f64,
    /// Replicates per row (default: the study's `samples`, or `--samples`).
    pub samples: Option<usize>,
    /// Reference epoch of the displacements (default: the first measured epoch).
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz): times and velocities.
    pub frame_rate_hz: Option<f64>,
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
    /// looks typed in metres; [`units`]), one line each naming the file, line, key and unit,
    /// without the `warning: ` prefix. The study's warnings and its report repeat them.
    pub warnings: Vec<String>,
}

// ---------------------------------------------------------------- raw TOML ---

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    seed: Option<u64>,
    samples: Option<Spanned<i64>>,
    chain_samples: Option<Spanned<i64>>,
    reference: Option<Spanned<String>>,
    calibration: Option<Spanned<RawCalibration>>,
    tie: Option<Spanned<RawTie>>,
    outward: Option<Spanned<RawPose>>,
    #[serde(default)]
    layout: Vec<Spanned<RawLayout>>,
    measure: Option<Spanned<RawMeasure>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMeasure {
    model: Option<Spanned<String>>,
    camera_a: Option<Spanned<String>>,
    camera_b: Option<Spanned<String>>,
    camera_c: Option<Spanned<String>>,
    observations: Option<Spanned<String>>,
    mm_per_unit: Option<Spanned<f64>>,
    sigma_a_position_mm: Option<Spanned<[f64; 3]>>,
    sigma_a_angles_deg: Option<Spanned<[f64; 3]>>,
    a_covariance: Option<Spanned<String>>,
    a_model: Option<Spanned<String>>,
    a_control_points: Option<Spanned<String>>,
    a_pixel_sigma_px: Option<Spanned<f64>>,
    a_intrinsics: Option<Spanned<String>>,
    pixel_sigma_px: Option<Spanned<f64>>,
    samples: Option<Spanned<i64>>,
    reference_epoch: Option<String>,
    frame_rate_hz: Option<Spanned<f64>>,
    threshold_mm: Option<Spanned<f64>>,
    max_reprojection_px: Option<Spanned<f64>>,
    cfc: Option<Spanned<i64>>,
    cfc_standard: Option<Spanned<String>>,
    sync_sigma_ms: Option<Spanned<f64>>,
    scale_bars: Option<Spanned<String>>,
    mpe_mm: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCalibration {
    model: Option<Spanned<String>>,
    camera_a: Option<Spanned<String>>,
    camera_b: Option<Spanned<String>>,
    scale_points: Option<Spanned<Vec<u64>>>,
    scale_length_mm: Option<Spanned<f64>>,
    mm_per_unit: Option<Spanned<f64>>,
    max_lag: Option<Spanned<i64>>,
    refine: Option<bool>,
    accept_rig_constrained: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTie {
    database: Option<Spanned<String>>,
    model: Option<Spanned<String>>,
    image_a: Option<Spanned<String>>,
    image_b: Option<Spanned<String>>,
    method: Option<Spanned<String>>,
    iterations: Option<Spanned<i64>>,
    mm_per_unit: Option<Spanned<f64>>,
    max_error_px: Option<Spanned<f64>>,
    base_mm: Option<Spanned<f64>>,
    resample: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPose {
    position_mm: Option<Spanned<[f64; 3]>>,
    angles_deg: Option<Spanned<[f64; 3]>>,
    sigma_position_mm: Option<Spanned<[f64; 3]>>,
    sigma_angles_deg: Option<Spanned<[f64; 3]>>,
    covariance_tangent: Option<Spanned<Vec<Vec<f64>>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayout {
    name: Option<Spanned<String>>,
    description: Option<String>,
    x_mm: Option<Spanned<[f64; 3]>>,
    y_mm: Option<Spanned<[f64; 3]>>,
    z_mm: Option<Spanned<[f64; 3]>>,
    threshold_mm: Option<Spanned<f64>>,
    pixel_sigma_px: Option<Spanned<f64>>,
    focal_px: Option<Spanned<f64>>,
    correlated: Option<bool>,
    #[serde(default)]
    observer: Vec<Spanned<RawObserver>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObserver {
    name: Option<String>,
    position_mm: Option<Spanned<[f64; 3]>>,
    from: Option<Spanned<String>>,
    sigma_position_mm: Option<Spanned<[f64; 3]>>,
    sigma_angles_deg: Option<Spanned<[f64; 3]>>,
    covariance_tangent: Option<Spanned<Vec<Vec<f64>>>>,
    aim: Option<Spanned<String>>,
    angles_deg: Option<Spanned<[f64; 3]>>,
    look_at_mm: Option<Spanned<[f64; 3]>>,
    camera: Option<Spanned<crashrig_mc::LensKeys>>,
    camera_from: Option<Spanned<String>>,
    pixel_sigma_px: Option<Spanned<f64>>,
}

pub(crate) use crashrig_input::location::line_of;

/// The line of `[name]` / `[[name]]` (the `n`-th occurrence), for errors about a section.
pub(crate) fn section_line(text: &str, name: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let l = l.split('#').next().unwrap_or("").trim();
            l == format!("[{name}]") || l == format!("[[{name}]]")
        })
        .nth(n)
        .map(|(i, _)| i + 1)
}

/// 1-based line of `key = …` in the `n`-th `[section]` (or `[[section]]`) of `text`, else of
/// the section header.
pub(crate) fn key_line(text: &str, section: &str, n: usize, key: &str) -> Option<usize> {
    let start = section_line(text, section, n)?;
    text.lines()
        .enumerate()
        .skip(start)
        .map(|(i, l)| (i, l.split('#').next().unwrap_or("").trim()))
        .take_while(|(_, l)| !l.starts_with('['))
        .find(|(_, l)| {
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map_or(Some(start), |(i, _)| Some(i + 1))
}

/// 1-based line of a top-level `key = …` (before the first section header).
pub(crate) fn key_line_top(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .take_while(|l| !l.starts_with('['))
        .position(|l| {
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|i| i + 1)
}

/// Keys of a study whose value is exactly three numbers (serde would silently drop a fourth).
const STUDY_THREE_VECTORS: &[&str] = &[
    "position_mm",
    "angles_deg",
    "sigma_position_mm",
    "sigma_angles_deg",
    "look_at_mm",
    "sigma_a_position_mm",
    "sigma_a_angles_deg",
    "x_mm",
    "y_mm",
    "z_mm",
];

/// The first 3-vector key of `text` whose array does not hold exactly three values:
/// (dotted key, 1-based line, length).
fn wrong_length_vector(text: &str) -> Option<(String, usize, usize)> {
    use toml::de::{DeTable, DeValue};
    fn walk(t: &DeTable<'_>, prefix: &str, text: &str) -> Option<(String, usize, usize)> {
        for (k, v) in t.iter() {
            let leaf = k.get_ref().as_ref();
            let key = if prefix.is_empty() {
                leaf.to_string()
            } else {
                format!("{prefix}.{leaf}")
            };
            match v.get_ref() {
                DeValue::Table(t) => {
                    if let Some(found) = walk(t, &key, text) {
                        return Some(found);
                    }
                }
                DeValue::Array(a) => {
                    for (i, e) in a.iter().enumerate() {
                        if let DeValue::Table(t) = e.get_ref()
                            && let Some(found) = walk(t, &format!("{key}[{i}]"), text)
                        {
                            return Some(found);
                        }
                    }
                    if STUDY_THREE_VECTORS.contains(&leaf) && a.len() != 3 {
                        return Some((key, line_of(text, v.span().start), a.len()));
                    }
                }
                _ => {}
            }
        }
        None
    }
    let doc = DeTable::parse(text).ok()?;
    walk(doc.get_ref(), "", text)
}

/// A number as the user would type it: `1e300`, not three hundred digits.
fn short(x: f64) -> String {
    if x.abs() >= 1e15 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
    dir: PathBuf,
}

impl Ctx<'_> {
    fn err<T>(
        &self,
        span: Option<std::ops::Range<usize>>,
        key: &str,
        message: impl Into<String>,
    ) -> Result<T, Error> {
        Err(Error::Key {
            path: self.path.to_path_buf(),
            line: span.map(|s| line_of(self.text, s.start)),
            key: key.to_string(),
            message: message.into(),
        })
    }

    fn required<'v, T>(
        &self,
        v: &'v Option<Spanned<T>>,
        section: std::ops::Range<usize>,
        key: &str,
    ) -> Result<&'v Spanned<T>, Error> {
        match v {
            Some(s) => Ok(s),
            None => self.err(Some(section), key, "missing (required)"),
        }
    }

    /// A name (a camera selector, an image name) that must not be empty or blank: an empty
    /// camera prefix would select every image.
    fn non_empty(&self, v: &Spanned<String>, key: &str) -> Result<String, Error> {
        if v.get_ref().trim().is_empty() {
            return self.err(Some(v.span()), key, "must not be empty");
        }
        Ok(v.get_ref().clone())
    }

    /// A path relative to the study file that must exist.
    fn existing_path(
        &self,
        v: &Spanned<String>,
        key: &str,
        dir_expected: bool,
    ) -> Result<PathBuf, Error> {
        let p = self.dir.join(v.get_ref());
        let ok = if dir_expected {
            p.is_dir()
        } else {
            p.is_file()
        };
        if !ok {
            let what = if dir_expected { "directory" } else { "file" };
            return self.err(
                Some(v.span()),
                key,
                format!("{} does not exist or is not a {what}", p.display()),
            );
        }
        Ok(p)
    }

    /// A positive number; a length (a key ending in `_mm`) at most
    /// [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] (the scenario's bound, docs/LIMITS.md).
    fn positive(&self, v: &Spanned<f64>, key: &str) -> Result<f64, Error> {
        let x = *v.get_ref();
        if !(x.is_finite() && x > 0.0) {
            return self.err(
                Some(v.span()),
                key,
                format!("must be a positive number, got {x}"),
            );
        }
        let max = crashrig_mc::limits::MAX_ABS_LENGTH_MM;
        if key.ends_with("_mm") && x > max {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{} mm exceeds the limit of {max} mm (10 km; docs/LIMITS.md)",
                    short(x)
                ),
            );
        }
        Ok(x)
    }

    /// A model scale (mm per model unit) within [`crashrig_measure::input::MM_PER_UNIT_RANGE`].
    fn scale(&self, v: &Spanned<f64>, key: &str) -> Result<f64, Error> {
        let (lo, hi) = crashrig_measure::input::MM_PER_UNIT_RANGE;
        let x = *v.get_ref();
        if !(x.is_finite() && (lo..=hi).contains(&x)) {
            return self.err(
                Some(v.span()),
                key,
                format!("must be a number from {lo:e} to {hi:e} (mm per model unit), got {x}"),
            );
        }
        Ok(x)
    }

    /// A count of work `min ..= max` (checked before anything is allocated or run).
    fn count(&self, v: &Spanned<i64>, key: &str, min: i64, max: usize) -> Result<usize, Error> {
        let x = *v.get_ref();
        if x < min {
            return self.err(
                Some(v.span()),
                key,
                format!("must be at least {min}, got {x}"),
            );
        }
        if x as u64 > max as u64 {
            return self.err(
                Some(v.span()),
                key,
                format!("{x} exceeds the limit of {max}"),
            );
        }
        Ok(x as usize)
    }

    /// Three finite numbers, each within the scenario's bound of its unit (docs/LIMITS.md):
    /// |v| ≤ [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] under a key ending in `_mm`, ≤
    /// [`crashrig_mc::limits::MAX_ABS_ANGLE_DEG`] under one ending in `_deg`.
    fn finite3(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vec3, Error> {
        use crashrig_mc::limits::{MAX_ABS_ANGLE_DEG, MAX_ABS_LENGTH_MM};
        let a = v.get_ref();
        if a.iter().any(|x| !x.is_finite()) {
            return self.err(Some(v.span()), key, "values must be finite");
        }
        let bound = if key.ends_with("_mm") {
            Some((MAX_ABS_LENGTH_MM, " mm", " (10 km)"))
        } else if key.ends_with("_deg") {
            Some((MAX_ABS_ANGLE_DEG, "°", ""))
        } else {
            None
        };
        if let Some((max, unit, what)) = bound
            && let Some(x) = a.iter().find(|x| x.abs() > max)
        {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{x}{unit} exceeds the limit of {max}{unit}{what} in size (docs/LIMITS.md)"
                ),
            );
        }
        Ok(Vec3::new(a[0], a[1], a[2]))
    }

    fn sigma3(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vec3, Error> {
        let s = self.finite3(v, key)?;
        if s.iter().any(|x| *x < 0.0) {
            return self.err(Some(v.span()), key, "σ must not be negative");
        }
        Ok(s)
    }

    /// `covariance_tangent` (mm, deg) → covariance (mm, rad).
    fn covariance(&self, v: &Spanned<Vec<Vec<f64>>>, key: &str) -> Result<Mat6, Error> {
        let rows = v.get_ref();
        if rows.len() != 6 || rows.iter().any(|r| r.len() != 6) {
            return self.err(
                Some(v.span()),
                key,
                "must be 6 rows of 6 numbers (x y z mm, θx θy θz deg)",
            );
        }
        let m = Mat6::from_fn(|i, j| rows[i][j]);
        match UncertainPose::from_covariance_deg(Rigid3::identity(), m) {
            Ok(p) => Ok(p.covariance),
            Err(problem) => self.err(Some(v.span()), key, problem.to_string()),
        }
    }

    /// σ keys or `covariance_tangent` (exactly one form) → covariance (mm, rad).
    fn noise(
        &self,
        section: std::ops::Range<usize>,
        prefix: &str,
        sp: &Option<Spanned<[f64; 3]>>,
        sa: &Option<Spanned<[f64; 3]>>,
        cov: &Option<Spanned<Vec<Vec<f64>>>>,
    ) -> Result<Mat6, Error> {
        let k = |f: &str| format!("{prefix}.{f}");
        match (sp, sa, cov) {
            (None, None, Some(c)) => self.covariance(c, &k("covariance_tangent")),
            (Some(p), Some(a), None) => {
                let p = self.sigma3(p, &k("sigma_position_mm"))?;
                let a = self.sigma3(a, &k("sigma_angles_deg"))?.map(f64::to_radians);
                Ok(UncertainPose::from_sigmas(Rigid3::identity(), p, a).covariance)
            }
            (_, _, Some(c)) => self.err(
                Some(c.span()),
                &k("covariance_tangent"),
                "give either covariance_tangent or sigma_position_mm + sigma_angles_deg, not both",
            ),
            (None, _, None) => self.err(
                Some(section),
                &k("sigma_position_mm"),
                "missing (or give covariance_tangent)",
            ),
            (_, None, None) => self.err(
                Some(section),
                &k("sigma_angles_deg"),
                "missing (or give covariance_tangent)",
            ),
        }
    }

    fn axis(
        &self,
        v: &Option<Spanned<[f64; 3]>>,
        section: std::ops::Range<usize>,
        key: &str,
    ) -> Result<(f64, f64, usize), Error> {
        let v = self.required(v, section, key)?;
        let a = v.get_ref();
        let c = a[2];
        if !(a[0].is_finite() && a[1].is_finite()) || c < 1.0 || c.fract() != 0.0 {
            return self.err(
                Some(v.span()),
                key,
                "must be [start, stop, count] with finite mm and a whole count ≥ 1",
            );
        }
        let max_mm = crashrig_mc::limits::MAX_ABS_LENGTH_MM;
        if let Some(x) = a[..2].iter().find(|x| x.abs() > max_mm) {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{} mm exceeds the limit of {max_mm} mm (10 km) in size (docs/LIMITS.md)",
                    short(*x)
                ),
            );
        }
        let max = crashrig_mc::limits::MAX_AXIS_COUNT;
        if c > max as f64 {
            return self.err(
                Some(v.span()),
                key,
                format!("count {c} exceeds the limit of {max} values per axis"),
            );
        }
        Ok((a[0], a[1], c as usize))
    }
}

/// Two observers of a layout closer than this (mm) are coincident: an error naming both.
pub const MIN_OBSERVER_DISTANCE_MM: f64 = 1.0;

/// Checks a layout's grid size against [`crashrig_mc::limits::MAX_GRID_POINTS`] and its draws
/// (points × `samples`) against [`crashrig_mc::limits::MAX_GRID_DRAWS`], before anything is
/// allocated; the message gives the memory the grid's results would need.
///
/// # Errors
/// The message (the caller names the file, line and key).
pub(crate) fn check_layout_size(layout: &Layout, samples: usize) -> Result<(), String> {
    use crashrig_mc::limits::{MAX_GRID_DRAWS, MAX_GRID_POINTS};
    let (nx, ny, nz) = (layout.x_mm.2, layout.y_mm.2, layout.z_mm.2);
    let points = nx as u128 * ny as u128 * nz as u128;
    if points > MAX_GRID_POINTS as u128 {
        // Per point: its statistics and at least one row of grid.csv (~200 bytes).
        let bytes = points * (std::mem::size_of::<crashrig_mc::PointStats>() as u128 + 200);
        return Err(format!(
            "{nx} × {ny} × {nz} = {points} grid points exceed the limit of {MAX_GRID_POINTS} (their results alone would need {} MiB)",
            bytes >> 20
        ));
    }
    let draws = points * samples as u128;
    if draws > MAX_GRID_DRAWS as u128 {
        return Err(format!(
            "{points} grid points × {samples} samples = {draws} draws exceed the limit of {MAX_GRID_DRAWS}"
        ));
    }
    Ok(())
}

/// `a_control_points` and its companions → [`MeasureANoise::Bundle`]; the companions without
/// `a_control_points`, or `a_control_points` with another source of A's σ, are errors.
fn a_bundle(cx: &Ctx<'_>, m: &RawMeasure, model: &Path) -> Result<MeasureANoise, Error> {
    let Some(cp) = &m.a_control_points else {
        unreachable!("called with a_control_points")
    };
    if m.a_covariance.is_some() || m.sigma_a_position_mm.is_some() || m.sigma_a_angles_deg.is_some()
    {
        return cx.err(
            Some(cp.span()),
            "measure.a_control_points",
            "give one source of A's σ: a_control_points (from the bundle), a_covariance, or sigma_a_position_mm / sigma_a_angles_deg",
        );
    }
    let control_points = cx.existing_path(cp, "measure.a_control_points", false)?;
    let model = match &m.a_model {
        Some(v) => cx.existing_path(v, "measure.a_model", true)?,
        None => model.to_path_buf(),
    };
    let pixel_sigma_px = m
        .a_pixel_sigma_px
        .as_ref()
        .map(|v| cx.positive(v, "measure.a_pixel_sigma_px"))
        .transpose()?;
    let intrinsics = match &m.a_intrinsics {
        None => crashrig_covariance::Intrinsics::All,
        Some(v) => crashrig_covariance::Intrinsics::parse(v.get_ref()).map_or_else(
            || {
                cx.err(
                    Some(v.span()),
                    "measure.a_intrinsics",
                    format!("`{}`: must be all, colmap or fixed", v.get_ref()),
                )
            },
            Ok,
        )?,
    };
    Ok(MeasureANoise::Bundle(ABundle {
        model,
        control_points,
        pixel_sigma_px,
        intrinsics,
    }))
}

fn measure_section(
    cx: &Ctx<'_>,
    m: &Spanned<RawMeasure>,
    has_tie: bool,
) -> Result<MeasureSection, Error> {
    let ms = m.span();
    let m = m.get_ref();
    let req = |v: &Option<Spanned<String>>, key: &str| -> Result<Spanned<String>, Error> {
        cx.required(v, ms.clone(), key).cloned()
    };
    let model = cx.existing_path(&req(&m.model, "measure.model")?, "measure.model", true)?;
    let observations = cx.existing_path(
        &req(&m.observations, "measure.observations")?,
        "measure.observations",
        false,
    )?;
    // A marker needs two views: camera B alone measures nothing.
    let Some(c) = &m.camera_c else {
        return cx.err(
            Some(ms),
            "measure.camera_c",
            "missing: a marker needs two views, and camera B alone gives one; name the tied camera C (camera_c, with a [tie] section)",
        );
    };
    if !has_tie {
        return cx.err(
            Some(c.span()),
            "measure.camera_c",
            "needs a [tie] section (the tie link B_from_C carries camera C)",
        );
    }
    let camera_c = cx.non_empty(c, "measure.camera_c")?;
    bundle_companions(cx, m)?;
    let a_noise = match (
        &m.a_covariance,
        &m.sigma_a_position_mm,
        &m.sigma_a_angles_deg,
    ) {
        _ if m.a_control_points.is_some() => a_bundle(cx, m, &model)?,
        (Some(f), None, None) => {
            MeasureANoise::File(cx.existing_path(f, "measure.a_covariance", false)?)
        }
        (Some(f), _, _) => {
            return cx.err(
                Some(f.span()),
                "measure.a_covariance",
                "give either a_covariance or sigma_a_position_mm / sigma_a_angles_deg, not both",
            );
        }
        (None, p, a) => MeasureANoise::Sigmas(
            p.as_ref().map_or(Ok(Vec3::zeros()), |v| {
                cx.sigma3(v, "measure.sigma_a_position_mm")
            })?,
            a.as_ref().map_or(Ok(Vec3::zeros()), |v| {
                cx.sigma3(v, "measure.sigma_a_angles_deg")
            })?,
        ),
    };
    let mm_per_unit = m
        .mm_per_unit
        .as_ref()
        .map(|v| cx.scale(v, "measure.mm_per_unit"))
        .transpose()?;
    if mm_per_unit.is_none() && matches!(a_noise, MeasureANoise::Bundle(..)) {
        return cx.err(
            Some(ms),
            "measure.mm_per_unit",
            "missing: a_control_points computes A's covariance from the bundle, which needs the model's units (mm per model unit: 1000 for a model in metres, 1 for millimetres)",
        );
    }
    if mm_per_unit.is_none() && matches!(a_noise, MeasureANoise::Sigmas(..)) {
        return cx.err(
            Some(ms),
            "measure.mm_per_unit",
            "missing: the model's units are never guessed; give mm per model unit (1000 for a model in metres, 1 for millimetres), or an a_covariance from `crashrig covariance` that states mm_per_unit",
        );
    }
    let pixel_sigma_px = match &m.pixel_sigma_px {
        None => 0.5,
        Some(v) if v.get_ref().is_finite() && *v.get_ref() >= 0.0 => *v.get_ref(),
        Some(v) => {
            return cx.err(
                Some(v.span()),
                "measure.pixel_sigma_px",
                "must be finite and not negative",
            );
        }
    };
    let frame_rate_hz = m
        .frame_rate_hz
        .as_ref()
        .map(|v| cx.positive(v, "measure.frame_rate_hz"))
        .transpose()?;
    let (cfc, sync_sigma_ms) = kinematics_keys(cx, m, frame_rate_hz)?;
    let (scale_bars, mpe_mm) = length_check_keys(cx, m)?;
    Ok(MeasureSection {
        model,
        camera_a: cx.non_empty(&req(&m.camera_a, "measure.camera_a")?, "measure.camera_a")?,
        camera_b: cx.non_empty(&req(&m.camera_b, "measure.camera_b")?, "measure.camera_b")?,
        camera_c: Some(camera_c),
        observations,
        mm_per_unit,
        a_noise,
        pixel_sigma_px,
        samples: m
            .samples
            .as_ref()
            .map(|v| {
                cx.count(
                    v,
                    "measure.samples",
                    2,
                    crashrig_measure::plausible::MAX_SAMPLES,
                )
            })
            .transpose()?,
        reference_epoch: m.reference_epoch.clone(),
        frame_rate_hz,
        threshold_mm: m
            .threshold_mm
            .as_ref()
            .map_or(Ok(5.0), |v| cx.positive(v, "measure.threshold_mm"))?,
        max_reprojection_px: m
            .max_reprojection_px
            .as_ref()
            .map(|v| cx.positive(v, "measure.max_reprojection_px"))
            .transpose()?,
        cfc,
        sync_sigma_ms,
        scale_bars,
        mpe_mm,
    })
}

/// `a_model`, `a_pixel_sigma_px` and `a_intrinsics` need `a_control_points`: an error naming the
/// first one given without it.
fn bundle_companions(cx: &Ctx<'_>, m: &RawMeasure) -> Result<(), Error> {
    if m.a_control_points.is_some() {
        return Ok(());
    }
    let companions = [
        (m.a_model.as_ref().map(|v| v.span()), "measure.a_model"),
        (
            m.a_pixel_sigma_px.as_ref().map(|v| v.span()),
            "measure.a_pixel_sigma_px",
        ),
        (
            m.a_intrinsics.as_ref().map(|v| v.span()),
            "measure.a_intrinsics",
        ),
    ];
    match companions.into_iter().find(|(s, _)| s.is_some()) {
        Some((span, key)) => cx.err(
            span,
            key,
            "needs measure.a_control_points (A's covariance from the bundle)",
        ),
        None => Ok(()),
    }
}

/// `[measure]`'s length-check keys: `scale_bars` (an existing file, relative to the study
/// file) and `mpe_mm` (> 0 mm, only with `scale_bars`); each error names the key and its line.
fn length_check_keys(
    cx: &Ctx<'_>,
    m: &RawMeasure,
) -> Result<(Option<PathBuf>, Option<f64>), Error> {
    let scale_bars = m
        .scale_bars
        .as_ref()
        .map(|v| cx.existing_path(v, "measure.scale_bars", false))
        .transpose()?;
    let mpe_mm = match (&m.mpe_mm, &scale_bars) {
        (Some(v), None) => {
            return cx.err(
                Some(v.span()),
                "measure.mpe_mm",
                "needs measure.scale_bars (the maximum permissible error of the bars' lengths)",
            );
        }
        (Some(v), Some(_)) => Some(cx.positive(v, "measure.mpe_mm")?),
        (None, _) => None,
    };
    Ok((scale_bars, mpe_mm))
}

/// `[measure]`'s kinematics keys: `cfc` (a class of [`crashrig_measure::filter::CLASSES`] whose
/// corner is well below the Nyquist frequency of `frame_rate_hz`, checked here by
/// [`crashrig_measure::filter::Cfc::new`]), `cfc_standard` (`j211`, default, or `iso6487`; only
/// with `cfc`) and `sync_sigma_ms` (0 … [`crashrig_measure::engine::MAX_SYNC_SIGMA_MS`]); each
/// error names the key and its line.
fn kinematics_keys(
    cx: &Ctx<'_>,
    m: &RawMeasure,
    frame_rate_hz: Option<f64>,
) -> Result<(Option<crashrig_measure::filter::CfcSpec>, f64), Error> {
    use crashrig_measure::filter::{Cfc, CfcSpec, Standard};
    let problem = |e: crashrig_measure::Error| match e {
        crashrig_measure::Error::Setting { problem, .. } => problem,
        other => crashrig_input::message::error_line(&other),
    };
    let standard = match &m.cfc_standard {
        None => Standard::J211,
        Some(v) if m.cfc.is_none() => {
            return cx.err(
                Some(v.span()),
                "measure.cfc_standard",
                "names the standard of a CFC filter: give `cfc` too",
            );
        }
        Some(v) => Standard::parse(v.get_ref())
            .or_else(|e| cx.err(Some(v.span()), "measure.cfc_standard", problem(e)))?,
    };
    let cfc = match &m.cfc {
        None => None,
        Some(v) => {
            let Ok(class) = u32::try_from(*v.get_ref()) else {
                return cx.err(
                    Some(v.span()),
                    "measure.cfc",
                    format!(
                        "{} is not a channel frequency class (60, 180, 600, 1000)",
                        v.get_ref()
                    ),
                );
            };
            let Some(hz) = frame_rate_hz else {
                return cx.err(
                    Some(v.span()),
                    "measure.cfc",
                    "needs measure.frame_rate_hz (the filter is defined in frames per second)",
                );
            };
            Cfc::new(class, standard, hz)
                .map_err(problem)
                .or_else(|p| cx.err(Some(v.span()), "measure.cfc", p))?;
            Some(CfcSpec { class, standard })
        }
    };
    let sync = match &m.sync_sigma_ms {
        None => 0.0,
        Some(v) => {
            let x = *v.get_ref();
            let max = crashrig_measure::engine::MAX_SYNC_SIGMA_MS;
            if !(x.is_finite() && (0.0..=max).contains(&x)) {
                return cx.err(
                    Some(v.span()),
                    "measure.sync_sigma_ms",
                    format!("must be a number from 0 to {max} (ms), got {x}"),
                );
            }
            if x > 0.0 && frame_rate_hz.is_none() {
                return cx.err(
                    Some(v.span()),
                    "measure.sync_sigma_ms",
                    "needs measure.frame_rate_hz (A's pose is interpolated between frames)",
                );
            }
            x
        }
    };
    Ok((cfc, sync))
}

/// The sections a study file may have (`[name]`, `[[layout]]`).
const SECTIONS: [&str; 5] = ["calibration", "tie", "outward", "layout", "measure"];

/// A top-level table or array of tables that is not a known section (a misspelled
/// `[calibraton]`): an error naming it as an unknown section at its header's line, with the
/// nearest known section (serde alone would call it an "unknown field").
fn unknown_section(text: &str, path: &Path) -> Option<Error> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(text).ok()?;
    doc.get_ref().iter().find_map(|(k, v)| {
        let name = k.get_ref().as_ref();
        let is_section = match v.get_ref() {
            DeValue::Table(_) => true,
            DeValue::Array(a) => {
                !a.is_empty() && a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_)))
            }
            _ => false,
        };
        if !is_section || SECTIONS.contains(&name) {
            return None;
        }
        let nearest = SECTIONS
            .iter()
            .min_by_key(|s| strsim::levenshtein(s, name))
            .copied()
            .unwrap_or("calibration");
        let bracket = |n: &str| {
            if n == "layout" {
                "[[layout]]".to_string()
            } else {
                format!("[{n}]")
            }
        };
        Some(Error::Key {
            path: path.to_path_buf(),
            line: Some(line_of(text, k.span().start)),
            key: name.to_string(),
            message: format!(
                "unknown section; did you mean {}? (sections: {})",
                bracket(nearest),
                SECTIONS.map(bracket).join(", ")
            ),
        })
    })
}

/// The study text as the raw TOML document: a syntax or type error names its line, column and
/// (for a value) its key; a vector of the wrong length names its key.
fn parse_raw(text: &str, path: &Path) -> Result<Raw, Error> {
    if let Some(e) = unknown_section(text, path) {
        return Err(e);
    }
    let raw: Raw = toml::from_str(text).map_err(|e| {
        let offset = e.span().map_or(0, |s| s.start);
        let line = line_of(text, offset);
        let col = text[..offset.min(text.len())]
            .rfind('\n')
            .map_or(offset, |p| offset - p - 1)
            + 1;
        // A type error is located at the value: name its key as every other error does.
        let message = e.message().trim();
        let message = match crashrig_input::location::toml_value_key(text, offset) {
            Some(key) => format!("`{key}`: {message}"),
            None => message.to_string(),
        };
        Error::Toml {
            path: path.to_path_buf(),
            line,
            column: col,
            message,
        }
    })?;
    if let Some((key, line, n)) = wrong_length_vector(text) {
        return Err(Error::Key {
            path: path.to_path_buf(),
            line: Some(line),
            key,
            message: format!("must have exactly 3 values, found {n}"),
        });
    }
    Ok(raw)
}

/// A missing section has no line of its own: the file's first line.
fn missing_section(cx: &Ctx<'_>, name: &str) -> Error {
    Error::Key {
        path: cx.path.to_path_buf(),
        line: Some(1),
        key: name.to_string(),
        message: "missing section (required)".into(),
    }
}

/// The top-level keys `samples`, `chain_samples` (with their defaults) and `reference`.
fn top_level_keys(cx: &Ctx<'_>, raw: &Raw) -> Result<(usize, usize), Error> {
    let samples = raw.samples.as_ref().map_or(Ok(2000), |v| {
        cx.count(v, "samples", 2, crashrig_mc::limits::MAX_SAMPLES)
    })?;
    let chain_samples = raw.chain_samples.as_ref().map_or(Ok(200_000), |v| {
        cx.count(v, "chain_samples", 2, crashrig_mc::limits::MAX_SAMPLES)
    })?;
    if let Some(r) = &raw.reference
        && r.get_ref() != "kaminski2023"
    {
        return cx.err(
            Some(r.span()),
            "reference",
            format!(
                "unknown reference {:?} (known: \"kaminski2023\")",
                r.get_ref()
            ),
        );
    }
    Ok((samples, chain_samples))
}

/// `[calibration]`.
fn calibration_section(
    cx: &Ctx<'_>,
    c: Option<&Spanned<RawCalibration>>,
) -> Result<CalibrationSection, Error> {
    let c = c.ok_or_else(|| missing_section(cx, "[calibration]"))?;
    let cs = c.span();
    let c = c.get_ref();
    let model = cx.existing_path(
        cx.required(&c.model, cs.clone(), "calibration.model")?,
        "calibration.model",
        true,
    )?;
    let name = |v: &Option<Spanned<String>>, key: &str| -> Result<String, Error> {
        cx.non_empty(cx.required(v, cs.clone(), key)?, key)
    };
    let camera_a = name(&c.camera_a, "calibration.camera_a")?;
    let camera_b = name(&c.camera_b, "calibration.camera_b")?;
    let scale = calibration_scale(cx, c, cs)?;
    Ok(CalibrationSection {
        model,
        camera_a,
        camera_b,
        scale,
        max_lag: c.max_lag.as_ref().map_or(Ok(10), |v| {
            cx.count(v, "calibration.max_lag", 1, usize::MAX)
        })?,
        refine: c.refine.unwrap_or(true),
        accept_rig_constrained: c.accept_rig_constrained.unwrap_or(false),
    })
}

/// The scale of `[calibration]`: a scale bar (`scale_points` + `scale_length_mm`) or
/// `mm_per_unit`, exactly one of them.
fn calibration_scale(
    cx: &Ctx<'_>,
    c: &RawCalibration,
    cs: std::ops::Range<usize>,
) -> Result<StudyScale, Error> {
    Ok(
        match (&c.scale_points, &c.scale_length_mm, &c.mm_per_unit) {
            (Some(p), Some(l), None) => {
                if p.get_ref().len() != 2 || p.get_ref()[0] == p.get_ref()[1] {
                    return cx.err(
                        Some(p.span()),
                        "calibration.scale_points",
                        "must be two different point3D ids",
                    );
                }
                StudyScale::ScaleBar {
                    points: [p.get_ref()[0], p.get_ref()[1]],
                    length_mm: cx.positive(l, "calibration.scale_length_mm")?,
                }
            }
            (None, None, Some(f)) => StudyScale::MmPerUnit(cx.scale(f, "calibration.mm_per_unit")?),
            // Located at the key that is there (the missing one has no line).
            (Some(p), None, _) => {
                return cx.err(
                    Some(p.span()),
                    "calibration.scale_length_mm",
                    "required with scale_points",
                );
            }
            (None, Some(l), _) => {
                return cx.err(
                    Some(l.span()),
                    "calibration.scale_points",
                    "required with scale_length_mm",
                );
            }
            (Some(_), Some(_), Some(f)) => {
                return cx.err(
                    Some(f.span()),
                    "calibration.mm_per_unit",
                    "give either mm_per_unit or the scale bar, not both",
                );
            }
            (None, None, None) => {
                return cx.err(
                    Some(cs),
                    "calibration.scale_points",
                    "missing: give scale_points + scale_length_mm or mm_per_unit",
                );
            }
        },
    )
}

/// `[tie]`.
fn tie_section(cx: &Ctx<'_>, t: &Spanned<RawTie>) -> Result<TieSection, Error> {
    let ts = t.span();
    let t = t.get_ref();
    let req = |v: &Option<Spanned<String>>, key: &str| -> Result<Spanned<String>, Error> {
        cx.required(v, ts.clone(), key).cloned()
    };
    let database = cx.existing_path(&req(&t.database, "tie.database")?, "tie.database", false)?;
    let model = cx.existing_path(&req(&t.model, "tie.model")?, "tie.model", true)?;
    let method = match t.method.as_ref().map(|m| (m.get_ref().as_str(), m.span())) {
        None | Some(("absolute", _)) => TieMethod::Absolute,
        Some(("relative", _)) => TieMethod::Relative,
        Some((other, span)) => {
            return cx.err(
                Some(span),
                "tie.method",
                format!("must be \"absolute\" or \"relative\", got {other:?}"),
            );
        }
    };
    let resample = match t
        .resample
        .as_ref()
        .map(|m| (m.get_ref().as_str(), m.span()))
    {
        None | Some(("inliers", _)) => TieResample::Inliers,
        Some(("matches", _)) => TieResample::AllMatches,
        Some((other, span)) => {
            return cx.err(
                Some(span),
                "tie.resample",
                format!("must be \"inliers\" or \"matches\", got {other:?}"),
            );
        }
    };
    Ok(TieSection {
        database,
        model,
        image_a: cx.non_empty(&req(&t.image_a, "tie.image_a")?, "tie.image_a")?,
        image_b: cx.non_empty(&req(&t.image_b, "tie.image_b")?, "tie.image_b")?,
        method,
        iterations: t.iterations.as_ref().map_or(Ok(500), |v| {
            cx.count(v, "tie.iterations", 2, crashrig_bootstrap::MAX_ITERATIONS)
        })?,
        mm_per_unit: t
            .mm_per_unit
            .as_ref()
            .map_or(Ok(1.0), |v| cx.scale(v, "tie.mm_per_unit"))?,
        max_error_px: t
            .max_error_px
            .as_ref()
            .map_or(Ok(4.0), |v| cx.positive(v, "tie.max_error_px"))?,
        base_mm: t
            .base_mm
            .as_ref()
            .map(|v| cx.positive(v, "tie.base_mm"))
            .transpose()?,
        resample,
    })
}

/// `[outward]`: camera A's world pose with its covariance.
fn outward_section(cx: &Ctx<'_>, o: Option<&Spanned<RawPose>>) -> Result<UncertainPose, Error> {
    let o = o.ok_or_else(|| missing_section(cx, "[outward]"))?;
    let os = o.span();
    let o = o.get_ref();
    let position = cx.finite3(
        cx.required(&o.position_mm, os.clone(), "outward.position_mm")?,
        "outward.position_mm",
    )?;
    let angles = cx
        .finite3(
            cx.required(&o.angles_deg, os.clone(), "outward.angles_deg")?,
            "outward.angles_deg",
        )?
        .map(f64::to_radians);
    let covariance = cx.noise(
        os,
        "outward",
        &o.sigma_position_mm,
        &o.sigma_angles_deg,
        &o.covariance_tangent,
    )?;
    let world_from_a = Rigid3::from_parts(
        position.into(),
        crashrig_geometry::opk::rotation_from_opk(angles.x, angles.y, angles.z).into(),
    );
    Ok(UncertainPose {
        b_from_a: world_from_a,
        covariance,
    })
}

/// The `[[layout]]` sections (at least one; names unique once made file-name safe).
fn layout_sections(
    cx: &Ctx<'_>,
    raw: &[Spanned<RawLayout>],
    has_tie: bool,
    samples: usize,
) -> Result<Vec<Layout>, Error> {
    if raw.is_empty() {
        return Err(missing_section(cx, "[[layout]]"));
    }
    let mut layouts: Vec<Layout> = Vec::new();
    for (li, l) in raw.iter().enumerate() {
        let ls = l.span();
        let k = |f: &str| format!("layout[{li}].{f}");
        let layout_name_span = l
            .get_ref()
            .name
            .as_ref()
            .map(|n| n.span())
            .unwrap_or(ls.clone());
        let layout = layout_section(cx, li, l, has_tie)?;
        check_layout_size(&layout, samples).map_err(|message| Error::Key {
            path: cx.path.to_path_buf(),
            line: Some(line_of(cx.text, ls.start)),
            key: format!("layout[{li}]"),
            message,
        })?;
        if layout.slug().is_empty() || layouts.iter().any(|o| o.slug() == layout.slug()) {
            return cx.err(
                Some(layout_name_span),
                &k("name"),
                format!(
                    "{:?} is empty or not unique once made file-name safe",
                    layout.name
                ),
            );
        }
        layouts.push(layout);
    }
    Ok(layouts)
}

/// One `[[layout]]` (the `li`-th): name, pixel noise, observers, grid, threshold.
fn layout_section(
    cx: &Ctx<'_>,
    li: usize,
    l: &Spanned<RawLayout>,
    has_tie: bool,
) -> Result<Layout, Error> {
    let ls = l.span();
    let l = l.get_ref();
    let k = |f: &str| format!("layout[{li}].{f}");
    let name = match &l.name {
        Some(n) if !n.get_ref().trim().is_empty() => n.get_ref().clone(),
        Some(n) => return cx.err(Some(n.span()), &k("name"), "must not be empty"),
        None => format!("layout{}", li + 1),
    };
    let pixel = match (&l.pixel_sigma_px, &l.focal_px) {
        (None, None) => None,
        (Some(s), Some(f)) => {
            let sv = *s.get_ref();
            if !(sv.is_finite() && sv >= 0.0) {
                return cx.err(
                    Some(s.span()),
                    &k("pixel_sigma_px"),
                    "must be finite and not negative",
                );
            }
            Some((sv, cx.positive(f, &k("focal_px"))?))
        }
        // Located at the key that is there (the missing one has no line).
        (Some(s), None) => {
            return cx.err(
                Some(s.span()),
                &k("focal_px"),
                "required with pixel_sigma_px",
            );
        }
        (None, Some(f)) => {
            return cx.err(
                Some(f.span()),
                &k("pixel_sigma_px"),
                "required with focal_px",
            );
        }
    };
    if l.observer.len() < 2 {
        return cx.err(
            Some(ls),
            &k("observer"),
            format!(
                "needs at least two [[layout.observer]], found {}",
                l.observer.len()
            ),
        );
    }
    let mut observers: Vec<Observer> = Vec::new();
    for (oi, ob) in l.observer.iter().enumerate() {
        let o = observer_section(cx, (li, oi), ob, &observers, l.correlated, has_tie)?;
        observers.push(o);
    }
    Ok(Layout {
        name,
        description: l.description.clone().unwrap_or_default(),
        x_mm: cx.axis(&l.x_mm, ls.clone(), &k("x_mm"))?,
        y_mm: cx.axis(&l.y_mm, ls.clone(), &k("y_mm"))?,
        z_mm: cx.axis(&l.z_mm, ls.clone(), &k("z_mm"))?,
        threshold_mm: l
            .threshold_mm
            .as_ref()
            .map_or(Ok(5.0), |v| cx.positive(v, &k("threshold_mm")))?,
        pixel,
        correlated: l.correlated,
        observers,
    })
}

/// One `[[layout.observer]]` (observer `oi` of layout `li`), checked against the layout's
/// observers before it (`earlier`): position, noise (`from` a chain camera or given σ) and,
/// with `aim = "fixed"`, its fixed camera.
fn observer_section(
    cx: &Ctx<'_>,
    (li, oi): (usize, usize),
    ob: &Spanned<RawObserver>,
    earlier: &[Observer],
    correlated: Option<bool>,
    has_tie: bool,
) -> Result<Observer, Error> {
    let obs = ob.span();
    let ob = ob.get_ref();
    let ko = |f: &str| format!("layout[{li}].observer[{oi}].{f}");
    let position = cx.required(&ob.position_mm, obs.clone(), &ko("position_mm"))?;
    let position_mm = cx.finite3(position, &ko("position_mm"))?;
    if let Some((oj, other)) = earlier
        .iter()
        .enumerate()
        .find(|(_, o)| (o.position_mm - position_mm).norm() < MIN_OBSERVER_DISTANCE_MM)
    {
        return cx.err(
            Some(position.span()),
            &ko("position_mm"),
            format!(
                "observer {:?} is {:.3} mm from observer[{oj}] {:?} (less than {MIN_OBSERVER_DISTANCE_MM} mm): coincident cameras see a point along the same ray and cannot intersect it (σ would be empty)",
                ob.name.clone().unwrap_or_else(|| format!("obs{}", oi + 1)),
                (other.position_mm - position_mm).norm(),
                other.name
            ),
        );
    }
    let noise = match &ob.from {
        Some(f) => observer_from(cx, &ko("from"), ob, f, has_tie)?,
        None => ObserverNoise::Given(cx.noise(
            obs.clone(),
            &format!("layout[{li}].observer[{oi}]"),
            &ob.sigma_position_mm,
            &ob.sigma_angles_deg,
            &ob.covariance_tangent,
        )?),
    };
    let fixed = crate::fixed_observer::fixed_from_raw(
        &crate::fixed_observer::Site {
            path: cx.path,
            text: cx.text,
            dir: &cx.dir,
            prefix: format!("layout[{li}].observer[{oi}]"),
            span: obs.clone(),
        },
        &crate::fixed_observer::RawFixed {
            aim: &ob.aim,
            angles_deg: &ob.angles_deg,
            look_at_mm: &ob.look_at_mm,
            camera: &ob.camera,
            camera_from: &ob.camera_from,
            pixel_sigma_px: &ob.pixel_sigma_px,
        },
        &position_mm,
    )?;
    if fixed.is_some()
        && correlated == Some(true)
        && let (ObserverNoise::From(_), Some(f)) = (&noise, &ob.from)
    {
        return cx.err(
            Some(f.span()),
            &ko("from"),
            "a fixed observer takes the chain camera's propagated covariance, drawn independently; it cannot be drawn jointly (correlated = true)",
        );
    }
    Ok(Observer {
        name: ob.name.clone().unwrap_or_else(|| format!("obs{}", oi + 1)),
        position_mm,
        noise,
        fixed: fixed.map(Box::new),
    })
}

/// An observer's `from` (key `key`): the chain camera whose propagated covariance it takes
/// (not together with its own σ keys; `tie` only with a `[tie]`).
fn observer_from(
    cx: &Ctx<'_>,
    key: &str,
    ob: &RawObserver,
    f: &Spanned<String>,
    has_tie: bool,
) -> Result<ObserverNoise, Error> {
    if ob.sigma_position_mm.is_some()
        || ob.sigma_angles_deg.is_some()
        || ob.covariance_tangent.is_some()
    {
        return cx.err(
            Some(f.span()),
            key,
            "give either from or the σ / covariance_tangent keys, not both",
        );
    }
    Ok(match f.get_ref().as_str() {
        "outward" => ObserverNoise::From(ChainCamera::Outward),
        "inward" => ObserverNoise::From(ChainCamera::Inward),
        "tie" if has_tie => ObserverNoise::From(ChainCamera::Tie),
        "tie" => {
            return cx.err(Some(f.span()), key, "\"tie\" needs a [tie] section");
        }
        other => {
            return cx.err(
                Some(f.span()),
                key,
                format!("must be \"outward\", \"inward\" or \"tie\", got {other:?}"),
            );
        }
    })
}

impl Study {
    /// Reads and validates a study file: every path it names must exist.
    ///
    /// # Errors
    /// [`Error::Read`], [`Error::Toml`] or [`Error::Key`] naming the file, key and line.
    pub fn from_path(path: &Path) -> Result<Study, Error> {
        let text =
            crashrig_input::file::read_text_limited(path, crashrig_input::file::MAX_TOML_BYTES)
                .map_err(|source| Error::Read {
                    path: path.to_path_buf(),
                    source,
                })?;
        Study::from_toml_str(&text, path)
    }

    /// Parses and validates study text; relative paths are resolved against `path`'s folder.
    ///
    /// # Errors
    /// As [`Study::from_path`].
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Study, Error> {
        let raw = parse_raw(text, path)?;
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        let cx = Ctx { path, text, dir };
        let (samples, chain_samples) = top_level_keys(&cx, &raw)?;
        let calibration = calibration_section(&cx, raw.calibration.as_ref())?;
        let tie = raw.tie.as_ref().map(|t| tie_section(&cx, t)).transpose()?;
        let outward = outward_section(&cx, raw.outward.as_ref())?;
        let layouts = layout_sections(&cx, &raw.layout, tie.is_some(), samples)?;
        let measure = match &raw.measure {
            None => None,
            Some(m) => Some(measure_section(&cx, m, tie.is_some())?),
        };
        let warnings = units::read_warnings(
            &cx,
            &raw,
            &units::Read {
                outward: &outward,
                layouts: &layouts,
                tie: tie.as_ref(),
                measure: measure.as_ref(),
            },
        );
        Ok(Study {
            path: path.to_path_buf(),
            text: text.to_string(),
            seed: raw.seed.unwrap_or(1),
            samples,
            chain_samples,
            calibration,
            tie,
            outward,
            layouts,
            reference: raw.reference.map(Spanned::into_inner),
            measure,
            warnings,
        })
    }

    /// 1-based line of `[name]` (the `n`-th `[[name]]`) in the study file.
    pub(crate) fn section_line(&self, name: &str, n: usize) -> Option<usize> {
        section_line(&self.text, name, n)
    }

    /// An error about `key` of the first `[section]`, located at the key's line (else the
    /// section's).
    pub(crate) fn key_error(&self, section: &str, key: &str, message: impl Into<String>) -> Error {
        Error::Key {
            path: self.path.clone(),
            line: key_line(&self.text, section, 0, key),
            key: format!("{section}.{key}"),
            message: message.into(),
        }
    }

    /// An [`Error::Step`] for a failure of the step configured by section `key`, located at
    /// the line of the key the failure is about ([`Error::step_key`]), else at the section's.
    pub(crate) fn step_error(&self, key: &str, n: usize, source: impl Into<Error>) -> Error {
        let section = key.split('[').next().unwrap_or(key);
        let source = source.into();
        let line = source
            .step_key()
            .and_then(|k| key_line(&self.text, section, n, k))
            .or_else(|| self.section_line(section, n))
            .or(Some(1));
        Error::Step {
            path: self.path.clone(),
            line,
            key: key.to_string(),
            source: Box::new(source),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn own() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml")
    }

    fn text() -> String {
        std::fs::read_to_string(own()).unwrap()
    }

    /// Parses `t` as if it were the own project's study file (same folder, so paths resolve).
    fn parse(t: &str) -> Result<Study, Error> {
        Study::from_toml_str(t, &own())
    }

    fn message(t: &str) -> String {
        parse(t).unwrap_err().to_string()
    }

    #[test]
    fn own_project_study_file_reads() {
        let s = Study::from_path(&own()).unwrap();
        assert_eq!(s.seed, 11);
        assert_eq!(s.samples, 300);
        assert_eq!(s.layouts.len(), 3);
        assert!(s.calibration.model.is_dir());
        assert_eq!(s.tie.as_ref().unwrap().iterations, 60);
        assert_eq!(
            s.layouts[0].observers[1].noise,
            ObserverNoise::From(ChainCamera::Tie)
        );
        // σ keys → diagonal covariance (mm², rad²).
        let c = s.outward.covariance;
        assert!((c[(2, 2)] - 1.44).abs() < 1e-15);
        assert!((c[(5, 5)] - 0.012_f64.to_radians().powi(2)).abs() < 1e-20);
        // covariance_tangent is taken in mm and deg and kept with its off-diagonal term.
        let ObserverNoise::Given(g) = &s.layouts[1].observers[1].noise else {
            panic!()
        };
        assert!((g[(0, 1)] - 0.2).abs() < 1e-15);
        assert!((g[(3, 3)] - 1e-4 * (std::f64::consts::PI / 180.0).powi(2)).abs() < 1e-20);
    }

    /// The fixed layout's observers: `look_at_mm` aims the optical axis (third column of
    /// `R_vehicle_from_cam`) at the target; `camera_from` takes camera 1 of the tie model; the
    /// `[measure]` section resolves its paths against the study file.
    #[test]
    fn own_project_fixed_layout_and_measure_read() {
        let s = Study::from_path(&own()).unwrap();
        let l = &s.layouts[2];
        let rear = l.observers[0].fixed.as_ref().expect("fixed");
        let axis = rear.rotation.column(2).into_owned();
        let want = (Vec3::new(1100.0, 0.0, 0.0) - l.observers[0].position_mm).normalize();
        assert!((axis - want).norm() < 1e-12, "{axis:?}");
        assert_eq!((rear.lens.width, rear.lens.height), (1920, 1200));
        assert_eq!(rear.lens.params[0], 1400.0);
        assert_eq!(rear.pixel_sigma_px, 0.5);
        assert!(s.layouts[0].observers.iter().all(|o| o.fixed.is_none()));
        let m = s.measure.as_ref().expect("[measure]");
        assert!(m.model.is_dir() && m.observations.is_file());
        assert_eq!(m.camera_c.as_deref(), Some("3"));
        assert_eq!(m.frame_rate_hz, Some(1000.0));
        assert_eq!(
            m.a_noise,
            MeasureANoise::Sigmas(Vec3::repeat(0.3), Vec3::repeat(0.004))
        );
    }

    #[test]
    fn missing_section_names_file_and_section() {
        let t = text().replace("[calibration]", "[calibrationx]");
        let m = message(&t);
        assert!(m.contains("study.toml"), "{m}");
        assert!(m.contains("calibrationx"), "{m}");
        let cut = text();
        let i = cut.find("[outward]").unwrap();
        let j = cut.find("[[layout]]").unwrap();
        let t = format!("{}{}", &cut[..i], &cut[j..]);
        let m = message(&t);
        assert!(
            m.contains("study.toml") && m.contains("[outward]") && m.contains("missing section"),
            "{m}"
        );
    }

    /// Issue 36: an empty selector would make every image camera A (or B, C); an empty image
    /// name finds nothing. Each is refused naming its key and line.
    #[test]
    fn empty_selectors_name_their_key_and_line() {
        let t = text();
        let lines: Vec<&str> = t.lines().collect();
        for (from, key) in [
            ("camera_a = \"cam_out/\"", "calibration.camera_a"),
            ("camera_b = \"cam_in/\"", "calibration.camera_b"),
            ("image_a = \"in/0001.png\"", "tie.image_a"),
            ("image_b = \"side/0001.png\"", "tie.image_b"),
            ("camera_b = \"2\"", "measure.camera_b"),
            ("camera_c = \"3\"", "measure.camera_c"),
        ] {
            let at = lines.iter().position(|l| *l == from).expect(from);
            let mut edited = lines.clone();
            let blank = format!("{} = \" \"", from.split(' ').next().unwrap());
            edited[at] = &blank;
            let m = message(&edited.join("\n"));
            assert!(
                m.contains(&format!(
                    "study.toml:{}: `{key}`: must not be empty",
                    at + 1
                )),
                "{m}"
            );
        }
        // [measure] camera_a is the second `camera_a = "cam_out/"`.
        let at = lines
            .iter()
            .rposition(|l| *l == "camera_a = \"cam_out/\"")
            .unwrap();
        let mut edited = lines.clone();
        edited[at] = "camera_a = \"\"";
        let m = message(&edited.join("\n"));
        assert!(
            m.contains(&format!(
                "study.toml:{}: `measure.camera_a`: must not be empty",
                at + 1
            )),
            "{m}"
        );
    }

    #[test]
    fn missing_path_names_key_and_line() {
        let t = text().replace("model = \"calibration\"", "model = \"no/such/model\"");
        let line = t.lines().position(|l| l.contains("no/such/model")).unwrap() + 1;
        let m = message(&t);
        assert!(
            m.contains(&format!("study.toml:{line}: `calibration.model`")),
            "{m}"
        );
        assert!(m.contains("does not exist"), "{m}");
        let t = text().replace("tie/database.db", "tie/nothing.db");
        let m = message(&t);
        assert!(
            m.contains("`tie.database`") && m.contains("nothing.db"),
            "{m}"
        );
    }

    #[test]
    fn bad_values_name_their_keys() {
        let m = message(&text().replace("from = \"tie\"", "from = \"door\""));
        assert!(m.contains("`layout[0].observer[1].from`"), "{m}");
        let m = message(&text().replace(
            "[0.0, 0.0, 0.0, 1.0e-4, 0.0, 0.0]",
            "[0.0, 0.0, 0.0, 1.0e-4, 0.5, 0.0]",
        ));
        assert!(
            m.contains("`layout[1].observer[1].covariance_tangent`") && m.contains("symmetric"),
            "{m}"
        );
        let m = message(&text().replace("threshold_mm = 3.0", "threshold_mm = -3.0"));
        assert!(m.contains("`layout[0].threshold_mm`"), "{m}");
        let m = message(&text().replace("samples = 300", "samples = 300\nsmaples = 3"));
        assert!(m.contains("study.toml:") && m.contains("smaples"), "{m}");
        let m = message(&text().replace("method = \"absolute\"", "method = \"magic\""));
        assert!(m.contains("`tie.method`"), "{m}");
    }

    /// `[measure]`'s kinematics keys: read into the section, and every bad value is one error
    /// naming the key and its line.
    #[test]
    fn measure_kinematics_keys_and_their_errors() {
        use crashrig_measure::filter::{CfcSpec, Standard};
        let with = |keys: &str| {
            // `pixel_sigma_px = 0.3` is [measure]'s alone (the fixed cameras have 0.5).
            text().replace(
                "pixel_sigma_px = 0.3\n",
                &format!("pixel_sigma_px = 0.3\n{keys}\n"),
            )
        };
        let t = with("cfc = 180\ncfc_standard = \"iso6487\"\nsync_sigma_ms = 0.5");
        let m = parse(&t).unwrap().measure.unwrap();
        assert_eq!(
            m.cfc,
            Some(CfcSpec {
                class: 180,
                standard: Standard::Iso6487
            })
        );
        assert_eq!(m.sync_sigma_ms, 0.5);
        let m = parse(&text()).unwrap().measure.unwrap();
        assert_eq!((m.cfc, m.sync_sigma_ms), (None, 0.0));
        for (keys, key, needle) in [
            ("cfc = 100", "cfc", "100 is not a channel frequency class"),
            ("cfc = -60", "cfc", "-60 is not a channel frequency class"),
            (
                "cfc = 1000",
                "cfc",
                "CFC 1000 is too high for 1000 frames/s",
            ),
            (
                "cfc = 60\ncfc_standard = \"sae\"",
                "cfc_standard",
                "`sae` is not a filter standard",
            ),
            ("cfc_standard = \"j211\"", "cfc_standard", "give `cfc` too"),
            (
                "sync_sigma_ms = -1.0",
                "sync_sigma_ms",
                "from 0 to 1000 (ms)",
            ),
            (
                "sync_sigma_ms = 2000.0",
                "sync_sigma_ms",
                "from 0 to 1000 (ms)",
            ),
        ] {
            let t = with(keys);
            let last = keys.lines().last().unwrap();
            let line = t.rfind(last).map(|i| t[..i].lines().count() + 1).unwrap();
            let m = message(&t);
            assert!(
                m.contains(&format!("study.toml:{line}: `measure.{key}`")) && m.contains(needle),
                "{keys}: {m}"
            );
        }
        // Without a frame rate the filter and the offset have no time base.
        let t = with("cfc = 60").replace("frame_rate_hz = 1000.0\n", "");
        let m = message(&t);
        assert!(
            m.contains("`measure.cfc`") && m.contains("frame_rate_hz"),
            "{m}"
        );
        let t = with("sync_sigma_ms = 1.0").replace("frame_rate_hz = 1000.0\n", "");
        let m = message(&t);
        assert!(
            m.contains("`measure.sync_sigma_ms`") && m.contains("frame_rate_hz"),
            "{m}"
        );
    }

    #[test]
    fn one_observer_is_an_error() {
        let t = text();
        let i = t
            .find("[[layout.observer]]\nname = \"side (tie)\"")
            .unwrap();
        let j = t[i..].find("\n[[layout]]").unwrap() + i;
        let m = message(&format!("{}{}", &t[..i], &t[j..]));
        assert!(
            m.contains("`layout[0].observer`") && m.contains("at least two"),
            "{m}"
        );
    }

    /// The 1-based line of the first line of `t` that starts with `start`.
    fn line_starting(t: &str, start: &str) -> usize {
        t.lines()
            .position(|l| l.starts_with(start))
            .expect("the line")
            + 1
    }

    /// A misspelled section is an unknown section with the nearest known name, at its header's
    /// line (serde alone calls it an "unknown field").
    #[test]
    fn misspelled_section_is_an_unknown_section_with_the_nearest_name() {
        let t = text().replace("[calibration]", "[calibraton]");
        let m = message(&t);
        let line = line_starting(&t, "[calibraton]");
        assert!(
            m.contains(&format!("study.toml:{line}: `calibraton`")),
            "{m}"
        );
        assert!(
            m.contains("unknown section; did you mean [calibration]?"),
            "{m}"
        );
        assert!(!m.contains("unknown field"), "{m}");
        let t = text().replace("[outward]", "[outwrad]");
        let m = message(&t);
        assert!(m.contains("did you mean [outward]?"), "{m}");
        assert!(
            m.contains(&format!(":{}:", line_starting(&t, "[outwrad]"))),
            "{m}"
        );
        // An array of tables too.
        let t = format!("{}\n[[layuots]]\nname = \"x\"\n", text());
        let m = message(&t);
        assert!(
            m.contains("`layuots`: unknown section; did you mean [[layout]]?"),
            "{m}"
        );
        assert!(
            m.contains(&format!(":{}:", line_starting(&t, "[[layuots]]"))),
            "{m}"
        );
        // A misspelled key stays an unknown field.
        let m = message(&text().replace("samples = 300", "sampels = 300"));
        assert!(m.contains("unknown field") && m.contains("sampels"), "{m}");
    }

    /// `required with …` points at the key that is there, not at the section.
    #[test]
    fn a_lone_partner_key_points_at_its_own_line() {
        let t = text().replace("scale_length_mm = 1500.0\n", "");
        let m = message(&t);
        let line = line_starting(&t, "scale_points");
        assert!(
            m.contains(&format!(
                ":{line}: `calibration.scale_length_mm`: required with scale_points"
            )),
            "{m}"
        );
    }

    /// Runs the study of `t` without sensitivity; returns the error's message and the steps
    /// the progress callback saw.
    fn run_error(t: &str) -> (String, Vec<String>) {
        let study = parse(t).expect("the study file reads");
        let steps = std::sync::Mutex::new(Vec::new());
        let cb = |stage: &str, _: u64, _: u64| steps.lock().unwrap().push(stage.to_string());
        let options = crate::Options {
            no_sensitivity: true,
            samples: Some(4),
            progress: Some(&cb),
            ..Default::default()
        };
        let e = crate::run_study(&study, &options).expect_err("the study fails");
        // The one line the CLI prints: the error's own context, then its sources.
        (
            crashrig_input::message::error_line(&e),
            steps.into_inner().unwrap(),
        )
    }

    /// A calibration camera that matches no image is reported at the key's line, not at
    /// `[calibration]`'s.
    #[test]
    fn a_wrong_calibration_camera_points_at_its_key_line() {
        let t = text().replace("camera_b = \"cam_in/\"", "camera_b = \"cam_ni/\"");
        let (m, _) = run_error(&t);
        let line = line_starting(&t, "camera_b = \"cam_ni/\"");
        assert!(
            m.contains(&format!("study.toml:{line}: [calibration]")),
            "{m}"
        );
        assert!(m.contains("camera B `cam_ni/` matches no image"), "{m}");
        assert!(m.contains("`cam_in/`"), "the nearest name: {m}");
    }

    /// A camera prefix without its trailing slash selects the images but pairs none: the error
    /// gets the hint and points at that key's line.
    #[test]
    fn a_camera_prefix_without_its_slash_gets_a_hint() {
        let t = text().replace(
            "camera_a = \"cam_out/\"\ncamera_b",
            "camera_a = \"cam_out\"\ncamera_b",
        );
        let (m, _) = run_error(&t);
        let line = line_starting(&t, "camera_a = \"cam_out\"");
        assert!(
            m.contains(&format!("study.toml:{line}: [calibration]")),
            "{m}"
        );
        assert!(m.contains("no epoch pairs camera A and B"), "{m}");
        assert!(
            m.contains("hint: `cam_out` is a directory of the image names: write `cam_out/`"),
            "{m}"
        );
    }

    /// A wrong `[measure]` camera is reported before any step runs (no calibration, no layout),
    /// at the key's line.
    #[test]
    fn a_wrong_measure_camera_is_reported_before_any_work() {
        let t = text().replace("camera_b = \"2\"", "camera_b = \"27\"");
        let (m, steps) = run_error(&t);
        let line = line_starting(&t, "camera_b = \"27\"");
        assert!(m.contains(&format!("study.toml:{line}: [measure]")), "{m}");
        assert!(m.contains("camera B (27)"), "{m}");
        assert!(steps.is_empty(), "no step ran before the error: {steps:?}");
    }
}
