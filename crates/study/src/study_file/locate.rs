//! Text locators: the line of a section or key in the study file, and the errors of the
//! sections and steps located there.

use super::Study;
use crate::{Error, StepError};

pub(crate) use crashrig_input::location::line_of;

/// The line of `[name]` / `[[name]]` (the `n`-th occurrence), for errors about a section.
pub(crate) fn section_line(text: &str, name: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let l = l.split('#').next().unwrap_or("").trim();
            l == format!("[{name}]") || l == format!("[[{name}]]")
        })
        .nth(n)
        .map(|(i, _)| i + 1)
}

/// 1-based line of `key = …` in the `n`-th `[section]` (or `[[section]]`) of `text`, else of
/// the section header.
pub(crate) fn key_line(text: &str, section: &str, n: usize, key: &str) -> Option<usize> {
    let start = section_line(text, section, n)?;
    text.lines()
        .enumerate()
        .skip(start)
        .map(|(i, l)| (i, l.split('#').next().unwrap_or("").trim()))
        .take_while(|(_, l)| !l.starts_with('['))
        .find(|(_, l)| {
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map_or(Some(start), |(i, _)| Some(i + 1))
}

/// 1-based line of a top-level `key = …` (before the first section header).
pub(crate) fn key_line_top(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .take_while(|l| !l.starts_with('['))
        .position(|l| {
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|i| i + 1)
}

impl Study {
    /// 1-based line of `[name]` (the `n`-th `[[name]]`) in the study file.
    pub(crate) fn section_line(&self, name: &str, n: usize) -> Option<usize> {
        section_line(&self.text, name, n)
    }

    /// An error about `key` of the first `[section]`, located at the key's line (else the
    /// section's).
    pub(crate) fn key_error(&self, section: &str, key: &str, message: impl Into<String>) -> Error {
        Error::Key {
            path: self.path.clone(),
            line: key_line(&self.text, section, 0, key),
            key: format!("{section}.{key}"),
            message: message.into(),
        }
    }

    /// An [`Error::Step`] for a failure of the step configured by section `key`, located at
    /// the line of the key the failure is about ([`StepError::key`]), else at the section's.
    pub(crate) fn step_error(&self, key: &str, n: usize, source: impl Into<StepError>) -> Error {
        let section = key.split('[').next().unwrap_or(key);
        let source = source.into();
        let line = source
            .key()
            .and_then(|k| key_line(&self.text, section, n, k))
            .or_else(|| self.section_line(section, n))
            .or(Some(1));
        Error::Step {
            path: self.path.clone(),
            line,
            key: key.to_string(),
            source: Box::new(source),
        }
    }
}
