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
    /// configured it (its inputs are named by `source`).
    #[error("{}{}: [{key}]: {source}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Step {
        /// The study file.
        path: PathBuf,
        /// 1-based line of the section header.
        line: Option<usize>,
        /// The section (`calibration`, `tie`, `layout[0]`, …).
        key: String,
        /// The step's own error (names the data file at fault; boxed, it is large).
        #[source]
        source: Box<StepError>,
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
    /// A scenario file (of `grid` or `propagate`) cannot be used: the Monte Carlo library's
    /// error, which names the file and line itself unless `path` is given.
    #[error("{}{source}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Scenario {
        /// The file, when the error does not name it.
        path: Option<PathBuf>,
        /// The error.
        #[source]
        source: crashrig_mc::Error,
    },
    /// A setting of a command out of its range.
    #[error("{name} {problem}")]
    Setting {
        /// The setting as the command line spells it (`--samples`).
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A grid result that cannot be reported (a non-finite σ at a measurable point).
    #[error("{}: {problem}", path.display())]
    Grid {
        /// The scenario file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A CSV document could not be formatted.
    #[error("formatting {what}: {source}")]
    Csv {
        /// Which document.
        what: &'static str,
        /// The CSV writer's error.
        #[source]
        source: csv::Error,
    },
    /// The output directory cannot be used or written.
    #[error(transparent)]
    OutDir(#[from] crashrig_outdir::Error),
    /// A file of a shard directory (`crashrig merge`) that cannot be used.
    #[error("{}{}: {problem}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Shard {
        /// The file.
        path: PathBuf,
        /// 1-based line, where known.
        line: Option<usize>,
        /// What is wrong.
        problem: String,
    },
    /// A bundled input of `crashrig paper` is missing or unusable (a bug of the program).
    #[error("internal: {problem}")]
    Bundled {
        /// What is wrong.
        problem: String,
    },
    /// A scenario without cameras given to `propagate`.
    #[error("{}: `camera`: the scenario has no camera", path.display())]
    NoCamera {
        /// The scenario file.
        path: PathBuf,
    },
    /// Options of a command that do not fit together or are out of range, named as the front
    /// end spells them ([`crashrig_geometry::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
    /// The caller's [`crashrig_stats::progress::Monitor`] cancelled the call: nothing was
    /// written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}

/// Why a step of a study failed: the typed error of the library that ran it (the source of
/// [`Error::Step`]; its message is the library's own).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StepError {
    /// The calibration (`[calibration]`).
    #[error(transparent)]
    Calibration(#[from] crate::calibration::CalibrationError),
    /// The tie bootstrap (`[tie]`).
    #[error(transparent)]
    Tie(#[from] crate::tie::TieError),
    /// The Monte Carlo library refused the chain (`[outward]`) or a layout.
    #[error(transparent)]
    Mc(#[from] crashrig_mc::Error),
    /// The measurement of the test sequence (`[measure]`).
    #[error(transparent)]
    Measure(#[from] crashrig_measure::Error),
    /// The bundle covariance of camera A (`[measure]` with `a_covariance = "bundle"`).
    #[error(transparent)]
    Covariance(#[from] crashrig_covariance::Error),
    /// A layout whose grid exceeds the limits (`docs/LIMITS.md`).
    #[error("{problem}")]
    LayoutSize {
        /// The limit exceeded and by how much.
        problem: String,
    },
    /// `[measure] camera_c` without a `[tie]` to link camera C.
    #[error("camera_c needs a [tie] section (the link B_from_C)")]
    CameraCWithoutTie,
}
