//! The one error type of `crashrig-place`.

use std::path::PathBuf;

/// Everything that can go wrong in [`crate::run`]; every message names the file (and line)
/// or the option at fault, so the CLI prints it as one `error:` line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The scenario or the candidates file `path` is invalid (the reader's error does not name
    /// the file).
    #[error("{}", path.display())]
    Input {
        /// The file.
        path: PathBuf,
        /// The reader's error.
        #[source]
        source: crashrig_mc::Error,
    },
    /// The scenario or the candidates file cannot be read: the reader's error, which names the
    /// file (and the line) itself.
    #[error(transparent)]
    InputFile(crashrig_mc::Error),
    /// An option is out of range (`--choose`, `--samples`).
    #[error("`{name}`: {problem}")]
    Setting {
        /// The option.
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A step of `crashrig grid` (the confirmation and the chosen layout's output) failed.
    #[error(transparent)]
    Grid(#[from] crashrig_grid::Error),
    /// The output directory.
    #[error(transparent)]
    OutDir(#[from] crashrig_outdir::Error),
    /// A shard directory given to `merge` (or its inputs) does not fit the run.
    #[error("{}: {problem}", path.display())]
    Shard {
        /// The shard file (or directory) at fault.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// `placement.json` could not be formatted.
    #[error("{}: formatting placement.json: {problem}", out.display())]
    Output {
        /// The output directory.
        out: PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// The caller's [`crashrig_stats::progress::Monitor`] cancelled the call: nothing was
    /// written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}

impl Error {
    /// An input error of `path`: the file is named once (the reader's located errors name it
    /// already).
    pub(crate) fn input(path: &std::path::Path, e: crashrig_mc::Error) -> Self {
        match e {
            crashrig_mc::Error::Io { .. }
            | crashrig_mc::Error::Toml { .. }
            | crashrig_mc::Error::Located { .. } => Error::InputFile(e),
            other => Error::Input {
                path: path.to_path_buf(),
                source: other,
            },
        }
    }
}
