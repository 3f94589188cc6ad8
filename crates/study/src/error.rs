//! The error types of `crashrig-study`: [`Error`] (every command and the study), and the
//! step errors it carries ([`StepError`], [`CalibrationError`], [`TieError`]). They import
//! nothing from the other modules, so every module can use them (no module cycle).

use crashrig_rig::Error as RigError;
use crashrig_stats::progress::Cancelled;
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
        /// The step's own error (names the data file at fault; boxed, it is large).
        #[source]
        source: Box<StepError>,
    },
    /// The Monte Carlo library refused the chain or a layout built from the study.
    #[error("{}", path.display())]
    Mc {
        /// The study file.
        path: PathBuf,
        /// The error.
        #[source]
        source: crashrig_mc::Error,
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
        /// What is wrong.
        #[source]
        problem: BundledError,
    },
    /// Options of a command that do not fit together or are out of range, named as the front
    /// end spells them ([`crashrig_input::options::Spelling`]).
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
    Calibration(#[from] CalibrationError),
    /// The tie bootstrap (`[tie]`).
    #[error(transparent)]
    Tie(#[from] TieError),
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

impl StepError {
    /// The key of the step's section that the error is about, when it is one key (a camera
    /// selector, the scale bar): its study-file error then points at that key's line, not at
    /// the section's.
    pub fn key(&self) -> Option<&'static str> {
        let camera = |role: char| match role {
            'A' => Some("camera_a"),
            'B' => Some("camera_b"),
            'C' => Some("camera_c"),
            _ => None,
        };
        match self {
            Self::Calibration(e) => match e {
                CalibrationError::NoImagesForCamera { role, .. }
                | CalibrationError::EmptyCamera { role } => camera(*role),
                CalibrationError::NoEpochs {
                    hint: Some((role, _)),
                    ..
                } => camera(*role),
                CalibrationError::UnknownPoint { .. }
                | CalibrationError::ZeroLengthScaleBar { .. } => Some("scale_points"),
                CalibrationError::InvalidScaleLength { .. } => Some("scale_length_mm"),
                _ => None,
            },
            Self::Measure(crashrig_measure::Error::Camera { role, .. }) => camera(*role),
            Self::CameraCWithoutTie => Some("camera_c"),
            _ => None,
        }
    }
}

/// Everything that can go wrong in a calibration; each message names the model directory (and
/// the option at fault).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationError {
    /// Reading the COLMAP model failed (the message names the file).
    #[error(transparent)]
    Colmap(#[from] crashrig_colmap::Error),
    /// The known length of a scale bar is zero, negative or not finite.
    #[error(
        "{}: invalid scale-bar length {length_mm} mm (--scale-length-mm / scale_length_mm must be finite and > 0)",
        model.display()
    )]
    InvalidScaleLength {
        /// The model directory.
        model: PathBuf,
        /// The rejected value.
        length_mm: f64,
    },
    /// The two scale-bar points coincide (zero model distance), so no scale follows.
    #[error(
        "{}: scale-bar points {point_1} and {point_2} are {distance} model units apart; \
         a scale needs two distinct points",
        model.display()
    )]
    ZeroLengthScaleBar {
        /// The model directory.
        model: PathBuf,
        /// First point3D id.
        point_1: u64,
        /// Second point3D id.
        point_2: u64,
        /// Their distance in model units.
        distance: f64,
    },
    /// A point3D id that is not in the model.
    #[error("{}: no point3D with id {point_id} (--scale-points / scale_points)", model.display())]
    UnknownPoint {
        /// The model directory.
        model: PathBuf,
        /// The missing id.
        point_id: u64,
    },
    /// A camera selector (prefix or camera id) that matches no image of the model.
    #[error(
        "{}: camera {role} `{selector}` matches no image (a name prefix such as `cam_out/`, \
         or a camera id; the model has {n_images} images{}{suggestions})",
        model.display(),
        if suggestions.is_empty() { "" } else { "; " }
    )]
    NoImagesForCamera {
        /// The model directory.
        model: PathBuf,
        /// `'A'` or `'B'`.
        role: char,
        /// The selector as given.
        selector: String,
        /// Number of images in the model.
        n_images: usize,
        /// What the model has nearest ([`crashrig_colmap::CameraSelector::suggestions`]).
        suggestions: String,
    },
    /// An empty (or blank) camera selector: it would select every image.
    #[error(
        "camera {role} is empty (--camera-{} / camera_{}): an empty image-name prefix would \
         select every image; give a prefix such as `cam_out/` or a camera id",
        role.to_ascii_lowercase(),
        role.to_ascii_lowercase()
    )]
    EmptyCamera {
        /// `'A'` or `'B'`.
        role: char,
    },
    /// Cameras A and B select the same images.
    #[error("{}: cameras A and B both select image `{image}`", model.display())]
    OverlappingCameras {
        /// The model directory.
        model: PathBuf,
        /// An image selected by both.
        image: String,
    },
    /// Images of both cameras exist but none pair up.
    #[error(
        "{}: no epoch pairs camera A and B: {unpaired_a} image(s) of A and {unpaired_b} of B \
         share neither a name (after removing the prefix) nor a frame{}",
        model.display(),
        hint.as_ref().map(|(_, h)| format!("; hint: {h}")).unwrap_or_default()
    )]
    NoEpochs {
        /// The model directory.
        model: PathBuf,
        /// Number of A images without a partner.
        unpaired_a: usize,
        /// Number of B images without a partner.
        unpaired_b: usize,
        /// A selector written without its trailing slash: its role (`'A'` or `'B'`) and the hint
        /// ([`crashrig_colmap::CameraSelector::slash_hint`]).
        hint: Option<(char, String)>,
    },
    /// Two images of the same camera claim the same epoch key.
    #[error("{}: images `{first}` and `{second}` of camera {role} both pair as epoch `{key}`", model.display())]
    DuplicateEpoch {
        /// The model directory.
        model: PathBuf,
        /// `'A'` or `'B'`.
        role: char,
        /// The epoch key.
        key: String,
        /// First image name.
        first: String,
        /// Second image name.
        second: String,
    },
    /// Every epoch gives the same link: the model was adjusted with a rig constraint.
    #[error(
        "{}: all {n_epochs} epochs give the same link A_from_B (spread {spread_mm:.1e} mm, \
         {spread_deg:.1e} deg: numerical zero). The model was adjusted with a rig constraint \
         (frames sharing one sensor_from_rig), so its epochs are not independent measurements \
         of the link and σ = σ/√n = 0 would mean nothing. Calibrate a model reconstructed \
         without rig constraints (each image in its own frame, as COLMAP's rig workflow does \
         before `rig_configurator`), or pass --accept-rig-constrained \
         (study file: accept_rig_constrained = true) to inspect this one",
        model.display()
    )]
    RigConstrained {
        /// The model directory.
        model: PathBuf,
        /// Number of epochs.
        n_epochs: usize,
        /// Largest σ of the base over the epochs (mm).
        spread_mm: f64,
        /// Largest σ of the rotation over the epochs (deg).
        spread_deg: f64,
    },
    /// The calibration of the epochs failed (scale, too few epochs, degenerate rotations).
    #[error("{}: calibration failed", model.display())]
    Rig {
        /// The model directory.
        model: PathBuf,
        /// What failed.
        source: RigError,
    },
    /// A plot could not be drawn.
    #[error("{}: plotting {what}", dir.display())]
    Plot {
        /// The plot directory.
        dir: PathBuf,
        /// Which figure.
        what: String,
        /// What failed.
        source: crashrig_plot::Error,
    },
    /// A plot file could not be written.
    #[error("{}: {what}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The caller's monitor cancelled the calibration.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Why a tie bootstrap failed. Every message names the file or option at fault.
#[derive(Debug, thiserror::Error)]
pub enum TieError {
    /// A configuration value is out of range.
    #[error("{message}")]
    Option {
        /// The option (CLI spelling, e.g. `--mm-per-unit`).
        option: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The COLMAP model cannot be read or lacks what the tie needs.
    #[error("{}: {message}", path.display())]
    Model {
        /// The model directory.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The COLMAP database cannot be read or lacks what the tie needs.
    #[error("{}: {message}", path.display())]
    Database {
        /// The database file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The pose estimation on the full sample failed (the file holding the correspondences).
    #[error("{}: {message}", path.display())]
    Estimation {
        /// The model (absolute) or database (relative) the correspondences came from.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// Too few replicates succeeded, or the replicate summary is undefined.
    #[error("{message}")]
    Replicates {
        /// What is wrong.
        message: String,
    },
    /// The caller's monitor cancelled the run.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// A plot or the replicates file could not be written ([`crate::tie::TieResult::write_files`]).
    #[error(transparent)]
    Write(#[from] crashrig_outdir::Error),
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

/// What is wrong with a bundled input of `crashrig paper` (the source of [`Error::Bundled`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BundledError {
    /// The generated study file does not serialise as TOML.
    #[error("the study file does not serialise")]
    Toml(#[source] toml::ser::Error),
    /// `scenarios/{stem}.toml` is not bundled.
    #[error("no bundled scenario {stem}")]
    NoScenario {
        /// The scenario's file stem.
        stem: String,
    },
    /// The bundled scenario has no `[grid]`.
    #[error("bundled scenario {stem} without a grid")]
    NoGrid {
        /// The scenario's file stem.
        stem: String,
    },
    /// The bundled scenario's observers do not match the paper's layout table.
    #[error("scenario {stem} has {observers} observers, the paper's layout table {expected}")]
    Observers {
        /// The scenario's file stem.
        stem: String,
        /// Observers in the scenario.
        observers: usize,
        /// Observers in the paper's layout table.
        expected: usize,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundled_messages_are_the_former_strings_and_keep_their_source() {
        let line = |e: &Error| crashrig_input::message::error_line(e);
        let e = Error::Bundled {
            problem: BundledError::NoScenario { stem: "s1".into() },
        };
        assert_eq!(line(&e), "internal: no bundled scenario s1");
        let e = Error::Bundled {
            problem: BundledError::NoGrid { stem: "s1".into() },
        };
        assert_eq!(line(&e), "internal: bundled scenario s1 without a grid");
        let e = Error::Bundled {
            problem: BundledError::Observers {
                stem: "s1".into(),
                observers: 3,
                expected: 2,
            },
        };
        assert_eq!(
            line(&e),
            "internal: scenario s1 has 3 observers, the paper's layout table 2"
        );
        // A bare number is no TOML document: a real serialiser error as the source.
        let toml_error = toml::to_string(&1.5_f64).unwrap_err();
        let text = toml_error.to_string();
        let e = Error::Bundled {
            problem: BundledError::Toml(toml_error),
        };
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
