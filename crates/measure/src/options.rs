//! The options of `crashrig measure` as a front end gives them (the CLI's flags, Python's
//! keywords) → a checked [`MeasureConfig`]: the pairs that go together or exclude each other,
//! the σ of camera A, the model's units, the link and the tie read, the filter.
//!
//! ```no_run
//! use crashrig_input::options::Spelling;
//! use crashrig_measure::MeasureOptions;
//! let options = MeasureOptions {
//!     mm_per_unit: Some(1000.0),
//!     sigma_a_position_mm: Some([0.5; 3]),
//!     ..MeasureOptions::new("seq/model", "cam_out/", "cam_in/", "link.json", "markers.csv")
//! };
//! let config = options.config(Spelling::Flag)?;
//! let run = crashrig_measure::run(&config, None)?;
//! for w in options.warnings(&run, Spelling::Flag) {
//!     eprintln!("warning: {w}");
//! }
//! # Ok::<(), crashrig_measure::Error>(())
//! ```

use crate::filter::CfcSpec;
use crate::pixel_check::PixelSigmaFrom;
use crate::{ANoise, Error, MeasureConfig, MeasureRun, OutputDir, Settings, input, rules};
use crashrig_geometry::Vec3;
use crashrig_input::options::{Spelling, check_mm_per_unit};
use std::path::PathBuf;

/// The seed of `measure` when none is given.
pub const DEFAULT_SEED: u64 = 1;

/// The options of `crashrig measure` (`crashrig.measure` in Python), unchecked.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeasureOptions {
    /// COLMAP model of the sequence.
    pub model: PathBuf,
    /// Camera A: image-name prefix or camera id.
    pub camera_a: String,
    /// Camera B: camera id or image-name prefix.
    pub camera_b: String,
    /// Camera C (tied to B by [`MeasureOptions::tie`]).
    pub camera_c: Option<String>,
    /// The calibrated link `A_from_B`: a `calibrate --json` result.
    pub link: PathBuf,
    /// The tie `B_from_C`: a `bootstrap --json` result.
    pub tie: Option<PathBuf>,
    /// Marker observations CSV.
    pub observations: PathBuf,
    /// The output directory (`None`: compute only).
    pub out: Option<OutputDir>,
    /// Model units → mm (else the units the A-covariance file states).
    pub mm_per_unit: Option<f64>,
    /// σ of A's projection centre per epoch (mm; absent: 0).
    pub sigma_a_position_mm: Option<[f64; 3]>,
    /// σ of A's rotation per epoch (degrees; absent: 0).
    pub sigma_a_angles_deg: Option<[f64; 3]>,
    /// A's pose covariance per epoch (JSON); excludes the σ.
    pub a_covariance: Option<PathBuf>,
    /// σ of each pixel coordinate (px); with [`PixelSigmaFrom::Estimate`] the σ the check
    /// compares the residuals with before its estimate replaces it.
    pub pixel_sigma_px: f64,
    /// The stated pixel σ, or the check's estimate (`--pixel-sigma-px estimate`,
    /// `pixel_sigma_px="estimate"`; needs camera C).
    #[serde(default)]
    pub pixel_sigma_from: PixelSigmaFrom,
    /// Monte Carlo replicates per row.
    pub samples: usize,
    /// The seed ([`DEFAULT_SEED`] when `None`).
    pub seed: Option<u64>,
    /// Reference epoch of the displacements.
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz).
    pub frame_rate_hz: Option<f64>,
    /// σ_max above which rows are flagged (mm).
    pub threshold_mm: f64,
    /// Reprojection residual above which rows are flagged (px).
    pub max_reprojection_px: Option<f64>,
    /// CFC filter class of the kinematics.
    pub cfc: Option<u32>,
    /// The filter's standard (`j211` when `None`); needs [`MeasureOptions::cfc`].
    pub cfc_standard: Option<String>,
    /// σ of A's trigger offset (ms).
    pub sync_sigma_ms: f64,
    /// The scale bars of the length check (CSV `name,marker_1,marker_2,length_mm,sigma_mm`).
    #[serde(default)]
    pub scale_bars: Option<PathBuf>,
    /// The lab's maximum permissible error of a length (mm); needs
    /// [`MeasureOptions::scale_bars`].
    #[serde(default)]
    pub mpe_mm: Option<f64>,
    /// Each frame's time (CSV `epoch,time_s`): the time axis instead of
    /// [`MeasureOptions::frame_rate_hz`], which it excludes.
    #[serde(default)]
    pub frame_times: Option<PathBuf>,
}

impl MeasureOptions {
    /// σ of each pixel coordinate when none is given (px): [`rules::DEFAULT_PIXEL_SIGMA_PX`],
    /// the default of [`MeasureOptions::pixel_sigma_px`] and of the study file's `[measure]
    /// pixel_sigma_px`.
    pub const DEFAULT_PIXEL_SIGMA_PX: f64 = rules::DEFAULT_PIXEL_SIGMA_PX;

    /// σ_max above which rows are flagged when no threshold is given (mm):
    /// [`rules::DEFAULT_THRESHOLD_MM`].
    pub const DEFAULT_THRESHOLD_MM: f64 = rules::DEFAULT_THRESHOLD_MM;

    /// The rule of camera A's σ: one source. An A-covariance file excludes the σ of A's centre
    /// and of its rotation; `true` when the file is given with either σ. Both
    /// [`MeasureOptions::config`] and the study file's `[measure]` refuse that, each naming its
    /// own keys.
    pub fn a_sources_conflict(
        a_covariance: bool,
        sigma_a_position_mm: bool,
        sigma_a_angles_deg: bool,
    ) -> bool {
        a_covariance && (sigma_a_position_mm || sigma_a_angles_deg)
    }

    /// The required inputs with every other option at the command's default.
    pub fn new(
        model: impl Into<PathBuf>,
        camera_a: impl Into<String>,
        camera_b: impl Into<String>,
        link: impl Into<PathBuf>,
        observations: impl Into<PathBuf>,
    ) -> MeasureOptions {
        MeasureOptions {
            model: model.into(),
            camera_a: camera_a.into(),
            camera_b: camera_b.into(),
            camera_c: None,
            link: link.into(),
            tie: None,
            observations: observations.into(),
            out: None,
            mm_per_unit: None,
            sigma_a_position_mm: None,
            sigma_a_angles_deg: None,
            a_covariance: None,
            pixel_sigma_px: MeasureOptions::DEFAULT_PIXEL_SIGMA_PX,
            pixel_sigma_from: PixelSigmaFrom::Stated,
            samples: 2000,
            seed: None,
            reference_epoch: None,
            frame_rate_hz: None,
            threshold_mm: MeasureOptions::DEFAULT_THRESHOLD_MM,
            max_reprojection_px: None,
            cfc: None,
            cfc_standard: None,
            sync_sigma_ms: 0.0,
            scale_bars: None,
            mpe_mm: None,
            frame_times: None,
        }
    }

    /// No uncertainty of camera A given (its pose is then treated as exact, with a warning).
    pub fn a_is_exact(&self) -> bool {
        self.a_covariance.is_none()
            && self.sigma_a_position_mm.is_none()
            && self.sigma_a_angles_deg.is_none()
    }

    /// Checks the options and reads the link, the tie and the A covariance's units.
    ///
    /// # Errors
    /// [`Error::Usage`] (names in `spelling`) for options that do not fit together or a σ or
    /// scale out of range; the errors of [`crate::check_out`], [`input::read_a_covariance`],
    /// [`input::model_scale`] and [`input::load_link`]; a setting against its [`rules`].
    pub fn config(&self, spelling: Spelling) -> Result<MeasureConfig, Error> {
        let name = |k| spelling.name(k);
        if let Some(out) = &self.out {
            crate::check_out(&out.dir)?;
        }
        if self.camera_c.is_some() != self.tie.is_some() {
            return Err(Error::Usage(format!(
                "{} and {} go together (give both for a tied-in camera C, or neither)",
                name("camera_c"),
                name("tie")
            )));
        }
        if self.pixel_sigma_from == PixelSigmaFrom::Estimate && self.camera_c.is_none() {
            return Err(Error::Usage(format!(
                "{} estimate needs {} and {} (the estimate comes from the rays of B and C missing each other)",
                name("pixel_sigma_px"),
                name("camera_c"),
                name("tie")
            )));
        }
        let conflict = MeasureOptions::a_sources_conflict(
            self.a_covariance.is_some(),
            self.sigma_a_position_mm.is_some(),
            self.sigma_a_angles_deg.is_some(),
        );
        if let Some(p) = &self.a_covariance
            && conflict
        {
            return Err(Error::Usage(format!(
                "{} ({}) excludes {} and {}",
                name("a_covariance"),
                p.display(),
                name("sigma_a_position_mm"),
                name("sigma_a_angles_deg")
            )));
        }
        let spelled = |k| spelling.name(k).to_string();
        let usage = |key, problem: String| Error::Usage(format!("{}: {problem}", name(key)));
        let standard =
            rules::cfc_standard(self.cfc_standard.as_deref(), self.cfc.is_some(), &spelled)
                .map_err(|p| usage("cfc_standard", p))?;
        if let Some(e) = self.mpe_mm {
            rules::mpe_mm(e, self.scale_bars.is_some(), &spelled)
                .map_err(|p| usage("mpe_mm", p))?;
        }
        let (frame_rate_hz, frame_times) = self.time_axis(spelling)?;
        let given = self
            .mm_per_unit
            .map(|f| check_mm_per_unit(f, name("mm_per_unit")))
            .transpose()
            .map_err(|e| Error::Usage(e.to_string()))?;
        // Units are never guessed: the option, or the units the A covariance states.
        let a_cov = self
            .a_covariance
            .as_deref()
            .map(input::read_a_covariance)
            .transpose()?;
        let mm_per_unit = input::model_scale(given, a_cov.as_ref(), name("mm_per_unit"))?;
        let a_noise = match &self.a_covariance {
            Some(p) => ANoise::File(p.clone()),
            None => ANoise::Sigmas {
                position_mm: sigmas(self.sigma_a_position_mm, name("sigma_a_position_mm"))?,
                angles_deg: sigmas(self.sigma_a_angles_deg, name("sigma_a_angles_deg"))?,
            },
        };
        let cfc = self.cfc.map(|class| CfcSpec { class, standard });
        Ok(MeasureConfig {
            model: self.model.clone(),
            camera_a: self.camera_a.clone(),
            camera_b: self.camera_b.clone(),
            camera_c: self.camera_c.clone(),
            a_from_b: input::load_link(&self.link)?,
            b_from_c: self.tie.as_deref().map(input::load_link).transpose()?,
            observations: self.observations.clone(),
            mm_per_unit,
            a_noise,
            settings: Settings {
                samples: self.samples,
                seed: self.seed.unwrap_or(DEFAULT_SEED),
                pixel_sigma_px: self.pixel_sigma_px,
                reference_epoch: self.reference_epoch.clone(),
                frame_rate_hz,
                frame_times,
                threshold_mm: self.threshold_mm,
                max_reprojection_px: self.max_reprojection_px,
                cfc,
                sync_sigma_ms: self.sync_sigma_ms,
            },
            pixel_sigma_from: self.pixel_sigma_from,
            scale_bars: self.scale_bars.clone().map(|path| crate::ScaleBarsFile {
                path,
                mpe_mm: self.mpe_mm,
            }),
            out: self.out.clone(),
        })
    }

    /// The time axis: [`MeasureOptions::frame_rate_hz`] as given, or the frame times read
    /// with the rate of their mean interval (with a CFC filter: the one interval the filter
    /// runs on, [`input::FrameTimes::uniform_interval`]).
    fn time_axis(
        &self,
        spelling: Spelling,
    ) -> Result<(Option<f64>, Option<input::FrameTimes>), Error> {
        let Some(path) = &self.frame_times else {
            return Ok((self.frame_rate_hz, None));
        };
        if self.frame_rate_hz.is_some() {
            return Err(Error::Usage(format!(
                "{} ({}) and {} exclude each other: the frame times are the time axis",
                frame_times_name(spelling),
                path.display(),
                spelling.name("frame_rate_hz")
            )));
        }
        let (rate, times) = input::read_time_axis(path, self.cfc.is_some())?;
        Ok((Some(rate), Some(times)))
    }

    /// The warnings of a finished run, in the order the command prints them: A treated as
    /// exact, the run's own, implausible values of the frame rate or the units.
    pub fn warnings(&self, run: &MeasureRun, spelling: Spelling) -> Vec<String> {
        let mut all = Vec::new();
        if self.a_is_exact() {
            all.push(format!(
                "no uncertainty given for camera A's pose ({}, {} or {}): it is treated as exact",
                spelling.name("sigma_a_position_mm"),
                spelling.name("sigma_a_angles_deg"),
                spelling.name("a_covariance")
            ));
        }
        all.extend(run.warnings.iter().cloned());
        // With frame times, the rate of their mean interval, named by the file's flag.
        let (rate, rate_name) = match self.frame_times {
            Some(_) => (
                run.summary.numbers.frame_rate_hz,
                frame_times_name(spelling),
            ),
            None => (self.frame_rate_hz, spelling.name("frame_rate_hz")),
        };
        all.extend(crate::plausible::warnings(
            &run.measurement,
            rate,
            rate_name,
            spelling.name("mm_per_unit"),
        ));
        all
    }
}

/// Three σ (absent: 0), finite and ≥ 0.
fn sigmas(v: Option<[f64; 3]>, name: &str) -> Result<Vec3, Error> {
    let x = Vec3::from(v.unwrap_or([0.0; 3]));
    if x.iter().all(|c| c.is_finite() && *c >= 0.0) {
        Ok(x)
    } else {
        Err(Error::Usage(format!(
            "{name}: σ must be finite numbers ≥ 0"
        )))
    }
}

/// `--frame-times` / `frame_times` as `spelling` names options.
fn frame_times_name(spelling: Spelling) -> &'static str {
    if spelling.name("frame_rate_hz").starts_with("--") {
        "--frame-times"
    } else {
        "frame_times"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> MeasureOptions {
        MeasureOptions::new(
            "no/model",
            "cam_out/",
            "cam_in/",
            "no/link.json",
            "no/markers.csv",
        )
    }

    fn message(o: &MeasureOptions, spelling: Spelling) -> String {
        o.config(spelling).unwrap_err().to_string()
    }

    #[test]
    fn options_that_do_not_fit_are_named_as_each_front_end_spells_them() {
        let c_alone = MeasureOptions {
            camera_c: Some("cam_door/".into()),
            ..options()
        };
        assert_eq!(
            message(&c_alone, Spelling::Flag),
            "--camera-c and --tie go together (give both for a tied-in camera C, or neither)"
        );
        assert_eq!(
            message(&c_alone, Spelling::Keyword),
            "camera_c and tie go together (give both for a tied-in camera C, or neither)"
        );
        let both = MeasureOptions {
            a_covariance: Some("a.json".into()),
            sigma_a_angles_deg: Some([0.1; 3]),
            ..options()
        };
        assert_eq!(
            message(&both, Spelling::Keyword),
            "a_covariance (a.json) excludes sigma_a_position_mm and sigma_a_angles_deg"
        );
        let standard = MeasureOptions {
            cfc_standard: Some("j211".into()),
            ..options()
        };
        assert_eq!(
            message(&standard, Spelling::Flag),
            "--cfc-standard: needs --cfc (it names the standard of a CFC filter)"
        );
        let units = MeasureOptions {
            mm_per_unit: Some(0.0),
            ..options()
        };
        assert_eq!(
            message(&units, Spelling::Flag),
            "--mm-per-unit: must be a number from 1e-9 to 1e9 mm per model unit"
        );
        let sigma = MeasureOptions {
            mm_per_unit: Some(1.0),
            sigma_a_position_mm: Some([0.1, f64::NAN, 0.1]),
            ..options()
        };
        assert_eq!(
            message(&sigma, Spelling::Keyword),
            "sigma_a_position_mm: σ must be finite numbers ≥ 0"
        );
        // Units are never guessed.
        assert!(message(&options(), Spelling::Flag).contains("--mm-per-unit"));
        let mpe = MeasureOptions {
            mpe_mm: Some(1.0),
            ..options()
        };
        assert_eq!(
            message(&mpe, Spelling::Flag),
            "--mpe-mm: needs --scale-bars (the maximum permissible error of the bars' lengths)"
        );
        let mpe = MeasureOptions {
            mpe_mm: Some(-1.0),
            scale_bars: Some("bars.csv".into()),
            ..options()
        };
        assert_eq!(
            message(&mpe, Spelling::Keyword),
            "mpe_mm: -1 is not a number > 0 (mm)"
        );
    }
}
