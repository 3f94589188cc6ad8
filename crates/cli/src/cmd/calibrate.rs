//! `crashrig calibrate`: rig calibration from an epoch sequence.

use crate::Global;
use std::path::PathBuf;

/// Arguments of `crashrig calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// COLMAP model directory (bundle without a rig constraint).
    pub model: PathBuf,
    /// Camera A (outward): an image-name prefix such as `cam_out/`, or a camera id.
    #[arg(long = "camera-a", value_name = "A")]
    pub camera_a: String,
    /// Camera B (inward): an image-name prefix or a camera id.
    #[arg(long = "camera-b", value_name = "B")]
    pub camera_b: String,
    /// Two point3D ids a known distance apart (scale bar).
    #[arg(long = "scale-points", num_args = 2, value_names = ["ID1", "ID2"])]
    pub scale_points: Option<Vec<u64>>,
    /// Known distance between the scale points, in mm.
    #[arg(long = "scale-length-mm", value_name = "L")]
    pub scale_length_mm: Option<f64>,
    /// Millimetres per model unit (default 1).
    #[arg(long = "mm-per-unit", value_name = "F")]
    pub mm_per_unit: Option<f64>,
    /// Directory for plots (per-epoch series, histograms).
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Runs `crashrig calibrate`.
pub fn run(_a: CalibrateArgs, _g: &Global) -> anyhow::Result<()> {
    Err(super::not_yet("calibrate"))
}
