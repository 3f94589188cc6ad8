//! The single error type of `crashrig-geometry`.

/// Everything that can go wrong in the geometry routines.
///
/// Pure maps (exp, log, composition) are total; only constructors from raw numbers, solvers and
/// statistics on data return this type.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A quaternion whose norm is zero, NaN or infinite cannot be normalised.
    #[error("quaternion cannot be normalised: norm = {norm}")]
    NonUnitQuaternion {
        /// Euclidean norm of the four components as given.
        norm: f64,
    },
    /// A value that must be finite was NaN or infinite.
    #[error("non-finite input in {what}")]
    NonFinite {
        /// Which input was not finite.
        what: &'static str,
    },
    /// Too few views for a forward intersection.
    #[error("too few views: needed {needed}, found {found}")]
    TooFewViews {
        /// Minimum number of views.
        needed: usize,
        /// Number of views given.
        found: usize,
    },
    /// Too few points (e.g. for an alignment).
    #[error("too few points: needed {needed}, found {found}")]
    TooFewPoints {
        /// Minimum number of points.
        needed: usize,
        /// Number of points given.
        found: usize,
    },
    /// Too few samples for a statistic (e.g. a standard deviation needs two).
    #[error("too few samples: needed {needed}, found {found}")]
    TooFewSamples {
        /// Minimum number of samples.
        needed: usize,
        /// Number of samples given.
        found: usize,
    },
    /// Two slices that must have the same length do not.
    #[error("length mismatch: {left} vs {right}")]
    LengthMismatch {
        /// Length of the first slice.
        left: usize,
        /// Length of the second slice.
        right: usize,
    },
    /// The problem is (numerically) degenerate; `condition` is the measure that failed.
    #[error("degenerate configuration ({what}): condition measure {condition:e}")]
    Degenerate {
        /// What is degenerate (e.g. "parallel rays").
        what: &'static str,
        /// The condition number or ratio that crossed its tolerance.
        condition: f64,
    },
    /// ω-φ-κ are singular here: |cos φ| is below the gimbal-lock tolerance.
    #[error("gimbal lock: phi = {phi} rad")]
    GimbalLock {
        /// The φ angle (radians), close to ±π/2.
        phi: f64,
    },
    /// A direction vector is zero (e.g. look-at target equal to the centre).
    #[error("zero-length direction")]
    ZeroDirection,
    /// The circular mean of angles is undefined (the resultant vector is ~0).
    #[error("angles have no defined circular mean: mean resultant length {resultant}")]
    UndefinedCircularMean {
        /// Mean resultant length |Σ e^{ia}|/n, in [0, 1].
        resultant: f64,
    },
    /// An iterative method did not converge.
    #[error("no convergence after {iterations} iterations (last step {last_step:e})")]
    NoConvergence {
        /// Iterations performed.
        iterations: usize,
        /// Size of the last update step.
        last_step: f64,
    },
}
