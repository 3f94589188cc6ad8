//! `crashrig grid`: forward-intersection precision over a grid. Arguments →
//! [`GridConfig`] → [`crashrig_grid::run_grid`] → print.

use crate::Global;
use crashrig_grid::GridConfig;
use std::path::PathBuf;

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
    /// Run only shard i of N (1 ≤ i ≤ N) and write a shard directory to --out; `crashrig
    /// merge` turns the N shard directories into the unsharded output (docs/SCALE.md).
    #[arg(long, value_name = "I/N", value_parser = crate::limits::parse_shard)]
    pub shard: Option<crashrig_outdir::shard::Shard>,
}

/// Runs `crashrig grid`.
pub fn run(a: GridArgs, g: &Global) -> anyhow::Result<()> {
    let config = GridConfig {
        scenario: a.scenario,
        out: a.out,
        samples: a.samples,
        seed: g.seed,
        plots: !a.no_plots,
    };
    let bar = crate::progress::Bar::new("crashrig grid");
    if let Some(shard) = a.shard {
        let r = crashrig_grid::shard::run_grid_shard(&config, shard, bar.reporter())?;
        bar.finish();
        return crate::output::print_shard(&r.manifest, r.files, &config.out, g.json);
    }
    let r = crashrig_grid::run_grid(&config, bar.reporter())?;
    bar.finish();
    print(&r, &config.out, g)
}

/// Prints a grid run (`crashrig grid`, and `crashrig merge` of grid shards).
pub fn print(r: &crashrig_grid::GridRun, out: &std::path::Path, g: &Global) -> anyhow::Result<()> {
    crate::output::warn_all(&r.warnings);
    let s = &r.summary;
    if g.json {
        return crate::output::print_json(s);
    }
    let print = || -> std::io::Result<()> {
        use std::io::Write;
        let mut w = std::io::stdout().lock();
        writeln!(
            w,
            "{} points × {} draws in {:.3} s ({:.3e} draws/s); σ_max median {:.3} mm, max {:.3} mm; {:.1} % below {} mm",
            s.points,
            s.samples_per_point,
            s.elapsed_s,
            s.samples_per_second,
            s.median_sigma_max_mm,
            s.max_sigma_mm,
            100.0 * s.fraction_below_threshold,
            s.threshold_mm
        )?;
        if s.fraction_measurable < 1.0 {
            writeln!(
                w,
                "{:.1} % of the points measurable (seen by two or more observers)",
                100.0 * s.fraction_measurable
            )?;
        }
        writeln!(w, "wrote {} files to {}", r.files, out.display())
    };
    crate::output::quiet_pipe(print())
}
