//! [`merge_shards`], the library entry of `crashrig merge`: the shard directories of a
//! `--shard i/N` run → exactly what the unsharded run writes, by the command that wrote them
//! (`place` shards here, `measure` shards by [`crashrig_measure::shard::merge`], the others by
//! [`crashrig_study::merge::merge_shards`]; this crate sits above `crashrig-study` and
//! `crashrig-measure` in the DAG, so the whole dispatch lives here).
//!
//! ```no_run
//! use crashrig_place::merge::{Merged, merge_shards};
//! use crashrig_study::merge::MergeRun;
//! let dirs: Vec<std::path::PathBuf> = (1..=4).map(|i| format!("out.shards/{i}").into()).collect();
//! match merge_shards(&dirs, std::path::Path::new("out"), true, None)? {
//!     Merged::Place(r) => println!("chose {:?}", r.placement.chosen),
//!     Merged::Measure(r) => println!("{} rows", r.measurement.rows.len()),
//!     Merged::Study(MergeRun::Grid(r)) => println!("{} points", r.summary.points),
//!     Merged::Study(_) => {}
//! }
//! # Ok::<(), crashrig_place::Error>(())
//! ```

use crate::{Error, PlaceRun, shard};
use crashrig_stats::progress::Monitor;
use crashrig_study::merge::MergeRun;
use std::path::{Path, PathBuf};

/// What a merge wrote.
#[derive(Debug, Clone)]
pub enum Merged {
    /// `place` shards: the placement, as [`crate::run`] returns it.
    Place(PlaceRun),
    /// `measure` shards: the measurement, as [`crashrig_measure::run`] returns it.
    Measure(Box<crashrig_measure::MeasureRun>),
    /// The shards of a command merged by `crashrig-study` (`grid`).
    Study(MergeRun),
}

/// Reads the shard set (refusing missing, repeated and foreign shards) and merges it into
/// `out` (`plots`: as the unsharded run without `--no-plots`).
///
/// `monitor` (optional) gets `(done, total)` shards read (a `place` merge counts one more unit
/// for the chosen layouts' rows) and is asked between them and before writing whether to stop:
/// then [`Error::Cancelled`] and nothing is written. The output does not depend on it.
///
/// # Errors
/// [`Error::OutDir`] for the shard set; [`shard::merge`]'s,
/// [`crashrig_measure::shard::merge`]'s ([`Error::Measure`]) and
/// [`crashrig_study::merge::merge_shards`]'s errors; [`Error::Cancelled`].
pub fn merge_shards(
    dirs: &[PathBuf],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<Merged, Error> {
    let shards = crashrig_outdir::shard::read_set(dirs)?;
    match shards.first() {
        Some((_, m)) if m.command == shard::COMMAND => {
            Ok(Merged::Place(shard::merge(&shards, out, plots, monitor)?))
        }
        Some((_, m)) if m.command == crashrig_measure::shard::COMMAND => {
            Ok(Merged::Measure(Box::new(crashrig_measure::shard::merge(
                &shards, out, plots, monitor,
            )?)))
        }
        _ => Ok(Merged::Study(crashrig_study::merge::merge_shards(
            dirs, out, plots, monitor,
        )?)),
    }
}
