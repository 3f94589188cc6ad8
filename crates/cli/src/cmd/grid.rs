//! `crashrig grid`: forward-intersection precision over a grid.

use crate::Global;
use std::path::PathBuf;

/// Arguments of `crashrig grid`.
#[derive(Debug, clap::Args)]
pub struct GridArgs {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Output directory: grid.csv, summary.json, heat maps.
    #[arg(long)]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
}

/// Runs `crashrig grid`.
pub fn run(_a: GridArgs, _g: &Global) -> anyhow::Result<()> {
    Err(super::not_yet("grid"))
}
