//! Option groups of `crashrig measure`: camera A's pose uncertainty (`--sigma-a-*`,
//! `--a-covariance`), the kinematics (`--cfc`, `--cfc-standard`, `--sync-sigma-ms`;
//! `docs/KINEMATICS.md`) and the length check (`--scale-bars`, `--mpe-mm`; `docs/MEASURE.md`);
//! each group sets its part of the library's [`MeasureOptions`].

use crashrig_measure::MeasureOptions;
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
    /// Each frame's time from the camera's clock: CSV `epoch,time_s` (as `crashrig track`
    /// writes frames.csv), the time axis of velocities, the CFC filter and ISO-MME instead of
    /// --frame-rate-hz (which it excludes).
    #[arg(long, value_name = "CSV")]
    pub frame_times: Option<PathBuf>,
}

/// The length check of scale bars fixed to the car body.
#[derive(Debug, Clone, clap::Args)]
pub struct LengthCheckArgs {
    /// Length check: scale bars fixed to the car body, CSV
    /// `name,marker_1,marker_2,length_mm,sigma_mm` (length_check.csv, summary's length_check).
    #[arg(long, value_name = "CSV")]
    pub scale_bars: Option<PathBuf>,
    /// The lab's maximum permissible error of a length (mm): each bar gets within_mpe (needs
    /// --scale-bars).
    #[arg(
        long,
        value_name = "MM",
        requires = "scale_bars",
        allow_negative_numbers = true
    )]
    pub mpe_mm: Option<f64>,
}

impl ANoiseArgs {
    /// Sets camera A's pose uncertainty of `o`.
    pub fn apply(&self, o: &mut MeasureOptions) {
        o.sigma_a_position_mm = three(&self.sigma_a_position_mm);
        o.sigma_a_angles_deg = three(&self.sigma_a_angles_deg);
        o.a_covariance = self.a_covariance.clone();
    }
}

impl KinematicsArgs {
    /// Sets the kinematics of `o`.
    pub fn apply(&self, o: &mut MeasureOptions) {
        o.cfc = self.cfc;
        o.cfc_standard = self.cfc_standard.clone();
        o.sync_sigma_ms = self.sync_sigma_ms;
        o.frame_times = self.frame_times.clone();
    }
}

impl LengthCheckArgs {
    /// Sets the length check of `o`.
    pub fn apply(&self, o: &mut MeasureOptions) {
        o.scale_bars = self.scale_bars.clone();
        o.mpe_mm = self.mpe_mm;
    }
}
