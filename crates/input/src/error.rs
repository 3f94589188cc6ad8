//! The one error enum of `crashrig-input` (the file reader reports [`std::io::Error`]s, the
//! result reader, feature `json`, its `result_json::ResultJsonError`).

/// Options that do not fit together or are out of range.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Options of a command that do not fit together or are out of range; the message names
    /// them as the front end spells them ([`crate::options::Spelling`]).
    #[error("{0}")]
    Usage(String),
}
