//! The error type of crashrig-stats.

/// Errors of the statistics helpers.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
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
    /// A probability outside [0, 1].
    #[error("probability {0} is outside [0, 1]")]
    BadProbability(f64),
}
