//! `crashrig grid`: forward-intersection precision over a grid. Arguments →
//! [`GridConfig`] → [`crashrig_study::run_grid`] → print.

use crate::Global;
use crashrig_study::GridConfig;
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
    let r = crashrig_study::run_grid(&config, bar.reporter())?;
    bar.finish();
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
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
        writeln!(w, "wrote {} files to {}", r.files, config.out.display())
    };
    super::propagate::quiet_pipe(print())
}
