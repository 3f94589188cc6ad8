//! The one error type of `crashrig-merge`.

use std::path::PathBuf;

/// Everything that can go wrong in [`crate::merge_shards`]: the shard set, a shard of a command
/// that is not merged, or the command's own merge (its message, unchanged).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The shard set: a directory that is not a shard, a missing, repeated or foreign shard.
    #[error(transparent)]
    OutDir(#[from] crashrig_outdir::Error),
    /// A shard written by a command this crashrig does not merge.
    #[error("{}: a `{command}` shard; this crashrig merges `grid`, `measure` and `place` shards", manifest.display())]
    Command {
        /// The shard's `shard.json`.
        manifest: PathBuf,
        /// The command it names.
        command: String,
    },
    /// The merge of `grid` shards ([`crashrig_grid::shard::merge_grid`]).
    #[error(transparent)]
    Grid(#[from] crashrig_grid::Error),
    /// The merge of `measure` shards ([`crashrig_measure::shard::merge`]).
    #[error(transparent)]
    Measure(#[from] crashrig_measure::Error),
    /// The merge of `place` shards ([`crashrig_place::shard::merge`]).
    #[error(transparent)]
    Place(#[from] crashrig_place::Error),
}
