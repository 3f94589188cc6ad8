//! The library entry of `crashrig study` as a whole: a study → [`run_study`] → every output
//! below the output directory (staged and swapped in whole, [`crate::report::write_outputs`])
//! → [`StudyRun`] with `results.json` (the command's `--json` document) and the warnings.
//! The CLI and the Python module call this one function.
//!
//! # Example
//! ```no_run
//! use crashrig_study::{StudyRunConfig, run_to_dir};
//! use crashrig_study::Study;
//! let path = std::path::Path::new("my_lab/study.toml");
//! let study = Study::from_path(path)?;
//! let config = StudyRunConfig {
//!     study_path: path.into(),
//!     out: "study_out".into(),
//!     seed: Some(1),
//!     samples: None,
//!     no_sensitivity: false,
//!     command: "crashrig study my_lab/study.toml --out study_out --seed 1".into(),
//! };
//! let run = run_to_dir(&study, &config, None, None)?;
//! println!("{}", run.json["layouts"][0]["name"]);
//! # Ok::<(), crashrig_study::Error>(())
//! ```

use crate::pipeline::{Options, run_study};
use crate::report::Provenance;
use crate::{Error, Study, StudyResult};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What [`run_to_dir`] runs.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyRunConfig {
    /// The study file (names it in messages; a study file inside `out` keeps its folder).
    pub study_path: PathBuf,
    /// The output directory: results.json, report.html, calibration/, tie/, `grid/<layout>/`.
    pub out: PathBuf,
    /// Seed (default: the study file's).
    pub seed: Option<u64>,
    /// Grid draws per point (default: the study file's `samples`).
    pub samples: Option<usize>,
    /// Skip the one-at-a-time sensitivity runs.
    pub no_sensitivity: bool,
    /// The command line stated in the report.
    pub command: String,
}

/// The result of [`run_to_dir`].
#[derive(Debug, Clone)]
pub struct StudyRun {
    /// The typed result.
    pub result: StudyResult,
    /// `results.json` (the `--json` document).
    pub json: serde_json::Value,
    /// Warnings for the user, one sentence each without the `warning:` prefix.
    pub warnings: Vec<String>,
}

/// A sink for one finished step's log line, e.g.
/// `crashrig study: [3/12] layout cabin: 0.84 s (total 2.10 s)`.
pub type StepLine<'a> = &'a (dyn Fn(&str) + Sync);

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
fn copy_tree(from: &Path, to: &Path) -> Result<(), Error> {
    let write = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Write { path, source }
    };
    // Into the staging directory: each step inside the gate (see `crashrig_outdir::gated`).
    crashrig_outdir::gated(|| std::fs::create_dir_all(to)).map_err(write(to))?;
    for entry in std::fs::read_dir(from).map_err(write(to))? {
        let entry = entry.map_err(write(to))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if entry.file_type().map_err(write(&dst))?.is_dir() {
            copy_tree(&src, &dst)?;
        } else {
            crashrig_outdir::gated(|| std::fs::copy(&src, &dst)).map_err(write(&dst))?;
        }
    }
    Ok(())
}

/// Runs `study` and writes every output below `config.out` (checked before any work: files
/// `study` does not write are refused; the directory is replaced as a whole, so a failed or
/// interrupted run leaves the old result). `progress` watches the steps; `step_line`
/// receives one log line per finished step.
///
/// # Errors
/// Any error of [`run_study`], [`crate::report::write_outputs`] and the output directory.
pub fn run_to_dir(
    study: &Study,
    config: &StudyRunConfig,
    progress: Option<crate::pipeline::Progress<'_>>,
    step_line: Option<StepLine<'_>>,
) -> Result<StudyRun, Error> {
    let out = &config.out;
    // A study file inside OUT (`paper`'s `DIR/inputs/study.toml`) keeps the top-level entry
    // holding it (`inputs/`): it is copied into the staging directory first.
    let kept = inputs_entry(&config.study_path, out);
    let staged = crashrig_outdir::Staged::new(out, |name| {
        replaceable(name) || kept.as_deref().is_some_and(|k| name == format!("{k}/"))
    })?;
    if let Some(k) = &kept {
        copy_tree(&out.join(k), &staged.dir().join(k))?;
    }
    let steps = StepLog::new(step_line);
    let report = |stage: &str, done: u64, total: u64| {
        if let Some(p) = progress {
            p(stage, done, total);
        }
        steps.report(stage, done, total);
    };
    let options = Options {
        seed: config.seed,
        samples: config.samples,
        no_sensitivity: config.no_sensitivity,
        progress: Some(&report),
    };
    let result = run_study(study, &options)?;
    let warnings = warnings(study, &result);
    let prov = Provenance {
        command: config.command.clone(),
        out_dir: out.display().to_string(),
        run_time_s: Some(steps.elapsed_s()),
        step_times_s: steps.into_steps(),
    };
    crate::report::write_outputs(staged.dir(), study, &result, &prov)?;
    staged.commit()?;
    Ok(StudyRun {
        json: result.to_json(),
        result,
        warnings,
    })
}

/// (steps done, when the last step finished, (step, seconds) of every finished step).
type StepState = (u64, Instant, Vec<(String, f64)>);

/// The study's steps with their times: each finished step is recorded and handed to the
/// optional line sink.
struct StepLog<'a> {
    line: Option<StepLine<'a>>,
    start: Instant,
    state: std::sync::Mutex<StepState>,
}

impl<'a> StepLog<'a> {
    fn new(line: Option<StepLine<'a>>) -> StepLog<'a> {
        let now = Instant::now();
        StepLog {
            line,
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
        let now = Instant::now();
        let step = now.duration_since(s.1).as_secs_f64();
        *s = (done, now, std::mem::take(&mut s.2));
        s.2.push((stage.to_string(), step));
        if let Some(line) = self.line {
            line(&format!(
                "crashrig study: [{done}/{total}] {stage}: {step:.2} s (total {:.2} s)",
                now.duration_since(self.start).as_secs_f64()
            ));
        }
    }

    fn elapsed_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    fn into_steps(self) -> Vec<(String, f64)> {
        self.state.into_inner().map(|s| s.2).unwrap_or_default()
    }
}

/// The study's warnings: its plausibility warnings ([`StudyResult::unit_warnings`]), then one per layout
/// that nothing can measure (fixed cameras of which no two see a common point) and per epoch of
/// `[measure]` without a pose of camera A.
pub fn warnings(study: &Study, r: &StudyResult) -> Vec<String> {
    let study_path = &study.path;
    let mut out = r.unit_warnings(study);
    for l in &r.layouts {
        if l.summary
            .fixed
            .as_ref()
            .is_some_and(|f| f.fraction_measurable == 0.0)
        {
            out.push(format!(
                "{}: layout {:?}: no grid point is seen by two or more observers; every point is not measurable",
                study_path.display(),
                l.layout.name
            ));
        }
    }
    for w in r.measure.iter().flat_map(|m| &m.warnings) {
        out.push(format!("{}: [measure]: {w}", study_path.display()));
    }
    out
}
