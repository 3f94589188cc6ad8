//! `crashrig measure` end to end on `fixtures/measure/sequence`: the contract's outputs,
//! determinism across thread counts, warnings, one-line errors and all-or-nothing output.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence")
}

fn base_args(out: &Path, observations: &Path) -> Vec<String> {
    let f = fixture();
    let p = |n: &str| f.join(n).display().to_string();
    vec![
        "measure".into(),
        p("model"),
        "--camera-a".into(),
        "cam_out/".into(),
        "--camera-b".into(),
        "2".into(),
        "--camera-c".into(),
        "3".into(),
        "--link".into(),
        p("link.json"),
        "--tie".into(),
        p("tie.json"),
        "--observations".into(),
        observations.display().to_string(),
        "--a-covariance".into(),
        p("a_covariance.json"),
        "--mm-per-unit".into(),
        "1000".into(),
        "--pixel-sigma-px".into(),
        "0.1".into(),
        "--frame-rate-hz".into(),
        "1000".into(),
        "--samples".into(),
        "300".into(),
        "--out".into(),
        out.display().to_string(),
    ]
}

fn run(args: &[String], extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .args(args)
        .args(extra)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn measure_writes_the_contract_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("m");
    let o = run(
        &base_args(&out, &fixture().join("observations.csv")),
        &["--json", "--seed", "9"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in [
        "epochs",
        "markers",
        "rows",
        "samples_per_point",
        "threshold_mm",
        "fraction_below_threshold",
    ] {
        assert!(summary.get(key).is_some(), "{key}");
    }
    assert_eq!(summary["epochs"], 50);
    assert_eq!(summary["markers"], 8);
    assert_eq!(summary["rows"], 400);
    assert_eq!(summary["samples_per_point"], 300);
    assert_eq!(summary["rows_fewer_than_two_views"], 5);
    let on_disk: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(on_disk["rows"], summary["rows"]);
    let traj = std::fs::read_to_string(out.join("trajectories.csv")).unwrap();
    let mut lines = traj.lines();
    assert_eq!(
        lines.next().unwrap(),
        "epoch,marker,x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,n_views"
    );
    assert_eq!(traj.lines().count(), 401);
    // A one-view row: kept, position and σ empty, flagged in displacements.csv.
    assert!(traj.contains("\n000021,knee_r,,,,,,,,1\n"), "{traj}");
    let disp = std::fs::read_to_string(out.join("displacements.csv")).unwrap();
    let row = disp
        .lines()
        .find(|l| l.starts_with("000021,knee_r,"))
        .unwrap();
    assert!(row.ends_with(",fewer_than_two_views"), "{row}");
    assert!(out.join("plots/head_l.png").is_file());
    assert!(out.join("plots/head_l.svg").is_file());
    // No temporary directory is left beside DIR.
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, vec![std::ffi::OsString::from("m")]);

    // Same seed, other thread counts: identical files (summary aside: elapsed time).
    for threads in ["1", "2"] {
        let out2 = tmp.path().join(format!("t{threads}"));
        let o = run(
            &base_args(&out2, &fixture().join("observations.csv")),
            &["--seed", "9", "--threads", threads, "--no-plots"],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        for f in ["trajectories.csv", "displacements.csv"] {
            assert_eq!(
                std::fs::read(out.join(f)).unwrap(),
                std::fs::read(out2.join(f)).unwrap(),
                "{f} with {threads} threads"
            );
        }
    }
    // A previous output is replaced.
    let o = run(
        &base_args(&out, &fixture().join("observations.csv")),
        &["--no-plots"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.join("plots").exists());
}

#[test]
fn epoch_without_a_pose_is_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let mut obs = std::fs::read_to_string(fixture().join("observations.csv")).unwrap();
    obs.push_str("000077,B,head_l,100,100\n000077,C,head_l,100,100\n");
    let obs_path = tmp.path().join("obs.csv");
    std::fs::write(&obs_path, obs).unwrap();
    let out = tmp.path().join("m");
    let o = run(&base_args(&out, &obs_path), &["--no-plots", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(
        err.lines().filter(|l| l.starts_with("warning:")).count(),
        1,
        "{err}"
    );
    assert!(
        err.contains("epoch `000077`") && err.contains("2 observation"),
        "{err}"
    );
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["skipped_epochs"][0]["epoch"], "000077");
}

/// Runs a failing case: exactly one `error:` line containing every `needle`, no panic, a
/// non-zero exit, and no output directory (nor temporary sibling) left behind.
fn fails(tmp: &Path, obs_text: &str, extra: &[&str], needles: &[&str]) {
    let obs_path = tmp.join("obs.csv");
    std::fs::write(&obs_path, obs_text).unwrap();
    let out = tmp.join("out");
    let mut args = base_args(&out, &obs_path);
    // `--link X` in `extra` replaces the fixture's link.
    let mut extra = extra.to_vec();
    if extra.first() == Some(&"--link") {
        let k = args.iter().position(|a| a == "--link").unwrap();
        args[k + 1] = extra[1].to_string();
        extra.drain(..2);
    }
    let o = run(&args, &extra);
    assert!(!o.status.success());
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("warning:")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{err}"
    );
    for n in needles {
        assert!(lines[0].contains(n), "`{n}` not in {}", lines[0]);
    }
    assert!(!out.exists(), "nothing may be written");
    let left: Vec<_> = std::fs::read_dir(tmp)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with(".measure"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn bad_input_is_one_error_line_and_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let head = "epoch,camera,marker,u_px,v_px\n";
    fails(
        t,
        &format!("{head}000001,B,m,1,2\n000001,C,m,nan,2\n"),
        &[],
        &["obs.csv:3:", "u_px is nan"],
    );
    fails(
        t,
        &format!("{head}000001,X,m,1,2\n"),
        &[],
        &["obs.csv:2:", "unknown camera `X`"],
    );
    fails(
        t,
        "epoch,camera,mark,u_px,v_px\n000001,B,m,1,2\n",
        &[],
        &["obs.csv:1:", "unknown column `mark`"],
    );
    fails(
        t,
        "epoch,marker,u_px,v_px\n000001,m,1,2\n",
        &[],
        &["obs.csv:1:", "missing column `camera`"],
    );
    fails(
        t,
        &format!("{head}000099,B,m,1,2\n"),
        &[],
        &["no observation belongs"],
    );
    let good = std::fs::read_to_string(fixture().join("observations.csv")).unwrap();
    fails(
        t,
        &good,
        &["--reference-epoch", "000999"],
        &["--reference-epoch", "000999"],
    );
    fails(t, &good, &["--samples", "1"], &["--samples"]);
    let bad_link = t.join("link.json");
    std::fs::write(&bad_link, r#"{"base_mm":[1,2,3],"angles_deg":[0,0,0]}"#).unwrap();
    fails(
        t,
        &good,
        &["--link", bad_link.to_str().unwrap()],
        &["link.json", "covariance_tangent"],
    );
}

#[test]
fn an_unrelated_existing_directory_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("mine");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "keep me").unwrap();
    let o = run(
        &base_args(&out, &fixture().join("observations.csv")),
        &["--no-plots"],
    );
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("not a previous `measure` output"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "keep me"
    );
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
}

#[test]
fn sigma_options_and_the_missing_uncertainty_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let obs = fixture().join("observations.csv");
    let strip = |args: Vec<String>| -> Vec<String> {
        let k = args.iter().position(|a| a == "--a-covariance").unwrap();
        args.iter()
            .enumerate()
            .filter(|(i, _)| *i != k && *i != k + 1)
            .map(|(_, a)| a.clone())
            .collect()
    };
    let sigma = |out: &Path, extra: &[&str]| {
        let o = run(&strip(base_args(out, &obs)), extra);
        assert!(o.status.success(), "{}", stderr(&o));
        let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (
            s["median_displacement_sigma_max_mm"].as_f64().unwrap(),
            stderr(&o),
        )
    };
    let (with, err) = sigma(
        &tmp.path().join("a"),
        &[
            "--json",
            "--no-plots",
            "--sigma-a-position-mm",
            "0.3",
            "0.3",
            "0.3",
            "--sigma-a-angles-deg",
            "0.004",
            "0.004",
            "0.004",
        ],
    );
    assert!(!err.contains("warning"), "{err}");
    let (without, err) = sigma(&tmp.path().join("b"), &["--json", "--no-plots"]);
    assert!(
        err.contains("warning: no uncertainty given for camera A"),
        "{err}"
    );
    // A's per-epoch error does not cancel in displacements: without it they are smaller.
    assert!(without < 0.8 * with, "{without} vs {with}");
}
