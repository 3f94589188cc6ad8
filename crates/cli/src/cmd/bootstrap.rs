//! `crashrig bootstrap`: pose uncertainty by resampling correspondences.

use crate::Global;
use std::path::PathBuf;

/// Arguments of `crashrig bootstrap`.
#[derive(Debug, clap::Args)]
pub struct BootstrapArgs {
    /// COLMAP database.db with verified matches.
    pub database: PathBuf,
    /// COLMAP model directory (3D points, cameras, poses).
    #[arg(long)]
    pub model: PathBuf,
    /// Name of image A (the reference).
    #[arg(long = "image-a", value_name = "NAME")]
    pub image_a: String,
    /// Name of image B (reported relative to A).
    #[arg(long = "image-b", value_name = "NAME")]
    pub image_b: String,
    /// `absolute` (resection of B) or `relative` (essential matrix A–B).
    #[arg(long, default_value = "absolute", value_parser = ["absolute", "relative"])]
    pub method: String,
    /// Number of bootstrap replicates.
    #[arg(long, default_value_t = 500)]
    pub iterations: usize,
    /// Millimetres per model unit.
    #[arg(long = "mm-per-unit", value_name = "F", default_value_t = 1.0)]
    pub mm_per_unit: f64,
    /// Directory for histograms (PNG and SVG).
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Runs `crashrig bootstrap`.
pub fn run(_a: BootstrapArgs, _g: &Global) -> anyhow::Result<()> {
    Err(super::not_yet("bootstrap"))
}
