//! The one line a front end prints for an error: the error's own message and those of its
//! sources, joined with ": ".
//!
//! Every library error shows its own context only and returns its cause from
//! [`std::error::Error::source`] (checked by `cargo xtask tidy`), so the chain holds each part
//! once and nothing needs removing.

/// `e` and its sources (`source()`, recursively) joined with ": ", an empty message skipped,
/// newlines as spaces: the text the CLI prints after `error: ` and Python raises.
///
/// ```
/// #[derive(Debug, thiserror::Error)]
/// #[error("a.toml: cannot read")]
/// struct Read(#[source] std::io::Error);
///
/// let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
/// let line = crashrig_input::message::error_line(&Read(io));
/// assert_eq!(line, "a.toml: cannot read: no such file");
/// ```
pub fn error_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut parts = Vec::new();
    let mut cause = Some(e);
    while let Some(c) = cause {
        let text = c.to_string();
        if !text.is_empty() {
            parts.push(text);
        }
        cause = c.source();
    }
    parts.join(": ").replace('\n', " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("outer")]
    struct Outer(#[source] Middle);

    #[derive(Debug, thiserror::Error)]
    #[error("")]
    struct Middle(#[source] std::io::Error);

    #[test]
    fn the_chain_is_joined_once_each_without_removing_repeats() {
        let io = std::io::Error::other("inner\nline");
        assert_eq!(error_line(&Outer(Middle(io))), "outer: inner line");
        // A text that repeats is printed as often as the chain holds it: the libraries do not
        // repeat their sources (tidy's check), and nothing is removed by substring.
        let io = std::io::Error::other("outer");
        assert_eq!(error_line(&Outer(Middle(io))), "outer: outer");
    }
}
