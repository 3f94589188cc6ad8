//! `crashrig measure`: marker trajectories with their uncertainty from a crash-test sequence.

use crate::Global;
use crashrig_input::options::Spelling;
use crashrig_measure::{MeasureOptions, OutputDir};
use std::path::PathBuf;

/// Arguments of `crashrig measure`.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasureArgs {
    /// COLMAP model of the sequence (camera A registered against the lab per epoch).
    pub model: PathBuf,
    /// Camera A: image-name prefix (e.g. `cam_out/`) or camera id; epochs are its images.
    #[arg(long, value_name = "A", value_parser = crate::limits::parse_camera)]
    pub camera_a: String,
    /// Camera B (inward, linked to A): camera id or an image-name prefix, for its intrinsics.
    #[arg(long, value_name = "B", value_parser = crate::limits::parse_camera)]
    pub camera_b: String,
    /// Camera C (tied to B by `--tie`): camera id or an image-name prefix.
    #[arg(long, value_name = "C", value_parser = crate::limits::parse_camera)]
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
    /// Model units → mm (required unless `--a-covariance` states `mm_per_unit`).
    #[arg(long, value_name = "F", value_parser = crate::limits::parse_mm_per_unit)]
    pub mm_per_unit: Option<f64>,
    /// Camera A's pose uncertainty per epoch.
    #[command(flatten)]
    pub a_noise: super::measure_options::ANoiseArgs,
    /// σ of each pixel coordinate of an observation (px), or `estimate`: the pixel σ check's
    /// estimate from the rays of B and C (needs --camera-c).
    #[arg(long, value_name = "PX|estimate", default_value_t = crate::limits::PixelSigmaArg::Px(crashrig_measure::MeasureOptions::DEFAULT_PIXEL_SIGMA_PX), value_parser = crate::limits::parse_pixel_sigma)]
    pub pixel_sigma_px: crate::limits::PixelSigmaArg,
    /// Monte Carlo replicates per row.
    #[arg(long, value_name = "N", default_value_t = 2000, value_parser = crate::limits::parse_measure_samples)]
    pub samples: usize,
    /// Reference epoch of the displacements (default: the first measured epoch).
    #[arg(long, value_name = "EPOCH")]
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz): adds times and velocities (finite differences).
    #[arg(long, value_name = "HZ")]
    pub frame_rate_hz: Option<f64>,
    /// Rows whose σ_max exceeds this are flagged (mm).
    #[arg(long, value_name = "MM", default_value_t = crashrig_measure::MeasureOptions::DEFAULT_THRESHOLD_MM)]
    pub threshold_mm: f64,
    /// Rows whose largest reprojection residual exceeds this are flagged (px; default: the
    /// robust limit median + 5·1.4826·MAD of the sequence's residuals).
    #[arg(long, value_name = "PX")]
    pub max_reprojection_px: Option<f64>,
    /// Skip the trajectory plots.
    #[arg(long)]
    pub no_plots: bool,
    /// The length check of scale bars.
    #[command(flatten)]
    pub length: super::measure_options::LengthCheckArgs,
    /// Filtered kinematics and A's trigger offset.
    #[command(flatten)]
    pub kinematics: super::measure_options::KinematicsArgs,
    /// Run only shard i of N (its share of the markers) and write a shard directory to --out;
    /// `crashrig merge` turns the N shard directories into the unsharded output (docs/SCALE.md).
    #[arg(long, value_name = "I/N", value_parser = crate::limits::parse_shard)]
    pub shard: Option<crashrig_outdir::shard::Shard>,
}

/// Runs the command: arguments → [`MeasureOptions`] → [`crashrig_measure::run`] → print.
pub fn run(a: MeasureArgs, g: &Global) -> anyhow::Result<()> {
    let options = options(&a, g.seed);
    let bar = crate::progress::Bar::new("crashrig measure");
    let replicates = bar.stage("replicates");
    if let Some(shard) = a.shard {
        let r = crashrig_measure::shard::run(&options, shard, &a.out, bar.monitor(&replicates))?;
        bar.finish();
        crate::output::warn_all(&options.warnings(&r.run, Spelling::Flag));
        return crate::output::print_shard(&r.manifest, r.files, &a.out, g.json);
    }
    let r = crashrig_measure::run(&options.config(Spelling::Flag)?, bar.monitor(&replicates))?;
    bar.finish();
    // Warnings after a successful run: a failed run prints its one `error:` line only.
    crate::output::print_measure(&r, &options.warnings(&r, Spelling::Flag), &a.out, g)
}

/// The library's options these arguments stand for.
fn options(a: &MeasureArgs, seed: Option<u64>) -> MeasureOptions {
    let mut o = MeasureOptions {
        camera_c: a.camera_c.clone(),
        tie: a.tie.clone(),
        out: Some(OutputDir {
            dir: a.out.clone(),
            plots: !a.no_plots,
        }),
        mm_per_unit: a.mm_per_unit,
        pixel_sigma_px: a.pixel_sigma_px.px(),
        pixel_sigma_from: a.pixel_sigma_px.from(),
        samples: a.samples,
        seed,
        reference_epoch: a.reference_epoch.clone(),
        frame_rate_hz: a.frame_rate_hz,
        threshold_mm: a.threshold_mm,
        max_reprojection_px: a.max_reprojection_px,
        ..MeasureOptions::new(
            a.model.clone(),
            a.camera_a.clone(),
            a.camera_b.clone(),
            a.link.clone(),
            a.observations.clone(),
        )
    };
    a.a_noise.apply(&mut o);
    a.kinematics.apply(&mut o);
    a.length.apply(&mut o);
    o
}
