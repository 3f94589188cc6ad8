//! The error type of `crashrig-rig`.

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
    /// Every epoch gives the same link (spread at numerical zero): the poses come from a
    /// bundle with a rig constraint, so the epochs are not independent measurements of it.
    #[error(
        "all {n_epochs} epochs give the same link A_from_B (spread {spread_mm:.1e} mm, \
         {spread_rad:.1e} rad: numerical zero); the poses were adjusted with a rig constraint, \
         so the epochs carry no independent evidence of the link"
    )]
    RigConstrained {
        /// Number of epochs.
        n_epochs: usize,
        /// Largest σ of the base over the epochs (mm).
        spread_mm: f64,
        /// Largest σ of the tangent rotation over the epochs (rad).
        spread_rad: f64,
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
    /// The caller's monitor cancelled the calibration.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}
