//! Progress reporting and cancellation for long library calls, without any user interface: a
//! caller passes one optional [`Monitor`] (or a plain [`Progress`] callback, or a [`Reporter`]
//! for an entry with named stages), the library counts finished units of work (replicates, grid
//! points, chunks of draws, iterations) with a [`Counter`], which reports `(done, total)` and,
//! between units, asks [`Monitor::cancelled`]; a cancelled call returns [`Cancelled`] (wrapped in
//! its crate's error enum).
//!
//! A counter costs one atomic increment per unit (units are chunks or points, never single
//! draws) and never changes what is computed: results are the same with and without a callback.
//! `done` never exceeds `total`; with parallel work the calls may arrive slightly out of order
//! (a display keeps the largest `done` it has seen).
//!
//! ```
//! use crashrig_stats::progress::Counter;
//! use std::sync::Mutex;
//!
//! let seen = Mutex::new(Vec::new());
//! let report = |done: usize, total: usize| seen.lock().unwrap().push((done, total));
//! let counter = Counter::new(Some(&report), 3);
//! for _ in 0..3 {
//!     counter.add(1);
//! }
//! assert_eq!(*seen.lock().unwrap(), vec![(1, 3), (2, 3), (3, 3)]);
//! ```

use std::sync::atomic::{AtomicUsize, Ordering};

/// A progress callback: `(done, total)` units of work, `done ≤ total`.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// The one optional argument of a long library step (`Option<&dyn Monitor>`): where it reports
/// `(done, total)` and whether its caller wants it to stop. Any `Fn(usize, usize) + Sync`
/// closure is a monitor that never cancels.
pub trait Monitor: Sync {
    /// `done` of `total` units are finished (`done ≤ total`; parallel work may report slightly
    /// out of order).
    fn report(&self, done: usize, total: usize);

    /// Whether the caller asks the call to stop: polled between units of work; the call then
    /// returns [`Cancelled`]. Never cancels unless overridden.
    fn cancelled(&self) -> bool {
        false
    }
}

impl<F: Fn(usize, usize) + Sync> Monitor for F {
    fn report(&self, done: usize, total: usize) {
        self(done, total);
    }
}

/// The error of a call whose [`Monitor`] (or [`Reporter`]) said it was cancelled: nothing was
/// returned and no output was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

/// Fails with [`Cancelled`] when `monitor` says the call was cancelled.
///
/// # Errors
/// [`Cancelled`] when `monitor` is given and [`Monitor::cancelled`] is true.
pub fn check(monitor: Option<&dyn Monitor>) -> Result<(), Cancelled> {
    match monitor {
        Some(m) if m.cancelled() => Err(Cancelled),
        _ => Ok(()),
    }
}

/// Part `index` of `parts` equal parts of one monitored call: reports `(index·t + done,
/// parts·t)` to `parent` and forwards its cancellation (a step that runs a sub-step several
/// times, such as a calibration's two refinements, shows one bar).
pub struct Part<'a> {
    parent: &'a dyn Monitor,
    index: usize,
    parts: usize,
}

impl<'a> Part<'a> {
    /// Part `index` (from 0) of `parts`.
    pub fn new(parent: &'a dyn Monitor, index: usize, parts: usize) -> Self {
        Self {
            parent,
            index,
            parts,
        }
    }
}

impl Monitor for Part<'_> {
    fn report(&self, done: usize, total: usize) {
        self.parent
            .report(self.index * total + done, self.parts * total);
    }

    fn cancelled(&self) -> bool {
        self.parent.cancelled()
    }
}

/// A sub-step of a monitored call whose units follow `offset` finished units of a call of
/// `total` units: reports `(offset + done, total)` to `parent`, forwarding its cancellation
/// (a tie bootstrap's replicates, then its leave-one-out values, on one bar).
pub struct Offset<'a> {
    parent: &'a dyn Monitor,
    offset: usize,
    total: usize,
}

impl<'a> Offset<'a> {
    /// Units after `offset` of `total`.
    pub fn new(parent: &'a dyn Monitor, offset: usize, total: usize) -> Self {
        Self {
            parent,
            offset,
            total,
        }
    }
}

impl Monitor for Offset<'_> {
    fn report(&self, done: usize, _: usize) {
        self.parent.report(self.offset + done, self.total);
    }

    fn cancelled(&self) -> bool {
        self.parent.cancelled()
    }
}

/// Progress of a library entry with named stages (`crashrig_study::run_grid`, …): the one
/// optional argument through which a front end watches a long call. The entry turns it into a
/// [`Progress`] per stage ([`stage`]); results never depend on it.
pub trait Reporter: Sync {
    /// `done` of `total` units of `stage` are finished (`done ≤ total`; parallel work may
    /// report slightly out of order).
    fn report(&self, stage: &str, done: usize, total: usize);

    /// Whether the caller asks the call to stop (see [`Monitor::cancelled`]).
    fn cancelled(&self) -> bool {
        false
    }
}

/// A `(done, total)` callback of `stage` reporting to `reporter`.
pub fn stage<'a>(reporter: &'a dyn Reporter, stage: &'a str) -> impl Fn(usize, usize) + Sync + 'a {
    move |done, total| reporter.report(stage, done, total)
}

/// Stage `stage` of `reporter` as a [`Monitor`] (reports and cancellation).
pub struct Stage<'a> {
    reporter: &'a dyn Reporter,
    stage: &'a str,
}

impl<'a> Stage<'a> {
    /// The monitor of `stage`.
    pub fn new(reporter: &'a dyn Reporter, stage: &'a str) -> Self {
        Self { reporter, stage }
    }
}

impl Monitor for Stage<'_> {
    fn report(&self, done: usize, total: usize) {
        self.reporter.report(self.stage, done, total);
    }

    fn cancelled(&self) -> bool {
        self.reporter.cancelled()
    }
}

/// A [`Monitor`] for tests of monitored calls: records every report and cancels once it has
/// seen `after` of them (`usize::MAX`: never).
///
/// ```
/// use crashrig_stats::progress::{Counter, Recorder};
/// let m = Recorder::cancelling_after(1);
/// let c = Counter::monitored(Some(&m), 2);
/// c.add(1);
/// assert!(c.check().is_err());
/// assert_eq!(m.seen(), vec![(1, 2)]);
/// ```
pub struct Recorder {
    after: usize,
    seen: std::sync::Mutex<Vec<(usize, usize)>>,
}

impl Recorder {
    /// A recorder that cancels after `after` reports.
    pub fn cancelling_after(after: usize) -> Self {
        Self {
            after,
            seen: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// A recorder that never cancels.
    pub fn new() -> Self {
        Self::cancelling_after(usize::MAX)
    }

    /// The reports so far, in the order they arrived.
    pub fn seen(&self) -> Vec<(usize, usize)> {
        self.seen.lock().map(|s| s.clone()).unwrap_or_default()
    }
}

impl Default for Recorder {
    fn default() -> Self {
        Self::new()
    }
}

impl Monitor for Recorder {
    fn report(&self, done: usize, total: usize) {
        if let Ok(mut s) = self.seen.lock() {
            s.push((done, total));
        }
    }

    fn cancelled(&self) -> bool {
        self.seen.lock().map_or(true, |s| s.len() >= self.after)
    }
}

/// Where a [`Counter`] reports.
#[derive(Clone, Copy)]
enum Sink<'a> {
    Callback(Progress<'a>),
    Monitor(&'a dyn Monitor),
}

/// Counts finished units of work and reports them to an optional [`Progress`] callback or
/// [`Monitor`].
pub struct Counter<'a> {
    report: Option<Sink<'a>>,
    done: AtomicUsize,
    total: usize,
}

impl<'a> Counter<'a> {
    /// A counter of `total` units reporting to `report` (nothing when `None`).
    pub fn new(report: Option<Progress<'a>>, total: usize) -> Self {
        Self {
            report: report.map(Sink::Callback),
            done: AtomicUsize::new(0),
            total,
        }
    }

    /// A counter of `total` units reporting to `monitor` (nothing when `None`); [`Self::check`]
    /// asks it whether the call was cancelled.
    pub fn monitored(monitor: Option<&'a dyn Monitor>, total: usize) -> Self {
        Self {
            report: monitor.map(Sink::Monitor),
            done: AtomicUsize::new(0),
            total,
        }
    }

    /// Fails with [`Cancelled`] when the monitor says the call was cancelled (a plain
    /// callback never cancels): polled between units of work.
    ///
    /// # Errors
    /// [`Cancelled`] as above.
    pub fn check(&self) -> Result<(), Cancelled> {
        match self.report {
            Some(Sink::Monitor(m)) if m.cancelled() => Err(Cancelled),
            _ => Ok(()),
        }
    }

    fn send(&self, done: usize) {
        match self.report {
            Some(Sink::Callback(f)) => f(done, self.total),
            Some(Sink::Monitor(m)) => m.report(done, self.total),
            None => {}
        }
    }

    /// A counter that reports nothing.
    pub fn silent() -> Counter<'static> {
        Counter::new(None, 0)
    }

    /// Whether a callback is attached.
    pub fn is_reporting(&self) -> bool {
        self.report.is_some()
    }

    /// The total number of units.
    pub fn total(&self) -> usize {
        self.total
    }

    /// `n` more units are finished (the report is clamped to the total).
    pub fn add(&self, n: usize) {
        if self.report.is_some() {
            let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
            self.send(done.min(self.total));
        }
    }

    /// Everything is finished: reports `(total, total)` (for work that ends early, such as an
    /// iteration that converges before its limit, or units that needed no work).
    pub fn finish(&self) {
        if self.report.is_some() {
            self.done.store(self.total, Ordering::Relaxed);
            self.send(self.total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[test]
    fn counter_never_exceeds_total_and_finishes_at_total() {
        let seen = Mutex::new(Vec::new());
        let report = |d: usize, t: usize| seen.lock().unwrap().push((d, t));
        let c = Counter::new(Some(&report), 2);
        c.add(1);
        c.add(5);
        c.finish();
        assert_eq!(*seen.lock().unwrap(), vec![(1, 2), (2, 2), (2, 2)]);
        // Silent: no callback, nothing to report, no panic.
        let s = Counter::silent();
        s.add(3);
        s.finish();
        assert!(!s.is_reporting());
        assert_eq!(s.check(), Ok(()));
    }

    #[test]
    fn counter_monitored_reports_and_checks_cancellation() {
        let m = Recorder::cancelling_after(2);
        let c = Counter::monitored(Some(&m), 3);
        c.add(1);
        assert_eq!(c.check(), Ok(()));
        c.add(1);
        assert_eq!(c.check(), Err(Cancelled));
        assert_eq!(check(Some(&m)), Err(Cancelled));
        assert_eq!(check(None), Ok(()));
        assert_eq!(m.seen(), vec![(1, 3), (2, 3)]);
        // A closure is a monitor that never cancels.
        let quiet = |_: usize, _: usize| {};
        assert_eq!(Counter::monitored(Some(&quiet), 1).check(), Ok(()));
    }

    #[test]
    fn part_and_offset_map_onto_the_parent_and_forward_cancellation() {
        let m = Recorder::cancelling_after(3);
        Part::new(&m, 1, 2).report(4, 10);
        Offset::new(&m, 7, 12).report(2, 5);
        assert!(!Part::new(&m, 0, 2).cancelled());
        assert!(!Stage::new(&Stopped(false), "x").cancelled());
        assert!(Stage::new(&Stopped(true), "x").cancelled());
        m.report(0, 0);
        assert!(Part::new(&m, 0, 2).cancelled() && Offset::new(&m, 0, 1).cancelled());
        assert_eq!(m.seen(), vec![(14, 20), (9, 12), (0, 0)]);
    }

    /// A reporter that is (or is not) cancelled.
    struct Stopped(bool);

    impl Reporter for Stopped {
        fn report(&self, _: &str, _: usize, _: usize) {}
        fn cancelled(&self) -> bool {
            self.0
        }
    }
}
