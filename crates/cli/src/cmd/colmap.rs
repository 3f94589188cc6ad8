//! `crashrig colmap info|convert`.

use crate::Global;
use std::path::PathBuf;

/// COLMAP subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum ColmapCommand {
    /// Counts of a sparse model directory or a database.db.
    Info {
        /// A sparse model directory (binary or text, 3.x or >=3.12) or a database.db file.
        path: PathBuf,
    },
    /// Read any COLMAP model and write all five files in the current layout.
    Convert {
        /// Input model directory.
        input: PathBuf,
        /// Output directory (created if missing).
        output: PathBuf,
        /// Output format.
        #[arg(long, value_parser = ["bin", "txt"])]
        to: String,
    },
}

/// Runs a COLMAP subcommand.
pub fn run(cmd: ColmapCommand, _g: &Global) -> anyhow::Result<()> {
    match cmd {
        ColmapCommand::Info { .. } => Err(super::not_yet("colmap info")),
        ColmapCommand::Convert { .. } => Err(super::not_yet("colmap convert")),
    }
}
