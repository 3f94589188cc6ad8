//! The error type of `crashrig-rig`.

use std::path::PathBuf;

/// Everything that can go wrong in a rig calibration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Fewer epochs than a statistic needs.
    #[error("{what} needs at least {needed} epochs, found {found}")]
    TooFewEpochs {
        /// What was being computed.
        what: &'static str,
        /// Minimum number of epochs.
        needed: usize,
        /// Number available.
        found: usize,
    },
    /// An epoch pose contains NaN or infinity.
    #[error("epoch `{name}`: the pose of camera {camera} is not finite")]
    NonFinitePose {
        /// Epoch name.
        name: String,
        /// `'A'` or `'B'`.
        camera: char,
    },
    /// The scale (mm per model unit) is zero, negative or not finite.
    #[error("invalid scale: {mm_per_unit} mm per model unit (must be finite and > 0)")]
    InvalidScale {
        /// The rejected value.
        mm_per_unit: f64,
    },
    /// The known length of a scale bar is zero, negative or not finite.
    #[error("invalid scale-bar length {length_mm} mm (must be finite and > 0)")]
    InvalidScaleLength {
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
    #[error("{}: no point3D with id {point_id}", model.display())]
    UnknownPoint {
        /// The model directory.
        model: PathBuf,
        /// The missing id.
        point_id: u64,
    },
    /// A camera selector (prefix or camera id) that matches no image of the model.
    #[error(
        "{}: camera {role} `{selector}` matches no image (a name prefix such as `cam_out/`, \
         or a camera id; the model has {n_images} images)",
        model.display()
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
         share neither a name (after removing the prefix) nor a frame",
        model.display()
    )]
    NoEpochs {
        /// The model directory.
        model: PathBuf,
        /// Number of A images without a partner.
        unpaired_a: usize,
        /// Number of B images without a partner.
        unpaired_b: usize,
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
    /// The rig-constrained normal equations are singular.
    #[error("rig refinement: the normal matrix is not positive definite ({n_unknowns} unknowns)")]
    SingularNormalMatrix {
        /// Size of the system.
        n_unknowns: usize,
    },
    /// The rig-constrained refinement did not converge.
    #[error("rig refinement did not converge in {iterations} iterations (last step {last_step:e})")]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// Norm of the last Gauss–Newton step.
        last_step: f64,
    },
    /// A geometric operation failed (degenerate rotation mean, gimbal lock, …).
    #[error(transparent)]
    Geometry(#[from] crashrig_geometry::Error),
    /// Reading the COLMAP model failed.
    #[error(transparent)]
    Colmap(#[from] crashrig_colmap::Error),
}
