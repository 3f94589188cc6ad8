//! Where to mount the cameras (`crashrig place`): choose K observers from a list of candidate
//! mounts, added to a scenario's own observers, to maximise the share of the grid with
//! σ_max ≤ `threshold_mm` (ties: the lower mean σ_max).
//!
//! 1. **Approximation** ([`approx`]): the first-order covariance of the forward intersection at
//!    every grid point, `A⁻¹ N A⁻¹` with `A` and `N` sums of per-observer 3 × 3 terms
//!    ([`crashrig_mc::LinearTerm`], the model of `grid`'s first-order map), so scoring a layout
//!    adds matrices instead of running a Monte Carlo (`docs/PLACE.md` has the formula).
//! 2. **Search** ([`search`]): every K-subset when there are at most
//!    [`EXHAUSTIVE_MAX_LAYOUTS`], else greedy forward selection and best-improvement swaps;
//!    memory does not depend on the number of subsets (a bounded board of the best layouts).
//! 3. **Confirmation**: the best layout and the runners-up whose approximate share is within
//!    [`CONFIRM_MARGIN`] of it (at most [`MAX_CONFIRMED`] layouts) run the Monte Carlo of
//!    `crashrig grid`; the layout with the best *confirmed* objective wins, and only confirmed
//!    numbers are reported. Its grid output is written to `OUT/grid/`, `placement.json` to `OUT`.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```no_run
//! use crashrig_place::{PlaceConfig, run};
//! let config = PlaceConfig {
//!     scenario: "examples/place/scenario.toml".into(),
//!     candidates: "examples/place/candidates.toml".into(),
//!     choose: 2,
//!     out: "place_out".into(),
//!     samples: Some(2000),
//!     seed: Some(1),
//!     plots: true,
//! };
//! let r = run(&config, None)?;
//! println!("mount {:?}: {:.1} % below the threshold (Monte Carlo)",
//!     r.placement.chosen, 100.0 * r.placement.share_below_threshold);
//! # Ok::<(), crashrig_place::Error>(())
//! ```
#![deny(missing_docs)]

pub mod approx;
mod error;
pub mod search;
pub mod shard;

pub use error::Error;

use crashrig_grid::{GridConfig, GridRun};
use crashrig_mc::{GridStudy, Observer, Scenario};
use crashrig_stats::progress::{self, Reporter};
use serde::Serialize;
use std::path::PathBuf;

/// Largest number of K-subsets searched exhaustively; above it, greedy + swap.
pub const EXHAUSTIVE_MAX_LAYOUTS: u64 = 200_000;

/// Runners-up whose approximate share is at least the best approximate share minus this are
/// confirmed by the Monte Carlo too (see `docs/PLACE.md` for why 0.05).
pub const CONFIRM_MARGIN: f64 = 0.05;

/// Most layouts confirmed by the Monte Carlo (the best and up to three runners-up).
pub const MAX_CONFIRMED: usize = 4;

/// Largest grid points × candidates: the approximation holds two 3 × 3 matrices and a
/// direction per entry (about 180 bytes, so at most about 180 MB).
pub const MAX_TERMS: usize = 1_000_000;

/// What `crashrig place` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaceConfig {
    /// The scenario (its grid, threshold, chain and own observers; it may have fewer than two
    /// observers).
    pub scenario: PathBuf,
    /// The candidates file (`[[candidate]]` tables).
    pub candidates: PathBuf,
    /// K: how many candidates to choose.
    pub choose: usize,
    /// The output directory (`placement.json`, `grid/`).
    pub out: PathBuf,
    /// Draws per point of the confirmation (default: the scenario's `samples`).
    pub samples: Option<usize>,
    /// Seed (default: the scenario's).
    pub seed: Option<u64>,
    /// Draw the chosen layout's heat maps.
    pub plots: bool,
}

/// One layout confirmed by the Monte Carlo (`placement.json` → `confirmed`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Confirmed {
    /// Candidate names in pick order.
    pub chosen: Vec<String>,
    /// Monte Carlo share of the grid with σ_max ≤ threshold.
    pub share_below_threshold: f64,
    /// Monte Carlo mean σ_max (mm) of the measurable, non-degenerate points.
    pub mean_sigma_max_mm: f64,
    /// The approximation's share (first order), for comparison.
    pub approximate_share_below_threshold: f64,
    /// The approximation's mean σ_max (mm).
    pub approximate_mean_sigma_max_mm: f64,
}

/// `placement.json` (contract fields first; the rest documented in `docs/PLACE.md`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Placement {
    /// The chosen candidates' names, in pick order.
    pub chosen: Vec<String>,
    /// Monte Carlo share of the grid with σ_max ≤ threshold.
    pub share_below_threshold: f64,
    /// Monte Carlo mean σ_max (mm) over the measurable, non-degenerate points.
    pub mean_sigma_max_mm: f64,
    /// `"exhaustive"` or `"greedy+swap"`.
    pub method: &'static str,
    /// Layouts scored by the approximation.
    pub evaluated: u64,
    /// Draws per point of the confirmation.
    pub samples: usize,
    /// Seed of the confirmation.
    pub seed: u64,
    /// K.
    pub choose: usize,
    /// Number of candidates.
    pub candidates: usize,
    /// The grid's threshold (mm).
    pub threshold_mm: f64,
    /// Grid points.
    pub points: usize,
    /// Every layout confirmed by the Monte Carlo, in the approximation's rank order.
    pub confirmed: Vec<Confirmed>,
}

/// The result of [`run`].
#[derive(Debug, Clone)]
pub struct PlaceRun {
    /// `placement.json`.
    pub placement: Placement,
    /// The chosen layout's grid run (written to `OUT/grid/`).
    pub grid: GridRun,
}

/// Whether a top-level entry of an existing output directory is something `place` writes.
fn replaceable(name: &str) -> bool {
    name == "placement.json" || name == "grid/" || name.starts_with(".tmp")
}

/// The inputs of a placement, read and checked before any work.
pub(crate) struct Inputs {
    pub(crate) scenario: Scenario,
    pub(crate) candidates: Vec<Observer>,
    pub(crate) threshold_mm: f64,
    pub(crate) k: usize,
    pub(crate) samples: usize,
    pub(crate) seed: u64,
    pub(crate) points: usize,
}

impl Inputs {
    /// Reads the scenario and the candidates of `config` and checks `--choose`, `--samples` and
    /// the size of the first-order table.
    pub(crate) fn read(config: &PlaceConfig) -> Result<Inputs, Error> {
        let scenario = Scenario::from_path_for_placement(&config.scenario)
            .map_err(|e| Error::input(&config.scenario, e))?;
        let Some(grid) = scenario.grid.clone() else {
            return Err(Error::input(&config.scenario, crashrig_mc::Error::NoGrid));
        };
        let candidates = crashrig_mc::read_candidates(&config.candidates, &scenario)
            .map_err(|e| Error::input(&config.candidates, e))?;
        let (base, n, k) = (grid.observers.len(), candidates.len(), config.choose);
        let choose = |problem: String| Error::Setting {
            name: "--choose",
            problem,
        };
        if k == 0 {
            return Err(choose("must be at least 1".into()));
        }
        if k > n {
            return Err(choose(format!(
                "{k} exceeds the {n} candidates of {}",
                config.candidates.display()
            )));
        }
        if base + k < 2 {
            return Err(choose(format!(
                "{} has {base} observer(s) of its own; choose at least {} so that points are seen twice",
                config.scenario.display(),
                2 - base
            )));
        }
        let samples = crashrig_grid::resolve_samples(config.samples, &scenario)?;
        let seed = config.seed.unwrap_or(scenario.seed);
        // Counted, not listed: nothing sized by the grid is allocated before the checks.
        let points = [grid.x.count, grid.y.count, grid.z.count]
            .iter()
            .fold(1usize, |a, &c| a.saturating_mul(c));
        if grid.adaptive.is_none() {
            crashrig_mc::limits::check_grid_draws(points, samples).map_err(|e| Error::Setting {
                name: "--samples",
                problem: format!("{samples}: {e}"),
            })?;
        }
        check_terms(points, n)?;
        Ok(Inputs {
            scenario,
            candidates,
            threshold_mm: grid.threshold_mm,
            k,
            samples,
            seed,
            points,
        })
    }

    /// The first-order table over the scenario's own observers and every candidate.
    pub(crate) fn table(
        &self,
        config: &PlaceConfig,
        progress: Option<&dyn Reporter>,
    ) -> Result<approx::Table, Error> {
        let own = self.scenario.grid.as_ref().map_or(0, |g| g.observers.len());
        let all = layout(&self.scenario, &self.candidates);
        let study = GridStudy::new(&all, self.samples, self.seed)
            .map_err(|e| Error::input(&config.candidates, e))?;
        let hook = progress.map(|r| progress::stage(r, "first-order terms"));
        let hook = hook.as_ref().map(|h| h as &(dyn Fn(usize, usize) + Sync));
        approx::Table::build(&study, own, hook).map_err(|e| Error::input(&config.candidates, e))
    }

    /// The layout with the candidates `order` (indices, in pick order) mounted.
    pub(crate) fn layout(&self, order: &[usize]) -> Scenario {
        let chosen: Vec<Observer> = order.iter().map(|&c| self.candidates[c].clone()).collect();
        layout(&self.scenario, &chosen)
    }

    /// The names of the candidates `order`.
    pub(crate) fn names(&self, order: &[usize]) -> Vec<String> {
        order
            .iter()
            .map(|&c| self.candidates[c].name.clone())
            .collect()
    }
}

/// Checks `points × candidates` against [`MAX_TERMS`] (before the table is allocated); the
/// message gives the memory the table would need.
///
/// # Errors
/// [`Error::Setting`] naming `--candidates`.
pub fn check_terms(points: usize, candidates: usize) -> Result<(), Error> {
    let terms = points.saturating_mul(candidates);
    if terms > MAX_TERMS {
        let mib = terms as f64 * approx::Table::BYTES_PER_TERM as f64 / (1u64 << 20) as f64;
        return Err(Error::Setting {
            name: "--candidates",
            problem: format!(
                "{points} grid points × {candidates} candidates = {terms} first-order terms exceed the limit of {MAX_TERMS} (the table would need {mib:.0} MiB; docs/LIMITS.md)"
            ),
        });
    }
    Ok(())
}

/// What the search chose for the Monte Carlo: the layouts in the approximation's rank order,
/// each as candidate indices in pick order with its approximate score.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Shortlist {
    pub(crate) method: &'static str,
    pub(crate) evaluated: u64,
    pub(crate) layouts: Vec<(approx::Score, Vec<usize>)>,
}

impl Shortlist {
    /// Builds the first-order table of `inputs`, searches it and keeps the layouts worth a
    /// Monte Carlo run.
    pub(crate) fn find(
        inputs: &Inputs,
        config: &PlaceConfig,
        progress: Option<&dyn Reporter>,
    ) -> Result<Shortlist, Error> {
        let table = inputs.table(config, progress)?;
        let found = search::search(&table, inputs.k, MAX_CONFIRMED);
        Ok(Shortlist::of(&table, &found))
    }

    /// The layouts of `found`'s board whose approximate share is within [`CONFIRM_MARGIN`] of
    /// the best, in rank order, each in pick order.
    pub(crate) fn of(table: &approx::Table, found: &search::Found) -> Shortlist {
        let best_share = found.board.entries.first().map_or(0.0, |(s, _)| s.share());
        let layouts = found
            .board
            .entries
            .iter()
            .filter(|(s, _)| s.share() >= best_share - CONFIRM_MARGIN)
            .map(|(s, set)| (*s, search::order_within(table, set, set.len())))
            .collect();
        Shortlist {
            method: found.method,
            evaluated: found.evaluated,
            layouts,
        }
    }

    /// `placement.json` from the Monte Carlo scores of the layouts (in shortlist order), and
    /// the winner's position: the best confirmed objective, ties in the approximation's order.
    pub(crate) fn decide(&self, inputs: &Inputs, mc: &[approx::Score]) -> (usize, Placement) {
        let mut winner = 0;
        for (i, s) in mc.iter().enumerate() {
            if s.compare(&mc[winner]) == std::cmp::Ordering::Greater {
                winner = i;
            }
        }
        let confirmed: Vec<Confirmed> = self
            .layouts
            .iter()
            .zip(mc)
            .map(|((approx, order), score)| Confirmed {
                chosen: inputs.names(order),
                share_below_threshold: score.share(),
                mean_sigma_max_mm: score.mean_sigma_max_mm(),
                approximate_share_below_threshold: approx.share(),
                approximate_mean_sigma_max_mm: approx.mean_sigma_max_mm(),
            })
            .collect();
        let w = &confirmed[winner];
        let placement = Placement {
            chosen: w.chosen.clone(),
            share_below_threshold: w.share_below_threshold,
            mean_sigma_max_mm: w.mean_sigma_max_mm,
            method: self.method,
            evaluated: self.evaluated,
            samples: inputs.samples,
            seed: inputs.seed,
            choose: inputs.k,
            candidates: inputs.candidates.len(),
            threshold_mm: inputs.threshold_mm,
            points: inputs.points,
            confirmed,
        };
        (winner, placement)
    }
}

/// Writes `placement.json` to `staged` and commits it.
pub(crate) fn commit(
    placement: &Placement,
    mut staged: crashrig_outdir::Staged,
    out: &std::path::Path,
) -> Result<(), Error> {
    let json = serde_json::to_vec_pretty(placement).map_err(|e| Error::Output {
        out: out.to_path_buf(),
        problem: e.to_string(),
    })?;
    staged.write("placement.json", &json)?;
    staged.commit()?;
    Ok(())
}

/// Runs the placement search of `config` and writes `OUT/placement.json` and `OUT/grid/` as one
/// unit (nothing is written on an error); `progress` watches the stages.
///
/// # Errors
/// [`Error::Input`] (the scenario or candidates file, with the line), [`Error::Setting`]
/// (`--choose`, `--samples`, `--candidates`), [`Error::OutDir`] — all before any work — and
/// [`Error::Grid`].
pub fn run(config: &PlaceConfig, progress: Option<&dyn Reporter>) -> Result<PlaceRun, Error> {
    let inputs = Inputs::read(config)?;
    // Fails before any work when OUT holds files `place` does not write.
    let staged = crashrig_outdir::Staged::new(&config.out, replaceable)?;
    let shortlist = Shortlist::find(&inputs, config, progress)?;

    // Confirmation by the Monte Carlo.
    let mut scores = Vec::with_capacity(shortlist.layouts.len());
    for (i, (_, order)) in shortlist.layouts.iter().enumerate() {
        let stage = format!("confirming layout {} of {}", i + 1, shortlist.layouts.len());
        let layout = inputs.layout(order);
        let score = monte_carlo_score(&layout, inputs.samples, inputs.seed, progress, &stage)
            .map_err(|e| Error::input(&config.candidates, e))?;
        scores.push(score);
    }
    let (winner, placement) = shortlist.decide(&inputs, &scores);
    let grid_config = GridConfig {
        scenario: config.scenario.clone(),
        out: staged.dir().join("grid"),
        samples: Some(inputs.samples),
        seed: Some(inputs.seed),
        plots: config.plots,
    };
    let winner_layout = inputs.layout(&shortlist.layouts[winner].1);
    let grid_run = crashrig_grid::run_grid_scenario(&winner_layout, &grid_config, progress)?;
    commit(&placement, staged, &config.out)?;
    Ok(PlaceRun {
        placement,
        grid: grid_run,
    })
}

/// `scenario` with its grid's observers replaced by `observers`.
fn with_observers(scenario: &Scenario, observers: impl Iterator<Item = Observer>) -> Scenario {
    let mut s = scenario.clone();
    if let Some(g) = s.grid.as_mut() {
        g.observers = observers.collect();
    }
    s
}

/// The layout of `scenario` with `chosen` mounted: its own observers, then `chosen`.
pub fn layout(scenario: &Scenario, chosen: &[Observer]) -> Scenario {
    let own = scenario.grid.iter().flat_map(|g| g.observers.iter());
    with_observers(scenario, own.chain(chosen).cloned())
}

/// The Monte Carlo objective of a layout: `grid`'s engine (same draws and seed, degenerate
/// points blanked), share with σ_max ≤ threshold and mean σ_max; `progress` watches `stage`.
///
/// # Errors
/// As [`GridStudy::new`] and [`GridStudy::run`].
pub fn monte_carlo_score(
    layout: &Scenario,
    samples: usize,
    seed: u64,
    progress: Option<&dyn Reporter>,
    stage: &str,
) -> Result<approx::Score, crashrig_mc::Error> {
    let study = GridStudy::new(layout, samples, seed)?;
    let stage = progress.map(|r| progress::Stage::new(r, stage));
    let monitor = stage.as_ref().map(|s| s as &dyn progress::Monitor);
    let result = study.run(&study.options(), monitor)?;
    Ok(score_of(result, study.grid()))
}

/// The Monte Carlo objective of a grid result (degenerate points blanked as `grid` blanks them).
pub(crate) fn score_of(
    mut result: crashrig_mc::GridResult,
    grid: &crashrig_mc::Grid,
) -> approx::Score {
    crashrig_mc::degenerate::mask_degenerate(&mut result, grid);
    approx::Score::of(
        result.points.iter().map(|p| Some(p.sigma_max_mm)),
        grid.threshold_mm,
    )
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
