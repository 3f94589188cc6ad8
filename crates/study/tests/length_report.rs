//! A study whose `[measure]` names scale bars (`scale_bars`, `mpe_mm`; the own study's
//! sequence with the bars of `fixtures/gen/scale_bars.py`): `results.json`'s
//! `measure.summary.length_check` carries the bars as `crashrig measure`'s `summary.json` does,
//! `DIR/measure/` gets `length_check.csv` and its plot, and the report a "Length check"
//! subsection before the trajectories and a verdict box; a bad key is an error naming it.

use crashrig_study::{Options, Provenance, Study, StudyResult, run_study, write_outputs};
use std::path::{Path, PathBuf};

fn study_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml")
}

/// The own study with `keys` added to `[measure]` and the observations with the bars' markers.
fn study_text(keys: &str) -> String {
    std::fs::read_to_string(study_path()).unwrap().replace(
        "observations = \"measure/observations.csv\"\n",
        &format!("observations = \"measure/observations_scale_bars.csv\"\n{keys}"),
    )
}

fn run(text: &str) -> (Study, StudyResult) {
    let study = Study::from_toml_str(text, &study_path()).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let r = run_study(&study, &options).expect("study runs");
    (study, r)
}

#[test]
fn study_with_scale_bars_reports_the_length_check() {
    let (study, r) = run(&study_text(
        "scale_bars = \"measure/scale_bars.csv\"\nmpe_mm = 1.0\n",
    ));
    let sec = study.measure.as_ref().unwrap();
    assert!(sec.scale_bars.as_ref().unwrap().is_absolute());
    assert_eq!(sec.mpe_mm, Some(1.0));
    let m = r.measure.as_ref().expect("[measure]");
    let lc = m.measurement.length_check.as_ref().expect("length check");
    assert_eq!(lc.bars.len(), 3);
    assert!(lc.bars.iter().all(|b| b.epochs.len() == 12));

    // results.json: measure.summary.length_check, the command's fields.
    let json = r.to_json();
    let bars = json["measure"]["summary"]["length_check"]
        .as_array()
        .unwrap();
    assert_eq!(bars.len(), 3);
    for b in bars {
        for key in [
            "name",
            "length_mm",
            "epochs",
            "mean_error_mm",
            "rms_error_mm",
            "max_abs_error_mm",
            "coverage_2sigma",
            "bias_z",
            "scatter_ratio",
            "verdict",
            "within_mpe",
        ] {
            assert!(b.get(key).is_some(), "{key}: {b}");
        }
    }

    let tmp = tempfile::tempdir().unwrap();
    write_outputs(tmp.path(), &study, &r, &Provenance::default()).expect("outputs");
    let d = tmp.path().join("measure");
    let csv = std::fs::read_to_string(d.join("length_check.csv")).unwrap();
    assert_eq!(
        csv,
        crashrig_measure::output::length_check_csv(&m.measurement).unwrap()
    );
    assert_eq!(csv.lines().count(), 1 + 12 * 3);
    assert!(d.join("length_check.png").is_file() && d.join("length_check.svg").is_file());
    // Both files parsed the same way (serde_json's parser is not correctly rounded in the
    // last bit, so a file is compared with a file).
    let read = |p: PathBuf| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let results = read(tmp.path().join("results.json"));
    assert_eq!(
        read(d.join("summary.json"))["length_check"],
        results["measure"]["summary"]["length_check"]
    );

    // The report: the verdict box, and the section before the trajectories.
    let html = std::fs::read_to_string(tmp.path().join("report.html")).unwrap();
    assert!(html.contains("Do the predicted σ hold on the test itself (scale bars)?"));
    let length = html
        .find("<h3>Length check (scale bars)</h3>")
        .expect("the section");
    let trajectories = html
        .find("<h3>Trajectories</h3>")
        .expect("its own subsection");
    let first_plot = html
        .find("x, y, z (world frame) against time with ±3σ bands")
        .expect("a trajectory plot");
    assert!(length < trajectories && trajectories < first_plot);
    for b in &lc.bars {
        // each bar's verdict in words opens with its name
        let start = format!("{}: ", b.bar.name);
        assert!(html[length..trajectories].contains(&start), "{start}");
    }
    assert!(html[length..trajectories].contains("Length check: measured − certificate length"));
}

#[test]
fn study_without_scale_bars_has_no_length_check() {
    let (_, r) = run(&std::fs::read_to_string(study_path()).unwrap());
    let m = r.measure.as_ref().unwrap();
    assert!(m.measurement.length_check.is_none());
    assert!(
        r.to_json()["measure"]["summary"]
            .get("length_check")
            .is_none()
    );
}

#[test]
fn bad_length_check_keys_name_the_key_and_line() {
    let err = |keys: &str| {
        Study::from_toml_str(&study_text(keys), &study_path())
            .unwrap_err()
            .to_string()
    };
    let e = err("mpe_mm = 1.0\n");
    assert!(
        e.contains("measure.mpe_mm") && e.contains("needs measure.scale_bars"),
        "{e}"
    );
    let e = err("scale_bars = \"measure/none.csv\"\n");
    assert!(e.contains("measure.scale_bars"), "{e}");
    let e = err("scale_bars = \"measure/scale_bars.csv\"\nmpe_mm = -2.0\n");
    assert!(e.contains("measure.mpe_mm"), "{e}");
    // A bad file: the [measure] step's error names the file and line.
    let tmp = tempfile::tempdir().unwrap();
    let bad = tmp.path().join("bars.csv");
    std::fs::write(
        &bad,
        "name,marker_1,marker_2,length_mm,sigma_mm\nx,bar_door_1,bar_door_1,300,0\n",
    )
    .unwrap();
    let study = Study::from_toml_str(
        &study_text(&format!("scale_bars = \"{}\"\n", bad.display())),
        &study_path(),
    )
    .unwrap();
    let options = Options {
        samples: Some(20),
        no_sensitivity: true,
        ..Options::default()
    };
    let e = crashrig_input::message::error_line(&run_study(&study, &options).unwrap_err());
    assert!(
        e.contains(&format!("{}:2:", bad.display())) && e.contains("to itself"),
        "{e}"
    );
}
