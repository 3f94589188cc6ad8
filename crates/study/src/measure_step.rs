//! The study's `[measure]` step: a crash-test sequence measured with the study's own calibrated
//! link (and tie), through the measurement library ([`crashrig_measure::measure`]).
//!
//! The link `A_from_B` is the calibration step's typed [`UncertainPose`] (mean link with its
//! SEM covariance) and the tie `B_from_C` the bootstrap's (with the replicates' covariance):
//! exactly what `crashrig measure --link calibrate.json --tie bootstrap.json` reads from those
//! commands' JSON, without the text round trip. The files below `DIR/measure/` are written by
//! the command's own writers, [`crashrig_measure::output`] (`trajectories.csv` with the
//! contract header, `displacements.csv`, `plots/<marker>.png|svg`, `summary.json`).

use crate::Error;
use crate::study_file::{MeasureANoise, MeasureSection, Study};
use crashrig_colmap::CameraSelector;
use crashrig_geometry::UncertainPose;
use crashrig_measure::engine::{Epoch, Measurement, Rig, Settings};
use crashrig_measure::input::{self, CameraNames};
use crashrig_measure::sequence;

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
    let model = crashrig_colmap::Reconstruction::read(&s.model).map_err(|e| step(&e))?;
    let seq = sequence::a_sequence(&model, &CameraSelector::parse(&s.camera_a), s.mm_per_unit)
        .map_err(|e| step(&e))?;
    let (b_id, camera_b) =
        sequence::inward_camera(&model, &CameraSelector::parse(&s.camera_b), 'B')
            .map_err(|e| step(&e))?;
    let c = match (&s.camera_c, b_from_c) {
        (Some(sel), Some(tie)) => {
            let (id, cam) = sequence::inward_camera(&model, &CameraSelector::parse(sel), 'C')
                .map_err(|e| step(&e))?;
            Some((id, tie, cam))
        }
        (Some(_), None) => return Err(step(&"camera_c needs a [tie] section (the link B_from_C)")),
        (None, _) => None,
    };
    let names = CameraNames {
        b_id: Some(b_id),
        c_id: c.as_ref().map(|(id, _, _)| *id),
        has_c: c.is_some(),
    };
    let observations = input::read_observations(&s.observations, &names).map_err(|e| step(&e))?;
    let a_cov = match &s.a_noise {
        MeasureANoise::File(p) => Some(input::read_a_covariance(p).map_err(|e| step(&e))?),
        MeasureANoise::Sigmas(..) => None,
    };
    let mut epochs = Vec::with_capacity(seq.poses.len());
    for p in &seq.poses {
        let world_from_a = match (&a_cov, &s.a_noise) {
            (Some(cov), _) => {
                let m = cov.for_epoch(&[&p.key, &p.name]).ok_or_else(|| {
                    step(&format!(
                        "{}: epochs: no covariance for epoch `{}` and no default covariance_tangent",
                        cov.path.display(),
                        p.name
                    ))
                })?;
                UncertainPose::from_covariance_deg(p.world_from_a, m)
                    .map_err(|e| step(&format!("{}: {e}", cov.path.display())))?
            }
            (None, MeasureANoise::Sigmas(pos, ang)) => {
                UncertainPose::from_sigmas(p.world_from_a, *pos, ang.map(f64::to_radians))
            }
            (None, MeasureANoise::File(_)) => unreachable!("read above"),
        };
        epochs.push(Epoch {
            key: p.key.clone(),
            name: p.name.clone(),
            world_from_a,
        });
    }
    let settings = Settings {
        samples,
        seed,
        pixel_sigma_px: s.pixel_sigma_px,
        reference_epoch: s.reference_epoch.clone(),
        frame_rate_hz: s.frame_rate_hz,
        threshold_mm: s.threshold_mm,
        max_reprojection_px: s.max_reprojection_px,
        cfc: None,
        sync_sigma_ms: 0.0,
    };
    let has_c = c.is_some();
    let rig = Rig {
        a_from_b,
        camera_b,
        c: c.map(|(_, tie, cam)| (tie, cam)),
    };
    let measurement =
        crashrig_measure::measure(&epochs, &rig, &observations, &settings).map_err(|e| step(&e))?;
    let warnings = measurement
        .skipped
        .iter()
        .map(|k| {
            format!(
                "epoch `{}` has no pose of camera A ({}) in {}: its {} observation(s) are skipped",
                k.epoch,
                s.camera_a,
                s.model.display(),
                k.observations
            )
        })
        .collect();
    let summary = MeasureSummary::new(&measurement, &settings, s.mm_per_unit, has_c);
    Ok(MeasureResult {
        measurement,
        summary,
        warnings,
    })
}
