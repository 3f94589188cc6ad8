//! The one error type of `crashrig-grid`.

use std::path::PathBuf;

/// Everything that can go wrong in `grid`, `grid --shard`, the merge of grid shards and
/// `propagate`.
///
/// Every variant's message names the file at fault (and the line where known) or the option,
/// so a front end prints it as one `error:` line.
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
    /// A figure could not be drawn.
    #[error("{what}")]
    Plot {
        /// Which figure.
        what: String,
        /// The plotting error.
        #[source]
        source: crashrig_plot::Error,
    },
    /// A scenario (of `grid` or `propagate`) cannot be used: the Monte Carlo library's error
    /// about the file `path`.
    #[error("{}", path.display())]
    Scenario {
        /// The scenario file.
        path: PathBuf,
        /// The error.
        #[source]
        source: crashrig_mc::Error,
    },
    /// A scenario file cannot be read: the Monte Carlo library's error, which names the file
    /// (and the line) itself.
    #[error(transparent)]
    ScenarioFile(crashrig_mc::Error),
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
    #[error("formatting {what}")]
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
    /// A scenario without cameras given to `propagate`.
    #[error("{}: `camera`: the scenario has no camera", path.display())]
    NoCamera {
        /// The scenario file.
        path: PathBuf,
    },
    /// The caller's [`crashrig_stats::progress::Monitor`] cancelled the call: nothing was
    /// written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}
