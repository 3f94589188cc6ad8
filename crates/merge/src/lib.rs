//! `crashrig merge` as a library: the shard directories of a `--shard i/N` run → exactly what
//! the unsharded run writes, by the command that wrote them (`docs/SCALE.md`).
//!
//! [`merge_shards`] reads the shard set once (`crashrig_outdir::shard::read_set`: refusing
//! missing, repeated and foreign shards) and hands it to the merge of the command named in the
//! manifests: [`crashrig_grid::shard::merge_grid`], [`crashrig_measure::shard::merge`] or
//! [`crashrig_place::shard::merge`]. Each of those reports its shards through the code of its
//! unsharded run, so the merged output is that run's, byte for byte.
//!
//! The dispatch is a crate of its own because it is the one place that knows every command
//! that shards: below it, `grid`, `measure` and `place` know only their own shards (and none
//! depends on another for merging); above it, the CLI and the Python module call this one
//! function and print or return the typed [`Merged`] result.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```no_run
//! use crashrig_merge::{Merged, merge_shards};
//! let dirs: Vec<std::path::PathBuf> = (1..=4).map(|i| format!("out.shards/{i}").into()).collect();
//! match merge_shards(&dirs, std::path::Path::new("out"), true, None)? {
//!     Merged::Grid(r) => println!("{} points", r.summary.points),
//!     Merged::Measure(r) => println!("{} rows", r.measurement.rows.len()),
//!     Merged::Place(r) => println!("chose {:?}", r.placement.chosen),
//! }
//! # Ok::<(), crashrig_merge::Error>(())
//! ```
#![deny(missing_docs)]

mod error;

pub use error::Error;

use crashrig_outdir::shard::MANIFEST;
use crashrig_stats::progress::Monitor;
use std::path::{Path, PathBuf};

/// What a merge wrote, by the command whose shards it merged.
#[derive(Debug, Clone)]
pub enum Merged {
    /// `grid` shards: the grid run, as [`crashrig_grid::run_grid`] returns it.
    Grid(crashrig_grid::GridRun),
    /// `measure` shards: the measurement, as [`crashrig_measure::run`] returns it.
    Measure(Box<crashrig_measure::MeasureRun>),
    /// `place` shards: the placement, as [`crashrig_place::run`] returns it.
    Place(crashrig_place::PlaceRun),
}

/// Reads the shard set (refusing missing, repeated and foreign shards) and merges it into
/// `out` (`plots`: as the unsharded run without `--no-plots`).
///
/// `monitor` (optional) gets `(done, total)` shards read (a `place` merge counts one more unit
/// for the chosen layouts' rows) and is asked between them and before writing whether to stop:
/// then the command's `Cancelled` error and nothing is written. The output does not depend on
/// it.
///
/// # Errors
/// [`Error::OutDir`] for the shard set; [`Error::Command`] for a shard of a command that is not
/// merged (nothing written); the command's merge errors ([`Error::Grid`], [`Error::Measure`],
/// [`Error::Place`]), a cancellation among them.
pub fn merge_shards(
    dirs: &[PathBuf],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<Merged, Error> {
    let shards = crashrig_outdir::shard::read_set(dirs)?;
    // `read_set` refuses an empty set, so there is a first shard.
    let command = shards.first().map_or("", |(_, m)| m.command.as_str());
    match command {
        crashrig_grid::shard::COMMAND => Ok(Merged::Grid(crashrig_grid::shard::merge_grid(
            &shards, out, plots, monitor,
        )?)),
        crashrig_measure::shard::COMMAND => Ok(Merged::Measure(Box::new(
            crashrig_measure::shard::merge(&shards, out, plots, monitor)?,
        ))),
        crashrig_place::shard::COMMAND => Ok(Merged::Place(crashrig_place::shard::merge(
            &shards, out, plots, monitor,
        )?)),
        other => Err(Error::Command {
            manifest: shards
                .first()
                .map_or_else(|| out.to_path_buf(), |(d, _)| d.join(MANIFEST)),
            command: other.to_string(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_outdir::shard::{Manifest, Shard};

    /// Two shard directories of one run of `command` (manifests only).
    fn shards(dir: &Path, command: &str) -> Vec<PathBuf> {
        (1..=2)
            .map(|i| {
                let d = dir.join(format!("{command}{i}"));
                std::fs::create_dir_all(&d).unwrap();
                let shard = Shard::new(i, 2).unwrap();
                let m = Manifest::new(
                    command,
                    shard,
                    4,
                    shard.range(4),
                    "f".repeat(64),
                    1,
                    10,
                    dir.join("input.toml"),
                );
                std::fs::write(d.join(MANIFEST), m.to_json()).unwrap();
                d
            })
            .collect()
    }

    #[test]
    fn merge_refuses_a_command_it_does_not_merge_and_writes_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let dirs = shards(tmp.path(), "colmap");
        let out = tmp.path().join("out");
        let e = merge_shards(&dirs, &out, false, None).unwrap_err();
        assert!(matches!(e, Error::Command { ref command, .. } if command == "colmap"));
        assert_eq!(
            e.to_string(),
            format!(
                "{}: a `colmap` shard; this crashrig merges `grid`, `measure` and `place` shards",
                dirs[0].join(MANIFEST).display()
            )
        );
        assert!(!out.exists());
    }

    #[test]
    fn merge_hands_each_command_its_own_merge() {
        // Manifests alone: each command's merge reads its shards' files and refuses the set
        // with its own error, which says which merge ran.
        let tmp = tempfile::tempdir().unwrap();
        for (command, is_its_own) in [
            (
                "grid",
                (|e| matches!(e, Error::Grid(_))) as fn(&Error) -> bool,
            ),
            ("measure", |e| matches!(e, Error::Measure(_))),
            ("place", |e| matches!(e, Error::Place(_))),
        ] {
            let dirs = shards(tmp.path(), command);
            let out = tmp.path().join(format!("out_{command}"));
            let e = merge_shards(&dirs, &out, false, None).unwrap_err();
            assert!(is_its_own(&e), "{command}: {e:?}");
            assert!(!out.exists(), "{command}");
        }
        let e = merge_shards(&[], &tmp.path().join("none"), false, None).unwrap_err();
        assert!(matches!(e, Error::OutDir(_)), "{e:?}");
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
