//! Progress bars on stderr, only when stderr is a terminal (none in pipes, logs and tests).
//!
//! The libraries report `(stage, done, total)` through a plain callback
//! ([`crashrig_study::pipeline::Progress`]); this module is the only place that draws.

use std::io::IsTerminal;

/// A progress bar that exists only when stderr is a terminal.
pub struct Bar(Option<indicatif::ProgressBar>);

impl Bar {
    /// A bar named `prefix` (hidden unless stderr is a terminal).
    pub fn new(prefix: &str) -> Bar {
        if !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        let b = indicatif::ProgressBar::new(1);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{prefix} [{bar:24}] {pos}/{len} {msg} ({elapsed})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.set_prefix(prefix.to_string());
        Bar(Some(b))
    }

    /// Reports `done` of `total` at `stage`; `done` is clamped to `total`.
    pub fn set(&self, stage: &str, done: u64, total: u64) {
        if let Some(b) = &self.0 {
            b.set_length(total);
            b.set_position(done.min(total));
            b.set_message(stage.to_string());
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}
