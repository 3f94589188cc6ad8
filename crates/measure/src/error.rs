//! The single error type of `crashrig-measure`.

use std::path::PathBuf;

/// Everything that can go wrong while reading the inputs of a measurement or running it.
///
/// Every variant that comes from a file names the file (and the line for CSV, the key for
/// JSON), so the CLI prints it as one `error:` line without adding context.
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
    /// A bad line (or header, line 1) of a CSV file.
    #[error("{}:{line}: {problem}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        problem: String,
    },
    /// A text input (CSV) that is not UTF-8: the line and column (bytes) of its first bad byte.
    #[error("{}:{line}:{column}: not valid UTF-8 text", path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column (bytes from the start of the line).
        column: usize,
    },
    /// A bad or missing key in a JSON file.
    #[error("{}: {key}: {problem}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The key (`$` for the document itself).
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// A camera selector that does not name a usable camera of the model.
    #[error("{}: camera {role} ({selector}): {problem}", model.display())]
    Camera {
        /// The model directory.
        model: PathBuf,
        /// `A`, `B` or `C`.
        role: char,
        /// The selector as given (prefix or camera id).
        selector: String,
        /// What is wrong.
        problem: String,
    },
    /// The model and the observations have no epoch in common, or similar whole-input problems.
    #[error("{0}")]
    Input(String),
    /// A setting out of its range (e.g. zero samples, a negative σ).
    #[error("invalid setting {name}: {problem}")]
    Setting {
        /// The setting (as the CLI spells it).
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A marker's trajectory plot could not be drawn.
    #[error("plotting marker `{marker}`")]
    Plot {
        /// The marker.
        marker: String,
        /// The plotting error.
        #[source]
        source: crashrig_plot::Error,
    },
    /// The COLMAP model could not be read.
    #[error(transparent)]
    Colmap(#[from] crashrig_colmap::Error),
    /// Camera A's epochs cannot carry the requested quantity (an image name without a frame
    /// number, frame numbers that do not increase): a problem of the model's image names.
    #[error("{0}")]
    Sequence(String),
    /// The output directory cannot be used (`problem` says why).
    #[error("{}: {problem}", path.display())]
    OutDir {
        /// The directory.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// Writing the output directory failed.
    #[error(transparent)]
    Write(#[from] crashrig_outdir::Error),
    /// An error of the engine placed in the file it is about ([`Error::in_files`]).
    #[error("{}", path.display())]
    Located {
        /// The observations file or the model directory.
        path: PathBuf,
        /// The engine's error.
        #[source]
        source: Box<Error>,
    },
    /// Options of the command that do not fit together or are out of range, named as the front
    /// end spells them ([`crashrig_input::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
    /// The caller's [`crashrig_stats::progress::Monitor`] cancelled the call: nothing was
    /// returned and nothing written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}

impl Error {
    /// Names the file an engine error is about, for a caller that knows the paths:
    /// [`Error::Input`] → the observations file, [`Error::Sequence`] → the model of the
    /// sequence; every other error already names its file (or is a setting) and is returned
    /// unchanged.
    pub fn in_files(self, observations: &std::path::Path, model: &std::path::Path) -> Error {
        let path = match &self {
            Error::Input(_) => observations,
            Error::Sequence(_) => model,
            _ => return self,
        };
        Error::Located {
            path: path.to_path_buf(),
            source: Box::new(self),
        }
    }
}
