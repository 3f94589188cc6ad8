//! The error type of crashrig-pose.

/// Errors of the pose estimators.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// The two correspondence lists have different lengths.
    #[error("correspondence lists differ in length: {left} vs {right}")]
    LengthMismatch {
        /// Length of the first list.
        left: usize,
        /// Length of the second list.
        right: usize,
    },
    /// Not enough correspondences for the estimator.
    #[error("too few correspondences: need at least {needed}, got {found}")]
    TooFewCorrespondences {
        /// Minimum number needed.
        needed: usize,
        /// Number given (or inliers left).
        found: usize,
    },
    /// A correspondence index (e.g. of a resample) is outside the correspondence list.
    #[error("correspondence index {index} is out of range (only {len} correspondences)")]
    IndexOutOfRange {
        /// The offending index.
        index: usize,
        /// Number of correspondences.
        len: usize,
    },
    /// An input coordinate is NaN or infinite.
    #[error("correspondence {index} is not finite")]
    NotFinite {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// A pixel could not be unprojected by the camera model.
    #[error("pixel of correspondence {index} cannot be unprojected by the camera model")]
    Unprojection {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// A point projects outside the camera model's domain (behind the camera, …) at the
    /// current pose.
    #[error("point of correspondence {index} cannot be projected at the current pose")]
    Projection {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// RANSAC found no model supported by enough inliers.
    #[error(
        "RANSAC found no pose with at least {needed} inliers in {iterations} iterations (best: {best})"
    )]
    NoConsensus {
        /// Minimum inlier count required.
        needed: usize,
        /// Best inlier count found.
        best: usize,
        /// Iterations run.
        iterations: usize,
    },
    /// The geometry does not determine the pose (collinear points, zero baseline, …): the
    /// normal equations are singular.
    #[error("degenerate geometry: {what}")]
    Degenerate {
        /// What was found singular.
        what: Degeneracy,
    },
    /// Levenberg–Marquardt did not reach a finite cost.
    #[error("Levenberg-Marquardt diverged (non-finite cost after {iterations} iterations)")]
    Diverged {
        /// Iterations run.
        iterations: usize,
    },
}

/// What is degenerate in an [`Error::Degenerate`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Degeneracy {
    /// The Gauss–Newton normal matrix JᵀJ is singular (pose not observable).
    SingularNormalEquations,
    /// Every correspondence is the same one (e.g. a resample of a single item).
    TooFewDistinct,
    /// Relative orientation: a pure rotation explains most inliers (no parallax, the base
    /// direction is not observable).
    NoParallax,
}

impl std::fmt::Display for Degeneracy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::SingularNormalEquations => f.write_str(
                "the normal equations are singular (pose not observable from these points)",
            ),
            Self::TooFewDistinct => f.write_str("too few distinct correspondences"),
            Self::NoParallax => f.write_str(
                "a pure rotation explains most matches (no parallax: the base is not observable)",
            ),
        }
    }
}
