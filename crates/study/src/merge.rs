//! [`merge_shards`], the library entry of `crashrig merge`: the shard directories of a
//! `--shard i/N` run → exactly what the unsharded run writes, whichever command wrote them.
//!
//! ```no_run
//! use crashrig_study::merge::{MergeRun, merge_shards};
//! let dirs: Vec<std::path::PathBuf> = (1..=4).map(|i| format!("out.shards/{i}").into()).collect();
//! match merge_shards(&dirs, std::path::Path::new("out"), true, None)? {
//!     MergeRun::Grid(r) => println!("{} points", r.summary.points),
//!     _ => {}
//! }
//! # Ok::<(), crashrig_study::Error>(())
//! ```

use crate::grid_run::GridRun;
use crate::{Error, grid_shard};
use crashrig_outdir::shard::{MANIFEST, read_set};
use crashrig_stats::progress::Monitor;
use std::path::{Path, PathBuf};

/// What a merge wrote, by the command whose shards it merged.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum MergeRun {
    /// `grid` shards: the grid run, as [`crate::run_grid`] returns it.
    Grid(GridRun),
}

/// Reads the shard set (refusing missing, repeated and foreign shards) and merges it into
/// `out` (`plots`: draw the plots, as the unsharded run without `--no-plots`); `monitor`
/// (optional) gets `(shards read, shards)` and may cancel before each shard and before
/// writing ([`Error::Cancelled`], nothing written).
///
/// # Errors
/// The shard set's errors ([`Error::OutDir`]), a shard of a command this library does not
/// merge ([`Error::Shard`] naming its `shard.json`), and the command's merge errors.
pub fn merge_shards(
    dirs: &[PathBuf],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<MergeRun, Error> {
    let shards = read_set(dirs)?;
    let Some((dir0, m0)) = shards.first() else {
        return Err(Error::Shard {
            path: out.to_path_buf(),
            line: None,
            problem: "no shard directory given".into(),
        });
    };
    match m0.command.as_str() {
        grid_shard::COMMAND => Ok(MergeRun::Grid(grid_shard::merge_grid(
            &shards, out, plots, monitor,
        )?)),
        other => Err(Error::Shard {
            path: dir0.join(MANIFEST),
            line: None,
            problem: format!("a `{other}` shard; this crashrig merges `grid` shards"),
        }),
    }
}
