//! The one error type of `crashrig-calibrate`: [`Error`], everything that can go wrong in a
//! calibration. Each message names the model directory (and the option at fault).

use crashrig_rig::Error as RigError;
use crashrig_stats::progress::Cancelled;
use std::path::PathBuf;

/// Everything that can go wrong in a calibration; each message names the model directory (and
/// the option at fault).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
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
    /// The plot directory could not be staged, written or swapped in (the message names the
    /// path), or it holds files that are not this command's plots.
    #[error(transparent)]
    Write(#[from] crashrig_outdir::Error),
    /// The caller's monitor cancelled the calibration.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// Options that do not fit together or are out of range ([`crate::Scale::from_options`]),
    /// named as the front end spells them ([`crashrig_input::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
}
