//! The library entry of `crashrig grid`: a typed [`GridConfig`] → [`run_grid`] → a typed
//! [`GridRun`], with `grid.csv`, `grid_detail.csv`, the heat maps and `summary.json` written
//! as one unit. The maps are drawn by [`crate::summary::level_maps`], the code the study's
//! layouts draw with ([`GRID_STYLE`] vs [`crate::summary::LAYOUT_STYLE`] names what differs).
//!
//! # Example
//! ```no_run
//! use crashrig_grid::{GridConfig, run_grid};
//! let config = GridConfig {
//!     scenario: "fixtures/scenarios/three_cameras_z0.toml".into(),
//!     out: "grid_out".into(),
//!     samples: Some(2000),
//!     seed: Some(1),
//!     plots: true,
//! };
//! let run = run_grid(&config, None)?;
//! println!("{:.1} % below {} mm", 100.0 * run.summary.fraction_below_threshold, run.summary.threshold_mm);
//! # Ok::<(), crashrig_grid::Error>(())
//! ```

use crate::Error;
use crate::summary::{MapSpec, MapStyle};
use crashrig_mc::{Grid, GridResult, GridStudy, PointStats, RunOptions, Scenario};
use crashrig_stats::progress::{self, Reporter};
use crashrig_stats::summary::median;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What `crashrig grid` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct GridConfig {
    /// The scenario file (TOML).
    pub scenario: PathBuf,
    /// The output directory (absent, empty or a previous `grid` output; replaced whole).
    pub out: PathBuf,
    /// Draws per point (default: the scenario's `samples`).
    pub samples: Option<usize>,
    /// Seed (default: the scenario's).
    pub seed: Option<u64>,
    /// Draw the heat maps.
    pub plots: bool,
}

/// The result of [`run_grid`].
#[derive(Debug, Clone)]
pub struct GridRun {
    /// The grid that ran.
    pub grid: Grid,
    /// Per-point statistics (degenerate points blanked).
    pub result: GridResult,
    /// `summary.json`.
    pub summary: GridDocument,
    /// Files written (summary.json included).
    pub files: usize,
    /// Warnings for the user, one sentence each without the `warning:` prefix.
    pub warnings: Vec<String>,
}

/// The maps of `crashrig grid`.
pub(crate) const GRID_STYLE: MapStyle = MapStyle {
    x_label: "x [mm]",
    label_observer_z: true,
    footprints_include_observers: true,
    sketch: false,
};

/// Minimum, median and maximum of the finite values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spread {
    /// Minimum.
    pub min: f64,
    /// Median.
    pub median: f64,
    /// Maximum.
    pub max: f64,
}

/// `summary.json` → `linear`: the first-order counterpart.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearSummary {
    /// Fraction of points with linear σ_max below the threshold.
    pub fraction_below_threshold: f64,
    /// Largest linear σ_max (mm).
    pub max_sigma_mm: f64,
    /// Median linear σ_max (mm).
    pub median_sigma_max_mm: f64,
    /// Monte Carlo σ_max over linear σ_max.
    pub ratio_mc_over_linear_sigma_max: Spread,
}

/// `summary.json` → `adaptive`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AdaptiveSummary {
    /// δ in mm (`tolerance_mm`), or null with `ndig`.
    pub tolerance_mm: Option<f64>,
    /// Significant digits of σ that set δ (`ndig`), or null with `tolerance_mm`.
    pub ndig: Option<u32>,
    /// Draws per batch.
    pub batch: usize,
    /// Upper bound of draws per point.
    pub max_samples: usize,
    /// Fewest draws of a point.
    pub draws_min: u64,
    /// Most draws of a point.
    pub draws_max: u64,
    /// All draws.
    pub draws_total: u64,
    /// Points that stopped at `max_samples` without meeting the tolerance.
    pub unconverged_points: usize,
}

/// `summary.json` → `correlation`: the same grid with independent observers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CorrelationSummary {
    /// Fraction below the threshold with independent observers.
    pub independent_fraction_below_threshold: f64,
    /// Median σ_max with independent observers (mm).
    pub independent_median_sigma_max_mm: f64,
    /// Correlated minus independent σ_max (mm).
    pub change_sigma_max_mm: Spread,
    /// Correlated over independent σ_max.
    pub ratio_correlated_over_independent: Spread,
}

/// `summary.json` of `crashrig grid` (and its `--json` output); docs/SCENARIO.md.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GridDocument {
    /// Grid points.
    pub points: usize,
    /// Draws per point.
    pub samples_per_point: u64,
    /// Threshold on σ_max (mm).
    pub threshold_mm: f64,
    /// Fraction of points with σ_max below the threshold.
    pub fraction_below_threshold: f64,
    /// Largest σ_max (mm).
    pub max_sigma_mm: f64,
    /// Median σ_max (mm).
    pub median_sigma_max_mm: f64,
    /// Share of points whose worst-direction σ (√ of the largest eigenvalue of the point's
    /// covariance) is below the threshold ([`crate::summary::WorstDirection`], as the study's
    /// layouts).
    pub fraction_worst_below_threshold: f64,
    /// Median worst-direction σ (mm).
    pub median_sigma_worst_mm: f64,
    /// Largest worst-direction σ (mm).
    pub max_sigma_worst_mm: f64,
    /// Wall-clock time of the Monte Carlo (s).
    pub elapsed_s: f64,
    /// Draws per second.
    pub samples_per_second: f64,
    /// Fraction of points seen by at least two observers (1 when every observer is aimed).
    pub fraction_measurable: f64,
    /// Per observer: aim and fraction of the grid it sees (only with fixed observers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observer_coverage: Option<Vec<crashrig_mc::coverage::Coverage>>,
    /// Seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// `tangent` or `euler`.
    pub rotation_noise: &'static str,
    /// Observers.
    pub observers: usize,
    /// Pixel σ (px), if the scenario gives pixel noise.
    pub pixel_sigma_px: Option<f64>,
    /// Focal length (px) of the pixel noise.
    pub focal_px: Option<f64>,
    /// Whether the observers share chain draws.
    pub correlated: bool,
    /// All draws.
    pub total_draws: u64,
    /// First-order counterpart.
    pub linear: LinearSummary,
    /// Adaptive run numbers.
    pub adaptive: Option<AdaptiveSummary>,
    /// Correlated vs independent observers.
    pub correlation: Option<CorrelationSummary>,
    /// Points whose intersection angle is below `min_intersection_angle_deg`: no σ, left out
    /// of medians, maxima and colour scales, counted as not below the threshold.
    pub degenerate_points: usize,
    /// The degenerate limit (degrees).
    pub min_intersection_angle_deg: f64,
    /// Files written.
    pub files: Vec<String>,
}

/// Reads a scenario; every error names the file (TOML errors also the line).
///
/// # Errors
/// [`Error::Scenario`].
pub(crate) fn load_scenario(path: &Path) -> Result<Scenario, Error> {
    Scenario::from_path(path).map_err(|e| match e {
        crashrig_mc::Error::Io { .. }
        | crashrig_mc::Error::Toml { .. }
        | crashrig_mc::Error::Located { .. } => Error::ScenarioFile(e),
        other => Error::Scenario {
            path: path.to_path_buf(),
            source: other,
        },
    })
}

/// The `samples` to use: the option, else the scenario's; at least 2, at most
/// [`crashrig_mc::limits::MAX_SAMPLES`].
///
/// # Errors
/// [`Error::Setting`] naming `--samples`.
pub fn resolve_samples(option: Option<usize>, scenario: &Scenario) -> Result<usize, Error> {
    let n = option.unwrap_or(scenario.samples);
    let bad = |problem| {
        Err(Error::Setting {
            name: "--samples",
            problem,
        })
    };
    if n < 2 {
        return bad(format!("must be at least 2, got {n}"));
    }
    let max = crashrig_mc::limits::MAX_SAMPLES;
    if n > max {
        return bad(format!("{n} exceeds the limit of {max} (docs/LIMITS.md)"));
    }
    Ok(n)
}

/// Whether a top-level entry of an existing output directory is something `grid` writes (so
/// an old result may be replaced as a whole): its CSV, JSON and heat-map files, and the `.tmp*`
/// files an interrupted older version could leave.
pub(crate) fn replaceable(name: &str) -> bool {
    [".csv", ".json", ".png", ".svg", ".ply"]
        .iter()
        .any(|ext| name.ends_with(ext))
        || name.starts_with(".tmp")
}

/// The files written so far (names, in order) and the staging directory they go to; the whole
/// directory replaces the output at the end, so a failed or interrupted run leaves the old
/// result.
pub(crate) struct Pending {
    staged: crashrig_outdir::Staged,
    names: Vec<String>,
}

impl Pending {
    /// Starts writing `out`; fails before any work when it holds files `replaceable` rejects.
    pub(crate) fn new(out: &Path, replaceable: impl Fn(&str) -> bool) -> Result<Self, Error> {
        Ok(Pending {
            staged: crashrig_outdir::Staged::new(out, replaceable)?,
            names: Vec::new(),
        })
    }

    pub(crate) fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), Error> {
        self.staged.write(name, bytes)?;
        self.names.push(name.to_string());
        Ok(())
    }

    /// Swaps the directory in; returns the number of files written.
    pub(crate) fn commit(self) -> Result<usize, Error> {
        let n = self.names.len();
        self.staged.commit()?;
        Ok(n)
    }
}

/// A grid run set up and checked, before any draw: the scenario, the resolved samples and
/// seed, and the prepared study.
pub(crate) struct Prepared {
    pub(crate) scenario: Scenario,
    pub(crate) samples: usize,
    pub(crate) seed: u64,
    pub(crate) study: GridStudy,
}

/// Reads and checks `scenario` with the `samples` / `seed` options (as `crashrig grid`).
pub(crate) fn prepare(
    path: &Path,
    samples: Option<usize>,
    seed: Option<u64>,
) -> Result<Prepared, Error> {
    prepare_scenario(load_scenario(path)?, path, samples, seed)
}

/// [`prepare`] on a scenario already read; `path` names it in messages.
pub(crate) fn prepare_scenario(
    scenario: Scenario,
    path: &Path,
    samples: Option<usize>,
    seed: Option<u64>,
) -> Result<Prepared, Error> {
    let samples = resolve_samples(samples, &scenario)?;
    let seed = seed.unwrap_or(scenario.seed);
    let study = GridStudy::new(&scenario, samples, seed).map_err(|e| locate(e, path))?;
    let grid = study.grid();
    if grid.adaptive.is_none() {
        // --samples may exceed what the scenario's own bound check saw.
        crashrig_mc::limits::check_grid_draws(grid.points().len(), samples).map_err(|e| {
            Error::Setting {
                name: "--samples",
                problem: format!("{samples}: {e}"),
            }
        })?;
    }
    Ok(Prepared {
        scenario,
        samples,
        seed,
        study,
    })
}

fn locate(e: crashrig_mc::Error, path: &Path) -> Error {
    Error::ScenarioFile(crashrig_mc::limits::locate(e, path))
}

/// The Monte Carlo statistics of a grid run before they are reported: the points of `study`
/// (all, or a shard's), and in correlated mode the same points with independent observers;
/// degenerate points not yet blanked.
#[derive(Debug, Clone)]
pub(crate) struct Computed {
    pub(crate) result: GridResult,
    pub(crate) independent: Option<GridResult>,
    /// Wall-clock seconds of the main run.
    pub(crate) elapsed_s: f64,
    /// Worker threads of the run.
    pub(crate) threads: usize,
}

/// Runs the draws of `study` (its selected points).
pub(crate) fn compute(
    p: &Prepared,
    study: &GridStudy,
    path: &Path,
    progress: Option<&dyn Reporter>,
) -> Result<Computed, Error> {
    let options = match study.grid().adaptive {
        Some(ad) => RunOptions::adaptive(ad, p.seed),
        None => RunOptions::samples(p.samples, p.seed),
    };
    let start = std::time::Instant::now();
    let run = |s: &GridStudy, stage: &str| {
        let stage = progress.map(|r| progress::Stage::new(r, stage));
        s.run(
            &options,
            stage.as_ref().map(|s| s as &dyn progress::Monitor),
        )
        .map_err(|e| locate(e, path))
    };
    let result = run(study, "grid points")?;
    let elapsed_s = start.elapsed().as_secs_f64();
    let independent = if result.correlated {
        Some(run(
            &study.independent(),
            "grid points, independent observers",
        )?)
    } else {
        None
    };
    Ok(Computed {
        result,
        independent,
        elapsed_s,
        threads: rayon::current_num_threads(),
    })
}

/// Runs the grid study of `config.scenario` and writes its output directory; `progress`
/// watches the Monte Carlo stages.
///
/// # Errors
/// [`Error::Scenario`] (the file, with the line where known), [`Error::Setting`],
/// [`Error::OutDir`] (checked before any work), [`Error::Grid`] for a non-finite σ, and
/// [`Error::Plot`].
pub fn run_grid(config: &GridConfig, progress: Option<&dyn Reporter>) -> Result<GridRun, Error> {
    let p = prepare(&config.scenario, config.samples, config.seed)?;
    run_prepared(&p, config, progress)
}

/// [`run_grid`] on a scenario already read (or built, e.g. by `crashrig place` from a
/// scenario and its chosen candidates); `config.scenario` names the file in messages.
///
/// # Errors
/// As [`run_grid`].
pub fn run_grid_scenario(
    scenario: &Scenario,
    config: &GridConfig,
    progress: Option<&dyn Reporter>,
) -> Result<GridRun, Error> {
    let p = prepare_scenario(
        scenario.clone(),
        &config.scenario,
        config.samples,
        config.seed,
    )?;
    run_prepared(&p, config, progress)
}

fn run_prepared(
    p: &Prepared,
    config: &GridConfig,
    progress: Option<&dyn Reporter>,
) -> Result<GridRun, Error> {
    // Fails before any work when the output holds files `grid` does not write.
    let files = Pending::new(&config.out, replaceable)?;
    let computed = compute(p, &p.study, &config.scenario, progress)?;
    finish(p, computed, &config.scenario, config.plots, files)
}

/// Reports a whole grid's statistics: blanks degenerate points, writes `grid.csv`,
/// `grid_detail.csv`, the heat maps and `summary.json` to `files` and commits them — the one
/// path of `crashrig grid` and of `crashrig merge` (which passes the shards' rows).
pub(crate) fn finish(
    p: &Prepared,
    computed: Computed,
    path: &Path,
    plots: bool,
    mut files: Pending,
) -> Result<GridRun, Error> {
    let (scenario, samples, seed) = (&p.scenario, p.samples, p.seed);
    let grid = p.study.grid().clone();
    let Computed {
        mut result,
        independent,
        elapsed_s,
        threads,
    } = computed;
    // Degenerate points (lines of sight nearly parallel): no σ, not in medians or colours.
    let angles = mask_degenerate(&mut result, &grid, path)?;
    let correlation = match independent {
        Some(mut ind) => {
            mask_degenerate(&mut ind, &grid, path)?;
            Some(correlation_summary(&result, &ind, grid.threshold_mm))
        }
        None => None,
    };
    // The scenario's plausibility warnings (units never guessed) first.
    let mut warnings = scenario.warnings.clone();
    if result.points.iter().all(|p| !p.is_measurable()) {
        warnings.push(format!(
            "{}: no grid point is seen by two or more observers; every point is not measurable",
            path.display()
        ));
    }
    let with_fixed = crashrig_mc::coverage::has_fixed(&grid);
    files.write("grid.csv", &main_csv(&result, &angles, with_fixed)?)?;
    files.write("grid_detail.csv", &detail_csv(&result, &angles)?)?;
    files.write("grid.ply", &crate::summary::grid_ply(&result))?;
    if plots {
        for h in crate::summary::level_maps(&grid, &result, &grid_specs(&grid), &GRID_STYLE)? {
            files.write(&h.file, &h.png)?;
            files.write(&h.file.replace(".png", ".svg"), &h.svg)?;
        }
    }
    let unconverged = result
        .points
        .iter()
        .filter(|p| p.converged == Some(false))
        .count();
    if unconverged > 0 {
        warnings.push(format!(
            "{}: {unconverged} of {} grid points stopped at max_samples without meeting the adaptive tolerance (grid.csv column `converged`)",
            path.display(),
            result.points.len()
        ));
    }
    let mut summary = document(scenario, &grid, &result, &angles, samples, seed, elapsed_s);
    summary.correlation = correlation;
    summary.threads = threads;
    summary.files = files
        .names
        .iter()
        .cloned()
        .chain(std::iter::once("summary.json".to_string()))
        .collect();
    let json = serde_json::to_vec_pretty(&summary).map_err(|e| Error::Grid {
        path: path.to_path_buf(),
        problem: format!("formatting summary.json: {e}"),
    })?;
    files.write("summary.json", &json)?;
    let n = files.commit()?;
    Ok(GridRun {
        grid,
        result,
        summary,
        files: n,
        warnings,
    })
}

/// The maps of `crashrig grid`: Monte Carlo and first-order σ_max on one saturated scale
/// (0 to 3× the threshold, so the region below the threshold stays readable next to the
/// degenerate zones) and their ratio on the data range.
fn grid_specs(grid: &Grid) -> [MapSpec; 3] {
    let top = 3.0 * grid.threshold_mm;
    let sat = Some((0.0, top));
    [
        MapSpec {
            stem: "sigma_max",
            title: "Monte Carlo sigma_max".into(),
            bar: format!("sigma_max [mm] (>= {top} saturated)"),
            threshold: Some(grid.threshold_mm),
            range: sat,
            value: |p| p.sigma_max_mm,
        },
        MapSpec {
            stem: "linear_sigma_max",
            title: "First-order sigma_max".into(),
            bar: format!("linear sigma_max [mm] (>= {top} saturated)"),
            threshold: Some(grid.threshold_mm),
            range: sat,
            value: |p| p.linear_sigma_max_mm(),
        },
        MapSpec {
            stem: "ratio_mc_linear",
            title: "sigma_max Monte Carlo / first order".into(),
            bar: "ratio [-]".into(),
            threshold: None,
            range: None,
            value: |p| p.sigma_max_mm / p.linear_sigma_max_mm(),
        },
    ]
}

fn correlation_summary(
    result: &GridResult,
    ind: &GridResult,
    threshold_mm: f64,
) -> CorrelationSummary {
    let pairs = || result.points.iter().zip(&ind.points);
    let change: Vec<f64> = pairs()
        .map(|(c, i)| c.sigma_max_mm - i.sigma_max_mm)
        .collect();
    let ratio: Vec<f64> = pairs()
        .map(|(c, i)| c.sigma_max_mm / i.sigma_max_mm)
        .collect();
    let ism: Vec<f64> = ind.points.iter().map(|p| p.sigma_max_mm).collect();
    CorrelationSummary {
        independent_fraction_below_threshold: ind.fraction_below(threshold_mm),
        independent_median_sigma_max_mm: median(&ism).unwrap_or(f64::NAN),
        change_sigma_max_mm: spread(&change),
        ratio_correlated_over_independent: spread(&ratio),
    }
}

/// `summary.json` without `correlation` and `files`.
fn document(
    scenario: &Scenario,
    grid: &Grid,
    result: &GridResult,
    angles: &[f64],
    samples: usize,
    seed: u64,
    elapsed_s: f64,
) -> GridDocument {
    let sm: Vec<f64> = result.points.iter().map(|p| p.sigma_max_mm).collect();
    let lsm: Vec<f64> = result
        .points
        .iter()
        .map(|p| p.linear_sigma_max_mm())
        .collect();
    let ratio: Vec<f64> = sm.iter().zip(&lsm).map(|(m, l)| m / l).collect();
    let counts: Vec<u64> = result.points.iter().map(|p| p.count).collect();
    let total_draws: u64 = counts.iter().sum();
    let unconverged = result
        .points
        .iter()
        .filter(|p| p.converged == Some(false))
        .count();
    let with_fixed = crashrig_mc::coverage::has_fixed(grid);
    let worst = crate::summary::WorstDirection::new(result, grid.threshold_mm);
    GridDocument {
        points: result.points.len(),
        // Not-measurable points draw nothing; the draws per point are those asked for.
        samples_per_point: match grid.adaptive {
            None => samples as u64,
            Some(_) => counts.iter().copied().max().unwrap_or(0),
        },
        threshold_mm: grid.threshold_mm,
        fraction_below_threshold: result.fraction_below(grid.threshold_mm),
        max_sigma_mm: sm.iter().copied().fold(f64::NAN, f64::max),
        median_sigma_max_mm: median(&sm).unwrap_or(f64::NAN),
        fraction_worst_below_threshold: worst.fraction_below_threshold,
        median_sigma_worst_mm: worst.median_mm,
        max_sigma_worst_mm: worst.max_mm,
        elapsed_s,
        samples_per_second: total_draws as f64 / elapsed_s,
        fraction_measurable: result.fraction_measurable(),
        observer_coverage: with_fixed.then(|| crashrig_mc::coverage::coverage(grid, result)),
        seed,
        threads: rayon::current_num_threads(),
        rotation_noise: match scenario.rotation_noise {
            crashrig_mc::RotationNoise::Tangent => "tangent",
            crashrig_mc::RotationNoise::Euler => "euler",
        },
        observers: grid.observers.len(),
        pixel_sigma_px: grid.pixel.map(|p| p.sigma_px),
        focal_px: grid.pixel.map(|p| p.focal_px),
        correlated: result.correlated,
        total_draws,
        linear: LinearSummary {
            fraction_below_threshold: lsm.iter().filter(|s| **s < grid.threshold_mm).count() as f64
                / lsm.len().max(1) as f64,
            max_sigma_mm: lsm.iter().copied().fold(f64::NAN, f64::max),
            median_sigma_max_mm: median(&lsm).unwrap_or(f64::NAN),
            ratio_mc_over_linear_sigma_max: spread(&ratio),
        },
        adaptive: grid.adaptive.map(|ad| AdaptiveSummary {
            tolerance_mm: match ad.tolerance {
                crashrig_mc::Tolerance::AbsoluteMm(t) => Some(t),
                crashrig_mc::Tolerance::SignificantDigits(_) => None,
            },
            ndig: match ad.tolerance {
                crashrig_mc::Tolerance::AbsoluteMm(_) => None,
                crashrig_mc::Tolerance::SignificantDigits(n) => Some(n),
            },
            batch: ad.batch,
            max_samples: ad.max_samples,
            draws_min: counts.iter().copied().min().unwrap_or(0),
            draws_max: counts.iter().copied().max().unwrap_or(0),
            draws_total: total_draws,
            unconverged_points: unconverged,
        }),
        correlation: None,
        degenerate_points: result
            .points
            .iter()
            .zip(angles)
            .filter(|(p, a)| crashrig_mc::degenerate::is_degenerate_point(p, **a))
            .count(),
        min_intersection_angle_deg: crashrig_mc::degenerate::MIN_INTERSECTION_ANGLE_DEG,
        files: Vec::new(),
    }
}

fn spread(v: &[f64]) -> Spread {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    Spread {
        min: finite.iter().copied().fold(f64::INFINITY, f64::min),
        median: median(&finite).unwrap_or(f64::NAN),
        max: finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

/// Blanks (NaN) the statistics of degenerate points and returns every point's intersection
/// angle; a non-finite σ at any other measurable point is an error naming the scenario and
/// the point.
fn mask_degenerate(r: &mut GridResult, grid: &Grid, scenario: &Path) -> Result<Vec<f64>, Error> {
    let angles = crashrig_mc::degenerate::mask_degenerate(r, grid);
    for (p, &angle) in r.points.iter().zip(&angles) {
        if p.is_measurable()
            && !crashrig_mc::degenerate::is_degenerate(angle)
            && !(p.sigma_max_mm.is_finite() && p.linear_sigma_max_mm().is_finite())
        {
            return Err(Error::Grid {
                path: scenario.to_path_buf(),
                problem: format!(
                    "grid point ({}, {}, {}) mm: the intersection σ is not finite (intersection angle {:.3}°); check the observers' σ and positions",
                    p.point.x, p.point.y, p.point.z, angle
                ),
            });
        }
    }
    Ok(angles)
}

/// A CSV document written by `rows` (errors: [`Error::Csv`] of the grid CSV).
pub(crate) fn csv_bytes(
    rows: impl Fn(&mut csv::Writer<&mut Vec<u8>>) -> csv::Result<()>,
) -> Result<Vec<u8>, Error> {
    let mut buf = Vec::new();
    {
        let mut w = csv::Writer::from_writer(&mut buf);
        rows(&mut w).map_err(csv_error)?;
        w.flush().map_err(|e| csv_error(e.into()))?;
    }
    Ok(buf)
}

/// A CSV cell: empty for a blanked (NaN: degenerate) value or a not-measurable point (fewer
/// than two observers see it).
fn cell(p: &PointStats, v: f64) -> String {
    if v.is_nan() || !p.is_measurable() {
        String::new()
    } else {
        v.to_string()
    }
}

/// The values of one `grid.csv` column, typed.
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnValues {
    /// Numbers; with `blank_nan` a NaN is an empty cell (a blanked or not-measurable σ),
    /// otherwise it is written as `NaN`.
    Float {
        /// One value per point.
        values: Vec<f64>,
        /// NaN is an empty cell.
        blank_nan: bool,
    },
    /// Counts.
    Count(Vec<u64>),
    /// Flags.
    Flag(Vec<bool>),
    /// Flags that may be absent (an empty cell).
    MaybeFlag(Vec<Option<bool>>),
}

/// One column of `grid.csv`: its header name and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Header name.
    pub name: &'static str,
    /// One value per grid point.
    pub values: ColumnValues,
}

impl Column {
    fn cell(&self, i: usize) -> String {
        match &self.values {
            ColumnValues::Float { values, blank_nan } if *blank_nan && values[i].is_nan() => {
                String::new()
            }
            ColumnValues::Float { values, .. } => values[i].to_string(),
            ColumnValues::Count(v) => v[i].to_string(),
            ColumnValues::Flag(v) => v[i].to_string(),
            ColumnValues::MaybeFlag(v) => v[i].map_or_else(String::new, |c| c.to_string()),
        }
    }
}

impl GridRun {
    /// The columns of `grid.csv`, typed (the CSV is written from them; the Python module's
    /// `grid` returns them as NumPy arrays).
    pub fn columns(&self) -> Vec<Column> {
        let angles = crashrig_mc::degenerate::grid_angles_deg(&self.grid);
        grid_columns(
            &self.result,
            &angles,
            crashrig_mc::coverage::has_fixed(&self.grid),
        )
    }
}

/// `grid.csv`'s columns: the contract's seven; when any point is degenerate, the columns
/// `intersection_angle_deg` and `degenerate` follow (the plain header stays exactly the
/// contract's for layouts without degenerate points); with fixed observers the column
/// `observers_seen` is appended and the σ cells of not-measurable points are empty; adaptive
/// runs add `draws` and `converged`.
pub(crate) fn grid_columns(r: &GridResult, angles: &[f64], with_seen: bool) -> Vec<Column> {
    let degenerate = crashrig_mc::degenerate::is_degenerate_point;
    let flagged = r.points.iter().zip(angles).any(|(p, a)| degenerate(p, *a));
    let float = |name, value: &dyn Fn(&PointStats) -> f64, blank_nan| Column {
        name,
        values: ColumnValues::Float {
            values: r.points.iter().map(value).collect(),
            blank_nan,
        },
    };
    // σ cells are empty for a blanked (NaN: degenerate) value or a not-measurable point.
    let sigma = |name, value: fn(&PointStats) -> f64| {
        float(
            name,
            &|p: &PointStats| {
                if p.is_measurable() {
                    value(p)
                } else {
                    f64::NAN
                }
            },
            true,
        )
    };
    let mut columns = vec![
        float("x_mm", &|p: &PointStats| p.point.x, false),
        float("y_mm", &|p: &PointStats| p.point.y, false),
        float("z_mm", &|p: &PointStats| p.point.z, false),
        sigma("sigma_x_mm", |p| p.sigma_mm.x),
        sigma("sigma_y_mm", |p| p.sigma_mm.y),
        sigma("sigma_z_mm", |p| p.sigma_mm.z),
        sigma("sigma_max_mm", |p| p.sigma_max_mm),
    ];
    if flagged {
        columns.push(Column {
            name: "intersection_angle_deg",
            values: ColumnValues::Float {
                values: angles.to_vec(),
                blank_nan: false,
            },
        });
        columns.push(Column {
            name: "degenerate",
            values: ColumnValues::Flag(
                r.points
                    .iter()
                    .zip(angles)
                    .map(|(p, a)| degenerate(p, *a))
                    .collect(),
            ),
        });
    }
    if with_seen {
        columns.push(Column {
            name: "observers_seen",
            values: ColumnValues::Count(r.points.iter().map(|p| p.observers_seen as u64).collect()),
        });
    }
    // Adaptive runs: the draws each point took and whether it met the tolerance.
    if r.points.iter().any(|p| p.converged.is_some()) {
        columns.push(Column {
            name: "draws",
            values: ColumnValues::Count(r.points.iter().map(|p| p.count).collect()),
        });
        columns.push(Column {
            name: "converged",
            values: ColumnValues::MaybeFlag(r.points.iter().map(|p| p.converged).collect()),
        });
    }
    columns
}

/// `grid.csv`, written from [`grid_columns`].
fn main_csv(r: &GridResult, angles: &[f64], with_seen: bool) -> Result<Vec<u8>, Error> {
    let columns = grid_columns(r, angles, with_seen);
    csv_bytes(|w| {
        w.write_record(columns.iter().map(|c| c.name))?;
        for i in 0..r.points.len() {
            w.write_record(columns.iter().map(|c| c.cell(i)))?;
        }
        Ok(())
    })
}

/// `grid_detail.csv`: per point the draws, mean, covariance, ellipsoid, first-order σ, the
/// intersection angle and, last, the worst-direction σ `sigma_worst_mm` (empty where σ_max is).
fn detail_csv(r: &GridResult, angles: &[f64]) -> Result<Vec<u8>, Error> {
    csv_bytes(|w| {
        w.write_record([
            "x_mm",
            "y_mm",
            "z_mm",
            "draws",
            "mean_x_mm",
            "mean_y_mm",
            "mean_z_mm",
            "cov_xx_mm2",
            "cov_xy_mm2",
            "cov_xz_mm2",
            "cov_yy_mm2",
            "cov_yz_mm2",
            "cov_zz_mm2",
            "ellipsoid_a_mm",
            "ellipsoid_b_mm",
            "ellipsoid_c_mm",
            "linear_sigma_x_mm",
            "linear_sigma_y_mm",
            "linear_sigma_z_mm",
            "linear_sigma_max_mm",
            "ratio_mc_over_linear",
            "intersection_angle_deg",
            "sigma_worst_mm",
        ])?;
        for (p, angle) in r.points.iter().zip(angles) {
            let c = p.covariance;
            let e = p.ellipsoid_semi_axes_mm();
            let l = p.linear_sigma_mm();
            let mut rec: Vec<String> = [p.point.x, p.point.y, p.point.z]
                .iter()
                .map(|v| v.to_string())
                .collect();
            rec.push(p.count.to_string());
            rec.extend(
                [
                    p.mean_mm.x,
                    p.mean_mm.y,
                    p.mean_mm.z,
                    c[(0, 0)],
                    c[(0, 1)],
                    c[(0, 2)],
                    c[(1, 1)],
                    c[(1, 2)],
                    c[(2, 2)],
                    e.x,
                    e.y,
                    e.z,
                    l.x,
                    l.y,
                    l.z,
                    p.linear_sigma_max_mm(),
                    p.sigma_max_mm / p.linear_sigma_max_mm(),
                ]
                .map(|v| cell(p, v)),
            );
            rec.push(angle.to_string());
            rec.push(cell(p, p.sigma_worst_mm()));
            w.write_record(&rec)?;
        }
        Ok(())
    })
}

fn csv_error(e: csv::Error) -> Error {
    Error::Csv {
        what: "grid CSV",
        source: e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `grid_detail.csv`'s last column is the worst-direction σ: √7 and 2√7 mm for the known
    /// covariances of [`crate::summary::tests::known_grid`], empty for the point not measurable.
    #[test]
    fn detail_csv_sigma_worst_known_answer() {
        let r = crate::summary::tests::known_grid();
        let csv = String::from_utf8(detail_csv(&r, &[90.0; 3]).unwrap()).unwrap();
        let mut lines = csv.lines();
        assert!(
            lines
                .next()
                .unwrap()
                .ends_with(",intersection_angle_deg,sigma_worst_mm")
        );
        let last: Vec<&str> = lines.map(|l| l.rsplit(',').next().unwrap()).collect();
        let s7 = 7f64.sqrt();
        assert!(
            (last[0].parse::<f64>().unwrap() - s7).abs() < 1e-12,
            "{csv}"
        );
        assert!(
            (last[1].parse::<f64>().unwrap() - 2.0 * s7).abs() < 1e-12,
            "{csv}"
        );
        assert_eq!(last[2], "");
    }
}
