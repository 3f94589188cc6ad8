//! Uncertain poses through `propagate` and the scenario file (`docs/REFERENCE.md` →
//! `docs/SCENARIO.md`, the tangent covariance of `docs/CONVENTIONS.md`): `covariance_tangent` in and out, `from = "…"`
//! references to command results, φ = ±90° inputs, and bad matrices / references as one
//! `error:` line naming the file, the key and the line.

use crate::contract::common::{assert_clean_error, field, fixture, json_of, matrix, run};
use serde_json::Value;
use std::path::Path;

fn propagate_json(scenario: &Path, samples: usize) -> Value {
    let s = scenario.display().to_string();
    let n = samples.to_string();
    json_of(&run([
        "propagate",
        s.as_str(),
        "--samples",
        n.as_str(),
        "--json",
    ]))
}

/// Largest |a − b| in units of the reference's σᵢσⱼ.
fn worst(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let mut w = 0.0f64;
    for i in 0..6 {
        for j in 0..6 {
            let scale = (b[i][i] * b[j][j]).sqrt();
            w = w.max((a[i][j] - b[i][j]).abs() / scale);
        }
    }
    w
}

#[test]
fn uncertain_propagate_covariance_tangent_matches_numpy() {
    // fixtures/mc: an independent NumPy Monte Carlo (2·10⁶ draws) of a 3-camera chain with
    // full covariances. 2 % (MC) and 3 % (linear) of σᵢσⱼ are > 8 combined standard errors
    // at 200 000 draws (see crates/mc/tests/uncertain.rs for the derivation).
    let v = propagate_json(&fixture("mc/chain_reference.toml"), 200_000);
    let text = std::fs::read_to_string(fixture("mc/chain_reference.json")).expect("read");
    let reference: Value = serde_json::from_str(&text).expect("json");
    let cams = field(&v, "cameras").as_array().expect("cameras");
    for (c, r) in cams
        .iter()
        .zip(reference["cameras"].as_array().expect("ref"))
    {
        // The contract's fields are all still there.
        for key in [
            "name",
            "position_mm",
            "angles_deg",
            "position_sigma_mm",
            "angles_sigma_deg",
        ] {
            field(c, key);
        }
        let mc = matrix(c, "covariance_tangent", 6);
        let lin = matrix(field(c, "linear"), "covariance_tangent", 6);
        let want = matrix(r, "mc_covariance_tangent", 6);
        let w = worst(&mc, &want);
        assert!(w < 0.02, "{}: MC covariance off by {w}", c["name"]);
        let w = worst(&lin, &want);
        assert!(w < 0.03, "{}: linear covariance off by {w}", c["name"]);
        // σ are the square roots of the diagonal.
        let ps = crate::contract::common::arr3(c, "position_sigma_mm");
        let ts = crate::contract::common::arr3(c, "tangent_sigma_deg");
        for k in 0..3 {
            assert!((ps[k] - mc[k][k].sqrt()).abs() < 1e-9);
            assert!((ts[k] - mc[3 + k][3 + k].sqrt()).abs() < 1e-12);
        }
    }
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p.display().to_string()
}

const CAM1_CERTAIN: &str = r#"seed = 3
samples = 2000
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
"#;

/// A full 6×6 in contract units, as JSON rows.
fn cov_rows() -> Vec<Vec<f64>> {
    let s = [0.2, 0.3, 0.1, 0.005, 0.004, 0.006];
    (0..6)
        .map(|i| {
            (0..6)
                .map(|j| {
                    if i == j {
                        s[i] * s[j]
                    } else {
                        0.4 * s[i] * s[j]
                    }
                })
                .collect()
        })
        .collect()
}

#[test]
fn uncertain_from_calibrate_and_bootstrap_results() {
    // cam1 is certain at the identity, so cam2's world pose IS the referenced link: its
    // first-order covariance_tangent must equal the referenced matrix (rounding only).
    let tmp = tempfile::tempdir().expect("temp dir");
    let calib = serde_json::json!({"n_epochs": 140, "base_mm": [61.98, -1.71, 179.76],
        "angles_deg": [179.92, -89.0, 179.76], "covariance_tangent": vec![vec![9.0; 6]; 6],
        "sem_covariance_tangent": cov_rows(), "sem_rule": "n"});
    let boot = serde_json::json!({"method": "absolute", "iterations": 500,
        "base_mm": [10.0, 20.0, 30.0], "angles_deg": [0.0, 90.0, 0.0],
        "covariance_tangent": cov_rows()});
    std::fs::create_dir(tmp.path().join("results")).expect("mkdir");
    write(tmp.path(), "results/calibration.json", &calib.to_string());
    write(tmp.path(), "results/tie.json", &boot.to_string());
    for (file, base) in [
        ("calibration.json", [61.98, -1.71, 179.76]),
        ("tie.json", [10.0, 20.0, 30.0]),
    ] {
        // `from` is relative to the scenario file's directory.
        let text = format!(
            "{CAM1_CERTAIN}[[camera]]\nname = \"cam2\"\nparent = \"cam1\"\nfrom = \"results/{file}\"\n"
        );
        let s = write(tmp.path(), "s.toml", &text);
        let v = propagate_json(Path::new(&s), 2000);
        let cam2 = &v["cameras"][1];
        let pos = crate::contract::common::arr3(cam2, "position_mm");
        for k in 0..3 {
            assert!((pos[k] - base[k]).abs() < 1e-9, "{file}: {pos:?}");
        }
        let lin = matrix(&cam2["linear"], "covariance_tangent", 6);
        let want = cov_rows();
        for i in 0..6 {
            for j in 0..6 {
                assert!(
                    (lin[i][j] - want[i][j]).abs() < 1e-12 * want[i][i].max(want[j][j]),
                    "{file} ({i},{j}): {} vs {}",
                    lin[i][j],
                    want[i][j]
                );
            }
        }
    }
}

#[test]
fn uncertain_phi_90_input_is_a_normal_pose() {
    // A camera looking along the world x axis: ω φ κ = (0, 90, 0) is a valid input; only its
    // ω φ κ σ output is undefined, which the JSON says (null + angles_singular) and one
    // warning line explains.
    let tmp = tempfile::tempdir().expect("temp dir");
    let s = write(
        tmp.path(),
        "fwd.toml",
        "[[camera]]\nname = \"fwd\"\nposition_mm = [0.0, 0.0, 0.0]\nangles_deg = [0.0, 90.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.02, 0.03]\n",
    );
    let r = run(["propagate", s.as_str(), "--samples", "2000", "--json"]);
    let v = json_of(&r);
    let c = &v["cameras"][0];
    assert!(c["angles_singular"].as_bool().expect("bool"));
    assert!(c["angles_sigma_deg"].is_null());
    assert!(c["linear"]["angles_sigma_deg"].is_null());
    let t = crate::contract::common::arr3(&c["linear"], "tangent_sigma_deg");
    assert!((t[1] - 0.02).abs() < 1e-12, "{t:?}");
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{}", r.stderr);
    assert!(lines[0].starts_with("warning: ") && lines[0].contains("fwd"));
}

/// A scenario with `[[camera]]` cam2 ending in `tail` (line 10 onward).
fn bad(dir: &Path, tail: &str) -> String {
    let text = format!("{CAM1_CERTAIN}[[camera]]\nname = \"cam2\"\nparent = \"cam1\"\n{tail}");
    write(dir, "bad.toml", &text)
}

fn rows_toml(rows: &[Vec<f64>]) -> String {
    let r: Vec<String> = rows
        .iter()
        .map(|row| {
            let v: Vec<String> = row.iter().map(|x| format!("{x:e}")).collect();
            format!("  [{}],", v.join(", "))
        })
        .collect();
    format!("covariance_tangent = [\n{}\n]\n", r.join("\n"))
}

#[test]
fn uncertain_bad_covariances_name_file_key_and_line() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let pose = "position_mm = [1.0, 2.0, 3.0]\nangles_deg = [0.0, 0.0, 0.0]\n";
    let mut nonsym = cov_rows();
    nonsym[0][4] += 0.01;
    let mut nonpsd = cov_rows();
    nonpsd[0][0] = -0.04;
    let five: Vec<Vec<f64>> = cov_rows().into_iter().take(5).collect();
    let mut short = cov_rows();
    short[2].pop();
    let cases = [
        (rows_toml(&nonsym), "not symmetric"),
        (rows_toml(&nonpsd), "not positive semi-definite"),
        (rows_toml(&five), "6 rows of 6 numbers"),
        (rows_toml(&short), "6 rows of 6 numbers"),
        (
            "covariance_tangent = \"big\"\n".to_string(),
            "6 rows of 6 numbers",
        ),
    ];
    for (cov, what) in cases {
        // Line 12: the key, after the 9 lines of cam1 and 2 of cam2's header and name/parent.
        let s = bad(tmp.path(), &format!("{pose}{cov}"));
        let r = run(["propagate", s.as_str(), "--json"]);
        assert_clean_error(&r, &["bad.toml:14:", "camera[1].covariance_tangent", what]);
    }
    // On an observer too.
    let text = format!(
        "{CAM1_CERTAIN}[grid]\nx_mm = [1000.0, 1000.0, 1]\ny_mm = [0.0, 0.0, 1]\nz_mm = [0.0, 0.0, 1]\n[[grid.observer]]\nposition_mm = [0.0, -300.0, 0.0]\n{}[[grid.observer]]\nposition_mm = [0.0, 300.0, 0.0]\nsigma_from = \"cam1\"\n",
        rows_toml(&nonpsd)
    );
    let s = write(tmp.path(), "obs.toml", &text);
    let out = tmp.path().join("out").display().to_string();
    let r = run(["grid", s.as_str(), "--out", out.as_str()]);
    assert_clean_error(
        &r,
        &[
            "obs.toml:15:",
            "grid.observer[0].covariance_tangent",
            "positive semi-definite",
        ],
    );
    assert!(!tmp.path().join("out/grid.csv").exists());
}

#[test]
fn uncertain_bad_references_name_file_key_line_and_reference() {
    let tmp = tempfile::tempdir().expect("temp dir");
    // A JSON of the wrong kind: a propagate result.
    write(tmp.path(), "prop.json", r#"{"samples": 10, "cameras": []}"#);
    // A calibrate result without the covariance of its mean.
    write(
        tmp.path(),
        "old.json",
        r#"{"n_epochs": 3, "base_mm": [0, 0, 0], "angles_deg": [0, 0, 0]}"#,
    );
    write(tmp.path(), "broken.json", "{ not json");
    let cases = [
        ("missing.json", "cannot read"),
        ("prop.json", "neither"),
        ("old.json", "sem_covariance_tangent"),
        ("broken.json", "not a JSON document"),
    ];
    for (file, what) in cases {
        let s = bad(tmp.path(), &format!("from = \"{file}\"\n"));
        let r = run(["propagate", s.as_str(), "--json"]);
        assert_clean_error(&r, &["bad.toml:12:", "camera[1].from", file, what]);
    }
    // `from` with numbers of its own, or on a world pose.
    let s = bad(
        tmp.path(),
        "from = \"prop.json\"\nposition_mm = [0.0, 0.0, 0.0]\n",
    );
    let r = run(["propagate", s.as_str(), "--json"]);
    assert_clean_error(&r, &["bad.toml:13:", "camera[1].position_mm", "from"]);
}

#[test]
fn uncertain_correlated_observer_away_from_its_camera() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let text = format!(
        "{CAM1_CERTAIN}[grid]\ncorrelated = true\nx_mm = [1000.0, 1000.0, 1]\ny_mm = [0.0, 0.0, 1]\nz_mm = [0.0, 0.0, 1]\n[[grid.observer]]\nposition_mm = [0.0, -300.0, 0.0]\nsigma_from = \"cam1\"\n[[grid.observer]]\nposition_mm = [0.0, 300.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n"
    );
    let s = write(tmp.path(), "corr.toml", &text);
    let out = tmp.path().join("out").display().to_string();
    let r = run(["grid", s.as_str(), "--out", out.as_str()]);
    assert_clean_error(
        &r,
        &[
            "corr.toml:15:",
            "grid.observer[0].position_mm",
            "cam1",
            "300.000 mm away",
        ],
    );
}
