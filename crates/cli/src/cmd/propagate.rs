//! `crashrig propagate`: Monte Carlo and linear propagation through a camera chain.
//! Arguments → [`PropagateConfig`] → [`crashrig_grid::run_propagate`] → print.

use crate::Global;
use crashrig_grid::PropagateConfig;
use crashrig_grid::PropagateJson;
use std::path::PathBuf;

/// Arguments of `crashrig propagate`.
#[derive(Debug, clap::Args)]
pub struct PropagateArgs {
    /// Scenario file (TOML, every key in docs/SCENARIO.md).
    pub scenario: PathBuf,
    /// Monte Carlo draws (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
}

/// Runs `crashrig propagate`.
pub fn run(a: PropagateArgs, g: &Global) -> anyhow::Result<()> {
    let config = PropagateConfig {
        scenario: a.scenario,
        samples: a.samples,
        seed: g.seed,
    };
    let bar = crate::progress::Bar::new("crashrig propagate");
    let r = crashrig_grid::run_propagate(&config, bar.reporter())?;
    bar.finish();
    crate::output::warn_all(&r.warnings);
    let out = r.document;
    if g.json {
        return crate::output::print_json(&out);
    }
    // A closed pipe (e.g. `| head`) ends the output quietly instead of panicking.
    crate::output::quiet_pipe(print_table(&out))
}

fn print_table(out: &PropagateJson) -> std::io::Result<()> {
    use std::io::Write;
    let mut w = std::io::stdout().lock();
    writeln!(
        w,
        "{} draws, seed {}, rotation noise {} ({:.3} s)",
        out.samples, out.seed, out.rotation_noise, out.elapsed_s
    )?;
    writeln!(
        w,
        "{:<12} {:>26} {:>29} {:>26} {:>29}",
        "camera",
        "σ position MC [mm]",
        "σ ω φ κ MC [°]",
        "σ position linear [mm]",
        "σ ω φ κ linear [°]"
    )?;
    for c in &out.cameras {
        let p = |v: [f64; 3]| format!("{:8.3} {:8.3} {:8.3}", v[0], v[1], v[2]);
        let q = |v: Option<[f64; 3]>| {
            v.map_or_else(
                || format!("{:>29}", "(φ = ±90°: see tangent σ)"),
                |v| format!("{:9.5} {:9.5} {:9.5}", v[0], v[1], v[2]),
            )
        };
        writeln!(
            w,
            "{:<12} {:>26} {:>29} {:>26} {:>29}",
            c.name,
            p(c.position_sigma_mm),
            q(c.angles_sigma_deg),
            p(c.linear.position_sigma_mm),
            q(c.linear.angles_sigma_deg)
        )?;
    }
    Ok(())
}
