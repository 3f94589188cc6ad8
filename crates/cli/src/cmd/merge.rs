//! `crashrig merge`: the shard directories of a `--shard i/N` run → the unsharded output.
//! Arguments → [`crashrig_merge::merge_shards`] (refuses missing, repeated and foreign
//! shards; merges by the command that wrote them) → the print of that command.

use crate::Global;
use crashrig_outdir::shard::MAX_SHARDS;
use std::path::PathBuf;

/// Arguments of `crashrig merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shard directories (all N of one run, in any order).
    #[arg(required = true, num_args = 1..=MAX_SHARDS, value_name = "SHARD_DIR")]
    pub shards: Vec<PathBuf>,
    /// Output directory: exactly what the unsharded run writes.
    #[arg(long)]
    pub out: PathBuf,
    /// Skip the plots (as the unsharded run's --no-plots).
    #[arg(long)]
    pub no_plots: bool,
}

/// Runs `crashrig merge`.
pub fn run(a: MergeArgs, g: &Global) -> anyhow::Result<()> {
    use crashrig_merge::{Merged, merge_shards};
    let bar = crate::progress::Bar::new("crashrig merge");
    let read = bar.stage("shards read");
    let merged = merge_shards(&a.shards, &a.out, !a.no_plots, bar.monitor(&read))?;
    bar.finish();
    match merged {
        Merged::Place(r) => super::place::print(&r, &a.out, g),
        Merged::Measure(r) => crate::output::print_measure(&r, &r.warnings, &a.out, g),
        Merged::Grid(r) => super::grid::print(&r, &a.out, g),
    }
}
