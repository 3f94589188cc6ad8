//! A study whose `[measure]` has camera C: the pixel σ check in `results.json`
//! (`measure.summary.pixel_sigma_check`), a verdict box and the subsection "Pixel σ checked on the
//! test" before the trajectories; with `pixel_sigma_px = "estimate"` the Monte Carlo uses the
//! check's estimate — the same numbers as stating that estimate.

use crashrig_study::{Options, Provenance, Study, StudyResult, run_study, write_outputs};
use std::path::{Path, PathBuf};

fn study_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml")
}

/// The own study with `[measure]`'s `pixel_sigma_px = 0.3` replaced by `value`.
fn run(value: &str) -> (Study, StudyResult) {
    let text = std::fs::read_to_string(study_path()).unwrap().replace(
        "pixel_sigma_px = 0.3\n",
        &format!("pixel_sigma_px = {value}\n"),
    );
    let study = Study::from_toml_str(&text, &study_path()).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let r = run_study(&study, &options).expect("study runs");
    (study, r)
}

fn report(study: &Study, r: &StudyResult) -> String {
    let tmp = tempfile::tempdir().unwrap();
    write_outputs(tmp.path(), study, r, &Provenance::default()).expect("outputs");
    std::fs::read_to_string(tmp.path().join("report.html")).unwrap()
}

#[test]
fn the_study_reports_the_pixel_sigma_check_and_uses_its_estimate() {
    let (study, stated) = run("0.3");
    let json = stated.to_json();
    let check = &json["measure"]["summary"]["pixel_sigma_check"];
    assert!(check["sigma_ratio"].as_f64().unwrap() > 0.0, "{check}");
    assert!(
        json["measure"]["summary"]
            .get("pixel_sigma_estimate")
            .is_none()
    );
    let html = report(&study, &stated);
    // (the page escapes ' and ")
    assert!(html.contains("Were the image errors what was stated (the test&#39;s own residuals)?"));
    let section = html
        .find("<h3>Pixel σ checked on the test</h3>")
        .expect("the section");
    let trajectories = html
        .find("<h3>Trajectories</h3>")
        .expect("its own subsection");
    assert!(section < trajectories);
    let verdict = check["verdict"].as_str().unwrap();
    assert!(html[section..trajectories].contains(verdict), "{verdict}");

    // "estimate": the check's estimate in every draw, said in results.json and the report.
    let (study_e, est) = run("\"estimate\"");
    let json_e = est.to_json();
    let used = &json_e["measure"]["summary"]["pixel_sigma_estimate"];
    let check_e = &json_e["measure"]["summary"]["pixel_sigma_check"];
    assert_eq!(used["B"]["scale"], check_e["sigma_ratio"], "{used}");
    // The estimate does not depend on the σ stated beside it (0.3 px here, 0.5 px there).
    let (a, b) = (
        check["estimate_px"].as_f64().unwrap(),
        check_e["estimate_px"].as_f64().unwrap(),
    );
    assert!((a - b).abs() <= 1e-9 * a, "{a} vs {b}");
    let html_e = report(&study_e, &est);
    assert!(html_e.contains("pixel_sigma_px = &quot;estimate&quot;: the Monte Carlo used"));
    // The same measurement as the run that states the estimate (one common estimate here).
    assert_eq!(used["per_camera"], false);
    let (_, typed) = run(&format!("{b}"));
    let (me, mt) = (
        &est.measure.as_ref().unwrap().measurement,
        &typed.measure.as_ref().unwrap().measurement,
    );
    assert_eq!(me.rows.len(), mt.rows.len());
    for (x, y) in me.rows.iter().zip(&mt.rows) {
        assert_eq!(x.sigma_mm, y.sigma_mm);
    }
}
