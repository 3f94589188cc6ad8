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

pub use error::Error;

use crashrig_mc::{GridStudy, Observer, Scenario};
use crashrig_stats::progress::{self, Reporter};
use crashrig_study::{GridConfig, GridRun};
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

/// Runs the placement search of `config` and writes `OUT/placement.json` and `OUT/grid/` as one
/// unit (nothing is written on an error); `progress` watches the stages.
///
/// # Errors
/// [`Error::Input`] (the scenario or candidates file, with the line), [`Error::Setting`]
/// (`--choose`, `--samples`), [`Error::OutDir`] — all before any work — and [`Error::Grid`].
pub fn run(config: &PlaceConfig, progress: Option<&dyn Reporter>) -> Result<PlaceRun, Error> {
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
    let samples = crashrig_study::grid_run::resolve_samples(config.samples, &scenario)?;
    let seed = config.seed.unwrap_or(scenario.seed);
    let points = grid.points().len();
    if grid.adaptive.is_none() {
        crashrig_mc::limits::check_grid_draws(points, samples).map_err(|e| Error::Setting {
            name: "--samples",
            problem: format!("{samples}: {e}"),
        })?;
    }
    if points.saturating_mul(n) > MAX_TERMS {
        return Err(Error::Setting {
            name: "--candidates",
            problem: format!(
                "{points} grid points × {n} candidates exceed the limit of {MAX_TERMS} (docs/PLACE.md)"
            ),
        });
    }
    // Fails before any work when OUT holds files `place` does not write.
    let mut staged = crashrig_outdir::Staged::new(&config.out, replaceable)?;

    // 1. The approximation's table over every candidate.
    let all = with_observers(&scenario, grid.observers.iter().chain(&candidates).cloned());
    let study =
        GridStudy::new(&all, samples, seed).map_err(|e| Error::input(&config.candidates, e))?;
    let hook = progress.map(|r| progress::stage(r, "first-order terms"));
    let hook = hook.as_ref().map(|h| h as &(dyn Fn(usize, usize) + Sync));
    let table = approx::Table::build(&study, base, hook)
        .map_err(|e| Error::input(&config.candidates, e))?;
    drop(study);

    // 2. The search.
    let found = search::search(&table, k, MAX_CONFIRMED);
    let best_share = found.board.entries.first().map_or(0.0, |(s, _)| s.share());
    let shortlist: Vec<_> = found
        .board
        .entries
        .iter()
        .filter(|(s, _)| s.share() >= best_share - CONFIRM_MARGIN)
        .collect();

    // 3. Confirmation by the Monte Carlo.
    let mut confirmed = Vec::with_capacity(shortlist.len());
    let mut layouts = Vec::with_capacity(shortlist.len());
    for (i, (approx_score, set)) in shortlist.iter().enumerate() {
        let order = search::order_within(&table, set, set.len());
        let layout = with_observers(
            &scenario,
            grid.observers
                .iter()
                .cloned()
                .chain(order.iter().map(|&c| candidates[c].clone())),
        );
        let stage = format!("confirming layout {} of {}", i + 1, shortlist.len());
        let score = monte_carlo_score(&layout, samples, seed, progress, &stage)
            .map_err(|e| Error::input(&config.candidates, e))?;
        confirmed.push(Confirmed {
            chosen: order.iter().map(|&c| candidates[c].name.clone()).collect(),
            share_below_threshold: score.share(),
            mean_sigma_max_mm: score.mean_sigma_max_mm(),
            approximate_share_below_threshold: approx_score.share(),
            approximate_mean_sigma_max_mm: approx_score.mean_sigma_max_mm(),
        });
        layouts.push((score, layout));
    }
    // The best confirmed objective; ties keep the approximation's order.
    let mut winner = 0;
    for (i, (s, _)) in layouts.iter().enumerate() {
        if s.compare(&layouts[winner].0) == std::cmp::Ordering::Greater {
            winner = i;
        }
    }
    let grid_config = GridConfig {
        scenario: config.scenario.clone(),
        out: staged.dir().join("grid"),
        samples: Some(samples),
        seed: Some(seed),
        plots: config.plots,
    };
    let grid_run = crashrig_study::run_grid_scenario(&layouts[winner].1, &grid_config, progress)?;
    let w = &confirmed[winner];
    let placement = Placement {
        chosen: w.chosen.clone(),
        share_below_threshold: w.share_below_threshold,
        mean_sigma_max_mm: w.mean_sigma_max_mm,
        method: found.method,
        evaluated: found.evaluated,
        samples,
        seed,
        choose: k,
        candidates: n,
        threshold_mm: grid.threshold_mm,
        points,
        confirmed,
    };
    let json = serde_json::to_vec_pretty(&placement).map_err(|e| Error::Output {
        out: config.out.clone(),
        problem: e.to_string(),
    })?;
    staged.write("placement.json", &json)?;
    staged.commit()?;
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
/// As [`GridStudy::new`] and [`GridStudy::evaluate`].
pub fn monte_carlo_score(
    layout: &Scenario,
    samples: usize,
    seed: u64,
    progress: Option<&dyn Reporter>,
    stage: &str,
) -> Result<approx::Score, crashrig_mc::Error> {
    let study = GridStudy::new(layout, samples, seed)?;
    let hook = progress.map(|r| progress::stage(r, stage));
    let hook = hook.as_ref().map(|h| h as &(dyn Fn(usize, usize) + Sync));
    let mut result = study.evaluate_with_progress(hook)?;
    crashrig_mc::degenerate::mask_degenerate(&mut result, study.grid());
    Ok(approx::Score::of(
        result.points.iter().map(|p| Some(p.sigma_max_mm)),
        study.grid().threshold_mm,
    ))
}
