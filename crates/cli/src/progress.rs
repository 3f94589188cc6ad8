//! Progress bars on stderr, only when stderr is a terminal (none in pipes, logs and tests).
//!
//! The libraries report `(done, total)` through a [`crashrig_stats::progress::Monitor`] or a
//! plain callback ([`crashrig_stats::progress::Progress`]; `study` adds a stage name:
//! [`crashrig_study::Progress`]); this module is the only place that draws. When
//! stderr is not a terminal no callback is handed to the libraries at all.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};

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

    /// Whether the bar is drawn (stderr is a terminal).
    pub fn is_shown(&self) -> bool {
        self.0.is_some()
    }

    /// Reports `done` of `total` at `stage`; `done` is clamped to `total`.
    pub fn set(&self, stage: &str, done: u64, total: u64) {
        if let Some(b) = &self.0 {
            b.set_length(total);
            b.set_position(done.min(total));
            b.set_message(stage.to_string());
        }
    }

    /// A `(done, total)` callback for one stage of work: the bar shows the largest `done`
    /// reported so far (parallel workers may report out of order), clamped to `total`.
    pub fn stage<'a>(&'a self, stage: &'a str) -> impl Fn(usize, usize) + Sync + 'a {
        let best = AtomicU64::new(0);
        move |done: usize, total: usize| {
            let d = best
                .fetch_max(done as u64, Ordering::Relaxed)
                .max(done as u64);
            self.set(stage, d, total as u64);
        }
    }

    /// `Some(monitor)` when the bar is drawn, else `None` (the library then counts nothing);
    /// the command line never cancels (Ctrl-C ends the process).
    pub fn monitor<'a>(
        &self,
        monitor: &'a dyn crashrig_stats::progress::Monitor,
    ) -> Option<&'a dyn crashrig_stats::progress::Monitor> {
        self.is_shown().then_some(monitor)
    }

    /// The bar as the libraries' progress argument: `Some` when it is drawn, else `None`
    /// (the library then counts nothing).
    pub fn reporter(&self) -> Option<&dyn crashrig_stats::progress::Reporter> {
        self.is_shown()
            .then_some(self as &dyn crashrig_stats::progress::Reporter)
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

impl crashrig_stats::progress::Reporter for Bar {
    fn report(&self, stage: &str, done: usize, total: usize) {
        self.set(stage, done as u64, total as u64);
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        // An error path leaves no half-drawn bar before its `error:` line.
        self.finish();
    }
}
