//! `crashrig study STUDY.toml --out DIR`: the whole study on the user's own data, with the
//! report. Thin: study file → [`crashrig_study::Study`] → one [`crashrig_study::run_study`]
//! call → [`crashrig_study::write_outputs`].

use crate::Global;
use crashrig_study::Study;
use crashrig_study::{StudyResult, StudyRun, StudyRunConfig, run_to_dir};
use std::path::{Path, PathBuf};

/// Arguments of `crashrig study`.
#[derive(Debug, clap::Args)]
pub struct StudyArgs {
    /// The study file (TOML; paths in it are relative to it).
    pub study: PathBuf,
    /// Output directory: results.json, report.html, calibration/, tie/, `grid/<layout>/`.
    #[arg(long)]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point (overrides the study file's `samples`).
    #[arg(long, value_parser = crate::limits::parse_samples)]
    pub samples: Option<usize>,
    /// Skip the one-at-a-time sensitivity runs (the verdict's "dominant input").
    #[arg(long)]
    pub no_sensitivity: bool,
}

/// Runs `crashrig study`.
pub fn run(a: StudyArgs, g: &Global) -> anyhow::Result<()> {
    let mut command = format!(
        "crashrig study {} --out {}",
        a.study.display(),
        a.out.display()
    );
    if let Some(s) = g.seed {
        command.push_str(&format!(" --seed {s}"));
    }
    if let Some(n) = a.samples {
        at_least_two("--samples", n)?;
        command.push_str(&format!(" --samples {n}"));
    }
    let run = execute(
        &a.study,
        &a.out,
        g.seed,
        a.samples,
        a.no_sensitivity,
        &command,
    )?;
    if g.json {
        return crate::output::print_json(&run.json);
    }
    println!("{}", summary_line(&a.out, &run.result));
    Ok(())
}

/// A Monte Carlo count given on the command line must be at least 2 (a σ needs two draws); the
/// error names the flag, not the study file that did not set it.
pub fn at_least_two(flag: &str, n: usize) -> anyhow::Result<()> {
    anyhow::ensure!(n >= 2, "{flag}: must be at least 2, got {n}");
    Ok(())
}

/// One line per run: where the report and `results.json` are, and per layout the share of the
/// grid that is measurable (seen by two or more cameras) and, of that, the share whose
/// worst-direction σ is below the threshold (the typed [`StudyResult`]'s layout verdicts, which
/// `results.json` holds as `layouts[].verdict`: the numbers of the report's first screen).
pub fn summary_line(out: &Path, result: &StudyResult) -> String {
    let layouts: Vec<String> = result
        .layouts
        .iter()
        .map(|l| {
            format!(
                "{} {:.1} % / {:.1} %",
                l.layout.name,
                100.0 * l.verdict.fraction_measurable,
                100.0 * l.verdict.fraction_below_threshold_of_measurable,
            )
        })
        .collect();
    format!(
        "report {}, numbers in {} (per layout: % of the grid measurable, i.e. seen by two or more cameras / % of those with worst-direction σ below the threshold: {})",
        out.join("report.html").display(),
        out.join("results.json").display(),
        layouts.join(", ")
    )
}

/// Reads the study, runs it and writes every output below `out`; returns the typed result with
/// `results.json`.
/// (The work is [`crashrig_study::run_to_dir`]; this adds the progress bar, the
/// step lines on stderr when there is no bar, and the warnings.)
pub fn execute(
    study_path: &Path,
    out: &Path,
    seed: Option<u64>,
    samples: Option<usize>,
    no_sensitivity: bool,
    command: &str,
) -> anyhow::Result<StudyRun> {
    let study = Study::from_path(study_path)?;
    let config = StudyRunConfig {
        study_path: study_path.to_path_buf(),
        out: out.to_path_buf(),
        seed,
        samples,
        no_sensitivity,
        command: command.to_string(),
    };
    let bar = crate::progress::Bar::new("crashrig study");
    let report = |stage: &str, done: u64, total: u64| bar.set(stage, done, total);
    let print = |line: &str| eprintln!("{line}");
    let step_line = (!bar.is_shown()).then_some(&print as &(dyn Fn(&str) + Sync));
    let run = run_to_dir(&study, &config, Some(&report), step_line);
    bar.finish();
    let run = run?;
    crate::output::warn_all(&run.warnings);
    Ok(run)
}
