//! `crashrig grid`: forward-intersection precision over a grid.

use super::propagate::{load_scenario, resolve_samples};
use crate::Global;
use anyhow::Context;
use crashrig_mc::{GridResult, GridStudy, PointStats};
use crashrig_plot::{Format, HeatMap, Marker};
use serde::Serialize;
use std::path::{Path, PathBuf};

mod fixed;

/// Arguments of `crashrig grid`.
#[derive(Debug, clap::Args)]
pub struct GridArgs {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Output directory: grid.csv, summary.json, heat maps.
    #[arg(long)]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Skip the heat maps (PNG/SVG), e.g. for timing the engine alone.
    #[arg(long)]
    pub no_plots: bool,
}

#[derive(Serialize)]
struct Spread {
    min: f64,
    median: f64,
    max: f64,
}

#[derive(Serialize)]
struct LinearSummary {
    fraction_below_threshold: f64,
    max_sigma_mm: f64,
    median_sigma_max_mm: f64,
    ratio_mc_over_linear_sigma_max: Spread,
}

#[derive(Serialize)]
struct AdaptiveSummary {
    /// δ in mm (`tolerance_mm`), or null with `ndig`.
    tolerance_mm: Option<f64>,
    /// Significant digits of σ that set δ (`ndig`), or null with `tolerance_mm`.
    ndig: Option<u32>,
    batch: usize,
    max_samples: usize,
    draws_min: u64,
    draws_max: u64,
    draws_total: u64,
    /// Points that stopped at `max_samples` without meeting the tolerance.
    unconverged_points: usize,
}

#[derive(Serialize)]
struct CorrelationSummary {
    independent_fraction_below_threshold: f64,
    independent_median_sigma_max_mm: f64,
    change_sigma_max_mm: Spread,
    ratio_correlated_over_independent: Spread,
}

#[derive(Serialize)]
struct Summary {
    points: usize,
    samples_per_point: u64,
    threshold_mm: f64,
    fraction_below_threshold: f64,
    max_sigma_mm: f64,
    median_sigma_max_mm: f64,
    elapsed_s: f64,
    samples_per_second: f64,
    // Extensions (documented in docs/table3.md, fixed cameras in docs/FIXED_CAMERAS.md).
    /// Fraction of points seen by at least two observers (1 when every observer is aimed).
    fraction_measurable: f64,
    /// Per observer: aim and fraction of the grid it sees (only with fixed observers).
    #[serde(skip_serializing_if = "Option::is_none")]
    observer_coverage: Option<Vec<fixed::Coverage>>,
    seed: u64,
    threads: usize,
    rotation_noise: &'static str,
    observers: usize,
    pixel_sigma_px: Option<f64>,
    focal_px: Option<f64>,
    correlated: bool,
    total_draws: u64,
    linear: LinearSummary,
    adaptive: Option<AdaptiveSummary>,
    correlation: Option<CorrelationSummary>,
    /// Points whose intersection angle is below `min_intersection_angle_deg`: no σ, left out
    /// of medians, maxima and colour scales, counted as not below the threshold.
    degenerate_points: usize,
    min_intersection_angle_deg: f64,
    files: Vec<String>,
}

/// Median of the finite values (degenerate points are NaN and left out).
fn median(v: &[f64]) -> f64 {
    // Degenerate and not-measurable points (NaN σ) are left out.
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    crashrig_stats::summary::quantile(&finite, 0.5).unwrap_or(f64::NAN)
}

fn spread(v: &[f64]) -> Spread {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    Spread {
        min: finite.iter().copied().fold(f64::INFINITY, f64::min),
        median: median(&finite),
        max: finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

/// Whether a top-level entry of an existing `--out` is something `grid` writes (so an old
/// result may be replaced as a whole): its CSV, JSON and heat-map files, and the `.tmp*` files
/// an interrupted older version could leave.
pub(crate) fn replaceable(name: &str) -> bool {
    [".csv", ".json", ".png", ".svg"]
        .iter()
        .any(|ext| name.ends_with(ext))
        || name.starts_with(".tmp")
}

/// The files written so far (names, in order) and the staging directory they go to; the whole
/// directory replaces `--out` at the end, so a failed or interrupted run leaves the old result.
struct Pending {
    staged: crashrig_outdir::Staged,
    names: Vec<String>,
}

impl Pending {
    fn len(&self) -> usize {
        self.names.len()
    }
}

fn write(_dir: &Path, name: &str, bytes: &[u8], files: &mut Pending) -> anyhow::Result<()> {
    files.staged.write(name, bytes)?;
    files.names.push(name.to_string());
    Ok(())
}

fn csv_bytes(
    rows: impl Fn(&mut csv::Writer<&mut Vec<u8>>) -> csv::Result<()>,
) -> anyhow::Result<Vec<u8>> {
    let mut buf = Vec::new();
    {
        let mut w = csv::Writer::from_writer(&mut buf);
        rows(&mut w).context("formatting CSV")?;
        w.flush().context("formatting CSV")?;
    }
    Ok(buf)
}

/// Blanks (NaN) the statistics of degenerate points and returns every point's intersection
/// angle; a non-finite σ at any other measurable point is an error naming the scenario and
/// the point.
fn mask_degenerate(
    r: &mut GridResult,
    grid: &crashrig_mc::Grid,
    scenario: &Path,
) -> anyhow::Result<Vec<f64>> {
    let angles = crashrig_mc::degenerate::mask_degenerate(r, grid);
    for (p, &angle) in r.points.iter().zip(&angles) {
        if p.is_measurable()
            && !crashrig_mc::degenerate::is_degenerate(angle)
            && !(p.sigma_max_mm.is_finite() && p.linear_sigma_max_mm().is_finite())
        {
            anyhow::bail!(
                "{}: grid point ({}, {}, {}) mm: the intersection σ is not finite (intersection angle {:.3}°); check the observers' σ and positions",
                scenario.display(),
                p.point.x,
                p.point.y,
                p.point.z,
                angle
            );
        }
    }
    Ok(angles)
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

/// `grid.csv`: the contract's seven columns; when any point is degenerate, the columns
/// `intersection_angle_deg` and `degenerate` follow (the plain header stays exactly the
/// contract's for layouts without degenerate points); with fixed observers the column
/// `observers_seen` is appended and the σ cells of not-measurable points are empty.
fn main_csv(r: &GridResult, angles: &[f64], with_seen: bool) -> anyhow::Result<Vec<u8>> {
    let degenerate = crashrig_mc::degenerate::is_degenerate_point;
    let flagged = r.points.iter().zip(angles).any(|(p, a)| degenerate(p, *a));
    csv_bytes(|w| {
        let mut header = vec![
            "x_mm",
            "y_mm",
            "z_mm",
            "sigma_x_mm",
            "sigma_y_mm",
            "sigma_z_mm",
            "sigma_max_mm",
        ];
        if flagged {
            header.extend(["intersection_angle_deg", "degenerate"]);
        }
        if with_seen {
            header.push("observers_seen");
        }
        // Adaptive runs: the draws each point took and whether it met the tolerance.
        let adaptive = r.points.iter().any(|p| p.converged.is_some());
        if adaptive {
            header.extend(["draws", "converged"]);
        }
        w.write_record(&header)?;
        for (p, &angle) in r.points.iter().zip(angles) {
            let mut rec: Vec<String> = [p.point.x, p.point.y, p.point.z]
                .map(|v| v.to_string())
                .to_vec();
            rec.extend(
                [p.sigma_mm.x, p.sigma_mm.y, p.sigma_mm.z, p.sigma_max_mm].map(|v| cell(p, v)),
            );
            if flagged {
                rec.push(angle.to_string());
                rec.push(degenerate(p, angle).to_string());
            }
            if with_seen {
                rec.push(p.observers_seen.to_string());
            }
            if adaptive {
                rec.push(p.count.to_string());
                rec.push(p.converged.map_or_else(String::new, |c| c.to_string()));
            }
            w.write_record(&rec)?;
        }
        Ok(())
    })
}

fn detail_csv(r: &GridResult, angles: &[f64]) -> anyhow::Result<Vec<u8>> {
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
            w.write_record(&rec)?;
        }
        Ok(())
    })
}

struct MapSpec<'a> {
    /// Colour range; `None` = data range.
    range: Option<(f64, f64)>,
    stem: &'a str,
    title: &'a str,
    bar: &'a str,
    threshold: Option<f64>,
    value: fn(&PointStats) -> f64,
}

/// Runs `crashrig grid`.
pub fn run(a: GridArgs, g: &Global) -> anyhow::Result<()> {
    let (summary, files) = compute_typed(&a, g.seed)?;
    if g.json {
        return crate::output::print_json(&summary);
    }
    let print = || -> std::io::Result<()> {
        use std::io::Write;
        let mut w = std::io::stdout().lock();
        writeln!(
            w,
            "{} points × {} draws in {:.3} s ({:.3e} draws/s); σ_max median {:.3} mm, max {:.3} mm; {:.1} % below {} mm",
            summary.points,
            summary.samples_per_point,
            summary.elapsed_s,
            summary.samples_per_second,
            summary.median_sigma_max_mm,
            summary.max_sigma_mm,
            100.0 * summary.fraction_below_threshold,
            summary.threshold_mm
        )?;
        if summary.fraction_measurable < 1.0 {
            writeln!(
                w,
                "{:.1} % of the points measurable (seen by two or more observers)",
                100.0 * summary.fraction_measurable
            )?;
        }
        writeln!(w, "wrote {} files to {}", files, a.out.display())
    };
    super::propagate::quiet_pipe(print())
}

/// Runs the grid study, writes every output file into `a.out` and returns `summary.json`'s
/// content (for the tests). `seed` overrides the scenario's seed.
#[cfg(test)]
fn compute(a: &GridArgs, seed: Option<u64>) -> anyhow::Result<serde_json::Value> {
    let (summary, _) = compute_typed(a, seed)?;
    serde_json::to_value(summary).context("formatting summary.json")
}

fn compute_typed(a: &GridArgs, seed: Option<u64>) -> anyhow::Result<(Summary, usize)> {
    let scenario = load_scenario(&a.scenario)?;
    let samples = resolve_samples(a.samples, &scenario)?;
    let seed = seed.unwrap_or(scenario.seed);
    let ctx =
        |e: crashrig_mc::Error| anyhow::Error::new(crashrig_mc::limits::locate(e, &a.scenario));
    let study = GridStudy::new(&scenario, samples, seed).map_err(ctx)?;
    let grid = study.grid().clone();
    if grid.adaptive.is_none() {
        // --samples may exceed what the scenario's own bound check saw.
        crashrig_mc::limits::check_grid_draws(grid.points().len(), samples)
            .map_err(|e| anyhow::anyhow!("--samples {samples}: {e}"))?;
    }
    // Fails before any work when --out holds files `grid` does not write.
    let mut files = Pending {
        staged: crashrig_outdir::Staged::new(&a.out, replaceable)?,
        names: Vec::new(),
    };

    let bar = crate::progress::Bar::new("crashrig grid");
    let start = std::time::Instant::now();
    let points = bar.stage("grid points");
    let result = match &grid.adaptive {
        Some(ad) => study.run_adaptive_with_progress(ad, seed, bar.hook(&points)),
        None => study.run_with_progress(samples, seed, bar.hook(&points)),
    }
    .map_err(ctx)?;
    let mut result = result;
    // Degenerate points (lines of sight nearly parallel): no σ, not in medians or colours.
    let angles = mask_degenerate(&mut result, &grid, &a.scenario)?;
    let elapsed_s = start.elapsed().as_secs_f64();
    let total_draws: u64 = result.points.iter().map(|p| p.count).sum();

    let correlation = if result.correlated {
        let points = bar.stage("grid points, independent observers");
        let ind = match &grid.adaptive {
            Some(ad) => study
                .independent()
                .run_adaptive_with_progress(ad, seed, bar.hook(&points)),
            None => study
                .independent()
                .run_with_progress(samples, seed, bar.hook(&points)),
        }
        .map_err(ctx)?;
        let mut ind = ind;
        mask_degenerate(&mut ind, &grid, &a.scenario)?;
        let change: Vec<f64> = result
            .points
            .iter()
            .zip(&ind.points)
            .map(|(c, i)| c.sigma_max_mm - i.sigma_max_mm)
            .collect();
        let ratio: Vec<f64> = result
            .points
            .iter()
            .zip(&ind.points)
            .map(|(c, i)| c.sigma_max_mm / i.sigma_max_mm)
            .collect();
        let ism: Vec<f64> = ind.points.iter().map(|p| p.sigma_max_mm).collect();
        Some(CorrelationSummary {
            independent_fraction_below_threshold: ind.fraction_below(grid.threshold_mm),
            independent_median_sigma_max_mm: median(&ism),
            change_sigma_max_mm: spread(&change),
            ratio_correlated_over_independent: spread(&ratio),
        })
    } else {
        None
    };
    bar.finish();

    let with_fixed = fixed::has_fixed(&grid);
    if result.points.iter().all(|p| !p.is_measurable()) {
        eprintln!(
            "warning: {}: no grid point is seen by two or more observers; every point is not measurable",
            a.scenario.display()
        );
    }
    write(
        &a.out,
        "grid.csv",
        &main_csv(&result, &angles, with_fixed)?,
        &mut files,
    )?;
    write(
        &a.out,
        "grid_detail.csv",
        &detail_csv(&result, &angles)?,
        &mut files,
    )?;

    if !a.no_plots {
        let xs = grid.x.values();
        let ys = grid.y.values();
        let zs = grid.z.values();
        let per_z = xs.len() * ys.len();
        // σ maps share one colour scale, 0 to 3× the threshold (larger values saturate), so
        // the region below the threshold stays readable next to the degenerate zones.
        let top = 3.0 * grid.threshold_mm;
        let sat = Some((0.0, top));
        let sat_label = format!("sigma_max [mm] (>= {top} saturated)");
        let sat_label_lin = format!("linear sigma_max [mm] (>= {top} saturated)");
        let specs = [
            MapSpec {
                range: sat,
                stem: "sigma_max",
                title: "Monte Carlo sigma_max",
                bar: &sat_label,
                threshold: Some(grid.threshold_mm),
                value: |p| p.sigma_max_mm,
            },
            MapSpec {
                range: sat,
                stem: "linear_sigma_max",
                title: "First-order sigma_max",
                bar: &sat_label_lin,
                threshold: Some(grid.threshold_mm),
                value: |p| p.linear_sigma_max_mm(),
            },
            MapSpec {
                range: None,
                stem: "ratio_mc_linear",
                title: "sigma_max Monte Carlo / first order",
                bar: "ratio [-]",
                threshold: None,
                value: |p| p.sigma_max_mm / p.linear_sigma_max_mm(),
            },
        ];
        for (iz, z) in zs.iter().enumerate() {
            let pts = &result.points[iz * per_z..(iz + 1) * per_z];
            let labels: Vec<String> = grid
                .observers
                .iter()
                .map(|o| {
                    if (o.position_mm.z - z).abs() > 0.5 {
                        format!("{} (z {:.0})", o.name, o.position_mm.z)
                    } else {
                        o.name.clone()
                    }
                })
                .collect();
            let markers: Vec<Marker> = grid
                .observers
                .iter()
                .zip(&labels)
                .map(|(o, l)| Marker {
                    x: o.position_mm.x,
                    y: o.position_mm.y,
                    label: l,
                })
                .collect();
            // Fixed observers: field-of-view footprints on this plane, hatched not-measurable
            // cells, and a map of the number of cameras that see each point.
            let fp = if with_fixed {
                fixed::footprints(&grid, *z, fixed::footprint_bounds(&grid, &xs, &ys))
            } else {
                Vec::new()
            };
            let outlines = fixed::outlines(&fp);
            let overlay = if with_fixed {
                fixed::overlay(&outlines, &[])
            } else {
                crashrig_plot::Overlay::default()
            };
            let seen_labels: Vec<String> =
                pts.iter().map(|p| p.observers_seen.to_string()).collect();
            let seen_overlay = fixed::overlay(&outlines, &seen_labels);
            let n_obs = grid.observers.len() as f64;
            let seen_spec = MapSpec {
                range: Some((0.0, n_obs.max(1.0))),
                stem: "observers_seen",
                title: "Cameras seeing the point",
                bar: "observers seeing the point [-]",
                threshold: None,
                value: |p| p.observers_seen as f64,
            };
            let extra = with_fixed.then_some(&seen_spec);
            for spec in specs.iter().chain(extra) {
                let values: Vec<f64> = pts.iter().map(spec.value).collect();
                // A level where every point is degenerate has no data range: any range will do.
                let range = match spec.range {
                    None if !values.iter().any(|v| v.is_finite()) => Some((0.0, 1.0)),
                    r => r,
                };
                let title = format!("{} at z = {} mm", spec.title, z);
                let all_missing = values.iter().all(|v| !v.is_finite());
                let map = HeatMap {
                    xs: &xs,
                    ys: &ys,
                    values: &values,
                    title: &title,
                    x_label: "x [mm]",
                    y_label: "y [mm]",
                    colorbar_label: spec.bar,
                    threshold: spec.threshold,
                    markers: &markers,
                    // A level with no finite value (all degenerate or all not measurable)
                    // still renders, all hatched.
                    value_range: range.or(all_missing.then_some((0.0, 1.0))),
                };
                let ov = if spec.stem == "observers_seen" {
                    &seen_overlay
                } else {
                    &overlay
                };
                for (fmt, ext) in [(Format::Png, "png"), (Format::Svg, "svg")] {
                    let bytes = crashrig_plot::heatmap_with(&map, ov, fmt)
                        .with_context(|| format!("heat map {} z = {z}", spec.stem))?;
                    let name = format!("{}_z{:02}_{}mm.{ext}", spec.stem, iz, z);
                    write(&a.out, &name, &bytes, &mut files)?;
                }
            }
        }
    }

    let sm: Vec<f64> = result.points.iter().map(|p| p.sigma_max_mm).collect();
    let lsm: Vec<f64> = result
        .points
        .iter()
        .map(|p| p.linear_sigma_max_mm())
        .collect();
    let ratio: Vec<f64> = sm.iter().zip(&lsm).map(|(m, l)| m / l).collect();
    let counts: Vec<u64> = result.points.iter().map(|p| p.count).collect();
    let unconverged = result
        .points
        .iter()
        .filter(|p| p.converged == Some(false))
        .count();
    if unconverged > 0 {
        eprintln!(
            "warning: {}: {unconverged} of {} grid points stopped at max_samples without meeting the adaptive tolerance (grid.csv column `converged`)",
            a.scenario.display(),
            result.points.len()
        );
    }
    let summary = Summary {
        points: result.points.len(),
        // Not-measurable points draw nothing; the draws per point are those asked for.
        samples_per_point: match grid.adaptive {
            None => samples as u64,
            Some(_) => counts.iter().copied().max().unwrap_or(0),
        },
        threshold_mm: grid.threshold_mm,
        fraction_below_threshold: result.fraction_below(grid.threshold_mm),
        max_sigma_mm: sm.iter().copied().fold(f64::NAN, f64::max),
        median_sigma_max_mm: median(&sm),
        elapsed_s,
        samples_per_second: total_draws as f64 / elapsed_s,
        fraction_measurable: result.fraction_measurable(),
        observer_coverage: with_fixed.then(|| fixed::coverage(&grid, &result)),
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
            median_sigma_max_mm: median(&lsm),
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
        correlation,
        degenerate_points: result
            .points
            .iter()
            .zip(&angles)
            .filter(|(p, a)| crashrig_mc::degenerate::is_degenerate_point(p, **a))
            .count(),
        min_intersection_angle_deg: crashrig_mc::degenerate::MIN_INTERSECTION_ANGLE_DEG,
        files: files
            .names
            .iter()
            .cloned()
            .chain(std::iter::once("summary.json".to_string()))
            .collect(),
    };
    let json = serde_json::to_vec_pretty(&summary).context("formatting summary.json")?;
    write(&a.out, "summary.json", &json, &mut files)?;
    let n = files.len();
    files.staged.commit()?;
    Ok((summary, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENARIO: &str = r#"
seed = 5
samples = 300
[grid]
x_mm = [400.0, 800.0, 3]
y_mm = [-200.0, 200.0, 2]
z_mm = [0.0, 300.0, 2]
[[grid.observer]]
name = "rear"
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]
[[grid.observer]]
name = "door"
position_mm = [1300.0, -700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

    fn args(dir: &Path, scenario: &Path, no_plots: bool) -> GridArgs {
        GridArgs {
            scenario: scenario.to_path_buf(),
            out: dir.to_path_buf(),
            samples: None,
            no_plots,
        }
    }

    #[test]
    fn grid_compute_nominal_same_csv_for_one_and_two_threads() {
        let tmp = tempfile::tempdir().unwrap();
        let scen = tmp.path().join("s.toml");
        std::fs::write(&scen, SCENARIO).unwrap();
        let run = |threads: usize, name: &str, plots: bool| {
            let out = tmp.path().join(name);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let summary = pool
                .install(|| compute(&args(&out, &scen, !plots), None))
                .unwrap();
            (std::fs::read(out.join("grid.csv")).unwrap(), summary, out)
        };
        let (a, summary, out) = run(1, "one", true);
        let (b, _, _) = run(2, "two", false);
        assert_eq!(a, b, "grid.csv differs between 1 and 2 threads");
        let text = String::from_utf8(a).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm"
        );
        assert_eq!(lines.count(), 12);
        for key in [
            "points",
            "samples_per_point",
            "threshold_mm",
            "fraction_below_threshold",
            "max_sigma_mm",
            "median_sigma_max_mm",
            "elapsed_s",
            "samples_per_second",
        ] {
            assert!(summary.get(key).is_some(), "summary.json lacks {key}");
        }
        assert_eq!(summary["points"], 12);
        assert_eq!(summary["samples_per_point"], 300);
        // One PNG and one SVG per z level and map kind.
        for z in ["z00_0mm", "z01_300mm"] {
            for ext in ["png", "svg"] {
                assert!(out.join(format!("sigma_max_{z}.{ext}")).is_file());
            }
        }
    }

    #[test]
    fn grid_compute_bad_scenario_names_file_and_key() {
        let tmp = tempfile::tempdir().unwrap();
        let scen = tmp.path().join("bad.toml");
        std::fs::write(
            &scen,
            SCENARIO.replace("[2.53, 2.51, 2.55]", "[2.53, -2.51, 2.55]"),
        )
        .unwrap();
        let err = compute(&args(&tmp.path().join("o"), &scen, true), None).unwrap_err();
        let msg = format!("{err:#}");
        assert!(msg.contains("bad.toml"), "{msg}");
        assert!(msg.contains("grid.observer[1].sigma_position_mm"), "{msg}");
        assert!(!tmp.path().join("o").join("grid.csv").exists());
    }
}
