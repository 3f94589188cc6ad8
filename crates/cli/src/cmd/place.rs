//! `crashrig place`: where to mount the cameras. Arguments → [`PlaceConfig`] →
//! [`crashrig_place::run`] → print.

use crate::Global;
use crashrig_place::PlaceConfig;
use std::path::{Path, PathBuf};

/// Arguments of `crashrig place`.
#[derive(Debug, clap::Args)]
pub struct PlaceArgs {
    /// Scenario file (TOML): grid, threshold, chain and the observers already mounted.
    pub scenario: PathBuf,
    /// Candidates file (TOML): `[[candidate]]` tables, a name and the keys of a [[grid.observer]].
    #[arg(long, value_name = "FILE.toml")]
    pub candidates: PathBuf,
    /// How many candidates to choose (K).
    #[arg(long, value_name = "K")]
    pub choose: usize,
    /// Output directory: placement.json and the chosen layout's grid output in grid/.
    #[arg(long)]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point of the confirmation (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Skip the chosen layout's heat maps (PNG/SVG).
    #[arg(long)]
    pub no_plots: bool,
    /// Run only shard i of N (1 ≤ i ≤ N) and write a shard directory to --out; `crashrig
    /// merge` turns the N shard directories into the unsharded output (docs/SCALE.md).
    #[arg(long, value_name = "I/N", value_parser = crate::limits::parse_shard)]
    pub shard: Option<crashrig_outdir::shard::Shard>,
}

/// Runs `crashrig place`.
pub fn run(a: PlaceArgs, g: &Global) -> anyhow::Result<()> {
    let config = PlaceConfig {
        scenario: a.scenario,
        candidates: a.candidates,
        choose: a.choose,
        out: a.out,
        samples: a.samples,
        seed: g.seed,
        plots: !a.no_plots,
    };
    let bar = crate::progress::Bar::new("crashrig place");
    if let Some(shard) = a.shard {
        let r = crashrig_place::shard::run_shard(&config, shard, bar.reporter())?;
        bar.finish();
        return crate::output::print_shard(&r.manifest, r.files, &config.out, g.json);
    }
    let r = crashrig_place::run(&config, bar.reporter())?;
    bar.finish();
    print(&r, &config.out, g)
}

/// Prints a placement (`crashrig place`, and `crashrig merge` of place shards).
pub fn print(r: &crashrig_place::PlaceRun, out: &Path, g: &Global) -> anyhow::Result<()> {
    crate::output::warn_all(&r.grid.warnings);
    let p = &r.placement;
    if g.json {
        return crate::output::print_json(p);
    }
    let print = || -> std::io::Result<()> {
        use std::io::Write;
        let mut w = std::io::stdout().lock();
        writeln!(
            w,
            "chose {} of {} candidates ({}, {} layouts scored to first order): {}",
            p.choose,
            p.candidates,
            p.method,
            p.evaluated,
            p.chosen.join(", ")
        )?;
        for c in &p.confirmed {
            writeln!(
                w,
                "  {:<40} Monte Carlo {:5.1} % ≤ {} mm, mean σ_max {:.3} mm (first order {:5.1} %, {:.3} mm)",
                c.chosen.join(", "),
                100.0 * c.share_below_threshold,
                p.threshold_mm,
                c.mean_sigma_max_mm,
                100.0 * c.approximate_share_below_threshold,
                c.approximate_mean_sigma_max_mm
            )?;
        }
        writeln!(
            w,
            "confirmed ({} draws per point, seed {}): {:.1} % of {} points with σ_max ≤ {} mm, mean σ_max {:.3} mm",
            p.samples,
            p.seed,
            100.0 * p.share_below_threshold,
            p.points,
            p.threshold_mm,
            p.mean_sigma_max_mm
        )?;
        writeln!(
            w,
            "wrote placement.json and {} files to {}",
            r.grid.files,
            out.join("grid").display()
        )
    };
    crate::output::quiet_pipe(print())
}
