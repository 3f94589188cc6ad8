//! The options of the two Monte Carlo entries, [`crate::GridStudy::run`] and
//! [`crate::Chain::monte_carlo`]: how many draws, the seed and the instruction-set level. Progress
//! and cancellation are the entries' second argument, an optional
//! [`crashrig_stats::progress::Monitor`].

use crate::kernel::Isa;
use crate::model::Adaptive;

/// How many draws a grid study takes per point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Draws {
    /// A fixed number of draws per point.
    Samples(usize),
    /// The adaptive stopping rule of GUM-S1 §7.9 per point (see [`Adaptive`]).
    Adaptive(Adaptive),
}

/// How [`crate::GridStudy::run`] runs: draws per point, seed, instruction-set level.
///
/// [`crate::GridStudy::options`] gives the settings the study was built with (its samples and
/// seed, or its grid's adaptive rule).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOptions {
    /// Draws per point.
    pub draws: Draws,
    /// Seed of the Philox streams (task `p·2²⁴ + k` for chunk or batch `k` of point `p`).
    pub seed: u64,
    /// Instruction-set level of the kernels: every level gives the same bits, only the speed
    /// differs ([`Isa::Auto`]: the CPU's best).
    pub isa: Isa,
}

impl RunOptions {
    /// `samples` draws per point under `seed`, at the CPU's best level.
    pub fn samples(samples: usize, seed: u64) -> Self {
        Self {
            draws: Draws::Samples(samples),
            seed,
            isa: Isa::Auto,
        }
    }

    /// The adaptive rule per point under `seed`, at the CPU's best level.
    pub fn adaptive(adaptive: Adaptive, seed: u64) -> Self {
        Self {
            draws: Draws::Adaptive(adaptive),
            seed,
            isa: Isa::Auto,
        }
    }
}

/// How [`crate::Chain::monte_carlo`] runs: joint draws, seed, instruction-set level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChainOptions {
    /// Joint draws of every camera and link.
    pub samples: usize,
    /// Seed of the Philox streams (task `k` for chunk `k`).
    pub seed: u64,
    /// Instruction-set level of the kernels (every level gives the same bits).
    pub isa: Isa,
}

impl ChainOptions {
    /// `samples` joint draws under `seed`, at the CPU's best level.
    pub fn new(samples: usize, seed: u64) -> Self {
        Self {
            samples,
            seed,
            isa: Isa::Auto,
        }
    }
}
