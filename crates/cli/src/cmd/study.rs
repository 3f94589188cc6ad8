//! `crashrig study STUDY.toml --out DIR`: the whole study on the user's own data, with the
//! report. Thin: study file → [`crashrig_study::Study`] → one [`crashrig_study::run_study`]
//! call → [`crashrig_study::report::write_outputs`].

use crate::Global;
use crashrig_study::report::Provenance;
use crashrig_study::{Options, Study, run_study};
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
    let results = execute(
        &a.study,
        &a.out,
        g.seed,
        a.samples,
        a.no_sensitivity,
        &command,
    )?;
    if g.json {
        return crate::output::print_json(&results);
    }
    println!("{}", summary_line(&a.out, &results));
    Ok(())
}

/// A Monte Carlo count given on the command line must be at least 2 (a σ needs two draws); the
/// error names the flag, not the study file that did not set it.
pub fn at_least_two(flag: &str, n: usize) -> anyhow::Result<()> {
    anyhow::ensure!(n >= 2, "{flag}: must be at least 2, got {n}");
    Ok(())
}

/// One line per run: where the report is and each layout's fraction below the threshold.
pub fn summary_line(out: &Path, results: &serde_json::Value) -> String {
    let layouts: Vec<String> = results["layouts"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|l| {
            format!(
                "{} {:.0} %",
                l["name"].as_str().unwrap_or(""),
                100.0
                    * l["summary"]["fraction_below_threshold"]
                        .as_f64()
                        .unwrap_or(f64::NAN)
            )
        })
        .collect();
    format!(
        "report {} (below threshold: {})",
        out.join("report.html").display(),
        layouts.join(", ")
    )
}

/// Top-level entries of OUT that `study` writes (directories end with `/`).
fn replaceable(name: &str) -> bool {
    matches!(
        name,
        "results.json"
            | "report.html"
            | "calibration/"
            | "tie/"
            | "grid/"
            | "measure/"
            | "report-screenshot.png"
    ) || name.starts_with(".tmp")
}

/// The top-level entry of `out` that holds the study file, if the study file is inside `out`.
fn inputs_entry(study_path: &Path, out: &Path) -> Option<String> {
    let (s, o) = (study_path.canonicalize().ok()?, out.canonicalize().ok()?);
    let first = s.strip_prefix(&o).ok()?.components().next()?;
    Some(first.as_os_str().to_string_lossy().into_owned())
}

/// Copies the directory tree `from` to `to` (files and directories only).
fn copy_tree(from: &Path, to: &Path) -> anyhow::Result<()> {
    use anyhow::Context;
    std::fs::create_dir_all(to).with_context(|| format!("{}: cannot create", to.display()))?;
    for entry in
        std::fs::read_dir(from).with_context(|| format!("{}: cannot read", from.display()))?
    {
        let entry = entry?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if entry.file_type()?.is_dir() {
            copy_tree(&src, &dst)?;
        } else {
            std::fs::copy(&src, &dst)
                .with_context(|| format!("{}: cannot copy to {}", src.display(), dst.display()))?;
        }
    }
    Ok(())
}

/// Reads the study, runs it and writes every output below `out`; returns `results.json`.
pub fn execute(
    study_path: &Path,
    out: &Path,
    seed: Option<u64>,
    samples: Option<usize>,
    no_sensitivity: bool,
    command: &str,
) -> anyhow::Result<serde_json::Value> {
    let study = Study::from_path(study_path)?;
    // OUT is staged (checked before any work: files `study` does not write are refused) and
    // swapped in whole. A study file inside OUT (`paper`'s `DIR/inputs/study.toml`) keeps the
    // top-level entry holding it (`inputs/`): it is copied into the staging directory first.
    let kept = inputs_entry(study_path, out);
    let staged = crashrig_outdir::Staged::new(out, |name| {
        replaceable(name) || kept.as_deref().is_some_and(|k| name == format!("{k}/"))
    })?;
    if let Some(k) = &kept {
        copy_tree(&out.join(k), &staged.dir().join(k))?;
    }
    let bar = crate::progress::Bar::new("crashrig study");
    let steps = StepLog::new(!bar.is_shown());
    let report = |stage: &str, done: u64, total: u64| {
        bar.set(stage, done, total);
        steps.report(stage, done, total);
    };
    let options = Options {
        seed,
        samples,
        no_sensitivity,
        progress: Some(&report),
    };
    let result = run_study(&study, &options);
    bar.finish();
    let result = result?;
    warnings(study_path, &result);
    let prov = Provenance {
        command: command.to_string(),
        out_dir: out.display().to_string(),
        run_time_s: Some(steps.elapsed_s()),
        step_times_s: steps.into_steps(),
    };
    // Written into a staging directory that replaces OUT as a whole: a failed or interrupted
    // run leaves the old result, never a mix.
    crashrig_study::report::write_outputs(staged.dir(), &study, &result, &prov)?;
    staged.commit()?;
    Ok(result.to_json())
}

/// (steps done, when the last step finished, (step, seconds) of every finished step).
type StepState = (u64, std::time::Instant, Vec<(String, f64)>);

/// The study's steps with their times: each finished step is recorded and, when stderr is not
/// a terminal (logs, CI, pipes: no progress bar), printed as one line
/// `crashrig study: [3/12] layout cabin: 0.84 s (total 2.10 s)`.
struct StepLog {
    print: bool,
    start: std::time::Instant,
    state: std::sync::Mutex<StepState>,
}

impl StepLog {
    fn new(print: bool) -> StepLog {
        let now = std::time::Instant::now();
        StepLog {
            print,
            start: now,
            state: std::sync::Mutex::new((0, now, Vec::new())),
        }
    }

    /// A progress report of the study: a step finished when `done` grows.
    fn report(&self, stage: &str, done: u64, total: u64) {
        let Ok(mut s) = self.state.lock() else { return };
        if done <= s.0 {
            return;
        }
        let now = std::time::Instant::now();
        let step = now.duration_since(s.1).as_secs_f64();
        *s = (done, now, std::mem::take(&mut s.2));
        s.2.push((stage.to_string(), step));
        if self.print {
            eprintln!(
                "crashrig study: [{done}/{total}] {stage}: {step:.2} s (total {:.2} s)",
                now.duration_since(self.start).as_secs_f64()
            );
        }
    }

    fn elapsed_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    fn into_steps(self) -> Vec<(String, f64)> {
        self.state.into_inner().map(|s| s.2).unwrap_or_default()
    }
}

/// One `warning:` line per layout that nothing can measure (fixed cameras of which no two see
/// a common point) and per epoch of `[measure]` without a pose of camera A.
fn warnings(study_path: &Path, r: &crashrig_study::StudyResult) {
    if let Some(w) = r
        .calibration
        .baseline_warning("calibration.scale_length_mm", "calibration.mm_per_unit")
    {
        eprintln!("warning: {}: [calibration]: {w}", study_path.display());
    }
    for l in &r.layouts {
        if l.summary
            .fixed
            .as_ref()
            .is_some_and(|f| f.fraction_measurable == 0.0)
        {
            eprintln!(
                "warning: {}: layout {:?}: no grid point is seen by two or more observers; every point is not measurable",
                study_path.display(),
                l.layout.name
            );
        }
    }
    for w in r.measure.iter().flat_map(|m| &m.warnings) {
        eprintln!("warning: {}: [measure]: {w}", study_path.display());
    }
}
