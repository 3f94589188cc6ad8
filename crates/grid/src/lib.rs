//! The Monte Carlo of a scenario file as commands: `crashrig grid` (σ of forward-intersected
//! points over a grid of the car interior, with its CSV files, heat maps and `summary.json`),
//! `grid --shard i/N` with the merge of its shards, and `crashrig propagate` (σ of every camera
//! of the chain). `crashrig-study` draws its layouts with the same summaries and maps, and
//! `crashrig-place` confirms its layouts with the same grid run.
//!
//! Each entry takes a typed config and an optional progress
//! [`Reporter`](crashrig_stats::progress::Reporter) and returns a typed
//! result; front ends (the CLI, Python) only turn their arguments into the config and print.
//! - [`run_grid`] ([`GridConfig`] → [`GridRun`]; [`run_grid_scenario`] for a scenario already
//!   built, as `place` has it): `grid.csv`, `grid_detail.csv`, heat maps and `summary.json`
//!   ([`GridDocument`]) written as one unit into a staged output directory.
//! - [`shard`]: [`shard::run_grid_shard`] runs a contiguous share of the grid points and writes
//!   them exactly; [`shard::merge_grid`] reads the shards back and reports them through the
//!   code of [`run_grid`], so a merged output is the unsharded one byte for byte.
//! - [`run_propagate`] ([`PropagateConfig`] → [`PropagateRun`]): the chain's Monte Carlo and
//!   first-order σ, the `propagate --json` document ([`PropagateJson`]).
//! - [`summary`]: the typed summary of a grid study ([`summary::GridSummary`],
//!   [`summary::WorstDirection`]), its CSV text and the one heat-map renderer
//!   ([`summary::level_maps`]) of both `grid` and the study's layouts; [`fixed_maps`]: the
//!   coverage and field-of-view footprints of fixed cameras drawn on them.
//!
//! Every error is an [`Error`] naming the file (and line) or option at fault.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! A small scenario run whole and in two shards: the merged output is the unsharded one.
//! ```
//! use crashrig_grid::{GridConfig, run_grid, shard};
//! use crashrig_outdir::shard::{Shard, read_set};
//!
//! let dir = std::env::temp_dir().join(format!("crashrig-grid-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let scenario = dir.join("scenario.toml");
//! std::fs::write(&scenario, r#"
//! seed = 7
//! samples = 200
//! [grid]
//! x_mm = [400.0, 800.0, 3]
//! y_mm = [0.0, 0.0, 1]
//! z_mm = [0.0, 0.0, 1]
//! threshold_mm = 5.0
//! [[grid.observer]]
//! position_mm = [200.0, 0.0, 0.0]
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! [[grid.observer]]
//! position_mm = [600.0, -700.0, 0.0]
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! "#)?;
//! let config = |out: &str| GridConfig {
//!     scenario: scenario.clone(),
//!     out: dir.join(out),
//!     samples: None, // the scenario's 200 draws per point
//!     seed: None,
//!     plots: false,
//! };
//! let whole = run_grid(&config("whole"), None)?;
//! assert_eq!(whole.summary.points, 3);
//! assert!(whole.summary.median_sigma_max_mm < 5.0);
//!
//! let mut shards = Vec::new();
//! for i in 1..=2 {
//!     shard::run_grid_shard(&config(&format!("part{i}")), Shard::new(i, 2)?, None)?;
//!     shards.push(dir.join(format!("part{i}")));
//! }
//! shard::merge_grid(&read_set(&shards)?, &dir.join("merged"), false, None)?;
//! let csv = |d: &str| std::fs::read(dir.join(d).join("grid.csv"));
//! assert_eq!(csv("merged")?, csv("whole")?);
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod error;
pub mod fixed_maps;
mod propagate;
mod run;
pub mod shard;
pub mod summary;

pub use error::Error;
pub use propagate::{
    CameraJson, LinearJson, PropagateConfig, PropagateJson, PropagateRun, run_propagate,
};
pub use run::{
    AdaptiveSummary, Column, ColumnValues, CorrelationSummary, GridConfig, GridDocument, GridRun,
    LinearSummary, Spread, resolve_samples, run_grid, run_grid_scenario,
};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
