//! The study's `[measure]` step: a crash-test sequence measured with the study's own calibrated
//! link (and tie), through the command's library entry ([`crashrig_measure::run`]).
//!
//! The link `A_from_B` is the calibration step's typed [`UncertainPose`] (mean link with its
//! SEM covariance) and the tie `B_from_C` the bootstrap's (with the replicates' covariance):
//! exactly what `crashrig measure --link calibrate.json --tie bootstrap.json` reads from those
//! commands' JSON, without the text round trip. The files below `DIR/measure/` are written by
//! the command's own writers, [`crashrig_measure::output`] (`trajectories.csv` with the
//! contract header, `displacements.csv`, `plots/<marker>.png|svg`, `summary.json`; with `cfc`,
//! `kinematics.csv` and `plots/<marker>_kinematics.png|svg`).

use crate::Error;
use crate::study_file::{MeasureANoise, MeasureSection, Study};
use crashrig_geometry::UncertainPose;
use crashrig_measure::engine::{Measurement, Settings};
use crashrig_measure::input;
use crashrig_measure::{ANoise, MeasureConfig};

/// The measured sequence of a study.
#[derive(Debug, Clone)]
pub struct MeasureResult {
    /// The rows, epochs and markers (typed).
    pub measurement: Measurement,
    /// Summary (`DIR/measure/summary.json`, `results.json` → `"measure"`).
    pub summary: MeasureSummary,
    /// Epochs of the observations without a pose of camera A (skipped; one warning each).
    pub warnings: Vec<String>,
}

/// The summary of the study's measured sequence: the fields of `crashrig measure`'s
/// `summary.json` that do not depend on timing or file names.
pub type MeasureSummary = crashrig_measure::output::Summary;

/// Measures the study's sequence with the calibrated link `a_from_b` and the tie `b_from_c`
/// (required when the section names `camera_c`), `samples` replicates per row and `seed`.
///
/// # Errors
/// [`Error::Step`] naming the study file and `[measure]` with the measurement library's
/// message (which names the data file).
pub fn run_measure(
    study: &Study,
    s: &MeasureSection,
    a_from_b: UncertainPose,
    b_from_c: Option<UncertainPose>,
    samples: usize,
    seed: u64,
) -> Result<MeasureResult, Error> {
    let step = |e: &dyn std::fmt::Display| study.step_error("measure", 0, e.to_string());
    if s.camera_c.is_some() && b_from_c.is_none() {
        return Err(step(&"camera_c needs a [tie] section (the link B_from_C)"));
    }
    // Units are never guessed: the key, or the units the A covariance file states.
    let a_cov = match &s.a_noise {
        MeasureANoise::File(p) => Some(input::read_a_covariance(p).map_err(|e| step(&e))?),
        MeasureANoise::Sigmas(..) => None,
    };
    let mm_per_unit = input::model_scale(s.mm_per_unit, a_cov.as_ref(), "measure.mm_per_unit")
        .map_err(|e| match e {
            crashrig_measure::Error::Setting { problem, .. } => {
                study.key_error("measure", "mm_per_unit", problem)
            }
            e => step(&e),
        })?;
    let config = MeasureConfig {
        model: s.model.clone(),
        camera_a: s.camera_a.clone(),
        camera_b: s.camera_b.clone(),
        camera_c: s.camera_c.clone(),
        a_from_b,
        b_from_c: b_from_c.filter(|_| s.camera_c.is_some()),
        observations: s.observations.clone(),
        mm_per_unit,
        a_noise: match &s.a_noise {
            MeasureANoise::File(p) => ANoise::File(p.clone()),
            MeasureANoise::Sigmas(pos, ang) => ANoise::Sigmas {
                position_mm: *pos,
                angles_deg: *ang,
            },
        },
        settings: Settings {
            samples,
            seed,
            pixel_sigma_px: s.pixel_sigma_px,
            reference_epoch: s.reference_epoch.clone(),
            frame_rate_hz: s.frame_rate_hz,
            threshold_mm: s.threshold_mm,
            max_reprojection_px: s.max_reprojection_px,
            cfc: s.cfc,
            sync_sigma_ms: s.sync_sigma_ms,
        },
        out: None,
    };
    let r = crashrig_measure::run(&config).map_err(|e| step(&e))?;
    let mut warnings = r.warnings;
    warnings.extend(crashrig_measure::plausible::warnings(
        &r.measurement,
        s.frame_rate_hz,
        "measure.frame_rate_hz",
        "measure.mm_per_unit",
    ));
    Ok(MeasureResult {
        measurement: r.measurement,
        summary: r.summary.numbers,
        warnings,
    })
}
