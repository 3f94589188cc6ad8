//! `crashrig calibrate`: rig calibration from an epoch sequence.
//!
//! Arguments → [`CalibrationConfig`] → [`crashrig_calibrate::calibrate`] → the JSON
//! document or the text report (and plots). The pipeline itself (pairing, scale, statistics,
//! retry policy, JSON, report, plots) lives in `crashrig_calibrate`.

use crate::Global;
use crashrig_calibrate::{CalibrationConfig, Scale, calibrate};
use crashrig_input::options::{ScaleOptions, Spelling};
use std::path::PathBuf;

/// Arguments of `crashrig calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// COLMAP model directory (bundle without a rig constraint).
    pub model: PathBuf,
    /// Camera A (outward): an image-name prefix such as `cam_out/`, or a camera id.
    #[arg(long = "camera-a", value_name = "A", value_parser = crate::limits::parse_camera)]
    pub camera_a: String,
    /// Camera B (inward): an image-name prefix or a camera id.
    #[arg(long = "camera-b", value_name = "B", value_parser = crate::limits::parse_camera)]
    pub camera_b: String,
    /// Two point3D ids a known distance apart (scale bar).
    #[arg(long = "scale-points", num_args = 2, value_names = ["ID1", "ID2"],
          requires = "scale_length_mm", conflicts_with = "mm_per_unit")]
    pub scale_points: Option<Vec<u64>>,
    /// Known distance between the scale points, in mm.
    #[arg(
        long = "scale-length-mm",
        value_name = "L",
        requires = "scale_points",
        allow_negative_numbers = true
    )]
    pub scale_length_mm: Option<f64>,
    /// Millimetres per model unit (default 1).
    #[arg(long = "mm-per-unit", value_name = "F", allow_negative_numbers = true, value_parser = crate::limits::parse_mm_per_unit)]
    pub mm_per_unit: Option<f64>,
    /// Directory for plots (per-epoch series, histograms), PNG and SVG.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Largest lag of the autocorrelation report.
    #[arg(long = "max-lag", value_name = "K", default_value_t = 10)]
    pub max_lag: usize,
    /// Skip the rig-constrained refinement.
    #[arg(long = "no-refine")]
    pub no_refine: bool,
    /// Accept a model whose epochs all give the same link (adjusted with a rig constraint)
    /// for inspection; refused by default.
    #[arg(long = "accept-rig-constrained")]
    pub accept_rig_constrained: bool,
}

impl CalibrateArgs {
    /// The library configuration these arguments stand for.
    pub fn config(&self) -> Result<CalibrationConfig, crashrig_calibrate::Error> {
        let options = ScaleOptions {
            scale_points: self.scale_points.clone(),
            scale_length_mm: self.scale_length_mm,
            mm_per_unit: self.mm_per_unit,
        };
        let scale = Scale::from_options(&options, Spelling::Flag)?;
        Ok(CalibrationConfig {
            model: self.model.clone(),
            camera_a: self.camera_a.clone(),
            camera_b: self.camera_b.clone(),
            scale,
            max_lag: self.max_lag,
            refine: !self.no_refine,
            accept_rig_constrained: self.accept_rig_constrained,
        })
    }
}

/// Runs `crashrig calibrate`.
pub fn run(a: CalibrateArgs, g: &Global) -> anyhow::Result<()> {
    let bar = crate::progress::Bar::new("crashrig calibrate");
    let rounds = bar.stage("refinement: weighting rounds");
    let r = calibrate(&a.config()?, bar.monitor(&rounds))?;
    bar.finish();
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(dir) = &a.plots {
        r.write_plots(dir)?;
    }
    if g.json {
        return crate::output::print_json(&r.to_json());
    }
    print!("{}", r.text_report());
    Ok(())
}
