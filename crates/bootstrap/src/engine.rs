//! The resampling engine: replicates in parallel, one RNG stream per replicate.

use crate::Error;
use crashrig_stats::progress::{Counter, Monitor};
use rand::RngExt;
use rayon::prelude::*;

/// One failed replicate: its index and the statistic's error.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure<E> {
    /// Replicate index in `0..replicates`.
    pub replicate: usize,
    /// What the statistic returned.
    pub error: E,
}

/// The outcome of [`run`]: every successful replicate value with its index, and every failure.
///
/// `values` and `failures` are sorted by replicate index and together cover `0..replicates`
/// exactly once, so a failure rate is `failures.len() / replicates` and nothing is dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct Replicates<T, E> {
    /// Number of replicates asked for.
    pub replicates: usize,
    /// Successful replicates as `(replicate index, value)`, by increasing index.
    pub values: Vec<(usize, T)>,
    /// Failed replicates, by increasing index.
    pub failures: Vec<Failure<E>>,
}

impl<T, E> Replicates<T, E> {
    /// The successful values alone, in replicate order.
    pub fn values_only(&self) -> impl Iterator<Item = &T> {
        self.values.iter().map(|(_, v)| v)
    }

    /// Fraction of replicates that failed.
    pub fn failure_rate(&self) -> f64 {
        self.failures.len() as f64 / self.replicates as f64
    }
}

/// The resample of replicate `replicate`: `n_items` indices drawn uniformly with replacement from
/// `0..n_items` with the stream `crashrig_stats::stream(seed, replicate)`, sorted increasingly.
///
/// This is exactly what [`run`] hands to the statistic, exposed so callers can reproduce it.
pub fn resample(n_items: usize, seed: u64, replicate: usize) -> Vec<usize> {
    let mut rng = crashrig_stats::stream(seed, replicate as u64);
    let mut idx: Vec<usize> = (0..n_items).map(|_| rng.random_range(0..n_items)).collect();
    idx.sort_unstable();
    idx
}

/// Runs a nonparametric bootstrap: `replicates` resamples of `n_items` items with replacement,
/// each passed to `statistic` as a sorted slice of item indices (repeats included).
///
/// Replicates run in parallel on the current rayon pool; replicate `r` draws its indices from
/// `crashrig_stats::stream(seed, r)` and the results are collected by index, so the output is
/// bit-identical whatever the number of threads. A statistic that returns `Err` marks its
/// replicate failed; the error is kept in [`Replicates::failures`].
///
/// `monitor` (optional) gets `(replicates done, replicates)` after each replicate (one atomic
/// increment each) and is asked before each replicate whether the call was cancelled; the
/// result is the same with and without it.
///
/// # Errors
/// [`Error::NoItems`], [`Error::NoReplicates`], and [`Error::Cancelled`] when `monitor` said
/// so.
pub fn run<T, E, F>(
    n_items: usize,
    replicates: usize,
    seed: u64,
    statistic: F,
    monitor: Option<&dyn Monitor>,
) -> Result<Replicates<T, E>, Error>
where
    T: Send,
    E: Send,
    F: Fn(&[usize]) -> Result<T, E> + Sync,
{
    if n_items == 0 {
        return Err(Error::NoItems);
    }
    if replicates == 0 {
        return Err(Error::NoReplicates);
    }
    let counter = Counter::monitored(monitor, replicates);
    let outcomes: Vec<Result<T, E>> = (0..replicates)
        .into_par_iter()
        .map(|r| {
            counter.check()?;
            let outcome = statistic(&resample(n_items, seed, r));
            counter.add(1);
            Ok(outcome)
        })
        .collect::<Result<_, crashrig_stats::progress::Cancelled>>()?;
    let mut values = Vec::with_capacity(replicates);
    let mut failures = Vec::new();
    for (replicate, outcome) in outcomes.into_iter().enumerate() {
        match outcome {
            Ok(v) => values.push((replicate, v)),
            Err(error) => failures.push(Failure { replicate, error }),
        }
    }
    Ok(Replicates {
        replicates,
        values,
        failures,
    })
}

/// Jackknife: the statistic on each leave-one-out sample (`0..n_items` without item `i`), in
/// parallel, returned in item order. Needed for the BCa acceleration.
///
/// `monitor` (optional) gets `(leave-one-out values done, n_items)` and may cancel, as in
/// [`run`]; the result is the same with and without it.
///
/// # Errors
/// [`Error::TooFewValues`] for fewer than two items, [`Error::Cancelled`].
pub fn jackknife<T, E, F>(
    n_items: usize,
    statistic: F,
    monitor: Option<&dyn Monitor>,
) -> Result<Vec<Result<T, E>>, Error>
where
    T: Send,
    E: Send,
    F: Fn(&[usize]) -> Result<T, E> + Sync,
{
    if n_items < 2 {
        return Err(Error::TooFewValues {
            needed: 2,
            found: n_items,
        });
    }
    let counter = Counter::monitored(monitor, n_items);
    Ok((0..n_items)
        .into_par_iter()
        .map(|i| {
            counter.check()?;
            let idx: Vec<usize> = (0..n_items).filter(|&j| j != i).collect();
            let value = statistic(&idx);
            counter.add(1);
            Ok(value)
        })
        .collect::<Result<_, crashrig_stats::progress::Cancelled>>()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean_of(data: &[f64], idx: &[usize]) -> Result<f64, &'static str> {
        Ok(idx.iter().map(|&i| data[i]).sum::<f64>() / idx.len() as f64)
    }

    #[test]
    fn run_nominal_covers_every_replicate() {
        let data: Vec<f64> = (0..20).map(f64::from).collect();
        let statistic = |idx: &[usize]| {
            if idx[0] == 0 {
                Err("starts with item 0")
            } else {
                mean_of(&data, idx)
            }
        };
        let out = run(data.len(), 50, 3, statistic, None).unwrap();
        assert_eq!(out.replicates, 50);
        assert_eq!(out.values.len() + out.failures.len(), 50);
        let mut seen: Vec<usize> = out
            .values
            .iter()
            .map(|(r, _)| *r)
            .chain(out.failures.iter().map(|f| f.replicate))
            .collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..50).collect::<Vec<_>>());
        // With 20 items, P(item 0 drawn) = 1 − (19/20)^20 ≈ 0.64: some replicates fail.
        assert!(!out.failures.is_empty());
        for f in &out.failures {
            assert_eq!(resample(20, 3, f.replicate)[0], 0);
            assert_eq!(f.error, "starts with item 0");
        }
    }

    #[test]
    fn run_identical_on_one_and_two_threads() {
        let data: Vec<f64> = (0..97).map(|i| f64::from(i).sin()).collect();
        let go = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| run(data.len(), 300, 11, |idx| mean_of(&data, idx), None).unwrap())
        };
        let one = go(1);
        let two = go(2);
        assert_eq!(one.values.len(), 300);
        // Bit-identical: compare the bit patterns, not approximately.
        let bits = |r: &Replicates<f64, &str>| {
            r.values
                .iter()
                .map(|(i, v)| (*i, v.to_bits()))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&one), bits(&two));
    }

    #[test]
    fn run_with_a_monitor_counts_every_replicate_and_changes_nothing() {
        let data: Vec<f64> = (0..31).map(|i| f64::from(i).cos()).collect();
        let seen = std::sync::Mutex::new(Vec::new());
        let report = |d: usize, t: usize| seen.lock().unwrap().push((d, t));
        let with = run(data.len(), 40, 9, |idx| mean_of(&data, idx), Some(&report)).unwrap();
        assert_eq!(
            with,
            run(data.len(), 40, 9, |idx| mean_of(&data, idx), None).unwrap()
        );
        let mut seen = seen.into_inner().unwrap();
        assert_eq!(seen.len(), 40);
        assert!(seen.iter().all(|&(d, t)| t == 40 && d <= t));
        // Each count 1..=40 reported exactly once (one atomic increment per replicate).
        seen.sort_unstable();
        assert_eq!(seen, (1..=40).map(|d| (d, 40)).collect::<Vec<_>>());
    }

    #[test]
    fn jackknife_with_a_monitor_counts_every_item_and_changes_nothing() {
        let data = [1.0, 2.0, 3.0, 10.0, -4.0];
        let seen = std::sync::Mutex::new(Vec::new());
        let report = |d: usize, t: usize| seen.lock().unwrap().push((d, t));
        let with = jackknife(5, |idx| mean_of(&data, idx), Some(&report)).unwrap();
        assert_eq!(with, jackknife(5, |idx| mean_of(&data, idx), None).unwrap());
        let mut seen = seen.into_inner().unwrap();
        seen.sort_unstable();
        assert_eq!(seen, (1..=5).map(|d| (d, 5)).collect::<Vec<_>>());
    }

    /// Cancels once `after` replicates are done.
    struct StopAfter(usize, std::sync::atomic::AtomicUsize);

    impl Monitor for StopAfter {
        fn report(&self, done: usize, _: usize) {
            self.1.fetch_max(done, std::sync::atomic::Ordering::Relaxed);
        }
        fn cancelled(&self) -> bool {
            self.1.load(std::sync::atomic::Ordering::Relaxed) >= self.0
        }
    }

    #[test]
    fn run_and_jackknife_stop_when_cancelled() {
        let data: Vec<f64> = (0..31).map(f64::from).collect();
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let counted = |idx: &[usize]| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            mean_of(&data, idx)
        };
        let stop = StopAfter(5, 0.into());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let e = pool.install(|| run(data.len(), 1000, 9, counted, Some(&stop)).unwrap_err());
        assert_eq!(e, Error::Cancelled(crashrig_stats::progress::Cancelled));
        // One thread: the statistic ran for the five replicates before the cancellation only.
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 5);
        let e = jackknife(data.len(), counted, Some(&StopAfter(0, 0.into()))).unwrap_err();
        assert_eq!(e.to_string(), "cancelled");
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 5);
    }

    #[test]
    fn run_rejects_empty_inputs() {
        let f = |_: &[usize]| Ok::<f64, ()>(0.0);
        assert_eq!(run(0, 10, 1, f, None).unwrap_err(), Error::NoItems);
        assert_eq!(run(5, 0, 1, f, None).unwrap_err(), Error::NoReplicates);
    }

    #[test]
    fn resample_is_with_replacement_and_seeded() {
        let a = resample(1000, 5, 7);
        assert_eq!(a, resample(1000, 5, 7));
        assert_ne!(a, resample(1000, 5, 8));
        assert_eq!(a.len(), 1000);
        assert!(a.windows(2).all(|w| w[0] <= w[1]));
        // Expected number of distinct items is n(1 − (1 − 1/n)^n) ≈ 632 for n = 1000; its
        // standard deviation is about 9, so 580..690 is a > 5σ band.
        let mut d = a.clone();
        d.dedup();
        assert!((580..690).contains(&d.len()), "{} distinct", d.len());
    }

    #[test]
    fn jackknife_nominal_leaves_one_out() {
        let data = [1.0, 2.0, 3.0, 10.0];
        let jk = jackknife(4, |idx| mean_of(&data, idx), None).unwrap();
        let got: Vec<f64> = jk.into_iter().map(Result::unwrap).collect();
        // Hand computed: (15/3, 14/3, 13/3, 6/3).
        approx::assert_relative_eq!(got[0], 5.0, epsilon = 1e-15);
        approx::assert_relative_eq!(got[3], 2.0, epsilon = 1e-15);
        assert_eq!(
            jackknife(1, |idx| mean_of(&data, idx), None).unwrap_err(),
            Error::TooFewValues {
                needed: 2,
                found: 1
            }
        );
    }
}
