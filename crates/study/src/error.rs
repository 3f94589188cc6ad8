//! The one error type of `crashrig-study`: [`Error`], everything that can go wrong while reading
//! a study file or running a study. A failed step is [`Error::Step`] (the study file, line and
//! section) whose source is the error of the library that ran it ([`Error::Calibration`],
//! [`Error::Tie`], …); a bundled input of `crashrig paper` that is unusable is
//! [`Error::Bundled`] with its problem as the source. The module imports nothing from the
//! other modules, so every module can use it (no module cycle).

use std::path::PathBuf;

/// Everything that can go wrong while reading a study file or running a study.
///
/// Every variant's message names the file at fault and, for the study file, the key (and
/// line) so the CLI can print it as one `error:` line.
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
    #[error("{}{}: [{key}]", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Step {
        /// The study file.
        path: PathBuf,
        /// 1-based line of the section header.
        line: Option<usize>,
        /// The section (`calibration`, `tie`, `layout[0]`, …).
        key: String,
        /// The step's own error (names the data file at fault; boxed, it is large): one of
        /// the step variants below ([`Error::Calibration`] … [`Error::CameraCWithoutTie`]).
        #[source]
        source: Box<Error>,
    },
    /// Writing an output file failed.
    #[error("{}: cannot write", path.display())]
    Write {
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
    /// A bundled scenario of `crashrig paper` cannot be used: the Monte Carlo library's
    /// error, which names the file and line itself.
    #[error(transparent)]
    Scenario {
        /// The error.
        source: crashrig_mc::Error,
    },
    /// A layout's grid summary or maps (`crashrig_grid`'s error, which names the file).
    #[error(transparent)]
    Grid(#[from] crashrig_grid::Error),
    /// The output directory cannot be used or written.
    #[error(transparent)]
    OutDir(#[from] crashrig_outdir::Error),
    /// A bundled input of `crashrig paper` is missing or unusable (a bug of the program).
    #[error("internal")]
    Bundled {
        /// What is wrong: one of the bundled-input variants below ([`Error::BundledToml`] …
        /// [`Error::BundledObservers`]).
        #[source]
        problem: Box<Error>,
    },
    /// Options of a command that do not fit together or are out of range, named as the front
    /// end spells them ([`crashrig_input::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
    /// The caller's [`crashrig_stats::progress::Monitor`] cancelled the call: nothing was
    /// written.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
    /// The calibration (`[calibration]`; the source of an [`Error::Step`]).
    #[error(transparent)]
    Calibration(#[from] crashrig_calibrate::Error),
    /// The tie bootstrap (`[tie]`; the source of an [`Error::Step`]).
    #[error(transparent)]
    Tie(#[from] crashrig_tie::Error),
    /// The Monte Carlo library refused the chain (`[outward]`) or a layout (the source of an
    /// [`Error::Step`]).
    #[error(transparent)]
    Mc(#[from] crashrig_mc::Error),
    /// The measurement of the test sequence (`[measure]`; the source of an [`Error::Step`]).
    #[error(transparent)]
    Measure(#[from] crashrig_measure::Error),
    /// The bundle covariance of camera A (`[measure]` with `a_covariance = "bundle"`; the
    /// source of an [`Error::Step`]).
    #[error(transparent)]
    Covariance(#[from] crashrig_covariance::Error),
    /// A layout whose grid exceeds the limits (`docs/LIMITS.md`; the source of an
    /// [`Error::Step`]).
    #[error("{problem}")]
    LayoutSize {
        /// The limit exceeded and by how much.
        problem: String,
    },
    /// `[measure] camera_c` without a `[tie]` to link camera C (the source of an
    /// [`Error::Step`]).
    #[error("camera_c needs a [tie] section (the link B_from_C)")]
    CameraCWithoutTie,
    /// The generated study file does not serialise as TOML (the problem of an
    /// [`Error::Bundled`]).
    #[error("the study file does not serialise")]
    BundledToml(#[source] toml::ser::Error),
    /// `scenarios/{stem}.toml` is not bundled (the problem of an [`Error::Bundled`]).
    #[error("no bundled scenario {stem}")]
    NoScenario {
        /// The scenario's file stem.
        stem: String,
    },
    /// The bundled scenario has no `[grid]` (the problem of an [`Error::Bundled`]).
    #[error("bundled scenario {stem} without a grid")]
    NoGrid {
        /// The scenario's file stem.
        stem: String,
    },
    /// The bundled scenario's observers do not match the paper's layout table (the problem of
    /// an [`Error::Bundled`]).
    #[error("scenario {stem} has {observers} observers, the paper's layout table {expected}")]
    BundledObservers {
        /// The scenario's file stem.
        stem: String,
        /// Observers in the scenario.
        observers: usize,
        /// Observers in the paper's layout table.
        expected: usize,
    },
}

impl Error {
    /// For the error of a step (the source of an [`Error::Step`]): the key of the step's
    /// section that the error is about, when it is one key (a camera selector, the scale bar);
    /// its study-file error then points at that key's line, not at the section's.
    pub fn step_key(&self) -> Option<&'static str> {
        let camera = |role: char| match role {
            'A' => Some("camera_a"),
            'B' => Some("camera_b"),
            'C' => Some("camera_c"),
            _ => None,
        };
        match self {
            Self::Calibration(e) => match e {
                crashrig_calibrate::Error::NoImagesForCamera { role, .. }
                | crashrig_calibrate::Error::EmptyCamera { role } => camera(*role),
                crashrig_calibrate::Error::NoEpochs {
                    hint: Some((role, _)),
                    ..
                } => camera(*role),
                crashrig_calibrate::Error::UnknownPoint { .. }
                | crashrig_calibrate::Error::ZeroLengthScaleBar { .. } => Some("scale_points"),
                crashrig_calibrate::Error::InvalidScaleLength { .. } => Some("scale_length_mm"),
                _ => None,
            },
            Self::Measure(crashrig_measure::Error::Camera { role, .. }) => camera(*role),
            Self::CameraCWithoutTie => Some("camera_c"),
            _ => None,
        }
    }
}

/// A plot error of the measure crate's writers as the study's [`Error::Plot`]; `figure` names
/// the kind of plot (`trajectory`, `kinematics`).
pub(crate) fn measure_plot_error(e: crashrig_measure::Error, figure: &'static str) -> Error {
    match e {
        crashrig_measure::Error::Plot { marker, source } => Error::Plot {
            what: format!("{figure} of marker {marker}"),
            source,
        },
        // The plot writers fail only with `Plot`; anything else keeps its message.
        other => Error::Plot {
            what: format!("{figure} plots"),
            source: crashrig_plot::Error::Draw {
                figure,
                message: crashrig_input::message::error_line(&other),
            },
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundled_messages_are_the_former_strings_and_keep_their_source() {
        let line = |e: &Error| crashrig_input::message::error_line(e);
        let bundled = |problem: Error| Error::Bundled {
            problem: Box::new(problem),
        };
        let e = bundled(Error::NoScenario { stem: "s1".into() });
        assert_eq!(line(&e), "internal: no bundled scenario s1");
        let e = bundled(Error::NoGrid { stem: "s1".into() });
        assert_eq!(line(&e), "internal: bundled scenario s1 without a grid");
        let e = bundled(Error::BundledObservers {
            stem: "s1".into(),
            observers: 3,
            expected: 2,
        });
        assert_eq!(
            line(&e),
            "internal: scenario s1 has 3 observers, the paper's layout table 2"
        );
        // A bare number is no TOML document: a real serialiser error as the source.
        let toml_error = toml::to_string(&1.5_f64).unwrap_err();
        let text = toml_error.to_string();
        let e = bundled(Error::BundledToml(toml_error));
        assert_eq!(
            line(&e),
            format!("internal: the study file does not serialise: {text}")
        );
        // Each error shows its own context only; the chain holds the rest.
        assert_eq!(e.to_string(), "internal");
        let problem = std::error::Error::source(&e).expect("the typed problem");
        let toml = problem.source().expect("the serialiser's error");
        assert!(toml.downcast_ref::<toml::ser::Error>().is_some());
    }
}
