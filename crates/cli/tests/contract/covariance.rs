//! `crashrig covariance`: the JSON document (what `measure --a-covariance` reads) and one-line
//! errors on bad input, with nothing written.

use crate::contract::common::{assert_clean_error, fixture, json_of, run};
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

/// Issue 36: an empty selector is refused naming its flag (it would make every image camera A,
/// or B), here and in `calibrate` and `bootstrap`.
#[test]
fn empty_selectors_are_one_error_line_naming_the_flag() {
    expect_error_camera("", None, &[], &["--camera", "must name a camera"]);
    expect_error_camera("  ", None, &[], &["--camera", "must name a camera"]);
    let paper = fixture("rig/paper").display().to_string();
    let r = run([
        "calibrate",
        &paper,
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "",
        "--mm-per-unit",
        "1",
    ]);
    assert_clean_error(&r, &["--camera-b", "must name a camera"]);
    let r = run([
        "bootstrap",
        "x.db",
        "--model",
        &paper,
        "--image-a",
        "",
        "--image-b",
        "b.png",
    ]);
    assert_clean_error(&r, &["--image-a", "must name an image"]);
    // A prefix matching nothing names what the model has nearest.
    expect_error_camera(
        "cam_ot/",
        None,
        &[],
        &[
            "cam_ot/",
            "nearest image-name beginnings: `cam_out/` (8 images)",
        ],
    );
}

/// The generated scene of `crashrig_covariance::synthetic` written as a model with its
/// control points; returns (model dir, control file).
fn write_scene(dir: &Path, scene: &crashrig_covariance::synthetic::Scene) -> (String, String) {
    let model = dir.join("model");
    std::fs::create_dir_all(&model).unwrap();
    scene
        .model
        .write(&model, crashrig_colmap::ModelFormat::Binary)
        .unwrap();
    let cp = dir.join("control.csv");
    let body: String = scene
        .control_ids
        .iter()
        .map(|id| format!("{id}\n"))
        .collect();
    std::fs::write(&cp, format!("point3D_id\n{body}")).unwrap();
    (
        model.to_string_lossy().into_owned(),
        cp.to_string_lossy().into_owned(),
    )
}

/// Issue 36: points on a camera centre give one `warning:` line naming them and the output
/// lists them; a numerically singular bundle is one error line naming the frame, and nothing
/// is written.
#[test]
fn points_on_a_centre_warn_and_a_singular_bundle_is_refused() {
    use crashrig_covariance::synthetic::{ring_scene, with_line_image, with_points_at_centre};
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) = with_points_at_centre(&ring_scene(4, 0.3), 1, 2, 1e-10);
    let (model, cp) = write_scene(&dir.path().join("centre"), &scene);
    let out = dir.path().join("centre.json");
    let r = run([
        "covariance",
        &model,
        "--camera",
        "cam_out/",
        "--control-points",
        &cp,
        "--mm-per-unit",
        "1000",
        "--pixel-sigma-px",
        "0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(r.success, "{}", r.stderr);
    let warnings: Vec<&str> = r
        .stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", r.stderr);
    assert!(
        warnings[0].starts_with("warning: 2 point(s) lie on the projection centre")
            && warnings[0]
                .contains("point3D 20001 (images `cam_out/0001.png`, `cam_pan/0001.png`)"),
        "{}",
        warnings[0]
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["points_at_camera_centre"][0]["point3D_id"], 20_001);

    let scene = with_line_image(&ring_scene(4, 0.3), 1e-6);
    let (model, cp) = write_scene(&dir.path().join("line"), &scene);
    let out = dir.path().join("line.json");
    let r = run([
        "covariance",
        &model,
        "--camera",
        "cam_out/",
        "--control-points",
        &cp,
        "--mm-per-unit",
        "1000",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_clean_error(
        &r,
        &["singular system", "cam_out/9999.png", "not determined"],
    );
    assert!(!out.exists());
}
