//! `crashrig`: the command-line tool of the crashrig workspace.
//!
//! The CLI is thin: it parses arguments into plain structs, calls the library crates, and is
//! the only place that formats output (JSON, CSV, tables, plots). The contract it implements is
//! documented in `docs/REFERENCE.md`; `docs/ARCHITECTURE.md` maps commands to crates.

mod cmd;
mod limits;
mod output;
mod progress;

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
    /// Worker threads, 1 to 1024 (default: RAYON_NUM_THREADS or the number of cores).
    #[arg(long, global = true, value_name = "N", value_parser = limits::parse_threads)]
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
    /// Marker trajectories with σ (position, displacement, velocity) from a crash-test sequence.
    Measure(Box<cmd::measure::MeasureArgs>),
    /// The main job: reproduce the paper end to end from bundled fixtures, with a report.
    Paper(cmd::paper::PaperArgs),
    /// The whole study on your own COLMAP project (study file), with results.json and a report.
    Study(cmd::study::StudyArgs),
    /// Export a measure output to a crash lab's data system (ISO-MME).
    #[command(subcommand)]
    Export(cmd::export::ExportCommand),
    /// Camera A's per-epoch pose covariance from the bundle (input of measure --a-covariance).
    Covariance(cmd::covariance::CovarianceArgs),
    /// Merge the shard directories of a `--shard i/N` run into the unsharded output.
    Merge(cmd::merge::MergeArgs),
    /// Where to mount the cameras: choose K observers from candidates (Monte Carlo confirmed).
    Place(cmd::place::PlaceArgs),
    /// Camera files (Phantom .cine, Photron .cihx/.cih + .mraw, PNG/TIFF directories): info and export.
    #[command(subcommand)]
    Frames(cmd::frames::FramesCommand),
    /// Markers followed through one camera's frames: observations with each centre's own σ.
    Track(cmd::track::TrackArgs),
}

/// The error line of a failed run: the context chain joined with ": " (every library error
/// shows its own context only, so each part is there once), control characters escaped.
fn error_line(e: &anyhow::Error) -> String {
    output::escape_controls(&crashrig_input::message::error_line(e.as_ref()))
}

/// One `error: …` line for a usage error (clap's message is several lines long).
fn usage_error_line(e: &clap::Error) -> String {
    let rendered = e.render().to_string();
    let mut parts = Vec::new();
    for l in rendered.lines() {
        let l = l.trim();
        if l.starts_with("Usage:") || l.starts_with("For more information") {
            break;
        }
        if !l.is_empty() {
            parts.push(l.trim_start_matches("error:").trim().to_string());
        }
    }
    output::escape_controls(&format!("{} (see --help)", parts.join(" ")))
}

fn main() -> std::process::ExitCode {
    use clap::error::ErrorKind;
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            e.exit()
        }
        Err(e) => {
            eprintln!("error: {}", usage_error_line(&e));
            return std::process::ExitCode::from(2);
        }
    };
    // Bounded before any pool is built (rayon would spend minutes creating threads or panic).
    if let Err(e) = limits::check_rayon_env() {
        eprintln!("error: {e}");
        return std::process::ExitCode::from(2);
    }
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
        Command::Measure(a) => cmd::measure::run(*a, &cli.global),
        Command::Paper(a) => cmd::paper::run(a, &cli.global),
        Command::Study(a) => cmd::study::run(a, &cli.global),
        Command::Export(c) => cmd::export::run(c, &cli.global),
        Command::Covariance(a) => cmd::covariance::run(a, &cli.global),
        Command::Merge(a) => cmd::merge::run(a, &cli.global),
        Command::Place(a) => cmd::place::run(a, &cli.global),
        Command::Frames(c) => cmd::frames::run(c, &cli.global),
        Command::Track(a) => cmd::track::run(a, &cli.global),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One readable line naming what is wrong; causes joined with ": ".
            eprintln!("error: {}", error_line(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_line_joins_the_chain_in_one_line() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::new(io).context("x.toml: cannot read");
        assert_eq!(error_line(&e), "x.toml: cannot read: No such file");
        let e = anyhow::anyhow!("inner\u{1b}").context("outer");
        assert_eq!(error_line(&e), "outer: inner\\u{1b}");
    }

    #[test]
    fn usage_error_is_one_line() {
        let e = Cli::try_parse_from(["crashrig", "calibrate", "somewhere"]).unwrap_err();
        let line = usage_error_line(&e);
        assert!(!line.contains('\n'), "{line}");
        assert!(line.contains("--camera-a"), "{line}");
    }
}
