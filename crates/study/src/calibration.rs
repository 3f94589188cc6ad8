//! Rig calibration from a COLMAP model: epochs → link `A_from_B` with its tangent covariance.
//!
//! INTERIM (H11): a minimal implementation of the STUDY_API interface so the pipeline builds and
//! runs before H12a's module lands; at the merge this file is replaced by H12a's.

use crashrig_geometry::{Mat6, UncertainPose};
use serde_json::{Value, json};
use std::path::PathBuf;

/// How the model is scaled.
#[derive(Debug, Clone, PartialEq)]
pub enum Scale {
    /// A fixed factor.
    MmPerUnit(f64),
    /// A scale bar.
    ScaleBar {
        /// point3D ids.
        points: [u64; 2],
        /// Length (mm).
        length_mm: f64,
    },
}

/// What `calibrate` takes.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationConfig {
    /// Model directory.
    pub model: PathBuf,
    /// Camera A selector.
    pub camera_a: String,
    /// Camera B selector.
    pub camera_b: String,
    /// Scale.
    pub scale: Scale,
    /// Autocorrelation lags.
    pub max_lag: usize,
    /// Rig-constrained refinement.
    pub refine: bool,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        CalibrationConfig {
            model: PathBuf::new(),
            camera_a: String::new(),
            camera_b: String::new(),
            scale: Scale::MmPerUnit(1.0),
            max_lag: 10,
            refine: true,
        }
    }
}

/// Why a calibration failed (names the model).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct CalibrationError(String);

/// The calibration result.
#[derive(Debug, Clone)]
pub struct CalibrationResult {
    /// Mean link with its SEM covariance.
    pub link: UncertainPose,
    /// Spread of one epoch's link.
    pub epoch_covariance: Mat6,
    /// SEM rule.
    pub sem_rule: String,
    /// Epochs.
    pub n_epochs: usize,
    /// Warnings.
    pub warnings: Vec<String>,
    mm_per_unit: f64,
}

impl CalibrationResult {
    /// JSON.
    pub fn to_json(&self) -> Value {
        let l = UncertainPose {
            b_from_a: self.link.b_from_a,
            covariance: self.epoch_covariance,
        };
        json!({
            "n_epochs": self.n_epochs,
            "mm_per_unit": self.mm_per_unit,
            "base_mm": <[f64; 3]>::from(self.link.b_from_a.translation.vector),
            "covariance_tangent": crate::pipeline::covariance_deg_rows(&l.covariance),
            "sem_covariance_tangent": crate::pipeline::covariance_deg_rows(&self.link.covariance),
            "sem_rule": self.sem_rule,
        })
    }
}

/// Calibrates.
///
/// # Errors
/// Any failure, naming the model.
pub fn calibrate(c: &CalibrationConfig) -> Result<CalibrationResult, CalibrationError> {
    use crashrig_rig::colmap::{CameraSelector, epochs_from_model, scale_from_points};
    let e = |x: &dyn std::fmt::Display| CalibrationError(format!("{}: {x}", c.model.display()));
    let model = crashrig_colmap::Reconstruction::read(&c.model)
        .map_err(|x| CalibrationError(x.to_string()))?;
    let set = epochs_from_model(
        &model,
        &CameraSelector::parse(&c.camera_a),
        &CameraSelector::parse(&c.camera_b),
    )
    .map_err(|x| CalibrationError(x.to_string()))?;
    let mm = match c.scale {
        Scale::MmPerUnit(f) => f,
        Scale::ScaleBar { points, length_mm } => {
            scale_from_points(&model, points[0], points[1], length_mm)
                .map_err(|x| CalibrationError(x.to_string()))?
                .mm_per_unit
        }
    };
    let links = crashrig_rig::links_of(&set.epochs, mm).map_err(|x| e(&x))?;
    let samples: Vec<_> = links.iter().map(|l| l.a_from_b).collect();
    let spread = UncertainPose::from_samples(&samples).map_err(|x| e(&x))?;
    let n = samples.len();
    Ok(CalibrationResult {
        link: UncertainPose {
            b_from_a: spread.b_from_a,
            covariance: spread.covariance / n as f64,
        },
        epoch_covariance: spread.covariance,
        sem_rule: "covariance_tangent / n".into(),
        n_epochs: n,
        warnings: Vec::new(),
        mm_per_unit: mm,
    })
}
