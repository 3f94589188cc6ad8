//! `--shard i/N` and `crashrig merge` (contract section "Scale"): a bad `--shard` is one
//! `error:` line naming the flag; `merge` of all shards writes what the unsharded run writes;
//! a missing, repeated or foreign shard, or a directory that is not a shard, is one `error:`
//! line naming it, and nothing is written.

use crate::contract::common::{assert_clean_error, read_json, run, without_timing};
use std::path::{Path, PathBuf};

const SCENARIO: &str = r#"seed = 7
samples = 200
[grid]
x_mm = [0.0, 400.0, 5]
y_mm = [0.0, 300.0, 2]
z_mm = [1000.0, 1000.0, 1]
[[grid.observer]]
position_mm = [-300.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
position_mm = [700.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs shard `i/n` of `scenario` into `dir` with extra arguments.
fn shard(scenario: &Path, dir: &Path, i: usize, n: usize, extra: &[&str]) {
    let spec = format!("{i}/{n}");
    let mut args = vec![
        "grid",
        s(scenario),
        "--out",
        s(dir),
        "--shard",
        &spec,
        "--no-plots",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.success, "shard {spec}: {}", r.stderr);
}

fn setup() -> (tempfile::TempDir, PathBuf, Vec<PathBuf>) {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("s.toml");
    std::fs::write(&scen, SCENARIO).unwrap();
    let dirs: Vec<PathBuf> = (1..=3).map(|i| tmp.path().join(format!("s{i}"))).collect();
    for (k, d) in dirs.iter().enumerate() {
        shard(&scen, d, k + 1, 3, &[]);
    }
    (tmp, scen, dirs)
}

#[test]
fn grid_shard_bad_values_name_the_flag() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("s.toml");
    std::fs::write(&scen, SCENARIO).unwrap();
    let out = tmp.path().join("out");
    for bad in ["0/3", "4/3", "a/b", "1/0", "3", "1/1000000"] {
        let r = run(["grid", s(&scen), "--out", s(&out), "--shard", bad]);
        assert_clean_error(&r, &["--shard", bad]);
        assert!(!out.exists(), "--shard {bad}: something was written");
    }
}

#[test]
fn merge_of_all_shards_equals_the_unsharded_run() {
    let (tmp, scen, dirs) = setup();
    let whole = tmp.path().join("whole");
    let r = run(["grid", s(&scen), "--out", s(&whole), "--no-plots"]);
    assert!(r.success, "{}", r.stderr);
    let merged = tmp.path().join("merged");
    // Any order.
    let r = run([
        "merge",
        s(&dirs[2]),
        s(&dirs[0]),
        s(&dirs[1]),
        "--out",
        s(&merged),
        "--no-plots",
    ]);
    assert!(r.success, "{}", r.stderr);
    for f in ["grid.csv", "grid_detail.csv", "grid.ply"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(merged.join(f)).unwrap(),
            "{f}"
        );
    }
    assert_eq!(
        without_timing(read_json(&whole.join("summary.json"))),
        without_timing(read_json(&merged.join("summary.json")))
    );
    // The shard's manifest under --json.
    let d = tmp.path().join("json");
    let r = run(["--json", "grid", s(&scen), "--out", s(&d), "--shard", "2/3"]);
    let m = crate::contract::common::json_of(&r);
    assert_eq!(m["shard"]["index"], 2);
    assert_eq!(m["shard"]["count"], 3);
    assert_eq!(m["command"], "grid");
    assert!(m["fingerprint"].as_str().unwrap().starts_with("sha256:"));
}

#[test]
fn merge_refuses_missing_repeated_and_foreign_shards() {
    let (tmp, scen, dirs) = setup();
    let out = tmp.path().join("merged");
    let merge = |ds: &[&Path]| {
        let mut args: Vec<&str> = vec!["merge"];
        args.extend(ds.iter().map(|d| s(d)));
        args.extend(["--out", s(&out)]);
        run(&args)
    };
    // Missing.
    let r = merge(&[&dirs[0], &dirs[2]]);
    assert_clean_error(&r, &["missing", "2/3"]);
    // Repeated.
    let r = merge(&[&dirs[0], &dirs[1], &dirs[1], &dirs[2]]);
    assert_clean_error(&r, &["2/3", "twice", s(&dirs[1])]);
    // Foreign: another seed, sample count, N, scenario.
    let other = tmp.path().join("other");
    for (extra, what, i, n) in [
        (&["--seed", "8"][..], "seed", 2, 3),
        (&["--samples", "300"][..], "samples", 2, 3),
        (&[][..], "shard count N", 2, 4),
    ] {
        shard(&scen, &other, i, n, extra);
        let r = merge(&[&dirs[0], &other, &dirs[2]]);
        assert_clean_error(&r, &[s(&other), "another run", what]);
    }
    let scen2 = tmp.path().join("s2.toml");
    std::fs::write(&scen2, SCENARIO.replace("seed = 7", "seed = 7 # edited")).unwrap();
    shard(&scen2, &other, 2, 3, &[]);
    let r = merge(&[&dirs[0], &other, &dirs[2]]);
    assert_clean_error(&r, &[s(&other), "another run", "fingerprint"]);
    // Not a shard directory.
    let plain = tmp.path().join("plain");
    std::fs::create_dir(&plain).unwrap();
    let r = merge(&[&dirs[0], &plain, &dirs[2]]);
    assert_clean_error(&r, &[s(&plain), "not a shard directory"]);
    assert!(!out.exists(), "a refused merge wrote its output");
    // A usable merge after all the refusals.
    let r = merge(&[&dirs[0], &dirs[1], &dirs[2]]);
    assert!(r.success, "{}", r.stderr);
}

#[test]
fn xtask_shards_runs_xargs_and_merges_to_the_unsharded_output() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("s.toml");
    std::fs::write(&scen, SCENARIO).unwrap();
    let whole = tmp.path().join("whole");
    let r = run(["grid", s(&scen), "--out", s(&whole), "--no-plots"]);
    assert!(r.success, "{}", r.stderr);
    let out = tmp.path().join("merged");
    let args: Vec<String> = [
        "3",
        "-P",
        "2",
        "--out",
        s(&out),
        "--",
        s(&scen),
        "--no-plots",
    ]
    .iter()
    .map(|a| a.to_string())
    .collect();
    let (mut plan, bin) = crate::contract::xtask_shards::parse(&args).unwrap();
    plan.quiet = true;
    assert_eq!(bin, None);
    let dirs = crate::contract::xtask_shards::run(&plan, Path::new(env!("CARGO_BIN_EXE_crashrig")))
        .unwrap();
    assert_eq!(dirs.len(), 3);
    for d in &dirs {
        assert!(d.join("shard.json").is_file(), "{}", d.display());
    }
    for f in ["grid.csv", "grid_detail.csv", "grid.ply"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(out.join(f)).unwrap(),
            "{f}"
        );
    }
    assert_eq!(
        without_timing(read_json(&whole.join("summary.json"))),
        without_timing(read_json(&out.join("summary.json")))
    );
}

/// The Slurm example end to end through a real `sbatch`: `examples/scale/slurm-submit.sh`
/// submits a 3-task job array and the merge (dependency `afterok`); the merged output equals
/// the unsharded run. Needs a running Slurm cluster whose nodes see this directory (run on a
/// single-node Debian `slurm-wlm` cluster, docs/SCALE.md):
/// `cargo test -p crashrig-cli --test tests slurm -- --ignored`.
#[test]
#[ignore = "needs a running Slurm cluster (sbatch, squeue); docs/SCALE.md"]
fn slurm_job_array_and_merge_equal_the_unsharded_run() {
    let root = crate::contract::common::root();
    let tmp = tempfile::tempdir_in(std::env::temp_dir()).unwrap();
    let scen = tmp.path().join("s.toml");
    std::fs::write(&scen, SCENARIO).unwrap();
    let bin = env!("CARGO_BIN_EXE_crashrig");
    let submit = std::process::Command::new(root.join("examples/scale/slurm-submit.sh"))
        .args(["3", s(&scen), "out", "--samples", "300"])
        .current_dir(tmp.path())
        .env("CRASHRIG", bin)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&submit.stdout).to_string();
    assert!(
        submit.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&submit.stderr)
    );
    let merge_job = text
        .split("merge: job ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .expect("the merge job id")
        .to_string();
    // Wait until the merge job has left the queue (at most 5 minutes).
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    loop {
        let q = std::process::Command::new("squeue")
            .args(["-h", "-j", &merge_job])
            .output()
            .unwrap();
        if String::from_utf8_lossy(&q.stdout).trim().is_empty() {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "job {merge_job} still queued"
        );
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    let whole = tmp.path().join("whole");
    let r = run(["grid", s(&scen), "--samples", "300", "--out", s(&whole)]);
    assert!(r.success, "{}", r.stderr);
    let out = tmp.path().join("out");
    let mut names: Vec<String> = std::fs::read_dir(&whole)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n != "summary.json")
        .collect();
    names.sort();
    assert!(names.iter().any(|n| n.ends_with(".png")));
    for f in &names {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(out.join(f)).unwrap_or_default(),
            "{f}"
        );
    }
    assert_eq!(
        without_timing(read_json(&whole.join("summary.json"))),
        without_timing(read_json(&out.join("summary.json")))
    );
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/place")
        .join(name)
}

/// `place --shard i/N` + `merge`: bad `--shard` values name the flag; the merge of three
/// shards (given in reverse order) writes the unsharded `placement.json` byte for byte and the
/// same `grid/`; a missing shard is refused by name.
#[test]
fn place_shards_merge_to_the_unsharded_placement() {
    let tmp = tempfile::tempdir().unwrap();
    let (scen, cands) = (example("scenario.toml"), example("candidates.toml"));
    let place = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "place",
            s(&scen),
            "--candidates",
            s(&cands),
            "--choose",
            "2",
            "--samples",
            "100",
            "--no-plots",
            "--out",
            s(out),
        ];
        args.extend_from_slice(extra);
        run(&args)
    };
    let bad_out = tmp.path().join("bad");
    for bad in ["0/3", "4/3", "a/b", "1/0"] {
        let r = place(&bad_out, &["--shard", bad]);
        assert_clean_error(&r, &["--shard", bad]);
        assert!(!bad_out.exists(), "--shard {bad}: something was written");
    }
    let whole = tmp.path().join("whole");
    let r = place(&whole, &[]);
    assert!(r.success, "{}", r.stderr);
    let dirs: Vec<PathBuf> = (1..=3).map(|i| tmp.path().join(format!("p{i}"))).collect();
    for (k, d) in dirs.iter().enumerate() {
        let spec = format!("{}/3", k + 1);
        let r = place(d, &["--shard", &spec]);
        assert!(r.success, "{spec}: {}", r.stderr);
        assert!(r.stdout.contains(&format!("shard {spec}")), "{}", r.stdout);
    }
    let merged = tmp.path().join("merged");
    let merge = |ds: &[&PathBuf]| {
        let mut args: Vec<&str> = vec!["merge"];
        args.extend(ds.iter().map(|d| s(d)));
        args.extend(["--out", s(&merged), "--no-plots"]);
        run(&args)
    };
    let r = merge(&[&dirs[0], &dirs[2]]);
    assert_clean_error(&r, &["missing", "2/3"]);
    assert!(!merged.exists());
    let r = merge(&[&dirs[2], &dirs[1], &dirs[0]]);
    assert!(r.success, "{}", r.stderr);
    assert!(r.stdout.contains("confirmed"), "{}", r.stdout);
    for f in ["placement.json", "grid/grid.csv", "grid/grid_detail.csv"] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(merged.join(f)).unwrap(),
            "{f} differs"
        );
    }
    assert_eq!(
        without_timing(read_json(&whole.join("grid/summary.json"))),
        without_timing(read_json(&merged.join("grid/summary.json")))
    );
}

/// `crashrig measure` of the bundled sequence with `extra` arguments.
fn measure_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<String> {
    let f = |p: &str| crate::contract::common::fixture(&format!("measure/sequence/{p}"));
    let mut a: Vec<String> = [
        "measure".to_string(),
        f("model").display().to_string(),
        "--camera-a".into(),
        "cam_out/".into(),
        "--camera-b".into(),
        "2".into(),
        "--camera-c".into(),
        "3".into(),
        "--link".into(),
        f("link.json").display().to_string(),
        "--tie".into(),
        f("tie.json").display().to_string(),
        "--observations".into(),
        f("observations.csv").display().to_string(),
        "--mm-per-unit".into(),
        "1000".into(),
        "--sigma-a-position-mm".into(),
        "0.5".into(),
        "0.5".into(),
        "0.5".into(),
        "--samples".into(),
        "100".into(),
        "--frame-rate-hz".into(),
        "1000".into(),
        "--cfc".into(),
        "180".into(),
        "--out".into(),
        out.into(),
    ]
    .into();
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

#[test]
fn measure_shards_merge_to_the_unsharded_run() {
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    let r = run(measure_args(s(&whole), &[]));
    assert!(r.success, "{}", r.stderr);
    let dirs: Vec<PathBuf> = (1..=3).map(|i| tmp.path().join(format!("m{i}"))).collect();
    for (k, d) in dirs.iter().enumerate() {
        let spec = format!("{}/3", k + 1);
        let r = run(measure_args(s(d), &["--shard", &spec]));
        assert!(r.success, "{}", r.stderr);
        assert!(r.stdout.contains(&format!("shard {spec}")), "{}", r.stdout);
    }
    let merged = tmp.path().join("merged");
    let r = run([
        "merge",
        s(&dirs[1]),
        s(&dirs[2]),
        s(&dirs[0]),
        "--out",
        s(&merged),
    ]);
    assert!(r.success, "{}", r.stderr);
    assert!(r.stdout.starts_with("measured "), "{}", r.stdout);
    for f in [
        "trajectories.csv",
        "trajectories.ply",
        "displacements.csv",
        "kinematics.csv",
        "plots/head_l.png",
        "plots/head_l.svg",
    ] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(merged.join(f)).unwrap(),
            "{f}"
        );
    }
    let summary = |d: &Path| {
        let mut v = read_json(&d.join("summary.json"));
        v.as_object_mut().unwrap().remove("elapsed_s");
        v
    };
    assert_eq!(summary(&whole), summary(&merged));
    // Bad --shard values: one error line naming the flag, nothing written.
    let out = tmp.path().join("bad");
    for bad in ["0/3", "4/3", "a/b"] {
        let r = run(measure_args(s(&out), &["--shard", bad]));
        assert_clean_error(&r, &["--shard", bad]);
        assert!(!out.exists(), "--shard {bad}: something was written");
    }
    // A shard of another seed, and a missing one: refused by name, nothing written.
    let other = tmp.path().join("other");
    let r = run(measure_args(s(&other), &["--shard", "2/3", "--seed", "5"]));
    assert!(r.success, "{}", r.stderr);
    let r = run([
        "merge",
        s(&dirs[0]),
        s(&other),
        s(&dirs[2]),
        "--out",
        s(&out),
    ]);
    assert_clean_error(&r, &[s(&other), "another run", "seed"]);
    let r = run(["merge", s(&dirs[0]), s(&dirs[2]), "--out", s(&out)]);
    assert_clean_error(&r, &["missing", "2/3"]);
    assert!(!out.exists(), "a refused merge wrote its output");
}

/// `cargo xtask shards` runs `measure` shards too (the command named after `--`).
#[test]
fn xtask_shards_runs_measure_shards_and_merges() {
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    let r = run(measure_args(s(&whole), &["--no-plots"]));
    assert!(r.success, "{}", r.stderr);
    let out = tmp.path().join("merged");
    let mut args: Vec<String> = ["2", "-P", "2", "--out", s(&out), "--"]
        .iter()
        .map(|a| a.to_string())
        .collect();
    // measure_args without its `--out DIR` (the last two), with --no-plots.
    let m = measure_args("x", &["--no-plots"]);
    args.extend(m[..m.len() - 3].iter().cloned());
    args.push("--no-plots".into());
    let (mut plan, _) = crate::contract::xtask_shards::parse(&args).unwrap();
    plan.quiet = true;
    assert_eq!(plan.command, "measure");
    let dirs = crate::contract::xtask_shards::run(&plan, Path::new(env!("CARGO_BIN_EXE_crashrig")))
        .unwrap();
    assert_eq!(dirs.len(), 2);
    for f in [
        "trajectories.csv",
        "trajectories.ply",
        "displacements.csv",
        "kinematics.csv",
    ] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(out.join(f)).unwrap(),
            "{f}"
        );
    }
}
