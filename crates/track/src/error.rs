//! The one error type of `crashrig-track`.

use std::path::PathBuf;

/// Everything that can stop `crashrig track`. Every variant's message names the file at fault
/// (and the line for CSV), so a front end prints it as one `error:` line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The seeds file is malformed at `line`.
    #[error("{}:{line}: {reason}", path.display())]
    Seeds {
        /// The seeds file.
        path: PathBuf,
        /// 1-based line (the header is line 1).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A seed names no marker of the kind within reach.
    #[error("{}:{line}: no {kind} marker within {radius_px} px of the seed of '{marker}' at ({u_px}, {v_px}) in epoch {epoch}", path.display())]
    SeedNotFound {
        /// The seeds file.
        path: PathBuf,
        /// 1-based line of the seed.
        line: usize,
        /// Marker name.
        marker: String,
        /// The marker kind looked for.
        kind: &'static str,
        /// Search radius.
        radius_px: f64,
        /// The seed.
        u_px: f64,
        /// The seed.
        v_px: f64,
        /// The epoch of the seed.
        epoch: String,
    },
    /// The frames cannot be used.
    #[error("{}: {reason}", path.display())]
    Frames {
        /// The frames' directory or file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The camera-file reader's error (names the file and the frame).
    #[error(transparent)]
    FrameFile(#[from] crashrig_frames::FramesError),
    /// The output directory.
    #[error(transparent)]
    OutDir(#[from] crashrig_outdir::Error),
    /// The run's summary could not be serialised (kept as an error, not a panic).
    #[error("summary.json: the run's summary cannot be serialised")]
    Summary(#[source] serde_json::Error),
    /// The caller cancelled the run; nothing was written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}
