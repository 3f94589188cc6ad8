//! The single error type of `crashrig-covariance`.

use std::path::PathBuf;

/// Everything that can go wrong while reading the inputs or computing the covariance.
///
/// Every variant names the file (and the line for the control-point CSV), so the CLI prints
/// it as one `error:` line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read.
    #[error("{}: cannot read", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The COLMAP model could not be read.
    #[error(transparent)]
    Model(#[from] crashrig_colmap::Error),
    /// A bad line (or header, line 1) of the control-point CSV.
    #[error("{}:{line}: {problem}", path.display())]
    ControlCsv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        problem: String,
    },
    /// The control points do not fix the datum (too few, collinear, not in the model, …).
    #[error("{}: {problem}", path.display())]
    Datum {
        /// The control-point file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// Camera A's selector matches nothing usable.
    #[error("{}: camera A ({selector}): {problem}", model.display())]
    Camera {
        /// The model directory.
        model: PathBuf,
        /// The selector as given.
        selector: String,
        /// What is wrong.
        problem: String,
    },
    /// A gauge freedom is left or the information matrix is singular: some parameter is not
    /// determined by the observations and the control points.
    #[error("{}: singular system: {problem}", model.display())]
    Singular {
        /// The model directory.
        model: PathBuf,
        /// Which parameter is not determined, and why that usually happens.
        problem: String,
    },
    /// A setting out of its range (a negative σ, a zero scale, …).
    #[error("invalid setting {name}: {problem}")]
    Setting {
        /// The setting (as the CLI spells it).
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// Options of the command that do not fit together or are out of range, named as the front
    /// end spells them ([`crashrig_input::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
    /// The caller's [`crate::Monitor`] cancelled the call: nothing was returned.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}
