//! The one error type of `crashrig-study`.

use std::path::PathBuf;

/// Everything that can go wrong while reading a study file or running a study.
///
/// Every variant's message names the file at fault and, for the study file, the key (and
/// line) so the CLI can print it as one `error:` line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// TOML syntax or type error in the study file (line and column 1-based).
    #[error("{}:{line}:{column}: {message}", path.display())]
    Toml {
        /// The study file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The TOML parser's description.
        message: String,
    },
    /// A key of the study file is missing, out of range or names something that does not
    /// exist (a path, a camera, an image).
    #[error("{}{}: `{key}`: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Key {
        /// The study file.
        path: PathBuf,
        /// 1-based line of the key (or of its section), when it is in the file.
        line: Option<usize>,
        /// Dotted key, e.g. `calibration.model` or `layout[1].observer[0].from`.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A step of the study failed on its inputs; `key` is the study-file section that
    /// configured it (its inputs are named in `message`).
    #[error("{}{}: [{key}]: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Step {
        /// The study file.
        path: PathBuf,
        /// 1-based line of the section header.
        line: Option<usize>,
        /// The section (`calibration`, `tie`, `layout[0]`, …).
        key: String,
        /// The step's own error message (names the data file at fault).
        message: String,
    },
    /// The Monte Carlo library refused the chain or a layout built from the study.
    #[error("{}: {source}", path.display())]
    Mc {
        /// The study file.
        path: PathBuf,
        /// The error.
        #[source]
        source: crashrig_mc::Error,
    },
    /// Writing an output file failed.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A figure could not be drawn.
    #[error("{what}: {source}")]
    Plot {
        /// Which figure.
        what: String,
        /// The plotting error.
        #[source]
        source: crashrig_plot::Error,
    },
}
