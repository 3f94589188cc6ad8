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

/// The base arguments without `--frame-rate-hz`.
fn without_frame_rate(mut args: Vec<String>) -> Vec<String> {
    let k = args.iter().position(|a| a == "--frame-rate-hz").unwrap();
    args.drain(k..k + 2);
    args
}

#[test]
fn kinematics_trigger_offset_and_iso_mme_export() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("m");
    let obs = fixture().join("observations.csv");
    let o = run(
        &base_args(&out, &obs),
        &[
            "--cfc",
            "60",
            "--cfc-standard",
            "iso6487",
            "--sync-sigma-ms",
            "0.3",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("trigger offset σ 0.3 ms: share of the variance"),
        "{stdout}"
    );
    let kin = std::fs::read_to_string(out.join("kinematics.csv")).unwrap();
    assert_eq!(
        kin.lines().next().unwrap(),
        "epoch,marker,time_s,dx_mm,dy_mm,dz_mm,sigma_dx_mm,sigma_dy_mm,sigma_dz_mm,vx_m_s,vy_m_s,vz_m_s,sigma_vx_m_s,sigma_vy_m_s,sigma_vz_m_s,ax_m_s2,ay_m_s2,az_m_s2,sigma_ax_m_s2,sigma_ay_m_s2,sigma_az_m_s2"
    );
    let traj = std::fs::read_to_string(out.join("trajectories.csv")).unwrap();
    assert_eq!(kin.lines().count(), traj.lines().count());
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["kinematics"]["cfc"], 60);
    assert_eq!(s["kinematics"]["standard"], "iso6487");
    assert!(
        s["kinematics"]["filter"]
            .as_str()
            .unwrap()
            .starts_with("ISO 6487")
    );
    let share = &s["sync_offset"]["variance_share"]["filtered_displacement"]["median"];
    assert!((0.0..=1.0).contains(&share.as_f64().unwrap()), "{share}");
    assert!(out.join("plots").read_dir().unwrap().any(|e| {
        e.unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with("_kinematics.png")
    }));

    // Export: T.mme, Channel/T.chn, Channel/T.001 … with filter class D (CFC 60).
    let iso = tmp.path().join("iso");
    let e = Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .args(["export", "iso-mme"])
        .arg(&out)
        .arg("--out")
        .arg(&iso)
        .args(["--test-number", "T26", "--json"])
        .output()
        .unwrap();
    assert!(e.status.success(), "{}", stderr(&e));
    let j: serde_json::Value = serde_json::from_slice(&e.stdout).unwrap();
    assert_eq!(j["filter_class"], "D");
    assert_eq!(j["source"], "kinematics.csv");
    let n = j["channels"].as_array().unwrap().len();
    assert_eq!(n, 6 * s["markers"].as_u64().unwrap() as usize);
    assert!(iso.join("T26.mme").is_file() && iso.join("Channel/T26.chn").is_file());
    assert!(iso.join(format!("Channel/T26.{n:03}")).is_file());
}

#[test]
fn kinematics_bad_input_is_one_error_line_and_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let good = std::fs::read_to_string(fixture().join("observations.csv")).unwrap();
    fails(
        t,
        &good,
        &["--cfc", "100"],
        &["--cfc", "100", "60, 180, 600, 1000"],
    );
    fails(
        t,
        &good,
        &["--cfc", "600"],
        &["--cfc", "CFC 600", "1000 frames/s"],
    );
    fails(
        t,
        &good,
        &["--cfc", "60", "--cfc-standard", "iso"],
        &["--cfc-standard", "`iso`"],
    );
    fails(t, &good, &["--sync-sigma-ms", "-1"], &["--sync-sigma-ms"]);
    // Without a frame rate.
    let obs_path = t.join("obs.csv");
    let out = t.join("out");
    for (extra, needle) in [
        (["--cfc", "60"], "--cfc"),
        (["--sync-sigma-ms", "1"], "--sync-sigma-ms"),
    ] {
        let o = run(&without_frame_rate(base_args(&out, &obs_path)), &extra);
        let err = stderr(&o);
        assert!(!o.status.success());
        let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("warning:")).collect();
        assert_eq!(lines.len(), 1, "{err}");
        assert!(
            lines[0].starts_with("error: ")
                && lines[0].contains(needle)
                && lines[0].contains("--frame-rate-hz"),
            "{err}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn export_refuses_bad_input_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let m = tmp.path().join("m");
    let obs = fixture().join("observations.csv");
    // A measure output without a frame rate.
    let o = run(&without_frame_rate(base_args(&m, &obs)), &["--no-plots"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let export = |dir: &Path, extra: &[&str]| {
        let tn = if extra.contains(&"--test-number") {
            &[][..]
        } else {
            &["--test-number", "T1"][..]
        };
        Command::new(env!("CARGO_BIN_EXE_crashrig"))
            .args(["export", "iso-mme"])
            .arg(dir)
            .arg("--out")
            .arg(tmp.path().join("iso"))
            .args(tn)
            .args(extra)
            .output()
            .unwrap()
    };
    let one_error = |o: &Output, needles: &[&str]| {
        assert!(!o.status.success());
        let err = stderr(o);
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{err}");
        for n in needles {
            assert!(
                lines[0].starts_with("error: ") && lines[0].contains(n),
                "`{n}` not in {err}"
            );
        }
        assert!(!tmp.path().join("iso").exists(), "nothing may be written");
    };
    one_error(&export(&m, &[]), &["summary.json", "frame_rate_hz"]);
    // With a frame rate: bad channel maps.
    let m2 = tmp.path().join("m2");
    let o = run(&base_args(&m2, &obs), &["--no-plots"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let map = tmp.path().join("codes.csv");
    std::fs::write(&map, "marker,code\nhead,11HEAD0000H3\n").unwrap();
    one_error(
        &export(&m2, &["--channel-map", map.to_str().unwrap()]),
        &["codes.csv:2:", "16 characters"],
    );
    std::fs::write(&map, "marker,code\nnobody,11HEAD0000H3????\n").unwrap();
    one_error(
        &export(&m2, &["--channel-map", map.to_str().unwrap()]),
        &["codes.csv:2:", "`nobody`"],
    );
    one_error(&export(&m2, &["--test-number", "a/b"]), &["--test-number"]);
}

/// `--scale-bars` on the bundled sequence's three bars: `length_check.csv` with the contract's
/// header (one line per epoch and bar), `summary.json`'s `length_check` with every field of the
/// contract, one line per bar on stdout; the ISO-MME export of that output is unchanged.
#[test]
fn scale_bars_write_the_length_check() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("m");
    let f = fixture();
    let bars = f.join("scale_bars.csv").display().to_string();
    let o = run(
        &base_args(&out, &f.join("observations_scale_bars.csv")),
        &["--scale-bars", &bars, "--mpe-mm", "0.5"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stdout.matches("length check bar_").count(), 3, "{stdout}");
    let csv = std::fs::read_to_string(out.join("length_check.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("epoch,bar,length_mm,measured_mm,error_mm,sigma_mm,z")
    );
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&first[..3], ["000001", "bar_door", "300"]);
    assert_eq!(csv.lines().count(), 1 + 50 * 3);
    assert!(out.join("length_check.png").is_file() && out.join("length_check.svg").is_file());
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let bars = s["length_check"].as_array().unwrap();
    assert_eq!(bars.len(), 3);
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
        assert!(bars.iter().all(|b| b.get(key).is_some()), "{key}");
    }
    assert_eq!(bars[2]["name"], "bar_roof");
    assert_eq!(bars[2]["epochs"], 50);
    let files: Vec<&str> = s["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(files.contains(&"length_check.csv"), "{files:?}");

    // The export reads the same directory as before.
    let iso = tmp.path().join("iso");
    let e = Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .args(["export", "iso-mme"])
        .arg(&out)
        .arg("--out")
        .arg(&iso)
        .args(["--test-number", "T37", "--json"])
        .output()
        .unwrap();
    assert!(e.status.success(), "{}", stderr(&e));
    let j: serde_json::Value = serde_json::from_slice(&e.stdout).unwrap();
    assert_eq!(j["source"], "displacements.csv");
}

/// A bar that is not consistent is a `warning:` line naming the bar and the verdict, and its
/// reason is in `summary.json`'s `warnings`: the tie's baseline 1 % long is a bias.
#[test]
fn an_inconsistent_scale_bar_is_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let f = fixture();
    let mut tie: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(f.join("tie.json")).unwrap()).unwrap();
    for v in tie["base_mm"].as_array_mut().unwrap() {
        *v = (v.as_f64().unwrap() * 1.01).into();
    }
    let tie_path = tmp.path().join("tie.json");
    std::fs::write(&tie_path, serde_json::to_vec(&tie).unwrap()).unwrap();
    let out = tmp.path().join("m");
    let mut args = base_args(&out, &f.join("observations_scale_bars.csv"));
    let k = args.iter().position(|a| a == "--tie").unwrap();
    args[k + 1] = tie_path.display().to_string();
    let bars = f.join("scale_bars.csv").display().to_string();
    let k = args.iter().position(|a| a == "--samples").unwrap();
    args[k + 1] = "1000".into();
    let o = run(&args, &["--scale-bars", &bars]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let roof: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("warning: scale bar `bar_roof`"))
        .collect();
    assert_eq!(roof.len(), 1, "{err}");
    assert!(roof[0].contains(": bias — "), "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["length_check"][2]["verdict"], "bias");
    let warnings = s["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| format!("warning: {}", w.as_str().unwrap()) == roof[0]),
        "{warnings:?}"
    );
}

#[test]
fn bad_scale_bars_are_one_error_line_and_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let f = fixture();
    let out = tmp.path().join("out");
    let bars = tmp.path().join("bars.csv");
    std::fs::write(
        &bars,
        "name,marker_1,marker_2,length_mm,sigma_mm\nx,bar_door_1,nowhere,300,0.02\n",
    )
    .unwrap();
    let args = base_args(&out, &f.join("observations_scale_bars.csv"));
    let (bad, good) = (
        bars.display().to_string(),
        f.join("scale_bars.csv").display().to_string(),
    );
    let cases: [(Vec<&str>, String); 3] = [
        (
            vec!["--scale-bars", &bad],
            format!("{}:2: marker_2 `nowhere`", bars.display()),
        ),
        (vec!["--mpe-mm", "1"], "--scale-bars".to_string()),
        (
            vec!["--scale-bars", &good, "--mpe-mm", "-1"],
            "--mpe-mm: -1 is not a number > 0 (mm)".to_string(),
        ),
    ];
    for (extra, needle) in cases {
        let o = run(&args, &extra);
        let err = stderr(&o);
        assert!(!o.status.success(), "{extra:?}");
        let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("warning:")).collect();
        assert!(
            lines[0].starts_with("error: ") && err.contains(&needle),
            "{extra:?}: {err}"
        );
        // Ours are one line; clap's usage error (a flag without the one it needs) adds its
        // usage lines.
        if extra[0] == "--scale-bars" {
            assert_eq!(lines.len(), 1, "{err}");
        }
        assert!(!out.exists(), "{extra:?}");
    }
}

/// `base_args` with `--pixel-sigma-px` set to `value`.
fn with_pixel_sigma(mut args: Vec<String>, value: &str) -> Vec<String> {
    let i = args.iter().position(|a| a == "--pixel-sigma-px").unwrap();
    args[i + 1] = value.into();
    args
}

/// `--pixel-sigma-px estimate`: the Monte Carlo uses the pixel σ check's estimate, and says so
/// in `summary.json` (`pixel_sigma_estimate`, its scale the check's ratio). On this side-by-side
/// pair (one common estimate) every other file is byte for byte the run that states that
/// estimate as `--pixel-sigma-px`. Without camera C, or with a word that is not `estimate`:
/// one error line, nothing written.
#[test]
fn pixel_sigma_estimate_is_the_check_s_estimate_used() {
    let tmp = tempfile::tempdir().unwrap();
    let obs = fixture().join("observations.csv");
    let (est, typed) = (tmp.path().join("estimate"), tmp.path().join("typed"));
    let o = run(&with_pixel_sigma(base_args(&est, &obs), "estimate"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(est.join("summary.json")).unwrap()).unwrap();
    let check = &summary["pixel_sigma_check"];
    let used = &summary["pixel_sigma_estimate"];
    assert_eq!(used["per_camera"], false, "{used}");
    assert_eq!(check["stated_from"], "pixel_sigma_px");
    for cam in ["B", "C"] {
        assert_eq!(used[cam]["scale"], check["sigma_ratio"]);
        assert_eq!(used[cam]["estimate_px"], check["estimate_px"]);
        assert_eq!(used[cam]["estimate_95_px"], check["estimate_95_px"]);
    }
    // The fixture's pixels carry 0.1 px of noise: the estimate's interval covers it.
    let interval = check["estimate_95_px"].as_array().unwrap();
    let (lo, hi) = (interval[0].as_f64().unwrap(), interval[1].as_f64().unwrap());
    assert!(lo < 0.1 && 0.1 < hi, "{lo} … {hi}");
    // No warning that the stated (default) σ is wrong: the run does not use it.
    assert!(!stderr(&o).contains("pixel_sigma_check:"), "{}", stderr(&o));
    let px = check["estimate_px"].as_f64().unwrap().to_string();
    let o = run(&with_pixel_sigma(base_args(&typed, &obs), &px), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let files = |d: &Path| -> Vec<PathBuf> {
        let mut all = Vec::new();
        let mut todo = vec![d.to_path_buf()];
        while let Some(p) = todo.pop() {
            for e in std::fs::read_dir(&p).unwrap() {
                let e = e.unwrap().path();
                if e.is_dir() {
                    todo.push(e);
                } else {
                    all.push(e.strip_prefix(d).unwrap().to_path_buf());
                }
            }
        }
        all.sort();
        all
    };
    let names = files(&est);
    assert_eq!(names, files(&typed));
    assert!(names.len() >= 3, "{names:?}");
    for n in names.iter().filter(|n| n.as_os_str() != "summary.json") {
        let same = std::fs::read(est.join(n)).unwrap() == std::fs::read(typed.join(n)).unwrap();
        assert!(same, "{n:?} differs");
    }
    // Without camera C: nothing to estimate from.
    let mut no_c = with_pixel_sigma(base_args(&tmp.path().join("no_c"), &obs), "estimate");
    for flag in ["--camera-c", "--tie"] {
        let i = no_c.iter().position(|a| a == flag).unwrap();
        no_c.drain(i..i + 2);
    }
    for (args, needle) in [
        (no_c, "--pixel-sigma-px estimate needs --camera-c and --tie"),
        (
            with_pixel_sigma(base_args(&tmp.path().join("word"), &obs), "estimated"),
            "neither a number (px) nor `estimate`",
        ),
    ] {
        let o = run(&args, &[]);
        let err = stderr(&o);
        assert!(!o.status.success() && err.contains(needle), "{err}");
        assert!(err.lines().next().unwrap().starts_with("error: "), "{err}");
    }
    assert!(!tmp.path().join("no_c").exists() && !tmp.path().join("word").exists());
}
