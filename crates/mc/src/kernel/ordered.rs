//! A parallel map whose results are folded in task order, in memory bounded independently of
//! the number of tasks.
//!
//! The Monte Carlo runs split their draws into tasks of [`crate::CHUNK`] draws and merge the
//! tasks' sums in task order, so that the floating-point sums (and the results) do not depend
//! on the thread count. Collecting every task's sums first made memory grow with the number
//! of draws (10⁷ draws per point × 221 points: 540 000 partial sums, 70 MB). Here the tasks run
//! in windows of [`WINDOW`]: each window is mapped in parallel, then folded in order before
//! the next starts, so at most one window of results is alive; the fold order, and therefore
//! every bit of the result, is the one of a sequential loop.

use rayon::prelude::*;

/// Tasks per window: enough to keep every thread busy between two folds (a task is 4096 draws,
/// tens of microseconds), few enough to keep the results of a window small.
pub(crate) const WINDOW: usize = 1024;

/// Runs `map(t)` for `t` in `0..n` in parallel and calls `fold(t, result)` in increasing `t`,
/// holding at most [`WINDOW`] results at a time.
pub(crate) fn map_fold_in_order<T: Send>(
    n: usize,
    map: impl Fn(usize) -> T + Sync + Send,
    mut fold: impl FnMut(usize, T),
) {
    let mut start = 0;
    while start < n {
        let end = (start + WINDOW).min(n);
        let parts: Vec<T> = (start..end).into_par_iter().map(&map).collect();
        for (t, part) in (start..end).zip(parts) {
            fold(t, part);
        }
        start = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_every_task_once_in_order_across_windows() {
        // 2.5 windows: the fold sees 0, 1, 2, … exactly once, with its own map result.
        let n = 2 * WINDOW + WINDOW / 2;
        let mut seen = Vec::new();
        map_fold_in_order(n, |t| t * 3 + 1, |t, v| seen.push((t, v)));
        let want: Vec<(usize, usize)> = (0..n).map(|t| (t, t * 3 + 1)).collect();
        assert_eq!(seen, want);
        let mut none = 0;
        map_fold_in_order(0, |t| t, |_, _| none += 1);
        assert_eq!(none, 0);
    }

    #[test]
    fn float_sums_are_the_same_for_any_thread_count() {
        // Non-associative sums: the same bits with 1 and 3 threads (the fold is sequential).
        let sum = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut s = 0.0f64;
                map_fold_in_order(3000, |t| 1.0 / (t as f64 + 0.37), |_, v| s += v);
                s
            })
        };
        assert_eq!(sum(1).to_bits(), sum(3).to_bits());
    }
}
