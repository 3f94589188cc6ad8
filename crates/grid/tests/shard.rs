//! `grid --shard i/N` + `merge` (contract section "Scale"): for N = 1, 2, 3 the merged output
//! is the unsharded one — every CSV and plot byte for byte, `summary.json` equal except its
//! timings — on the aimed, adaptive, fixed-camera and correlated paths.

use crashrig_grid::shard::{merge_grid, run_grid_shard};
use crashrig_grid::{GridConfig, run_grid};
use crashrig_outdir::shard::{Shard, read_set};
use std::path::{Path, PathBuf};

const AIMED: &str = r#"
seed = 5
samples = 300
[grid]
x_mm = [400.0, 800.0, 3]
y_mm = [-200.0, 200.0, 3]
z_mm = [0.0, 300.0, 2]
[[grid.observer]]
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]
[[grid.observer]]
position_mm = [1300.0, -700.0, 0.0]
covariance_tangent = [
  [4.0, 0.5, 0.0, 0.0, 0.0, 0.0],
  [0.5, 4.0, 0.0, 0.0, 0.0, 0.0],
  [0.0, 0.0, 4.0, 0.0, 0.0, 0.0],
  [0.0, 0.0, 0.0, 0.0004, 0.0, 0.0],
  [0.0, 0.0, 0.0, 0.0, 0.0004, 0.0],
  [0.0, 0.0, 0.0, 0.0, 0.0, 0.0004],
]
"#;

const ADAPTIVE: &str = r#"
seed = 3
samples = 1000
[grid]
x_mm = [0.0, 400.0, 3]
y_mm = [0.0, 300.0, 2]
z_mm = [1000.0, 1000.0, 1]
[grid.adaptive]
tolerance_mm = 0.05
batch = 500
max_samples = 4000
[[grid.observer]]
position_mm = [-300.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
position_mm = [700.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(rel)
}

fn config(scenario: &Path, out: PathBuf, samples: Option<usize>, plots: bool) -> GridConfig {
    GridConfig {
        scenario: scenario.to_path_buf(),
        out,
        samples,
        seed: None,
        plots,
    }
}

/// `summary.json` without the timings (the only keys a merge may change).
fn summary(dir: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    let o = v.as_object_mut().unwrap();
    for key in ["elapsed_s", "samples_per_second"] {
        assert!(o.remove(key).is_some(), "summary.json lacks {key}");
    }
    v
}

/// Runs the scenario whole and in N = 1, 2, 3 shards (merged, shards given in reverse order)
/// and asserts the merged outputs equal the whole one.
fn assert_merge_is_whole(scenario: &Path, samples: Option<usize>, plots: bool) {
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    run_grid(&config(scenario, whole.clone(), samples, plots), None).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&whole)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert!(names.contains(&"grid_detail.csv".to_string()));
    assert_eq!(names.iter().any(|n| n.ends_with(".png")), plots);
    for n in 1..=3usize {
        let mut dirs = Vec::new();
        for i in (1..=n).rev() {
            let dir = tmp.path().join(format!("n{n}_s{i}"));
            let c = config(scenario, dir.clone(), samples, plots);
            let r = run_grid_shard(&c, Shard::new(i, n).unwrap(), None).unwrap();
            assert_eq!(r.manifest.shard.to_string(), format!("{i}/{n}"));
            dirs.push(dir);
        }
        let merged = tmp.path().join(format!("merged{n}"));
        merge_grid(&read_set(&dirs).unwrap(), &merged, plots, None).unwrap();
        let mut got: Vec<String> = std::fs::read_dir(&merged)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        got.sort();
        assert_eq!(got, names, "N = {n}: not the same files");
        for name in &names {
            if name == "summary.json" {
                continue;
            }
            let (a, b) = (
                std::fs::read(whole.join(name)).unwrap(),
                std::fs::read(merged.join(name)).unwrap(),
            );
            assert!(a == b, "N = {n}: {name} differs from the unsharded run");
        }
        assert_eq!(summary(&whole), summary(&merged), "N = {n}: summary.json");
    }
}

#[test]
fn grid_shard_merge_aimed_full_covariance_equals_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("aimed.toml");
    std::fs::write(&scen, AIMED).unwrap();
    assert_merge_is_whole(&scen, None, true);
}

#[test]
fn grid_shard_merge_adaptive_equals_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("adaptive.toml");
    std::fs::write(&scen, ADAPTIVE).unwrap();
    assert_merge_is_whole(&scen, None, false);
}

#[test]
fn grid_shard_merge_fixed_cameras_equals_whole() {
    // Fixed lenses: points that one camera does not see are not measurable (empty cells).
    assert_merge_is_whole(
        &fixture("scenarios/fixed_three_cameras.toml"),
        Some(64),
        false,
    );
}

#[test]
fn grid_shard_merge_correlated_equals_whole() {
    // Correlated mode: the independent run is sharded too (summary.json `correlation`).
    assert_merge_is_whole(
        &fixture("scenarios/three_cameras_correlated.toml"),
        Some(64),
        false,
    );
}

#[test]
fn grid_merge_refuses_a_changed_scenario_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("aimed.toml");
    std::fs::write(&scen, AIMED).unwrap();
    let mut dirs = Vec::new();
    for i in 1..=2 {
        let dir = tmp.path().join(format!("s{i}"));
        run_grid_shard(
            &config(&scen, dir.clone(), None, false),
            Shard::new(i, 2).unwrap(),
            None,
        )
        .unwrap();
        dirs.push(dir);
    }
    std::fs::write(&scen, AIMED.replace("seed = 5", "seed = 6")).unwrap();
    let out = tmp.path().join("merged");
    let e = merge_grid(&read_set(&dirs).unwrap(), &out, false, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("changed since the shards ran"), "{e}");
    assert!(!out.exists());
    // A truncated shard is refused naming its file.
    std::fs::write(&scen, AIMED).unwrap();
    let rows = dirs[1].join("points.csv");
    let text = std::fs::read_to_string(&rows).unwrap();
    let cut: Vec<&str> = text.lines().collect();
    std::fs::write(&rows, cut[..cut.len() - 1].join("\n")).unwrap();
    let e = merge_grid(&read_set(&dirs).unwrap(), &out, false, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("points.csv") && e.contains("incomplete"), "{e}");
    assert!(!out.exists());
}

/// A merge with a monitor: one report per shard read (monotone, ending at the shard count),
/// the same files as without; a monitor that cancels stops it with nothing written.
#[test]
fn merge_reports_shards_read_and_cancels_without_writing() {
    use crashrig_stats::progress::Recorder;
    let tmp = tempfile::tempdir().unwrap();
    let scenario = tmp.path().join("aimed.toml");
    std::fs::write(&scenario, AIMED).unwrap();
    let dirs: Vec<PathBuf> = (1..=3)
        .map(|i| {
            let dir = tmp.path().join(format!("s{i}"));
            let c = config(&scenario, dir.clone(), Some(50), false);
            run_grid_shard(&c, Shard::new(i, 3).unwrap(), None).unwrap();
            dir
        })
        .collect();
    let set = read_set(&dirs).unwrap();
    let plain = tmp.path().join("plain");
    merge_grid(&set, &plain, false, None).unwrap();
    let watched = tmp.path().join("watched");
    let m = Recorder::new();
    merge_grid(&set, &watched, false, Some(&m)).unwrap();
    assert_eq!(m.seen(), vec![(1, 3), (2, 3), (3, 3)]);
    for f in ["grid.csv", "grid_detail.csv"] {
        assert_eq!(
            std::fs::read(plain.join(f)).unwrap(),
            std::fs::read(watched.join(f)).unwrap(),
            "{f}"
        );
    }
    assert_eq!(summary(&plain), summary(&watched));
    // Cancelled after 1 shard, or after all 3 (before writing): nothing written.
    for after in [1, 3] {
        let out = tmp.path().join(format!("cancelled{after}"));
        let m = Recorder::cancelling_after(after);
        let e = merge_grid(&set, &out, false, Some(&m)).unwrap_err();
        assert!(
            matches!(e, crashrig_grid::Error::Cancelled(_)),
            "{after}: {e}"
        );
        assert_eq!(m.seen().len(), after);
        assert!(!out.exists(), "{after}");
    }
}
