//! `crashrig covariance`: camera A's per-epoch pose covariance from the bundle.
//!
//! Arguments → [`CovarianceConfig`] → [`crashrig_covariance::run`] → the JSON document (written
//! atomically to `--out`, and/or printed with `--json`). The method lives in
//! `crashrig_covariance`.

use crate::Global;
use crashrig_covariance::{CovarianceConfig, Intrinsics, Scale};
use crashrig_input::options::{ScaleOptions, Spelling};
use std::path::PathBuf;

/// Arguments of `crashrig covariance`.
#[derive(Debug, clap::Args)]
pub struct CovarianceArgs {
    /// COLMAP model directory (the bundle of the lab sequence).
    pub model: PathBuf,
    /// Camera A (outward): an image-name prefix such as `cam_out/`, or a camera id.
    #[arg(long = "camera", value_name = "A", value_parser = crate::limits::parse_camera)]
    pub camera: String,
    /// CSV with the column `point3D_id` and an optional `sigma_mm` (0 or absent: fixed).
    #[arg(long = "control-points", value_name = "FILE")]
    pub control_points: PathBuf,
    /// Output JSON (what `measure --a-covariance` reads); written atomically.
    #[arg(long, value_name = "FILE.json", required_unless_present = "json")]
    pub out: Option<PathBuf>,
    /// Millimetres per model unit.
    #[arg(long = "mm-per-unit", value_name = "F", allow_negative_numbers = true,
          value_parser = crate::limits::parse_mm_per_unit,
          required_unless_present = "scale_points", conflicts_with = "scale_points")]
    pub mm_per_unit: Option<f64>,
    /// Two point3D ids a known distance apart (scale bar), with --scale-length-mm.
    #[arg(long = "scale-points", num_args = 2, value_names = ["ID1", "ID2"],
          requires = "scale_length_mm")]
    pub scale_points: Option<Vec<u64>>,
    /// Known distance between the scale points, in mm.
    #[arg(
        long = "scale-length-mm",
        value_name = "L",
        requires = "scale_points",
        allow_negative_numbers = true
    )]
    pub scale_length_mm: Option<f64>,
    /// Pixel σ of the observations (default: the a-posteriori σ̂₀ of the model's residuals).
    #[arg(
        long = "pixel-sigma-px",
        value_name = "S",
        allow_negative_numbers = true
    )]
    pub pixel_sigma_px: Option<f64>,
    /// Intrinsics marginalised: all (default), colmap (focal + distortion), fixed (none).
    #[arg(long, value_name = "WHICH", default_value = "all", value_parser = ["all", "colmap", "fixed"])]
    pub intrinsics: String,
}

impl CovarianceArgs {
    /// The library configuration these arguments stand for.
    pub fn config(&self) -> Result<CovarianceConfig, crashrig_covariance::Error> {
        let options = ScaleOptions {
            scale_points: self.scale_points.clone(),
            scale_length_mm: self.scale_length_mm,
            mm_per_unit: self.mm_per_unit,
        };
        let scale = Scale::from_options(&options, Spelling::Flag)?;
        Ok(CovarianceConfig {
            model: self.model.clone(),
            camera_a: self.camera.clone(),
            control_points: self.control_points.clone(),
            scale,
            pixel_sigma_px: self.pixel_sigma_px,
            intrinsics: Intrinsics::parse(&self.intrinsics).unwrap_or(Intrinsics::All),
        })
    }
}

/// Runs `crashrig covariance`.
pub fn run(a: CovarianceArgs, g: &Global) -> anyhow::Result<()> {
    let bar = crate::progress::Bar::new("crashrig covariance");
    let phases = bar.stage("phases");
    let r = crashrig_covariance::run(&a.config()?, bar.monitor(&phases))?;
    bar.finish();
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(out) = &a.out {
        crate::output::write_atomic(out, r.json_text().as_bytes())?;
    }
    let doc = r.to_json();
    if g.json {
        return crate::output::print_json(&doc);
    }
    if let Some(out) = &a.out {
        eprintln!(
            "{} epochs of A, σ̂₀ = {:.3} px (used {:.3} px), {} observations: {}",
            r.epochs.len(),
            r.sigma0_px,
            r.pixel_sigma_px,
            r.observations,
            out.display()
        );
    }
    Ok(())
}
