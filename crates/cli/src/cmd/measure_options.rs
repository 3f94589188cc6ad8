//! Option groups of `crashrig measure`: camera A's pose uncertainty (`--sigma-a-*`,
//! `--a-covariance`) and the kinematics (`--cfc`, `--cfc-standard`, `--sync-sigma-ms`;
//! `docs/KINEMATICS.md`).

use std::path::PathBuf;

/// Camera A's pose uncertainty per epoch: σ values or a covariance file.
#[derive(Debug, Clone, clap::Args)]
pub struct ANoiseArgs {
    /// σ of A's projection centre per epoch (world axes, mm).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_position_mm: Option<Vec<f64>>,
    /// σ of A's rotation per epoch about its own axes (tangent, degrees).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_angles_deg: Option<Vec<f64>>,
    /// A's pose covariance per epoch: JSON with `covariance_tangent` and/or `epochs`.
    #[arg(long, value_name = "JSON", conflicts_with_all = ["sigma_a_position_mm", "sigma_a_angles_deg"])]
    pub a_covariance: Option<PathBuf>,
}

/// Three values of a flag with `num_args = 3` (clap gives exactly three).
pub fn three(v: &Option<Vec<f64>>) -> Option<[f64; 3]> {
    v.as_deref().map(|x| [x[0], x[1], x[2]])
}

/// Filtered kinematics and camera A's trigger offset.
#[derive(Debug, Clone, clap::Args)]
pub struct KinematicsArgs {
    /// CFC filter class (60, 180, 600, 1000) of the kinematics: each marker's displacement
    /// filtered in every replicate, velocity and acceleration from it (kinematics.csv; needs
    /// --frame-rate-hz).
    #[arg(long, value_name = "CLASS")]
    pub cfc: Option<u32>,
    /// The filter's standard: j211 (SAE J211-1, default) or iso6487 (ISO 6487).
    #[arg(long, value_name = "STANDARD", requires = "cfc")]
    pub cfc_standard: Option<String>,
    /// σ of camera A's trigger offset against the inward cameras (ms; needs --frame-rate-hz).
    #[arg(
        long,
        value_name = "MS",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub sync_sigma_ms: f64,
}
