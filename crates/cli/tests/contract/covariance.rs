//! `crashrig covariance`: the JSON document (what `measure --a-covariance` reads) and one-line
//! errors on bad input, with nothing written.

use crate::common::{assert_clean_error, fixture, json_of, run};
use std::path::Path;

fn args_with(camera: &str, cp: &str, out: &str) -> Vec<String> {
    let model = fixture("covariance/mc/model");
    vec![
        "covariance".into(),
        model.to_string_lossy().into_owned(),
        "--camera".into(),
        camera.into(),
        "--control-points".into(),
        cp.into(),
        "--mm-per-unit".into(),
        "1000".into(),
        "--out".into(),
        out.into(),
    ]
}

fn args(cp: &str, out: &str) -> Vec<String> {
    args_with("cam_out/", cp, out)
}

fn control() -> String {
    fixture("covariance/mc/control_points.csv")
        .to_string_lossy()
        .into_owned()
}

#[test]
fn covariance_writes_the_contract_document() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a_cov.json");
    let mut a = args(&control(), out.to_str().unwrap());
    a.push("--json".into());
    let r = run(&a);
    let v = json_of(&r);
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v, file, "--json prints the same object as --out holds");
    for key in [
        "sigma0_px",
        "pixel_sigma_px",
        "observations",
        "parameters",
        "control_points",
        "intrinsics",
        "mm_per_unit",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["intrinsics"], "all");
    // 24 in the file, 16 of them seen by A (the others are outside every image).
    assert_eq!(v["control_points"], 16);
    // 482 in the model; one free point is seen by a single image and left out.
    assert_eq!(v["observations"], 481);
    assert_eq!(v["points_left_out"], 1);
    // σ̂₀ of a model adjusted from 0.5 px noise: within 10 % (redundancy ~700: 2.7 % per SE).
    let s0 = v["sigma0_px"].as_f64().unwrap();
    assert!((s0 - 0.5).abs() < 0.05, "{s0}");
    assert_eq!(v["pixel_sigma_px"].as_f64().unwrap(), s0);
    let epochs = v["epochs"].as_object().unwrap();
    assert_eq!(epochs.len(), 8);
    assert!(epochs.contains_key("000001") && epochs.contains_key("000008"));
    for m in epochs.values() {
        let m = m.as_array().unwrap();
        assert_eq!(m.len(), 6);
        for (i, row) in m.iter().enumerate() {
            let row = row.as_array().unwrap();
            assert_eq!(row.len(), 6);
            assert!(row[i].as_f64().unwrap() > 0.0);
        }
    }
    let joint = &v["joint"];
    assert_eq!(joint["epochs"].as_array().unwrap().len(), 8);
    let cov = joint["covariance_tangent"].as_array().unwrap();
    assert_eq!(cov.len(), 48);
    assert!(cov.iter().all(|r| r.as_array().unwrap().len() == 48));
    // The per-epoch block is the joint's diagonal block.
    let first = &epochs["000001"][2][4];
    assert_eq!(first, &cov[2][4]);
    // --intrinsics fixed gives smaller variances than all.
    let mut b = args(&control(), dir.path().join("f.json").to_str().unwrap());
    b.extend(["--intrinsics".into(), "fixed".into(), "--json".into()]);
    let f = json_of(&run(&b));
    assert_eq!(f["intrinsics"], "fixed");
    let var =
        |d: &serde_json::Value, k: usize| d["joint"]["covariance_tangent"][k][k].as_f64().unwrap();
    assert!((0..48).all(|k| var(&f, k) <= var(&v, k) * (1.0 + 1e-9)));
}

fn expect_error(cp_text: Option<&str>, extra: &[&str], needles: &[&str]) {
    expect_error_camera("cam_out/", cp_text, extra, needles);
}

fn expect_error_camera(camera: &str, cp_text: Option<&str>, extra: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let cp = match cp_text {
        Some(t) => {
            let p = dir.path().join("cp.csv");
            std::fs::write(&p, t).unwrap();
            p.to_string_lossy().into_owned()
        }
        None => control(),
    };
    let out = dir.path().join("out.json");
    let mut a = args_with(camera, &cp, out.to_str().unwrap());
    a.extend(extra.iter().map(|s| s.to_string()));
    let r = run(&a);
    assert_clean_error(&r, needles);
    assert!(
        !Path::new(&out).exists(),
        "nothing may be written after an error"
    );
}

#[test]
fn covariance_bad_input_is_one_error_line_and_writes_nothing() {
    expect_error(Some(""), &[], &["cp.csv:1", "empty"]);
    expect_error(Some("point3D_id\n1\n2\n"), &[], &["cp.csv", "at least 3"]);
    expect_error(
        Some("point3D_id\n1\n2\n999999\n"),
        &[],
        &["cp.csv:4", "999999", "not a point"],
    );
    expect_error(
        Some("point3D_id,sigma_mm\n1,0\n2,abc\n3,0\n"),
        &[],
        &["cp.csv:3", "sigma_mm"],
    );
    expect_error_camera("nothing/", None, &[], &["model", "nothing/", "no image"]);
    expect_error(None, &["--pixel-sigma-px", "-1"], &["--pixel-sigma-px"]);
    // Control points with a prior so loose that they fix nothing: a gauge freedom is left.
    let loose: String = std::iter::once("point3D_id,sigma_mm\n".to_string())
        .chain((1..=24).map(|i| format!("{i},1e12\n")))
        .collect();
    expect_error(Some(&loose), &[], &["singular system", "not determined"]);
}
