//! `crashrig measure`: marker trajectories with their uncertainty from a crash-test sequence.

use crate::Global;
use crashrig_geometry::Vec3;
use crashrig_measure::input;
use crashrig_measure::{ANoise, MeasureConfig, OutputDir, Settings};
use std::path::PathBuf;

/// Default seed of `measure` when `--seed` is not given.
pub const DEFAULT_SEED: u64 = 1;

/// Arguments of `crashrig measure`.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasureArgs {
    /// COLMAP model of the sequence (camera A registered against the lab per epoch).
    pub model: PathBuf,
    /// Camera A: image-name prefix (e.g. `cam_out/`) or camera id; epochs are its images.
    #[arg(long, value_name = "A")]
    pub camera_a: String,
    /// Camera B (inward, linked to A): camera id or an image-name prefix, for its intrinsics.
    #[arg(long, value_name = "B")]
    pub camera_b: String,
    /// Camera C (tied to B by `--tie`): camera id or an image-name prefix.
    #[arg(long, value_name = "C")]
    pub camera_c: Option<String>,
    /// The calibrated link A_from_B: a `calibrate --json` result (uses sem_covariance_tangent).
    #[arg(long, value_name = "JSON")]
    pub link: PathBuf,
    /// The tie B_from_C: a `bootstrap --json` result (uses covariance_tangent).
    #[arg(long, value_name = "JSON")]
    pub tie: Option<PathBuf>,
    /// Marker observations: CSV `epoch,camera,marker,u_px,v_px` (COLMAP pixels).
    #[arg(long, value_name = "CSV")]
    pub observations: PathBuf,
    /// Output directory (written all-or-nothing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Model units → mm.
    #[arg(long, value_name = "F", default_value_t = 1.0)]
    pub mm_per_unit: f64,
    /// σ of A's projection centre per epoch (world axes, mm).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_position_mm: Option<Vec<f64>>,
    /// σ of A's rotation per epoch about its own axes (tangent, degrees).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_angles_deg: Option<Vec<f64>>,
    /// A's pose covariance per epoch: JSON with `covariance_tangent` and/or `epochs`.
    #[arg(long, value_name = "JSON", conflicts_with_all = ["sigma_a_position_mm", "sigma_a_angles_deg"])]
    pub a_covariance: Option<PathBuf>,
    /// σ of each pixel coordinate of an observation (px).
    #[arg(long, value_name = "PX", default_value_t = 0.5)]
    pub pixel_sigma_px: f64,
    /// Monte Carlo replicates per row.
    #[arg(long, value_name = "N", default_value_t = 2000)]
    pub samples: usize,
    /// Reference epoch of the displacements (default: the first measured epoch).
    #[arg(long, value_name = "EPOCH")]
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz): adds times and velocities (finite differences).
    #[arg(long, value_name = "HZ")]
    pub frame_rate_hz: Option<f64>,
    /// Rows whose σ_max exceeds this are flagged (mm).
    #[arg(long, value_name = "MM", default_value_t = 5.0)]
    pub threshold_mm: f64,
    /// Rows whose largest reprojection residual exceeds this are flagged (px; default: the
    /// robust limit median + 5·1.4826·MAD of the sequence's residuals).
    #[arg(long, value_name = "PX")]
    pub max_reprojection_px: Option<f64>,
    /// Skip the trajectory plots.
    #[arg(long)]
    pub no_plots: bool,
}

/// Runs the command: arguments → [`MeasureConfig`] → [`crashrig_measure::run`] → print.
pub fn run(a: MeasureArgs, g: &Global) -> anyhow::Result<()> {
    let config = config(&a, g.seed)?;
    let r = crashrig_measure::run(&config)?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    let s = &r.summary;
    if g.json {
        crate::output::print_json(s)?;
    } else {
        println!(
            "measured {} rows ({} epochs × {} markers seen), {} draws each; {:.1} % below {} mm; {} flagged; written to {}",
            s.numbers.rows,
            s.numbers.epochs,
            s.numbers.markers,
            s.numbers.samples_per_point,
            100.0 * s.numbers.fraction_below_threshold,
            s.numbers.threshold_mm,
            s.numbers.rows_flagged,
            a.out.display()
        );
    }
    Ok(())
}

fn vec3(v: &Option<Vec<f64>>, name: &str) -> anyhow::Result<Vec3> {
    match v {
        None => Ok(Vec3::zeros()),
        Some(v) => {
            let x = Vec3::new(v[0], v[1], v[2]);
            anyhow::ensure!(
                x.iter().all(|c| c.is_finite() && *c >= 0.0),
                "{name}: σ must be finite numbers ≥ 0"
            );
            Ok(x)
        }
    }
}

/// The typed configuration of the arguments: checks the flags and reads the link and the tie.
fn config(a: &MeasureArgs, seed: Option<u64>) -> anyhow::Result<MeasureConfig> {
    crashrig_measure::check_out(&a.out)?;
    anyhow::ensure!(
        a.camera_c.is_some() == a.tie.is_some(),
        "--camera-c and --tie go together (give both for a tied-in camera C, or neither)"
    );
    let a_noise = match &a.a_covariance {
        Some(p) => ANoise::File(p.clone()),
        None => {
            if a.sigma_a_position_mm.is_none() && a.sigma_a_angles_deg.is_none() {
                eprintln!(
                    "warning: no uncertainty given for camera A's pose (--sigma-a-position-mm, --sigma-a-angles-deg or --a-covariance): it is treated as exact"
                );
            }
            ANoise::Sigmas {
                position_mm: vec3(&a.sigma_a_position_mm, "--sigma-a-position-mm")?,
                angles_deg: vec3(&a.sigma_a_angles_deg, "--sigma-a-angles-deg")?,
            }
        }
    };
    Ok(MeasureConfig {
        model: a.model.clone(),
        camera_a: a.camera_a.clone(),
        camera_b: a.camera_b.clone(),
        camera_c: a.camera_c.clone(),
        a_from_b: input::load_link(&a.link)?,
        b_from_c: a.tie.as_deref().map(input::load_link).transpose()?,
        observations: a.observations.clone(),
        mm_per_unit: a.mm_per_unit,
        a_noise,
        settings: Settings {
            samples: a.samples,
            seed: seed.unwrap_or(DEFAULT_SEED),
            pixel_sigma_px: a.pixel_sigma_px,
            reference_epoch: a.reference_epoch.clone(),
            frame_rate_hz: a.frame_rate_hz,
            threshold_mm: a.threshold_mm,
            max_reprojection_px: a.max_reprojection_px,
        },
        out: Some(OutputDir {
            dir: a.out.clone(),
            plots: !a.no_plots,
        }),
    })
}
