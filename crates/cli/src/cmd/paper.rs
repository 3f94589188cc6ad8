//! `crashrig paper`: the whole study from bundled fixtures, with a report.

use crate::Global;
use std::path::PathBuf;

/// Arguments of `crashrig paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Output directory for report.html, results.json and figures.
    #[arg(long, default_value = "out/paper")]
    pub out: PathBuf,
}

/// Runs `crashrig paper`.
pub fn run(_a: PaperArgs, _g: &Global) -> anyhow::Result<()> {
    Err(super::not_yet("paper"))
}
