//! Option groups of `crashrig measure`: camera A's pose uncertainty (`--sigma-a-*`,
//! `--a-covariance`) and the kinematics (`--cfc`, `--cfc-standard`, `--sync-sigma-ms`;
//! `docs/KINEMATICS.md`).

use crashrig_geometry::Vec3;
use crashrig_measure::ANoise;
use crashrig_measure::filter::{CfcSpec, Standard};
use std::path::PathBuf;

/// The warning when no uncertainty of A is given.
pub const A_EXACT_WARNING: &str = "no uncertainty given for camera A's pose (--sigma-a-position-mm, --sigma-a-angles-deg or --a-covariance): it is treated as exact";

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

impl ANoiseArgs {
    /// No uncertainty given at all (A's pose is then treated as exact, with a warning).
    pub fn is_empty(&self) -> bool {
        self.a_covariance.is_none()
            && self.sigma_a_position_mm.is_none()
            && self.sigma_a_angles_deg.is_none()
    }

    /// The typed noise of A (σ must be finite and ≥ 0; absent σ are 0).
    pub fn to_config(&self) -> anyhow::Result<ANoise> {
        Ok(match &self.a_covariance {
            Some(p) => ANoise::File(p.clone()),
            None => ANoise::Sigmas {
                position_mm: vec3(&self.sigma_a_position_mm, "--sigma-a-position-mm")?,
                angles_deg: vec3(&self.sigma_a_angles_deg, "--sigma-a-angles-deg")?,
            },
        })
    }
}

fn vec3(v: &Option<Vec<f64>>, name: &str) -> anyhow::Result<Vec3> {
    let x = v.as_deref().map_or(Vec3::zeros(), Vec3::from_row_slice);
    let ok = x.iter().all(|c| c.is_finite() && *c >= 0.0);
    anyhow::ensure!(ok, "{name}: σ must be finite numbers ≥ 0");
    Ok(x)
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

impl KinematicsArgs {
    /// The filter of `--cfc` / `--cfc-standard` (default standard: j211), if any.
    pub fn cfc_spec(&self) -> anyhow::Result<Option<CfcSpec>> {
        let Some(class) = self.cfc else {
            return Ok(None);
        };
        let standard = Standard::parse(self.cfc_standard.as_deref().unwrap_or("j211"))?;
        Ok(Some(CfcSpec { class, standard }))
    }
}
