//! Rig calibration from a COLMAP model, the library of `crashrig calibrate`: epochs → link
//! `A_from_B` with its tangent covariance.
//!
//! One call, [`calibrate`], reads the model, pairs the images of cameras A and B into epochs
//! ([`epochs_from_model`]), converts model units to mm (scale bar or a factor), and calibrates the
//! link with `crashrig_rig::calibrate`: statistics over the epochs (the paper's Tables 1–2),
//! outliers, drift, the spread of one epoch's link (`covariance_tangent`) and the uncertainty
//! of the mean link (`sem_covariance_tangent`, autocorrelation-aware, rule in `sem_rule`).
//! The [`CalibrationResult`] prints itself as the `calibrate --json` document
//! ([`CalibrationResult::to_json`]) or the text report ([`CalibrationResult::text_report`]),
//! and writes its plots ([`CalibrationResult::write_plots`]). Library values are in mm and
//! radians; the JSON and the report use degrees. Every field is documented in
//! `docs/CALIBRATE.md`.
//!
//! # Entry points
//! - [`calibrate`]`(&`[`CalibrationConfig`]`, monitor)` → [`CalibrationResult`]: the library
//!   entry of `crashrig calibrate` and of a study's `[calibration]`.
//! - [`epochs_from_model`] ([`EpochSet`]) and [`scale_from_points`] ([`ScaleBar`]): the pairing
//!   of A and B images into epochs and the scale bar, on a model already read.
//! - [`CalibrationResult::document`] ([`contract::CalibrationDocument`]): the `calibrate --json`
//!   document; [`Reprojection`] and [`SplitHalf`]: the calibration's quality values.
//! - [`Error`]: the one error type; every message names the model directory or option.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```no_run
//! use crashrig_calibrate::{CalibrationConfig, Scale, calibrate};
//!
//! let config = CalibrationConfig {
//!     model: "calibration/sparse/0".into(),
//!     camera_a: "cam_out/".into(),
//!     camera_b: "cam_in/".into(),
//!     scale: Scale::ScaleBar { points: [1, 2], length_mm: 2000.0 },
//!     ..CalibrationConfig::default()
//! };
//! let result = calibrate(&config, None)?;
//! // The mean link A_from_B with the uncertainty of the mean (mm, rad): what a chain uses.
//! let link = result.link;
//! println!("{}", result.to_json());
//! # Ok::<(), crashrig_calibrate::Error>(())
//! ```

#![deny(missing_docs)]
#![warn(unnameable_types)]

pub mod contract;
mod epochs;
mod error;
mod quality;

use crate::contract::{
    CalibrationDocument, DriftDocument, EpochDocument, LinkDocument, LinkStatisticsDocument,
    PairingDocument, RefinedDocument, ScaleDocument, SemDetailDocument,
};
pub use crate::epochs::{CameraSelector, EpochSet, ScaleBar, epochs_from_model, scale_from_points};
pub use crate::error::Error;
pub use crate::quality::{Reprojection, SPLIT_HALF_Z, SplitHalf};
use crashrig_colmap::Reconstruction;
use crashrig_geometry::{Mat6, UncertainPose, Vec3, opk};
use crashrig_rig::refine::RefineOptions;
use crashrig_rig::robust::outlier_rule_description;
use crashrig_rig::stats::LinkStatistics;
use crashrig_rig::{CalibrateOptions, Calibration, DriftReport, Error as RigError, Refinement};
use crashrig_stats::progress::Monitor;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Names of the six ω φ κ parameters, in the library's order.
const PARAMS: [&str; 6] = ["x", "y", "z", "omega", "phi", "kappa"];
/// Names of the six tangent axes (centre in A's axes, rotation about B's axes).
const TANGENT: [&str; 6] = ["x", "y", "z", "theta_x", "theta_y", "theta_z"];
/// Axis labels of the six parameters.
const LABELS: [&str; 6] = [
    "base X [mm]",
    "base Y [mm]",
    "base Z [mm]",
    "omega [deg]",
    "phi [deg]",
    "kappa [deg]",
];

/// Where the scale (mm per model unit) comes from.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Scale {
    /// No scale given: 1 mm per model unit.
    #[default]
    Default,
    /// A given factor (`--mm-per-unit F`).
    MmPerUnit(f64),
    /// Two point3D ids a known distance apart (`--scale-points ID1 ID2 --scale-length-mm L`).
    ScaleBar {
        /// The two point3D ids.
        points: [u64; 2],
        /// Their known distance (mm).
        length_mm: f64,
    },
}

impl Scale {
    /// The scale the options give: a factor, a scale bar or neither ([`Scale::Default`]).
    ///
    /// # Errors
    /// [`Error::Usage`] (names in `spelling`): both given, a bar without its length or
    /// points, a factor out of range.
    pub fn from_options(
        options: &crashrig_input::options::ScaleOptions,
        spelling: crashrig_input::options::Spelling,
    ) -> Result<Scale, Error> {
        use crashrig_input::options::GivenScale;
        match options.given(spelling) {
            Ok(Some(GivenScale::MmPerUnit(f))) => Ok(Scale::MmPerUnit(f)),
            Ok(Some(GivenScale::ScaleBar { points, length_mm })) => {
                Ok(Scale::ScaleBar { points, length_mm })
            }
            Ok(None) => Ok(Scale::Default),
            Err(e) => Err(Error::Usage(e.to_string())),
        }
    }
}

/// What `crashrig calibrate` takes.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationConfig {
    /// COLMAP model directory.
    pub model: PathBuf,
    /// Camera A: an image-name prefix (e.g. `cam_out/`) or a camera id.
    pub camera_a: String,
    /// Camera B: an image-name prefix or a camera id.
    pub camera_b: String,
    /// The scale.
    pub scale: Scale,
    /// Largest lag of the autocorrelation report (default 10).
    pub max_lag: usize,
    /// Run the rig-constrained refinement (default true).
    pub refine: bool,
    /// Accept a model whose epochs all give the same link (default false: refused).
    pub accept_rig_constrained: bool,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            model: PathBuf::new(),
            camera_a: String::new(),
            camera_b: String::new(),
            scale: Scale::Default,
            max_lag: 10,
            refine: true,
            accept_rig_constrained: false,
        }
    }
}

/// The scale as resolved against the model.
#[derive(Debug, Clone, PartialEq)]
pub enum ResolvedScale {
    /// From a scale bar.
    Bar(ScaleBar),
    /// Given.
    Given(f64),
    /// Not given (1 mm per unit).
    Default,
}

impl CalibrationResult {
    /// The warning (without `warning: `) for a baseline |base_mm| outside
    /// [`BASELINE_RANGE_MM`], naming the input that set the scale and its unit: `bar_key` for a
    /// scale bar's length (mm), `factor_key` for a given or default mm per model unit.
    pub fn baseline_warning(&self, bar_key: &str, factor_key: &str) -> Option<String> {
        let base = self.link.b_from_a.translation.vector.norm();
        let (lo, hi) = BASELINE_RANGE_MM;
        if (lo..=hi).contains(&base) || !base.is_finite() {
            return None;
        }
        let cause = match &self.scale {
            ResolvedScale::Bar(b) => format!(
                "check {bar_key} = {} (mm: the scale bar's length in millimetres)",
                b.length_mm
            ),
            ResolvedScale::Given(f) => format!("check {factor_key} = {f} (mm per model unit)"),
            ResolvedScale::Default => format!(
                "the model's units were taken as mm: give {factor_key} (mm per model unit) or a scale bar"
            ),
        };
        Some(format!(
            "the rig baseline |base_mm| = {base:.3} mm is outside the plausible {lo} mm – {} m; {cause}",
            hi / 1000.0
        ))
    }
}

impl ResolvedScale {
    /// mm per model unit.
    pub fn mm_per_unit(&self) -> f64 {
        match self {
            ResolvedScale::Bar(b) => b.mm_per_unit,
            ResolvedScale::Given(f) => *f,
            ResolvedScale::Default => 1.0,
        }
    }
}

/// Plausible rig baselines (mm): an on-board camera pair is more than 20 mm and less than 5 m
/// apart; a baseline outside is a scale in the wrong unit (a 1.2 m scale bar typed as 1.2 mm).
pub const BASELINE_RANGE_MM: (f64, f64) = (20.0, 5000.0);

/// A finished calibration: typed values, printed by [`CalibrationResult::to_json`] and
/// [`CalibrationResult::text_report`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationResult {
    /// The mean link `A_from_B` (mm) with `sem_covariance_tangent` (mm, rad): what a crash
    /// test uses.
    pub link: UncertainPose,
    /// Spread of one epoch's link over the epochs (n − 1), mm and rad: `covariance_tangent`.
    pub epoch_covariance: Mat6,
    /// The rule of `sem_covariance_tangent` (`crashrig_rig::sem`).
    pub sem_rule: String,
    /// Number of epochs.
    pub n_epochs: usize,
    /// Effective number of epochs per tangent axis (n over the variance factor of the rule).
    pub effective_n: [f64; 6],
    /// Per tangent axis: false where the effective n is below 10 (the sequence is too short
    /// for the drift seen; the SE stays finite but cannot hold).
    pub sem_reliable: [bool; 6],
    /// Warnings (unpaired images, autocorrelation, a skipped refinement, an accepted
    /// rig-constrained model), one line each; printed on stderr by the CLI.
    pub warnings: Vec<String>,
    /// The configuration it was computed from.
    pub config: CalibrationConfig,
    /// The pairing of the images into epochs.
    pub pairing: EpochSet,
    /// The scale used.
    pub scale: ResolvedScale,
    /// Everything the rig crate computed (statistics, outliers, drift, refinement).
    pub calibration: Calibration,
    /// Reprojection residuals of camera A's and camera B's observations in the model
    /// (COLMAP's camera models, the model's own poses and points), A first.
    pub reprojection: Vec<Reprojection>,
    /// The split-half check of the link (the mean link of each half of the sequence with its
    /// σ of the mean; `None` below 4 epochs).
    pub split_half: Option<SplitHalf>,
}

/// Calibrates as `crashrig calibrate` does (see the module doc).
///
/// A refinement that fails to converge or is singular does not fail the calibration: the
/// epoch statistics do not depend on it; it is left out with a warning. `monitor` (optional)
/// follows the rig-constrained refinement (weighting rounds, see [`crashrig_rig::calibrate`])
/// and may cancel it; the result is the same with and without it.
///
/// # Errors
/// Every [`Error`]: an unreadable model, a bad selector or scale, no epochs, a
/// rig-constrained model (unless accepted), too few epochs; [`Error::Cancelled`].
pub fn calibrate(
    config: &CalibrationConfig,
    monitor: Option<&dyn Monitor>,
) -> Result<CalibrationResult, Error> {
    let model = Reconstruction::read(&config.model)?;
    let sel_a = CameraSelector::parse(&config.camera_a);
    let sel_b = CameraSelector::parse(&config.camera_b);
    let set = epochs_from_model(&model, &sel_a, &sel_b)?;
    let rig_err = |source: RigError| match source {
        RigError::Cancelled(c) => Error::Cancelled(c),
        source => Error::Rig {
            model: config.model.clone(),
            source,
        },
    };
    let scale = match &config.scale {
        Scale::ScaleBar { points, length_mm } => {
            ResolvedScale::Bar(scale_from_points(&model, points[0], points[1], *length_mm)?)
        }
        Scale::MmPerUnit(f) => {
            ResolvedScale::Given(crashrig_rig::check_scale(*f).map_err(rig_err)?)
        }
        Scale::Default => ResolvedScale::Default,
    };
    let mut warnings = unpaired_warnings(&set);
    let options = CalibrateOptions {
        max_lag: config.max_lag,
        refine: config.refine.then(RefineOptions::default),
        accept_rig_constrained: config.accept_rig_constrained,
    };
    let split_half = crate::quality::split_half(&set.epochs, scale.mm_per_unit(), &options);
    let run = |o: &CalibrateOptions| {
        crashrig_rig::calibrate(&set.epochs, scale.mm_per_unit(), o, monitor)
    };
    let cal = match run(&options) {
        Ok(c) => c,
        Err(e @ (RigError::NoConvergence { .. } | RigError::SingularNormalMatrix { .. })) => {
            warnings.push(format!("rig-constrained refinement skipped: {e}"));
            run(&CalibrateOptions {
                refine: None,
                ..options
            })
            .map_err(rig_err)?
        }
        Err(RigError::RigConstrained {
            n_epochs,
            spread_mm,
            spread_rad,
        }) => {
            return Err(Error::RigConstrained {
                model: config.model.clone(),
                n_epochs,
                spread_mm,
                spread_deg: spread_rad.to_degrees(),
            });
        }
        Err(e) => return Err(rig_err(e)),
    };
    if cal.rig_constrained {
        warnings.push(format!(
            "all {} epochs give the same link (a rig-constrained model, accepted for inspection): \
             σ, SEM and every covariance are 0 and are no measure of the link's uncertainty",
            cal.links.len()
        ));
    }
    if let Some(d) = &cal.drift
        && d.any_optimistic()
    {
        warnings.push(format!(
            "the epoch series is autocorrelated ({}); σ/√n is likely optimistic",
            optimistic_list(d)
        ));
    }
    if cal.sem.autocorrelated.iter().any(|&a| a) {
        let axes: Vec<String> = (0..6)
            .filter(|&j| cal.sem.autocorrelated[j])
            .map(|j| format!("{} × {:.2}", TANGENT[j], cal.sem.inflation[j].sqrt()))
            .collect();
        warnings.push(format!(
            "sem_covariance_tangent is widened for drift (rule {}; SE {})",
            cal.sem.rule,
            axes.join(", ")
        ));
    }
    for j in (0..6).filter(|&j| !cal.sem.reliable[j]) {
        warnings.push(format!(
            "axis {}: effective n {:.1} < {} (n = {}): the sequence is too short for the drift \
             seen, so the SE of the mean on this axis is not reliable (sem_reliable = false)",
            TANGENT[j],
            cal.sem.effective_n[j],
            crashrig_rig::sem::RELIABLE_EFFECTIVE_N,
            cal.links.len()
        ));
    }
    let reprojection = vec![
        crate::quality::reprojection(&model, &config.camera_a, 'A'),
        crate::quality::reprojection(&model, &config.camera_b, 'B'),
    ];
    let mut result = CalibrationResult {
        reprojection,
        split_half,
        link: cal.link,
        epoch_covariance: cal.epoch_spread.covariance,
        sem_rule: cal.sem.rule.to_string(),
        n_epochs: cal.links.len(),
        effective_n: cal.sem.effective_n,
        sem_reliable: cal.sem.reliable,
        warnings,
        config: config.clone(),
        pairing: set,
        scale,
        calibration: cal,
    };
    // Units are never guessed: an implausible baseline names the scale input (the command's
    // flags here; the study names its own keys).
    if let Some(w) = result.baseline_warning("--scale-length-mm", "--mm-per-unit") {
        result.warnings.push(w);
    }
    Ok(result)
}

fn unpaired_warnings(set: &EpochSet) -> Vec<String> {
    let mut out = Vec::new();
    for (what, v) in [
        ("image(s) of camera A have no partner in B", &set.unpaired_a),
        ("image(s) of camera B have no partner in A", &set.unpaired_b),
        (
            "paired image(s) have no pose (epoch skipped)",
            &set.without_pose,
        ),
    ] {
        if !v.is_empty() {
            let shown: Vec<&str> = v.iter().take(10).map(String::as_str).collect();
            let more = if v.len() > 10 { ", …" } else { "" };
            out.push(format!("{} {what}: {}{more}", v.len(), shown.join(", ")));
        }
    }
    out
}

fn optimistic_list(d: &DriftReport) -> String {
    (0..6)
        .filter(|&j| d.optimistic[j])
        .map(|j| {
            format!(
                "{}: lag-1 r = {:.2}, n_eff ≈ {:.0}, SEM × {:.2}",
                PARAMS[j], d.autocorrelation[j][0], d.effective_n[j], d.sem_inflation[j]
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn deg3(v: &Vec3) -> [f64; 3] {
    [v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees()]
}

fn arr3(v: &Vec3) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

/// A (mm, rad) covariance as nested arrays in (mm, deg).
fn cov_deg(c: &Mat6) -> Vec<Vec<f64>> {
    let f = |k: usize| if k < 3 { 1.0 } else { 1f64.to_degrees() };
    (0..6)
        .map(|i| (0..6).map(|j| c[(i, j)] * f(i) * f(j)).collect())
        .collect()
}

fn stats_document(s: &LinkStatistics) -> LinkStatisticsDocument {
    LinkStatisticsDocument {
        angles_deg: deg3(&s.angles),
        angles_sem_deg: deg3(&s.angles_sem),
        angles_sigma_deg: deg3(&s.angles_sigma),
        base_mm: arr3(&s.base_mm),
        base_sem_mm: arr3(&s.base_sem_mm),
        base_sigma_mm: arr3(&s.base_sigma_mm),
        covariance: cov_deg(&s.covariance),
        mean_rotation_angles_deg: deg3(&s.mean_rotation_angles),
        n_epochs: s.n,
    }
}

/// What the refinement's covariance is (in the JSON and the report).
const REFINED_LABEL: &str = "a weighted mean of the same per-epoch poses (not independent \
evidence); covariance from the normal equations, which treat the epochs as independent, \
raised on each tangent axis to at least sem_covariance_tangent";

fn refined_document(r: &Refinement) -> RefinedDocument {
    RefinedDocument {
        angles_deg: deg3(&r.angles),
        angles_sigma_deg: deg3(&r.angles_sigma),
        base_mm: arr3(&r.base_mm),
        base_sigma_mm: arr3(&r.base_sigma_mm),
        covariance: cov_deg(&r.covariance),
        covariance_tangent: cov_deg(&r.tangent_covariance),
        covariance_tangent_independent: cov_deg(&r.tangent_covariance_independent),
        floor_factors: r.floor_factors,
        iterations: r.iterations,
        n_unknowns: r.n_unknowns,
        redundancy: r.redundancy,
        sigma_position_mm: arr3(&r.sigma_position_mm),
        sigma_rotation_deg: deg3(&r.sigma_rotation),
        variance_factor: r.variance_factor,
        what: REFINED_LABEL,
    }
}

fn drift_document(d: &DriftReport) -> DriftDocument {
    DriftDocument {
        effective_n: d.effective_n,
        lags: d.autocorrelation.clone(),
        order: PARAMS,
        sem_inflation: d.sem_inflation,
        sem_optimistic: d.optimistic,
        warning: d.any_optimistic(),
        white_noise_band: d.white_noise_band,
    }
}

/// ω φ κ (deg) of a rotation.
fn opk_deg(u: &UncertainPose) -> [f64; 3] {
    let a = opk::opk_from_rotation(&u.rotation());
    [
        a.omega.to_degrees(),
        a.phi.to_degrees(),
        a.kappa.to_degrees(),
    ]
}

impl CalibrationResult {
    /// The `calibrate --json` document: the contract's fields, `covariance_tangent`,
    /// `sem_covariance_tangent`, `sem_rule`, and the extension fields of `docs/CALIBRATE.md`.
    pub fn document(&self) -> CalibrationDocument {
        let c = &self.calibration;
        let epochs = c
            .links
            .iter()
            .zip(&c.outliers.outlier)
            .zip(&c.outliers.z_scores)
            .map(|((l, o), z)| EpochDocument {
                angles_deg: deg3(&l.angles),
                base_mm: arr3(&l.base_mm),
                name: l.name.clone(),
                outlier: *o,
                z_scores: *z,
            })
            .collect();
        let scale = match &self.scale {
            ResolvedScale::Bar(b) => ScaleDocument {
                distance_units: Some(b.distance_units),
                length_mm: Some(b.length_mm),
                point_ids: Some([b.point_1, b.point_2]),
                source: "scale_bar",
            },
            ResolvedScale::Given(_) => ScaleDocument::source("mm_per_unit"),
            ResolvedScale::Default => ScaleDocument::source("default"),
        };
        let set = &self.pairing;
        // The contract's statistics over all epochs are exactly `stats_document` of them; the
        // rest are extension fields.
        let LinkStatisticsDocument {
            angles_deg,
            angles_sem_deg,
            angles_sigma_deg,
            base_mm,
            base_sem_mm,
            base_sigma_mm,
            covariance,
            mean_rotation_angles_deg,
            n_epochs,
        } = stats_document(&c.all);
        CalibrationDocument {
            angles_deg,
            angles_sem_deg,
            angles_sigma_deg,
            autocorrelation: c.drift.as_ref().map(drift_document),
            base_mm,
            base_sem_mm,
            base_sigma_mm,
            camera_a: self.config.camera_a.clone(),
            camera_b: self.config.camera_b.clone(),
            covariance,
            covariance_tangent: cov_deg(&self.epoch_covariance),
            effective_n: self.effective_n,
            epochs,
            link: LinkDocument {
                angles_deg: opk_deg(&self.link),
                base_mm: arr3(&self.link.center()),
            },
            mean_rotation_angles_deg,
            mm_per_unit: c.mm_per_unit,
            model: self.config.model.display().to_string(),
            n_epochs,
            n_outliers: c.outliers.indices().len(),
            outlier_rule: outlier_rule_description(c.links.len()),
            outlier_threshold: c.outliers.threshold,
            outlier_thresholds: c.outliers.thresholds,
            pairing: PairingDocument {
                by_frame: set.paired_by_frame,
                by_name: set.paired_by_name,
                unpaired_a: set.unpaired_a.clone(),
                unpaired_b: set.unpaired_b.clone(),
                without_pose: set.without_pose.clone(),
            },
            refined: c.refined.as_ref().map(refined_document),
            refined_without_outliers: c.refined_without_outliers.as_ref().map(refined_document),
            rig_constrained: c.rig_constrained,
            scale,
            scale_factor: c.mm_per_unit,
            sem_covariance_tangent: cov_deg(&self.link.covariance),
            sem_detail: SemDetailDocument {
                autocorrelated: c.sem.autocorrelated,
                drift_rho: c.sem.drift_rho,
                drift_share: c.sem.drift_share,
                lag1: c.sem.lag1,
                order: TANGENT,
                small_sample_factor: c.sem.small_sample_factor,
                variance_inflation: c.sem.inflation,
            },
            sem_reliable: self.sem_reliable,
            sem_rule: self.sem_rule.clone(),
            warnings: self.warnings.clone(),
            without_outliers: c.without_outliers.as_ref().map(stats_document),
        }
    }

    /// [`Self::document`] as a JSON value (what `crashrig calibrate --json` prints).
    pub fn to_json(&self) -> Value {
        // Serialising plain numbers, strings and arrays cannot fail; non-finite numbers
        // become null.
        serde_json::to_value(self.document()).unwrap_or(Value::Null)
    }

    /// What `crashrig calibrate` prints without `--json`: Tables 1–2 and the rest.
    pub fn text_report(&self) -> String {
        let mut o = String::new();
        self.report_header(&mut o);
        self.report_tables(&mut o);
        self.report_tangent(&mut o);
        self.report_outliers(&mut o);
        self.report_drift(&mut o);
        self.report_refinement(&mut o);
        o
    }

    /// The title line (model, cameras, epochs, pairing), the scale and the rig-constrained warning.
    fn report_header(&self, o: &mut String) {
        let c = &self.calibration;
        let set = &self.pairing;
        let s = &c.all;
        let _ = writeln!(
            o,
            "Rig calibration of {}: B ({}) relative to A ({}), {} epochs ({} by name, {} by frame)",
            self.config.model.display(),
            self.config.camera_b,
            self.config.camera_a,
            s.n,
            set.paired_by_name,
            set.paired_by_frame
        );
        let _ = match &self.scale {
            ResolvedScale::Bar(b) => writeln!(
                o,
                "Scale: {:.6} mm per model unit (scale bar: points {} and {}, {:.3} mm = {:.6} units)",
                b.mm_per_unit, b.point_1, b.point_2, b.length_mm, b.distance_units
            ),
            ResolvedScale::Given(f) => writeln!(o, "Scale: {f} mm per model unit (given)"),
            ResolvedScale::Default => {
                writeln!(o, "Scale: 1 mm per model unit (default; no scale given)")
            }
        };
        if c.rig_constrained {
            let _ = writeln!(
                o,
                "RIG-CONSTRAINED MODEL (accepted for inspection): every epoch gives the same link; \
                 the σ, SEM and covariances below are 0 and mean nothing."
            );
        }
    }

    /// Tables 1–2: the base and ω φ κ over all epochs (mean, σ, σ/√n) and the SO(3) mean.
    fn report_tables(&self, o: &mut String) {
        let s = &self.calibration.all;
        let _ = writeln!(o);
        let _ = writeln!(o, "Table 1 – base: B's projection centre in A's frame (mm)");
        header(o, ["X", "Y", "Z"]);
        stats_rows(o, s, true);
        let _ = writeln!(o);
        let _ = writeln!(o, "Table 2 – orientation: ω φ κ of R_A_from_B (deg)");
        header(o, ["ω", "φ", "κ"]);
        stats_rows(o, s, false);
        row(o, "SO(3) mean", deg3(&s.mean_rotation_angles), 4);
        let _ = writeln!(o);
    }

    /// The tangent covariance: σ of one epoch and SE of the mean per axis, with the SE rule.
    fn report_tangent(&self, o: &mut String) {
        let c = &self.calibration;
        let sd = |m: &Mat6, j: usize| {
            let f = if j < 3 { 1.0 } else { 1f64.to_degrees() };
            m[(j, j)].max(0.0).sqrt() * f
        };
        let _ = writeln!(
            o,
            "Tangent covariance (centre in A's axes, mm; rotation about B's axes, deg)"
        );
        let _ = writeln!(
            o,
            "  {:<10}{:>14}{:>18}{:>12}{:>12}",
            "axis", "σ one epoch", "SE of the mean", "SE × ", "eff. n"
        );
        for (j, name) in TANGENT.iter().enumerate() {
            let d = if j < 3 { 3 } else { 4 };
            let _ = writeln!(
                o,
                "  {:<10}{:>14.d$}{:>18.d$}{:>12.2}{:>12.1}{}",
                name,
                sd(&self.epoch_covariance, j),
                sd(&self.link.covariance, j),
                c.sem.inflation[j].sqrt(),
                self.effective_n[j],
                if self.sem_reliable[j] {
                    ""
                } else {
                    "  NOT RELIABLE (effective n < 10)"
                },
                d = d + 1
            );
        }
        let _ = writeln!(
            o,
            "  SE rule: {} (docs/CALIBRATE.md); Tables 1–2 keep the paper's σ/√n",
            self.sem_rule
        );
        let _ = writeln!(o);
    }

    /// The outlier epochs with their z-scores, and the statistics without them.
    fn report_outliers(&self, o: &mut String) {
        let c = &self.calibration;
        let idx = c.outliers.indices();
        let _ = writeln!(
            o,
            "Outliers (|modified z| > {:.2} on any parameter, ≤ 0.5 % false-flag rate per sequence): {}",
            c.outliers.threshold,
            idx.len()
        );
        for &i in &idx {
            let z = c.outliers.z_scores[i];
            let _ = writeln!(
                o,
                "  {:<16} z = [{}]",
                c.links[i].name,
                z.iter()
                    .map(|v| format!("{v:.1}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        if !idx.is_empty() {
            match &c.without_outliers {
                Some(w) => {
                    let _ = writeln!(o, "Without outliers ({} epochs):", w.n);
                    header(o, ["X (mm)", "Y (mm)", "Z (mm)"]);
                    stats_rows(o, w, true);
                    header(o, ["ω (deg)", "φ (deg)", "κ (deg)"]);
                    stats_rows(o, w, false);
                }
                None => {
                    let _ = writeln!(o, "Without outliers: fewer than two epochs remain");
                }
            }
        }
    }

    /// The drift report: lag-1 autocorrelation, effective n and SEM inflation per parameter.
    fn report_drift(&self, o: &mut String) {
        let c = &self.calibration;
        if let Some(d) = &c.drift {
            let _ = writeln!(o);
            let _ = writeln!(
                o,
                "Drift: lag-1 autocorrelation (white-noise band ±{:.3})",
                d.white_noise_band
            );
            for (j, name) in PARAMS.iter().enumerate() {
                let _ = writeln!(
                    o,
                    "  {:<6} r1 = {:>6.3}   n_eff ≈ {:>6.1}   SEM × {:.2}{}",
                    name,
                    d.autocorrelation[j][0],
                    d.effective_n[j],
                    d.sem_inflation[j],
                    if d.optimistic[j] {
                        "   σ/√n likely optimistic"
                    } else {
                        ""
                    }
                );
            }
        }
    }

    /// The rig-constrained refinement (with and without the outliers) against the epoch mean.
    fn report_refinement(&self, o: &mut String) {
        let c = &self.calibration;
        let s = &c.all;
        let idx = c.outliers.indices();
        if let Some(r) = &c.refined {
            let _ = writeln!(o);
            let _ = writeln!(
                o,
                "Rig-constrained refinement ({} unknowns, redundancy {}, {} Gauss–Newton steps)",
                r.n_unknowns, r.redundancy, r.iterations,
            );
            let _ = writeln!(
                o,
                "  A weighted mean of the same per-epoch poses, not independent evidence; its σ is\n  \
                 raised on each axis to at least the SE of the mean above."
            );
            let sr = deg3(&r.sigma_rotation);
            let sp = arr3(&r.sigma_position_mm);
            let _ = writeln!(
                o,
                "  per-pose σ in A's axes: rotation ({:.4}, {:.4}, {:.4}) deg, centre ({:.3}, {:.3}, {:.3}) mm",
                sr[0], sr[1], sr[2], sp[0], sp[1], sp[2]
            );
            let _ = writeln!(
                o,
                "  {:<8}{:>27}{:>27}",
                "", "epoch mean ± σ/√n", "refined ± σ"
            );
            for (j, name) in PARAMS.iter().enumerate() {
                let (m, e, rv, rs, d) = if j < 3 {
                    (
                        s.base_mm[j],
                        s.base_sem_mm[j],
                        r.base_mm[j],
                        r.base_sigma_mm[j],
                        3,
                    )
                } else {
                    let k = j - 3;
                    (
                        s.angles[k].to_degrees(),
                        s.angles_sem[k].to_degrees(),
                        r.angles[k].to_degrees(),
                        r.angles_sigma[k].to_degrees(),
                        4,
                    )
                };
                let _ = writeln!(
                    o,
                    "  {:<8}{:>16.d$} ± {:>8.d$}{:>16.d$} ± {:>8.d$}",
                    name,
                    m,
                    e,
                    rv,
                    rs,
                    d = d
                );
            }
        }
        if let (Some(r), Some(w)) = (&c.refined_without_outliers, &c.without_outliers) {
            let _ = writeln!(
                o,
                "Rig-constrained refinement without the {} outlier epoch(s) ({} epochs):",
                idx.len(),
                w.n
            );
            for (j, name) in PARAMS.iter().enumerate() {
                let (v, sd, d) = if j < 3 {
                    (r.base_mm[j], r.base_sigma_mm[j], 3)
                } else {
                    (
                        r.angles[j - 3].to_degrees(),
                        r.angles_sigma[j - 3].to_degrees(),
                        4,
                    )
                };
                let _ = writeln!(o, "  {name:<8}{:>43.d$} ± {:>8.d$}", v, sd, d = d);
            }
        }
    }

    /// The per-epoch series, histograms and autocorrelation plots of the six parameters, as
    /// (file name, bytes): `series_<p>.png|svg`, `hist_<p>.png|svg`, `acf_<p>.png|svg` with
    /// `p` in x y z omega phi kappa (`acf_*` only when there is a drift report).
    ///
    /// # Errors
    /// [`Error::Plot`] (with `dir` empty) when a figure cannot be drawn.
    pub fn plots(&self) -> Result<Vec<(String, Vec<u8>)>, Error> {
        use crashrig_plot::{Format, histogram, series};
        let c = &self.calibration;
        let plot_err = |what: String| {
            move |source| Error::Plot {
                dir: PathBuf::new(),
                what,
                source,
            }
        };
        let series_rad =
            crashrig_rig::stats::parameter_series(&c.links).map_err(|source| Error::Rig {
                model: self.config.model.clone(),
                source,
            })?;
        let xs: Vec<f64> = (1..=c.links.len()).map(|i| i as f64).collect();
        let mut out = Vec::new();
        for j in 0..6 {
            let f = if j < 3 { 1.0 } else { 1f64.to_degrees() };
            let ys: Vec<f64> = series_rad[j].iter().map(|v| v * f).collect();
            let (mean, sigma) = if j < 3 {
                (c.all.base_mm[j], c.all.base_sigma_mm[j])
            } else {
                // Unwrapped series: the mean is continuous with the values.
                let m = ys.iter().sum::<f64>() / ys.len() as f64;
                (m, c.all.angles_sigma[j - 3].to_degrees())
            };
            for (fmt, ext) in [(Format::Png, "png"), (Format::Svg, "svg")] {
                let bytes = series(
                    &xs,
                    &ys,
                    &format!("{} per epoch", LABELS[j]),
                    "epoch",
                    LABELS[j],
                    fmt,
                )
                .map_err(plot_err(format!("the {} series", PARAMS[j])))?;
                out.push((format!("series_{}.{ext}", PARAMS[j]), bytes));
                let bytes = histogram(
                    &ys,
                    &[mean - sigma, mean, mean + sigma],
                    &format!(
                        "{} over {} epochs (lines: mean, mean ± σ)",
                        LABELS[j],
                        ys.len()
                    ),
                    LABELS[j],
                    fmt,
                )
                .map_err(plot_err(format!("the {} histogram", PARAMS[j])))?;
                out.push((format!("hist_{}.{ext}", PARAMS[j]), bytes));
                if let Some(d) = &c.drift {
                    let r = &d.autocorrelation[j];
                    let lags: Vec<f64> = (1..=r.len()).map(|k| k as f64).collect();
                    let bytes = series(
                        &lags,
                        r,
                        &format!(
                            "autocorrelation of {} (white-noise bound {:.3})",
                            LABELS[j], d.white_noise_band
                        ),
                        "lag [epochs]",
                        "r",
                        fmt,
                    )
                    .map_err(plot_err(format!("the {} autocorrelation", PARAMS[j])))?;
                    out.push((format!("acf_{}.{ext}", PARAMS[j]), bytes));
                }
            }
        }
        Ok(out)
    }

    /// Writes [`CalibrationResult::plots`] as the directory `dir`, replaced as a whole
    /// ([`crashrig_outdir::write_dir`]): an existing `dir` may hold only these plots' names (empty
    /// or an earlier run's), and a kill leaves the old plots, none or the new ones, never a mix.
    ///
    /// # Errors
    /// [`Error::Plot`] or [`Error::Write`] (including `dir` holding other files).
    pub fn write_plots(&self, dir: &Path) -> Result<(), Error> {
        let plots = self.plots().map_err(|e| match e {
            Error::Plot { what, source, .. } => Error::Plot {
                dir: dir.to_path_buf(),
                what,
                source,
            },
            e => e,
        })?;
        crashrig_outdir::write_dir(dir, &plots)?;
        Ok(())
    }
}

fn row(out: &mut String, label: &str, v: [f64; 3], decimals: usize) {
    let _ = writeln!(
        out,
        "  {label:<12}{:>12.d$}{:>12.d$}{:>12.d$}",
        v[0],
        v[1],
        v[2],
        d = decimals
    );
}

fn header(o: &mut String, names: [&str; 3]) {
    let _ = writeln!(
        o,
        "  {:<12}{:>12}{:>12}{:>12}",
        "", names[0], names[1], names[2]
    );
}

fn stats_rows(o: &mut String, s: &LinkStatistics, base: bool) {
    if base {
        row(o, "mean", arr3(&s.base_mm), 3);
        row(o, "σ (n−1)", arr3(&s.base_sigma_mm), 3);
        row(o, "σ/√n", arr3(&s.base_sem_mm), 3);
    } else {
        row(o, "mean", deg3(&s.angles), 4);
        row(o, "σ (n−1)", deg3(&s.angles_sigma), 4);
        row(o, "σ/√n", deg3(&s.angles_sem), 4);
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
