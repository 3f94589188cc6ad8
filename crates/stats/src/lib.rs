//! Seeded random streams and streaming statistics shared by the crashrig engines.
//!
//! # Conventions
//! - Every random step takes an explicit seed. Parallel work derives **one ChaCha8 stream per
//!   replicate** from `(seed, replicate index)` with [`stream`], so a replicate's numbers do not
//!   depend on which thread ran it or in which order.
//! - σ is the sample standard deviation (divisor n − 1); SEM = σ/√n.
//! - Streaming accumulators ([`Moments`]) hold O(1) memory whatever the number of samples and merge
//!   exactly (Chan et al.), so a parallel reduction over chunks *in a fixed order* is reproducible.
//!
//! # Entry points
//! - [`stream`]: the RNG for replicate `index` of a run seeded with `seed`.
//! - [`Moments`]: streaming mean / covariance of fixed-size vectors (Welford, mergeable).
//! - [`summary::Summary`], [`summary::quantile`], [`summary::median`]: batch summaries of a
//!   slice.
//! - [`progress::Monitor`], [`progress::Counter`]: `(done, total)` progress reports and
//!   cancellation of long calls (no UI).
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_stats::{Moments, stream};
//! use rand::RngExt;
//! use rand_distr::StandardNormal;
//!
//! // σ of 10 000 standard normal draws, accumulated without storing them.
//! let mut rng = stream(42, 0);
//! let mut m = Moments::<1>::new();
//! for _ in 0..10_000 {
//!     let x: f64 = rng.sample(StandardNormal);
//!     m.push(&[x]);
//! }
//! let sigma = m.std_dev()[0];
//! // 3 standard errors of σ for n = 10 000 is 3/√(2·9999) ≈ 0.021.
//! assert!((sigma - 1.0).abs() < 0.021);
//! ```
#![deny(missing_docs)]

mod error;
mod moments;
pub mod progress;
pub mod summary;

pub use error::Error;
pub use moments::Moments;

/// The RNG type of every replicate stream: ChaCha8 (counter-based, cheap to seek).
pub type StreamRng = rand::rngs::ChaCha8Rng;

/// RNG for replicate `index` of a run with master `seed`.
///
/// The stream is `ChaCha8Rng::seed_from_u64(seed)` moved to stream number `index`, so two
/// replicates never share numbers and a replicate's draws are the same on any thread.
pub fn stream(seed: u64, index: u64) -> StreamRng {
    use rand::SeedableRng;
    let mut rng = StreamRng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn stream_nominal_is_reproducible() {
        let a: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(stream(7, 3), |r, _| Some(r.random()))
            .collect();
        let b: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(stream(7, 3), |r, _| Some(r.random()))
            .collect();
        assert_eq!(a, b);
    }

    #[test]
    fn stream_distinct_indices_differ() {
        let a: u64 = stream(7, 3).random();
        let b: u64 = stream(7, 4).random();
        let c: u64 = stream(8, 3).random();
        assert_ne!(a, b);
        assert_ne!(a, c);
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
