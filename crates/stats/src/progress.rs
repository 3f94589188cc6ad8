//! Progress reporting for long library calls, without any user interface: a caller passes a
//! [`Progress`] callback, the library counts finished units of work (replicates, grid points,
//! chunks of draws, iterations) with a [`Counter`] and calls it with `(done, total)`.
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

/// Progress of a library entry with named stages (`crashrig_study::run_grid`, …): the one
/// optional argument through which a front end watches a long call. The entry turns it into a
/// [`Progress`] per stage ([`stage`]); results never depend on it.
pub trait Reporter: Sync {
    /// `done` of `total` units of `stage` are finished (`done ≤ total`; parallel work may
    /// report slightly out of order).
    fn report(&self, stage: &str, done: usize, total: usize);
}

/// A `(done, total)` callback of `stage` reporting to `reporter`.
pub fn stage<'a>(reporter: &'a dyn Reporter, stage: &'a str) -> impl Fn(usize, usize) + Sync + 'a {
    move |done, total| reporter.report(stage, done, total)
}

/// Counts finished units of work and reports them to an optional [`Progress`].
pub struct Counter<'a> {
    report: Option<Progress<'a>>,
    done: AtomicUsize,
    total: usize,
}

impl<'a> Counter<'a> {
    /// A counter of `total` units reporting to `report` (nothing when `None`).
    pub fn new(report: Option<Progress<'a>>, total: usize) -> Self {
        Self {
            report,
            done: AtomicUsize::new(0),
            total,
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
        if let Some(f) = self.report {
            let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
            f(done.min(self.total), self.total);
        }
    }

    /// Everything is finished: reports `(total, total)` (for work that ends early, such as an
    /// iteration that converges before its limit, or units that needed no work).
    pub fn finish(&self) {
        if let Some(f) = self.report {
            self.done.store(self.total, Ordering::Relaxed);
            f(self.total, self.total);
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
    }
}
