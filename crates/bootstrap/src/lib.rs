//! Generic nonparametric bootstrap: resample items with replacement, evaluate a statistic that
//! may fail, in parallel, and summarise the replicate distribution (σ, bias, percentile and BCa
//! intervals).
//!
//! The engine knows nothing about poses or COLMAP: a statistic is any
//! `Fn(&[usize]) -> Result<T, E>` over the indices of the resampled items.
//!
//! # Conventions
//! - Replicate `r` of a run with seed `s` draws its indices from `crashrig_stats::stream(s, r)`
//!   (ChaCha8, one stream per replicate); results are collected by replicate index, so output is
//!   bit-identical on any number of threads.
//! - Failed replicates are never dropped silently: [`Replicates`] holds the values *and* the
//!   failures (replicate index + error).
//! - σ is the sample standard deviation (n − 1) of the successful replicate values; quantiles
//!   are type 7 (NumPy's default).
//!
//! # Entry points
//! - [`run`]: the parallel bootstrap (an optional [`Monitor`] gets `(done, total)` reports
//!   and may cancel); [`resample`]: the indices of one replicate.
//! - [`jackknife`]: leave-one-out values (for the BCa acceleration).
//! - [`sigma`], [`bias`], [`percentile_interval`], [`bca_interval`]: scalar summaries.
//! - [`normal::cdf`], [`normal::inverse_cdf`]: Φ and Φ⁻¹.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_bootstrap::{bca_interval, jackknife, run, sigma};
//!
//! // Bootstrap the mean of 30 values.
//! let data: Vec<f64> = (0..30).map(|i| (i as f64 * 0.7).sin()).collect();
//! let mean = |idx: &[usize]| -> Result<f64, ()> {
//!     Ok(idx.iter().map(|&i| data[i]).sum::<f64>() / idx.len() as f64)
//! };
//! let reps = run(data.len(), 1000, 42, mean, None).unwrap();
//! assert_eq!(reps.failures.len(), 0);
//! let values: Vec<f64> = reps.values_only().copied().collect();
//! let se = sigma(&values).unwrap();
//! let all: Vec<usize> = (0..data.len()).collect();
//! let jk: Vec<f64> = jackknife(data.len(), mean, None).unwrap().into_iter().map(Result::unwrap).collect();
//! let ci = bca_interval(&values, mean(&all).unwrap(), &jk, 0.95).unwrap();
//! assert!(ci.lo < ci.hi && se > 0.0);
//! ```
#![deny(missing_docs)]

mod engine;
mod error;
mod interval;
pub mod normal;

pub use crashrig_stats::progress::{Cancelled, Monitor, Progress};

/// Largest number of bootstrap replicates a user may ask for (`bootstrap --iterations`, a
/// study's `[tie] iterations`): checked before the replicates are allocated
/// (`docs/LIMITS.md`).
pub const MAX_ITERATIONS: usize = 1_000_000;
pub use engine::{Failure, Replicates, jackknife, resample, run};
pub use error::{BcaReason, Error};
pub use interval::{
    Interval, acceleration, bca_interval, bias, bias_correction, percentile_interval, sigma,
};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
