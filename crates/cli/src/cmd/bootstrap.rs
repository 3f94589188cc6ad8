//! `crashrig bootstrap`: pose uncertainty of image B relative to A by resampling correspondences.
//!
//! A thin front end of [`crashrig_tie`] (which documents the method, the two resampling
//! modes and every JSON field): arguments → [`TieConfig`] → [`tie::bootstrap`] → print the JSON
//! or the text report, write the histograms (`--plots DIR`) and the replicates
//! (`--replicates FILE.csv`).

use crate::Global;
use crashrig_tie::{self as tie, Method, Resample, TieConfig};
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
    #[arg(long = "image-a", value_name = "NAME", value_parser = crate::limits::parse_image_name)]
    pub image_a: String,
    /// Name of image B (reported relative to A).
    #[arg(long = "image-b", value_name = "NAME", value_parser = crate::limits::parse_image_name)]
    pub image_b: String,
    /// `absolute` (resection of B) or `relative` (essential matrix A–B).
    #[arg(long, default_value = "absolute", value_parser = ["absolute", "relative"])]
    pub method: String,
    /// Number of bootstrap replicates.
    #[arg(long, default_value_t = 500, value_parser = crate::limits::parse_iterations)]
    pub iterations: usize,
    /// Millimetres per model unit.
    #[arg(long = "mm-per-unit", value_name = "F", default_value_t = 1.0, value_parser = crate::limits::parse_mm_per_unit)]
    pub mm_per_unit: f64,
    /// Directory for histograms (PNG and SVG).
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// RANSAC inlier threshold in pixels (reprojection error, or Sampson error for relative).
    #[arg(long = "max-error-px", value_name = "PX", default_value_t = 4.0)]
    pub max_error_px: f64,
    /// Relative method: base length in mm instead of the model's projection centres.
    #[arg(long = "base-mm", value_name = "L")]
    pub base_mm: Option<f64>,
    /// What each replicate resamples: `inliers` (the full-sample RANSAC inliers, LM
    /// warm-started) or `matches` (all candidate correspondences, LO-RANSAC re-run in every
    /// replicate: the paper's procedure).
    #[arg(long, default_value = "inliers", value_parser = ["inliers", "matches"])]
    pub resample: String,
    /// Write every successful replicate to this CSV file (header
    /// `replicate,x_mm,y_mm,z_mm,omega_deg,phi_deg,kappa_deg,tx_deg,ty_deg,tz_deg`).
    #[arg(long, value_name = "FILE.csv")]
    pub replicates: Option<PathBuf>,
}

/// Seed used when `--seed` is not given.
const DEFAULT_SEED: u64 = 1;

impl BootstrapArgs {
    /// The library configuration of these arguments.
    pub fn config(&self, seed: u64) -> TieConfig {
        TieConfig {
            database: self.database.clone(),
            model: self.model.clone(),
            image_a: self.image_a.clone(),
            image_b: self.image_b.clone(),
            // clap restricts both strings to the names parsed here.
            method: Method::from_name(&self.method).unwrap_or_default(),
            iterations: self.iterations,
            seed,
            mm_per_unit: self.mm_per_unit,
            max_error_px: self.max_error_px,
            base_mm: self.base_mm,
            resample: Resample::from_name(&self.resample).unwrap_or_default(),
        }
    }
}

/// Runs `crashrig bootstrap`.
pub fn run(a: BootstrapArgs, g: &Global) -> anyhow::Result<()> {
    let r = compute(&a, g.seed.unwrap_or(DEFAULT_SEED))?;
    if g.json {
        return crate::output::print_json(&r.json);
    }
    print!("{}", r.text);
    Ok(())
}

/// A finished bootstrap, not yet printed (for `crashrig paper` and other in-process callers).
pub struct BootstrapRun {
    /// The contract's JSON document with the extension fields.
    pub json: serde_json::Value,
    /// The text report.
    pub text: String,
}

/// Runs the bootstrap as `crashrig bootstrap` does (plots and replicates written when
/// `--plots` / `--replicates` are given, warnings on stderr), without printing the result.
pub fn compute(a: &BootstrapArgs, seed: u64) -> anyhow::Result<BootstrapRun> {
    let bar = crate::progress::Bar::new("crashrig bootstrap");
    let replicates = bar.stage("replicates + jackknife");
    let r = tie::bootstrap(&a.config(seed), bar.monitor(&replicates))?;
    bar.finish();
    for w in r.warnings() {
        eprintln!("warning: {w}");
    }
    r.write_files(a.plots.as_deref(), a.replicates.as_deref())?;
    Ok(BootstrapRun {
        json: r.to_json(),
        text: r.text_report(),
    })
}
