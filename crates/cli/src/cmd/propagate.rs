//! `crashrig propagate`: Monte Carlo and linear propagation through a camera chain.

use crate::Global;
use std::path::PathBuf;

/// Arguments of `crashrig propagate`.
#[derive(Debug, clap::Args)]
pub struct PropagateArgs {
    /// Scenario file (TOML, see docs/CONVENTIONS.md and shared/interface.md).
    pub scenario: PathBuf,
    /// Monte Carlo draws (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
}

/// Runs `crashrig propagate`.
pub fn run(_a: PropagateArgs, _g: &Global) -> anyhow::Result<()> {
    Err(super::not_yet("propagate"))
}
