//! [`merge_shards`], the library entry of `crashrig merge`: the shard directories of a
//! `--shard i/N` run → exactly what the unsharded run writes, by the command that wrote them
//! (`place` shards here, `measure` shards by [`crashrig_measure::shard::merge`], `grid` shards
//! by [`crashrig_grid::shard::merge_grid`]).
//!
//! ```no_run
//! use crashrig_place::merge::{Merged, merge_shards};
//! let dirs: Vec<std::path::PathBuf> = (1..=4).map(|i| format!("out.shards/{i}").into()).collect();
//! match merge_shards(&dirs, std::path::Path::new("out"), true, None)? {
//!     Merged::Place(r) => println!("chose {:?}", r.placement.chosen),
//!     Merged::Measure(r) => println!("{} rows", r.measurement.rows.len()),
//!     Merged::Grid(r) => println!("{} points", r.summary.points),
//! }
//! # Ok::<(), crashrig_place::Error>(())
//! ```

use crate::{Error, PlaceRun, shard};
use crashrig_outdir::shard::MANIFEST;
use crashrig_stats::progress::Monitor;
use std::path::{Path, PathBuf};

/// What a merge wrote.
#[derive(Debug, Clone)]
pub enum Merged {
    /// `place` shards: the placement, as [`crate::run`] returns it.
    Place(PlaceRun),
    /// `measure` shards: the measurement, as [`crashrig_measure::run`] returns it.
    Measure(Box<crashrig_measure::MeasureRun>),
    /// `grid` shards: the grid run, as [`crashrig_grid::run_grid`] returns it.
    Grid(crashrig_grid::GridRun),
}

/// Reads the shard set (refusing missing, repeated and foreign shards) and merges it into
/// `out` (`plots`: as the unsharded run without `--no-plots`).
///
/// `monitor` (optional) gets `(done, total)` shards read (a `place` merge counts one more unit
/// for the chosen layouts' rows) and is asked between them and before writing whether to stop:
/// then [`Error::Cancelled`] and nothing is written. The output does not depend on it.
///
/// # Errors
/// [`Error::OutDir`] for the shard set; [`Error::Shard`] for a shard of a command that is not
/// merged; [`shard::merge`]'s, [`crashrig_measure::shard::merge`]'s ([`Error::Measure`]) and
/// [`crashrig_grid::shard::merge_grid`]'s ([`Error::Grid`]) errors; [`Error::Cancelled`].
pub fn merge_shards(
    dirs: &[PathBuf],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<Merged, Error> {
    let shards = crashrig_outdir::shard::read_set(dirs)?;
    let Some((dir0, m0)) = shards.first() else {
        // `read_set` refuses an empty set already.
        return Err(Error::Shard {
            path: out.to_path_buf(),
            problem: "no shard directory given".into(),
        });
    };
    match m0.command.as_str() {
        shard::COMMAND => Ok(Merged::Place(shard::merge(&shards, out, plots, monitor)?)),
        crashrig_measure::shard::COMMAND => Ok(Merged::Measure(Box::new(
            crashrig_measure::shard::merge(&shards, out, plots, monitor)?,
        ))),
        crashrig_grid::shard::COMMAND => Ok(Merged::Grid(crashrig_grid::shard::merge_grid(
            &shards, out, plots, monitor,
        )?)),
        other => Err(Error::Shard {
            path: dir0.join(MANIFEST),
            problem: format!(
                "a `{other}` shard; this crashrig merges `grid`, `measure` and `place` shards"
            ),
        }),
    }
}
