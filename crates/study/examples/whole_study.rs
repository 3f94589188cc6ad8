//! A whole study from code: read a study file, run it, use the typed result, write the report.
//!
//! `cargo run -p crashrig-study --example whole_study [STUDY.toml OUT_DIR]`
//! (default: the bundled own project, output in a temporary directory).

use crashrig_study::{Options, Study, run_study};
use crashrig_study::{Provenance, write_outputs};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tmp = tempfile::tempdir()?;
    let (study_path, out) = match args.as_slice() {
        [s, o] => (PathBuf::from(s), PathBuf::from(o)),
        _ => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml"),
            tmp.path().join("out"),
        ),
    };
    let study = Study::from_path(&study_path)?;
    let options = Options {
        samples: Some(100),
        no_sensitivity: true,
        ..Options::default()
    };
    let result = run_study(&study, &options)?;
    let link = &result.calibration.link;
    println!(
        "link A_from_B: base {:.2?} mm from {} epochs",
        link.b_from_a.translation.vector, result.calibration.n_epochs
    );
    for l in &result.layouts {
        println!(
            "{}: {:.0} % below {} mm, median σ_max {:.2} mm",
            l.layout.name,
            100.0 * l.summary.fraction_below_threshold,
            l.summary.threshold_mm,
            l.summary.median_sigma_max_mm
        );
    }
    write_outputs(&out, &study, &result, &Provenance::default())?;
    println!("report: {}", out.join("report.html").display());
    Ok(())
}
