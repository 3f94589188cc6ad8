//! `[measure] a_control_points`: camera A's covariance computed from the bundle as a typed step
//! of the study (no JSON in between) feeds the measurement exactly as `crashrig covariance
//! --out FILE` + `crashrig measure --a-covariance FILE` would; the report and `results.json`
//! show A's σ per epoch and σ̂₀; bad keys are errors naming the study file, key and line.

use crashrig_colmap::{Image, ModelFormat, Reconstruction};
use crashrig_covariance::synthetic::{LabSettings, lab_scene};
use crashrig_measure::engine::Settings;
use crashrig_measure::{ANoise, MeasureConfig};
use crashrig_study::Study;
use crashrig_study::{Options, run_study};
use crashrig_study::{Provenance, write_outputs};
use std::path::{Path, PathBuf};

fn own() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own")
}

/// A lab bundle of camera A with the own study's epoch names (`cam_out/000001.png` …
/// `000012.png`): the synthetic lab sequence of `crashrig-covariance`, 0.3 px noise.
fn write_a_model(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = lab_scene(&LabSettings {
        epochs: 12,
        points: 300,
        path_length: 2.0,
        noise_px: 0.3,
        seed: 3,
    });
    let m = &scene.model;
    let images: Vec<Image> = m
        .images()
        .iter()
        .enumerate()
        .map(|(i, im)| {
            let mut im = im.clone();
            im.name = format!("cam_out/{:06}.png", i + 1);
            im
        })
        .collect();
    let renamed = Reconstruction::from_records(
        m.cameras().to_vec(),
        Vec::new(),
        Vec::new(),
        images,
        m.points3d().to_vec(),
    )
    .unwrap();
    let model = dir.join("a_model");
    std::fs::create_dir_all(&model).unwrap();
    renamed.write(&model, ModelFormat::Binary).unwrap();
    let mut csv = String::from("point3D_id,sigma_mm\n");
    for id in &scene.control_ids {
        csv.push_str(&format!("{id},0\n"));
    }
    let control = dir.join("control_points.csv");
    std::fs::write(&control, csv).unwrap();
    (model, control)
}

/// The own study with its paths made absolute and `[measure]`'s σ keys replaced by `a_keys`.
fn study_text(a_keys: &str) -> String {
    let o = own();
    let abs = |rel: &str| format!("\"{}\"", o.join(rel).display());
    let text = std::fs::read_to_string(o.join("study.toml")).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        let line = if line.starts_with("sigma_a_position_mm") {
            a_keys.to_string()
        } else if line.starts_with("sigma_a_angles_deg") {
            continue;
        } else {
            let mut l = line.to_string();
            for rel in [
                "calibration",
                "tie/database.db",
                "tie/model",
                "measure/model",
                "measure/observations.csv",
            ] {
                l = l.replace(&format!("= \"{rel}\""), &format!("= {}", abs(rel)));
            }
            l.replace(
                "\"tie/model:1\"",
                &format!("\"{}:1\"", o.join("tie/model").display()),
            )
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

#[test]
fn the_study_computes_a_from_the_bundle_and_measures_with_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, control) = write_a_model(tmp.path());
    let path = tmp.path().join("study.toml");
    std::fs::write(
        &path,
        study_text(&format!(
            "a_model = \"{}\"\na_control_points = \"{}\"\na_intrinsics = \"colmap\"",
            model.display(),
            control.display()
        )),
    )
    .unwrap();
    let study = Study::from_path(&path).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let r = run_study(&study, &options).expect("study runs");
    let m = r.measure.as_ref().expect("[measure]");
    let a = m.a_covariance.as_ref().expect("A from the bundle");
    assert_eq!(a.epochs.len(), 12);
    assert_eq!(a.intrinsics.name(), "colmap");
    // σ̂₀ of 0.3 px noise (redundancy ~ 2 n_obs: within 10 % for thousands of observations).
    assert!((a.sigma0_px - 0.3).abs() < 0.03, "{}", a.sigma0_px);
    assert_eq!(a.pixel_sigma_px, a.sigma0_px);

    // The same as the two commands through a file: `covariance --out` then `measure
    // --a-covariance` with the study's link, tie, samples and seed.
    let file = tmp.path().join("a_cov.json");
    std::fs::write(&file, serde_json::to_string(&a.to_json()).unwrap()).unwrap();
    let sec = study.measure.as_ref().unwrap();
    let config = MeasureConfig {
        model: sec.model.clone(),
        camera_a: sec.camera_a.clone(),
        camera_b: sec.camera_b.clone(),
        camera_c: sec.camera_c.clone(),
        a_from_b: r.calibration.link,
        b_from_c: r.tie.as_ref().map(|t| t.link),
        observations: sec.observations.clone(),
        mm_per_unit: 1000.0,
        a_noise: ANoise::File(file),
        settings: Settings {
            samples: 200,
            seed: r.seed,
            pixel_sigma_px: sec.pixel_sigma_px,
            reference_epoch: None,
            frame_rate_hz: sec.frame_rate_hz,
            frame_times: None,
            threshold_mm: sec.threshold_mm,
            max_reprojection_px: None,
            cfc: None,
            sync_sigma_ms: 0.0,
        },
        pixel_sigma_from: Default::default(),
        scale_bars: None,
        out: None,
    };
    let cmd = crashrig_measure::run(&config, None).unwrap();
    assert_eq!(cmd.measurement.rows.len(), m.measurement.rows.len());
    // serde_json's default float parser is within 1 ulp of the written shortest form, so the
    // file's matrices may differ from the typed ones in the last bit: the σ agree to 1e-12
    // relative (the Monte Carlo draws are the same streams).
    let close = |a: Option<nalgebra::Vector3<f64>>, b: Option<nalgebra::Vector3<f64>>| match (a, b)
    {
        (Some(a), Some(b)) => (a - b).amax() <= 1e-12 * a.amax(),
        (a, b) => a.is_none() && b.is_none(),
    };
    for (x, y) in cmd.measurement.rows.iter().zip(&m.measurement.rows) {
        assert!(
            close(x.sigma_mm, y.sigma_mm),
            "{:?} {:?}",
            x.sigma_mm,
            y.sigma_mm
        );
        assert!(
            close(x.displacement_sigma_mm, y.displacement_sigma_mm),
            "{:?} {:?}",
            x.displacement_sigma_mm,
            y.displacement_sigma_mm
        );
    }

    // The outputs: results.json's summary, the file, the plot, the report section.
    let out = tmp.path().join("out");
    write_outputs(&out, &study, &r, &Provenance::default()).unwrap();
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let ja = &results["measure"]["a_covariance"];
    assert_eq!(ja["sigma0_px"].as_f64(), Some(a.sigma0_px));
    assert_eq!(ja["epoch_sigmas"].as_array().map(Vec::len), Some(12));
    assert!(ja.get("joint").is_none());
    let written: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("measure/a_covariance.json")).unwrap(),
    )
    .unwrap();
    // The same document (numbers to serde_json's parsing, ≤ 1 ulp).
    let want = a.to_json();
    assert_eq!(written["epochs"].as_object().map(|o| o.len()), Some(12));
    assert_eq!(written["joint"]["epochs"], want["joint"]["epochs"]);
    let rows = |v: &serde_json::Value| -> Vec<Vec<f64>> {
        serde_json::from_value(v["joint"]["covariance_tangent"].clone()).unwrap()
    };
    let (w, g) = (rows(&written), rows(&want));
    assert_eq!(w.len(), 72);
    for (rw, rg) in w.iter().zip(&g) {
        for (x, y) in rw.iter().zip(rg) {
            assert!((x - y).abs() <= 2.0 * f64::EPSILON * y.abs(), "{x} vs {y}");
        }
    }
    assert!(out.join("measure/a_sigma.png").is_file());
    assert!(out.join("measure/a_sigma.svg").is_file());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("comes from the bundle"), "report section");
    assert!(html.contains(&format!("{:.3} px", a.sigma0_px)));
    assert!(html.contains("crashrig covariance "), "provenance command");
}

fn study_error(a_keys: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    let (model, control) = write_a_model(tmp.path());
    let keys = a_keys
        .replace("MODEL", &model.display().to_string())
        .replace("CONTROL", &control.display().to_string());
    let path = tmp.path().join("study.toml");
    std::fs::write(&path, study_text(&keys)).unwrap();
    let e = Study::from_path(&path).unwrap_err().to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    e
}

#[test]
fn bad_bundle_keys_name_the_key_and_line() {
    let line = |e: &str| {
        // Line of the first a_ key: the own study's [measure] sigma_a_position_mm line.
        let text = std::fs::read_to_string(own().join("study.toml")).unwrap();
        let n = text
            .lines()
            .position(|l| l.starts_with("sigma_a_position_mm"))
            .unwrap()
            + 1;
        assert!(e.contains(&format!(":{n}:")), "{e}");
    };
    let e = study_error("a_control_points = \"CONTROL\"\nsigma_a_position_mm = [1.0, 1.0, 1.0]");
    assert!(
        e.contains("measure.a_control_points") && e.contains("one source"),
        "{e}"
    );
    line(&e);
    let e = study_error("a_model = \"MODEL\"");
    assert!(
        e.contains("measure.a_model") && e.contains("needs measure.a_control_points"),
        "{e}"
    );
    line(&e);
    let e = study_error("a_control_points = \"CONTROL\"\na_intrinsics = \"some\"");
    assert!(
        e.contains("measure.a_intrinsics") && e.contains("all, colmap or fixed"),
        "{e}"
    );
    let e = study_error("a_control_points = \"CONTROL\"\na_pixel_sigma_px = -1.0");
    assert!(e.contains("measure.a_pixel_sigma_px"), "{e}");
    let e = study_error("a_control_points = \"nothing.csv\"");
    assert!(
        e.contains("measure.a_control_points") && e.contains("does not exist"),
        "{e}"
    );
    line(&e);
}

/// A bundle the datum cannot fix (two control points) fails the study's `[measure]` step
/// with the covariance library's error naming the control-point file.
#[test]
fn a_bundle_without_datum_fails_the_step_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, _) = write_a_model(tmp.path());
    let control = tmp.path().join("two.csv");
    std::fs::write(&control, "point3D_id\n1\n2\n").unwrap();
    let path = tmp.path().join("study.toml");
    std::fs::write(
        &path,
        study_text(&format!(
            "a_model = \"{}\"\na_control_points = \"{}\"",
            model.display(),
            control.display()
        )),
    )
    .unwrap();
    let study = Study::from_path(&path).expect("study");
    let options = Options {
        samples: Some(200),
        no_sensitivity: true,
        ..Options::default()
    };
    let e = crashrig_input::message::error_line(&run_study(&study, &options).unwrap_err());
    assert!(e.contains("[measure]") && e.contains("two.csv"), "{e}");
}
