//! `crashrig paper`: `crashrig study` on a bundled study file.
//!
//! The inputs (the paper's calibration sequence, the two-view tie scene) are embedded in the
//! binary and written to `DIR/inputs/` with the study file `DIR/inputs/study.toml` that names
//! them; then the study runs exactly as `crashrig study DIR/inputs/study.toml --out DIR` would,
//! so that command reproduces `DIR/results.json` bit for bit. The study file carries
//! `reference = "kaminski2023"`, which adds the paper's published values and the "what
//! differs" section to the report.

use crate::Global;
use anyhow::Context;
use crashrig_study::{PaperStudy, study_toml};
use std::path::{Path, PathBuf};

/// Arguments of `crashrig paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Output directory for report.html, results.json, figures and the inputs used.
    #[arg(long, default_value = "out/paper")]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point (the heat maps).
    #[arg(long, default_value_t = 2000, value_parser = crate::limits::parse_samples)]
    pub samples: usize,
    /// Monte Carlo draws of the chain propagation (Tables 3–4).
    #[arg(long = "chain-samples", default_value_t = 200_000, value_parser = crate::limits::parse_samples)]
    pub chain_samples: usize,
    /// Bootstrap replicates (Figures 8–9).
    #[arg(long, default_value_t = 500, value_parser = crate::limits::parse_iterations)]
    pub iterations: usize,
}

/// Default seed of the study when `--seed` is not given.
pub const DEFAULT_SEED: u64 = 20261121;

/// An embedded input file: its path below `DIR/inputs/` and its bytes.
type Embedded = (&'static str, &'static [u8]);

/// The inputs are read from `crates/cli/paper/`, symbolic links into the workspace's
/// `fixtures/` (one copy in the repository; `cargo package` stores the files themselves, so the
/// packaged crate builds on its own).
macro_rules! embed {
    ($($rel:literal),* $(,)?) => {
        &[$(($rel, include_bytes!(concat!("../../paper/", $rel)) as &[u8])),*]
    };
}

const INPUTS: &[Embedded] = embed![
    "rig_sequence/cameras.bin",
    "rig_sequence/images.bin",
    "rig_sequence/points3D.bin",
    "rig_sequence/rigs.bin",
    "rig_sequence/frames.bin",
    "twoview/model/cameras.bin",
    "twoview/model/images.bin",
    "twoview/model/points3D.bin",
    "twoview/model/rigs.bin",
    "twoview/model/frames.bin",
    "twoview/database.db",
    "scenarios/paper_chain.toml",
    "scenarios/four_cameras_z0.toml",
    "scenarios/four_cameras_z300.toml",
    "scenarios/three_cameras_z0.toml",
    "scenarios/three_cameras_z300.toml",
    "scenarios/three_cameras_correlated.toml",
];

/// Writes the embedded inputs below `dir`.
fn write_inputs(dir: &Path) -> anyhow::Result<()> {
    for (rel, bytes) in INPUTS {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create the directory", parent.display()))?;
        }
        crate::output::write_atomic(&path, bytes)?;
    }
    Ok(())
}

/// Runs `crashrig paper`.
pub fn run(a: PaperArgs, g: &Global) -> anyhow::Result<()> {
    let run = compute(&a, g)?;
    if g.json {
        crate::output::print_json(&run.json)?;
    } else {
        println!(
            "crashrig paper: {}",
            super::study::summary_line(&a.out, &run.result)
        );
    }
    Ok(())
}

/// Writes the inputs and the study file below `a.out`, runs the study there and returns the
/// typed result with `results.json`'s content.
pub fn compute(a: &PaperArgs, g: &Global) -> anyhow::Result<crashrig_study::StudyRun> {
    let seed = g.seed.unwrap_or(DEFAULT_SEED);
    super::study::at_least_two("--samples", a.samples)?;
    super::study::at_least_two("--chain-samples", a.chain_samples)?;
    let inputs = a.out.join("inputs");
    std::fs::create_dir_all(&inputs)
        .with_context(|| format!("{}: cannot create the output directory", inputs.display()))?;
    write_inputs(&inputs)?;
    let study = inputs.join("study.toml");
    let paper = PaperStudy {
        seed,
        samples: a.samples,
        chain_samples: a.chain_samples,
        iterations: a.iterations,
    };
    let bundled = |rel: &str| {
        INPUTS
            .iter()
            .find(|(r, _)| *r == rel)
            .and_then(|(_, bytes)| std::str::from_utf8(bytes).ok())
    };
    crate::output::write_atomic(&study, study_toml(&paper, &bundled)?.as_bytes())?;
    let command = format!(
        "crashrig paper --out {} --seed {seed} --samples {} --chain-samples {} --iterations {}   (= crashrig study {} --out {})",
        a.out.display(),
        a.samples,
        a.chain_samples,
        a.iterations,
        study.display(),
        a.out.display()
    );
    super::study::execute(&study, &a.out, None, None, false, &command)
}
