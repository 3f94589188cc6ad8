//! The study's `[measure]` step: a crash-test sequence measured with the study's own calibrated
//! link (and tie), through the command's library entry ([`crashrig_measure::run`]).
//!
//! The link `A_from_B` is the calibration step's typed [`UncertainPose`] (mean link with its
//! SEM covariance) and the tie `B_from_C` the bootstrap's (with the replicates' covariance):
//! exactly what `crashrig measure --link calibrate.json --tie bootstrap.json` reads from those
//! commands' JSON, without the text round trip. The files below `DIR/measure/` are written by
//! the command's own writers, [`crashrig_measure::output`] (`trajectories.csv` with the
//! contract header, `displacements.csv`, `plots/<marker>.png|svg`, `summary.json`; with `cfc`,
//! `kinematics.csv` and `plots/<marker>_kinematics.png|svg`; with `scale_bars`, the length
//! check's `length_check.csv` and `length_check.png|svg`).
//!
//! With `a_control_points`, camera A's per-epoch covariance comes from the bundle:
//! [`crashrig_covariance::run`] on the named model and control points, its typed result
//! handed to the measurement as [`ANoise::Covariance`] (per-epoch blocks and the joint
//! covariance, so A's epochs of one replicate are drawn jointly) — no JSON in between.

use crate::Error;
use crate::study_file::{ABundle, MeasureANoise, MeasureSection, Study};
use crashrig_covariance::{CovarianceConfig, CovarianceResult, Scale};
use crashrig_geometry::UncertainPose;
use crashrig_measure::engine::{Measurement, Settings};
use crashrig_measure::input::{self, ACovariance, JointA, MAX_JOINT_EPOCHS};
use crashrig_measure::{ANoise, MeasureConfig};
use std::path::Path;

/// The measured sequence of a study.
#[derive(Debug, Clone)]
pub struct MeasureResult {
    /// The rows, epochs and markers (typed).
    pub measurement: Measurement,
    /// Summary (`DIR/measure/summary.json`, `results.json` → `"measure"`).
    pub summary: MeasureSummary,
    /// Epochs of the observations without a pose of camera A (skipped; one warning each).
    pub warnings: Vec<String>,
    /// Camera A's covariance from the bundle (`a_control_points`), if the study asked for it.
    pub a_covariance: Option<CovarianceResult>,
}

/// A [`CovarianceResult`] as `measure` takes it: every epoch's block and, up to
/// [`MAX_JOINT_EPOCHS`] epochs, the joint covariance (`None` beyond: the epochs are drawn
/// independently, and the caller warns).
///
/// # Errors
/// [`crashrig_measure::Error::Json`] if the joint matrix is not a valid covariance (it always is
/// for a result of [`crashrig_covariance::run`]).
pub fn a_covariance_of(
    r: &CovarianceResult,
    model: &Path,
) -> Result<ACovariance, crashrig_measure::Error> {
    let joint = if r.epochs.len() <= MAX_JOINT_EPOCHS {
        Some(JointA::from_deg(
            model,
            r.epochs.iter().map(|e| e.name.clone()).collect(),
            r.joint_deg.clone(),
        )?)
    } else {
        None
    };
    Ok(ACovariance {
        default_deg: None,
        per_epoch_deg: r
            .epochs
            .iter()
            .map(|e| (e.name.clone(), e.world_from_a.covariance_deg()))
            .collect(),
        path: model.to_path_buf(),
        mm_per_unit: Some(r.mm_per_unit),
        joint,
    })
}

/// `crashrig covariance` on the study's model and control points (camera A and the scale of
/// the `[measure]` section).
fn bundle_covariance(
    b: &ABundle,
    camera_a: &str,
    mm_per_unit: f64,
) -> Result<CovarianceResult, crashrig_covariance::Error> {
    crashrig_covariance::run(
        &CovarianceConfig {
            model: b.model.clone(),
            camera_a: camera_a.to_string(),
            control_points: b.control_points.clone(),
            scale: Scale::MmPerUnit(mm_per_unit),
            pixel_sigma_px: b.pixel_sigma_px,
            intrinsics: b.intrinsics,
        },
        None,
    )
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
    let step = |e: Error| study.step_error("measure", 0, e);
    if s.camera_c.is_some() && b_from_c.is_none() {
        return Err(step(Error::CameraCWithoutTie));
    }
    // Units are never guessed: the key, or the units the A covariance file states.
    let a_cov = match &s.a_noise {
        MeasureANoise::File(p) => Some(input::read_a_covariance(p).map_err(|e| step(e.into()))?),
        MeasureANoise::Sigmas(..) | MeasureANoise::Bundle(..) => None,
    };
    let mm_per_unit = input::model_scale(s.mm_per_unit, a_cov.as_ref(), "measure.mm_per_unit")
        .map_err(|e| match e {
            crashrig_measure::Error::Setting { problem, .. } => {
                study.key_error("measure", "mm_per_unit", problem)
            }
            e => step(e.into()),
        })?;
    let mut warnings = Vec::new();
    let bundle = match &s.a_noise {
        MeasureANoise::Bundle(b) => {
            let r = bundle_covariance(b, &s.camera_a, mm_per_unit).map_err(|e| step(e.into()))?;
            let cov = a_covariance_of(&r, &b.model).map_err(|e| step(e.into()))?;
            if cov.joint.is_none() {
                warnings.push(format!(
                    "{} epochs of camera A are more than the {MAX_JOINT_EPOCHS} that measure draws jointly: A's epochs are drawn independently (each with its own covariance from the bundle)",
                    r.epochs.len()
                ));
            }
            warnings.extend(r.warnings.iter().cloned());
            Some((r, cov))
        }
        _ => None,
    };
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
            MeasureANoise::Bundle(_) => {
                ANoise::Covariance(Box::new(bundle.as_ref().expect("computed above").1.clone()))
            }
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
            frame_times: s.frame_times.clone(),
            threshold_mm: s.threshold_mm,
            max_reprojection_px: s.max_reprojection_px,
            cfc: s.cfc,
            sync_sigma_ms: s.sync_sigma_ms,
        },
        pixel_sigma_from: s.pixel_sigma_from,
        scale_bars: s
            .scale_bars
            .clone()
            .map(|path| crashrig_measure::ScaleBarsFile {
                path,
                mpe_mm: s.mpe_mm,
            }),
        out: None,
    };
    let r = crashrig_measure::run(&config, None).map_err(|e| step(e.into()))?;
    warnings.extend(r.warnings);
    warnings.extend(crashrig_measure::plausible::warnings(
        &r.measurement,
        s.frame_rate_hz,
        if s.frame_times.is_some() {
            "measure.frame_times"
        } else {
            "measure.frame_rate_hz"
        },
        "measure.mm_per_unit",
    ));
    Ok(MeasureResult {
        measurement: r.measurement,
        summary: r.summary.numbers,
        warnings,
        a_covariance: bundle.map(|(r, _)| r),
    })
}

/// The per-epoch σ of camera A's pose from the bundle, six panels against the epoch (its frame
/// number when every epoch name has one, else the sequence index): σ of the centre x, y, z
/// (world axes, mm) and of the rotation about A's own x, y, z axes (deg).
///
/// # Errors
/// The plotting library's (no finite value to draw).
pub fn a_sigma_plot(
    r: &CovarianceResult,
    format: crashrig_plot::Format,
) -> Result<Vec<u8>, crashrig_plot::Error> {
    let frames: Option<Vec<f64>> = r
        .epochs
        .iter()
        .map(|e| crashrig_measure::sequence::frame_number(&e.name).map(|f| f as f64))
        .collect();
    let (xs, x_label) = match frames {
        Some(f) => (f, "epoch (frame number)"),
        None => (
            (0..r.epochs.len()).map(|i| i as f64).collect(),
            "epoch (sequence index)",
        ),
    };
    let sigma: Vec<[f64; 6]> = r
        .epochs
        .iter()
        .map(|e| {
            let p = e.world_from_a.sigma_position();
            let a = e.world_from_a.sigma_rotation().map(f64::to_degrees);
            [p.x, p.y, p.z, a.x, a.y, a.z]
        })
        .collect();
    let ys: Vec<Vec<f64>> = (0..6)
        .map(|k| sigma.iter().map(|s| s[k]).collect())
        .collect();
    let none = vec![f64::NAN; xs.len()];
    let labels = [
        "σ x [mm]",
        "σ y [mm]",
        "σ z [mm]",
        "σ θx [deg]",
        "σ θy [deg]",
        "σ θz [deg]",
    ];
    let panels: Vec<crashrig_plot::BandPanel<'_>> = (0..6)
        .map(|k| crashrig_plot::BandPanel {
            y_label: labels[k],
            ys: &ys[k],
            half_widths: &none,
        })
        .collect();
    crashrig_plot::banded_panels(
        &xs,
        &panels,
        "camera A: σ of world_from_A per epoch, from the bundle",
        x_label,
        format,
    )
}
