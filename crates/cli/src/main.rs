//! `crashrig`: the command-line tool of the crashrig workspace.
//!
//! The CLI is thin: it parses arguments into plain structs, calls the library crates, and is
//! the only place that formats output (JSON, CSV, tables, plots). The contract it implements is
//! `shared/interface.md`; `docs/ARCHITECTURE.md` maps commands to crates.

mod cmd;
mod output;
mod report;

use clap::{Parser, Subcommand};

/// Photogrammetric uncertainty for on-board crash-test camera rigs, with a COLMAP bridge.
#[derive(Debug, Parser)]
#[command(name = "crashrig", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(flatten)]
    global: Global,
    #[command(subcommand)]
    command: Command,
}

/// Options every command accepts.
#[derive(Debug, Clone, clap::Args)]
pub struct Global {
    /// Print one JSON document on stdout and nothing else there.
    #[arg(long, global = true)]
    pub json: bool,
    /// Seed of every random step (the same seed gives bit-identical output on any thread count).
    #[arg(long, global = true, value_name = "S")]
    pub seed: Option<u64>,
    /// Worker threads (default: RAYON_NUM_THREADS or the number of cores).
    #[arg(long, global = true, value_name = "N")]
    pub threads: Option<usize>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Inspect and convert COLMAP sparse models and databases.
    #[command(subcommand)]
    Colmap(cmd::colmap::ColmapCommand),
    /// Rig calibration (base and ω φ κ of B relative to A) from an epoch sequence.
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// Pose uncertainty of image B relative to A by resampling correspondences.
    Bootstrap(cmd::bootstrap::BootstrapArgs),
    /// Monte Carlo and first-order propagation through a camera chain (scenario TOML).
    Propagate(cmd::propagate::PropagateArgs),
    /// Forward-intersection precision over a grid of the car interior (scenario TOML).
    Grid(cmd::grid::GridArgs),
    /// The main job: reproduce the paper end to end from bundled fixtures, with a report.
    Paper(cmd::paper::PaperArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    if let Some(n) = cli.global.threads
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
    {
        eprintln!("error: cannot set up {n} worker threads: {e}");
        return std::process::ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Colmap(c) => cmd::colmap::run(c, &cli.global),
        Command::Calibrate(a) => cmd::calibrate::run(a, &cli.global),
        Command::Bootstrap(a) => cmd::bootstrap::run(a, &cli.global),
        Command::Propagate(a) => cmd::propagate::run(a, &cli.global),
        Command::Grid(a) => cmd::grid::run(a, &cli.global),
        Command::Paper(a) => cmd::paper::run(a, &cli.global),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One readable line naming what is wrong; causes joined with ": ".
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
