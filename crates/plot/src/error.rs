//! The error type of the plotting crate.

/// Everything that can go wrong while rendering a figure.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The embedded font could not be registered with the renderer.
    #[error("the embedded DejaVu font could not be registered")]
    Font,
    /// The input data cannot be drawn (empty, mismatched lengths, no finite value).
    #[error("{figure}: bad input `{field}`: {problem}")]
    BadInput {
        /// Which figure kind (`heatmap`, `histogram`, `series`).
        figure: &'static str,
        /// Which argument.
        field: &'static str,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// The drawing backend reported an error.
    #[error("{figure}: drawing failed: {message}")]
    Draw {
        /// Which figure kind.
        figure: &'static str,
        /// The backend's own message.
        message: String,
    },
    /// PNG encoding failed.
    #[error("{figure}: PNG encoding failed")]
    Png {
        /// Which figure kind.
        figure: &'static str,
        /// The encoder's error.
        #[source]
        source: png::EncodingError,
    },
}
