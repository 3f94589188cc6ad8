//! Long calls: the library runs on a worker thread while the calling thread, with the GIL
//! released, waits for it; every [`TICK`] it takes the GIL to check for Ctrl-C and to hand
//! the latest progress to the user's `progress(stage, done, total)` callable.
//!
//! Ctrl-C (or an exception raised by the callable) sets a cancel flag. A library that takes a
//! [`Monitor`] ([`Watch::monitor`]: calibrate, bootstrap, measure, covariance, merge) sees it
//! through [`Monitor::cancelled`] between units of work and returns its typed `Cancelled`
//! error, writing nothing; [`run`] then raises the Python exception. Libraries that only
//! report (the Monte Carlo behind grid, propagate, place and study: the [`Reporter`] and
//! [`Watch::note_u64`]) are stopped at their next report by unwinding the worker
//! ([`std::panic::resume_unwind`], which prints nothing); their output directories are staged,
//! so an interrupted call leaves the previous output.

use crashrig_stats::progress::{Monitor, Reporter};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// How often the waiting thread looks at signals and progress.
const TICK: Duration = Duration::from_millis(50);

/// The unwind payload of a cancelled call.
struct Cancelled;

/// What the worker shares with the waiting thread: the cancel flag and the latest progress.
#[derive(Default)]
pub struct Watch {
    cancel: AtomicBool,
    latest: Mutex<Option<(String, usize, usize)>>,
}

impl Watch {
    /// Whether Ctrl-C or the callable asked the call to stop.
    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Records a report, or unwinds the worker when the call was cancelled (for libraries
    /// that do not ask [`Monitor::cancelled`]).
    fn note(&self, stage: &str, done: usize, total: usize) {
        if self.cancelled() {
            std::panic::resume_unwind(Box::new(Cancelled));
        }
        self.record(stage, done, total);
    }

    /// Records a report for the waiting thread (the largest `done` of a stage wins).
    fn record(&self, stage: &str, done: usize, total: usize) {
        if let Ok(mut l) = self.latest.lock() {
            let keep = l
                .as_ref()
                .is_some_and(|(s, d, t)| s == stage && *t == total && *d > done);
            if !keep {
                *l = Some((stage.to_string(), done, total));
            }
        }
    }

    /// The [`Monitor`] of one stage: records its reports and answers [`Monitor::cancelled`]
    /// with the cancel flag (the library stops itself; nothing unwinds).
    pub fn monitor<'a>(&'a self, stage: &'a str) -> StageMonitor<'a> {
        StageMonitor { watch: self, stage }
    }

    /// A `(stage, done, total)` callback with `u64` counts (the study pipeline's).
    pub fn note_u64(&self, stage: &str, done: u64, total: u64) {
        self.note(stage, done as usize, total as usize);
    }
}

impl Reporter for Watch {
    fn report(&self, stage: &str, done: usize, total: usize) {
        self.note(stage, done, total);
    }

    fn cancelled(&self) -> bool {
        Watch::cancelled(self)
    }
}

/// One stage of a [`Watch`] as a [`Monitor`] ([`Watch::monitor`]).
pub struct StageMonitor<'a> {
    watch: &'a Watch,
    stage: &'a str,
}

impl Monitor for StageMonitor<'_> {
    fn report(&self, done: usize, total: usize) {
        self.watch.record(self.stage, done, total);
    }

    fn cancelled(&self) -> bool {
        self.watch.cancelled()
    }
}

/// The worker's outcome: its value, or the payload of its unwind.
type Outcome<T> = std::thread::Result<T>;

/// Runs `work` on a worker thread with the GIL released; see the module docs.
///
/// # Errors
/// `KeyboardInterrupt` on Ctrl-C, the callable's exception, or `crashrig.Error` when the
/// library panicked.
pub fn run<T, F>(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Watch) -> T + Send,
{
    let watch = Watch::default();
    let done: (Mutex<Option<Outcome<T>>>, Condvar) = (Mutex::new(None), Condvar::new());
    let mut failure: Option<PyErr> = None;
    let mut shown: Option<(String, usize, usize)> = None;
    let outcome = std::thread::scope(|s| {
        s.spawn(|| {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&watch)));
            let (lock, cv) = &done;
            if let Ok(mut slot) = lock.lock() {
                *slot = Some(r);
            }
            cv.notify_all();
        });
        loop {
            let finished = py.detach(|| {
                let (lock, cv) = &done;
                let slot = lock.lock().unwrap_or_else(|p| p.into_inner());
                let (mut slot, _) = cv
                    .wait_timeout_while(slot, TICK, |o| o.is_none())
                    .unwrap_or_else(|p| p.into_inner());
                slot.take()
            });
            let show = |shown: &mut Option<(String, usize, usize)>| -> Option<PyErr> {
                let cb = progress?;
                let latest = watch.latest.lock().ok().and_then(|l| l.clone());
                if latest.is_none() || latest == *shown {
                    return None;
                }
                let err = latest
                    .as_ref()
                    .and_then(|(stage, d, t)| cb.call1((stage.as_str(), *d, *t)).err());
                *shown = latest;
                err
            };
            if let Some(o) = finished {
                // A call faster than one tick still shows its last progress report.
                if failure.is_none() {
                    failure = show(&mut shown);
                }
                return o;
            }
            if failure.is_some() {
                continue;
            }
            if let Err(e) = py.check_signals() {
                watch.cancel.store(true, Ordering::Relaxed);
                failure = Some(e);
                continue;
            }
            if let Some(e) = show(&mut shown) {
                watch.cancel.store(true, Ordering::Relaxed);
                failure = Some(e);
            }
        }
    });
    if let Some(e) = failure {
        return Err(e);
    }
    match outcome {
        Ok(v) => Ok(v),
        Err(payload) if payload.is::<Cancelled>() => {
            Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(()))
        }
        Err(payload) => {
            let text = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(crate::py_error(format!(
                "internal error (please report): {text}"
            )))
        }
    }
}
