//! The error type of crashrig-bootstrap.

/// Errors of the bootstrap engine and its summaries.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// Resampling needs at least one item.
    #[error("cannot resample an empty sample (0 items)")]
    NoItems,
    /// A run needs at least one replicate.
    #[error("the number of replicates must be at least 1")]
    NoReplicates,
    /// A summary needs at least `needed` values and got `found`.
    #[error("need at least {needed} values, got {found}")]
    TooFewValues {
        /// Minimum number of values.
        needed: usize,
        /// Number of values given.
        found: usize,
    },
    /// A value was NaN or infinite.
    #[error("value {index} is not finite ({value})")]
    NotFinite {
        /// Index of the offending value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A confidence level outside (0, 1).
    #[error("confidence level {level} is outside (0, 1)")]
    BadLevel {
        /// The level given.
        level: f64,
    },
    /// BCa needs a replicate distribution with the full-sample value strictly inside it
    /// and a jackknife with some spread.
    #[error("BCa interval undefined: {reason}")]
    BcaUndefined {
        /// Which condition failed.
        reason: BcaReason,
    },
    /// The caller's monitor cancelled the run.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
}

/// Why a BCa interval cannot be formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum BcaReason {
    /// Every replicate lies on one side of the full-sample estimate (z₀ = ±∞).
    EstimateOutsideReplicates,
    /// All jackknife values are equal (the acceleration is 0/0).
    ConstantJackknife,
}

impl std::fmt::Display for BcaReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::EstimateOutsideReplicates => {
                f.write_str("every replicate lies on one side of the full-sample estimate")
            }
            Self::ConstantJackknife => f.write_str("all jackknife values are equal"),
        }
    }
}
