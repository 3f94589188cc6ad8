//! `place --shard i/N` + `merge` (contract section "Scale"): for N = 1, 2, 3 the merged output
//! is the unsharded `place`'s — `placement.json` and every CSV and plot of `grid/` byte for
//! byte, `grid/summary.json` equal except its timings — on the bundled example (aimed and
//! fixed candidates with lenses) and in correlated mode; missing, repeated and foreign shards
//! and changed inputs are refused by name with nothing written.

use crashrig_outdir::shard::{Shard, read_set};
use crashrig_place::PlaceConfig;
use crashrig_place::shard::{merge, run_shard};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

fn config(scenario: &Path, candidates: &Path, k: usize, out: PathBuf, plots: bool) -> PlaceConfig {
    PlaceConfig {
        scenario: scenario.to_path_buf(),
        candidates: candidates.to_path_buf(),
        choose: k,
        out,
        samples: Some(200),
        seed: Some(11),
        plots,
    }
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

/// `summary.json` without the timings (the only keys a merge may change).
fn summary(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let o = v.as_object_mut().unwrap();
    for key in ["elapsed_s", "samples_per_second"] {
        assert!(o.remove(key).is_some(), "summary.json lacks {key}");
    }
    v
}

/// Runs the placement whole and in N = 1, 2, 3 shards (given to the merge in reverse order)
/// and asserts that each merged output equals the whole one.
fn assert_merge_is_whole(scenario: &Path, candidates: &Path, k: usize, plots: bool) {
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    let run =
        crashrig_place::run(&config(scenario, candidates, k, whole.clone(), plots), None).unwrap();
    assert!(
        run.placement.confirmed.len() >= 2,
        "the case should confirm runners-up too: {:?}",
        run.placement.confirmed
    );
    let names = files(&whole);
    assert!(names.contains(&"placement.json".to_string()));
    assert!(names.contains(&"grid/grid.csv".to_string()));
    assert_eq!(names.iter().any(|n| n.ends_with(".png")), plots);
    for n in 1..=3usize {
        let mut dirs = Vec::new();
        for i in (1..=n).rev() {
            let dir = tmp.path().join(format!("n{n}_s{i}"));
            let c = config(scenario, candidates, k, dir.clone(), plots);
            let r = run_shard(&c, Shard::new(i, n).unwrap(), None).unwrap();
            assert_eq!(r.manifest.shard.to_string(), format!("{i}/{n}"));
            assert_eq!(r.files, files(&dir).len());
            dirs.push(dir);
        }
        let merged = tmp.path().join(format!("merged{n}"));
        let m = merge(&read_set(&dirs).unwrap(), &merged, plots, None).unwrap();
        assert_eq!(m.placement, run.placement, "N = {n}");
        assert_eq!(files(&merged), names, "N = {n}: not the same files");
        for name in &names {
            if name == "grid/summary.json" {
                continue;
            }
            let (a, b) = (
                std::fs::read(whole.join(name)).unwrap(),
                std::fs::read(merged.join(name)).unwrap(),
            );
            assert!(a == b, "N = {n}: {name} differs from the unsharded run");
        }
        assert_eq!(
            summary(&whole.join("grid/summary.json")),
            summary(&merged.join("grid/summary.json")),
            "N = {n}: grid/summary.json"
        );
    }
}

#[test]
fn place_shard_merge_equals_whole_on_the_example() {
    // Aimed candidates and two fixed roof cameras with OpenCV lenses (not-measurable points).
    assert_merge_is_whole(
        &repo("examples/place/scenario.toml"),
        &repo("examples/place/candidates.toml"),
        2,
        true,
    );
}

const CORRELATED_CANDIDATES: &str = r#"
[[candidate]]
name = "at the outward camera (cam1's draws)"
position_mm = [379.8545733141943, -61.68880590454445, -2.2194107417403997]
sigma_from = "cam1"

[[candidate]]
name = "B pillar right"
position_mm = [1900.0, -700.0, 200.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]

[[candidate]]
name = "B pillar left"
position_mm = [1900.0, 700.0, 200.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]

[[candidate]]
name = "B pillar left, low"
position_mm = [1900.0, 700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

#[test]
fn place_shard_merge_equals_whole_in_correlated_mode() {
    // The shards hold every confirmed layout's independent rows too (summary `correlation`).
    let tmp = tempfile::tempdir().unwrap();
    let cands = tmp.path().join("cands.toml");
    std::fs::write(&cands, CORRELATED_CANDIDATES).unwrap();
    assert_merge_is_whole(
        &repo("fixtures/scenarios/three_cameras_correlated.toml"),
        &cands,
        1,
        false,
    );
}

/// Two shards of the example (K = 1, no plots) in `tmp`.
fn two_shards(tmp: &Path, scenario: &Path, candidates: &Path, k: usize) -> Vec<PathBuf> {
    (1..=2)
        .map(|i| {
            let dir = tmp.join(format!("k{k}_s{i}"));
            let c = config(scenario, candidates, k, dir.clone(), false);
            run_shard(&c, Shard::new(i, 2).unwrap(), None).unwrap();
            dir
        })
        .collect()
}

#[test]
fn place_merge_refuses_missing_repeated_foreign_and_changed_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("scenario.toml");
    let cands = tmp.path().join("cands.toml");
    let scen_text = std::fs::read_to_string(repo("examples/place/scenario.toml")).unwrap();
    let cands_text = std::fs::read_to_string(repo("examples/place/candidates.toml")).unwrap();
    std::fs::write(&scen, &scen_text).unwrap();
    std::fs::write(&cands, &cands_text).unwrap();
    let dirs = two_shards(tmp.path(), &scen, &cands, 1);
    let out = tmp.path().join("merged");
    let refused = |dirs: &[PathBuf]| -> String {
        let e = match read_set(dirs) {
            Err(e) => e.to_string(),
            Ok(set) => merge(&set, &out, false, None).unwrap_err().to_string(),
        };
        assert!(!out.exists(), "{e}");
        e
    };
    // Missing and repeated.
    let e = refused(&dirs[..1]);
    assert!(e.contains("missing shard(s) 2/2"), "{e}");
    let e = refused(&[dirs[0].clone(), dirs[1].clone(), dirs[1].clone()]);
    assert!(e.contains("shard 2/2 is given twice"), "{e}");
    // Foreign: another K (another input fingerprint), named by its directory.
    let other = two_shards(tmp.path(), &scen, &cands, 2);
    let e = refused(&[dirs[0].clone(), other[1].clone()]);
    assert!(
        e.contains(&other[1].display().to_string()) && e.contains("a shard of another run"),
        "{e}"
    );
    // A grid shard is not a place shard.
    let grid_shard = tmp.path().join("grid_shard");
    let gc = crashrig_grid::GridConfig {
        scenario: repo("fixtures/scenarios/three_cameras_z0.toml"),
        out: grid_shard.clone(),
        samples: Some(50),
        seed: Some(1),
        plots: false,
    };
    crashrig_grid::shard::run_grid_shard(&gc, Shard::new(2, 2).unwrap(), None).unwrap();
    let e = refused(&[dirs[0].clone(), grid_shard]);
    assert!(e.contains("a shard of another run"), "{e}");
    // Changed candidates since the shards ran.
    std::fs::write(&cands, cands_text.replace("2.53, 2.51", "2.54, 2.51")).unwrap();
    let e = refused(&dirs);
    assert!(e.contains("changed since the shards ran"), "{e}");
    std::fs::write(&cands, &cands_text).unwrap();
    // A shard whose search file names another method.
    let search = dirs[1].join(crashrig_place::shard::SEARCH_FILE);
    let text = std::fs::read_to_string(&search).unwrap();
    std::fs::write(&search, text.replace("\"exhaustive\"", "\"greedy+swap\"")).unwrap();
    let e = refused(&dirs);
    assert!(
        e.contains("place_shard.json") && e.contains("a shard of another run"),
        "{e}"
    );
    std::fs::write(&search, &text).unwrap();
    // A truncated row file names its file (truncated in every shard that has one: the
    // merge reads those of the layouts it confirms).
    let rows: Vec<PathBuf> = dirs
        .iter()
        .map(|d| d.join("layout1_points.csv"))
        .filter(|p| p.is_file())
        .collect();
    assert!(!rows.is_empty());
    let bodies: Vec<String> = rows
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    for (p, body) in rows.iter().zip(&bodies) {
        let cut: Vec<&str> = body.lines().collect();
        std::fs::write(p, cut[..cut.len() - 1].join("\n")).unwrap();
    }
    let e = refused(&dirs);
    assert!(
        e.contains("layout1_points.csv") && e.contains("incomplete"),
        "{e}"
    );
    for (p, body) in rows.iter().zip(&bodies) {
        std::fs::write(p, body).unwrap();
    }
    // Intact again: merges.
    merge(&read_set(&dirs).unwrap(), &out, false, None).unwrap();
    assert!(out.join("placement.json").is_file());
}

#[test]
fn place_shard_refuses_bad_choose_before_writing() {
    let tmp = tempfile::tempdir().unwrap();
    for k in [0, 9] {
        let out = tmp.path().join(format!("k{k}"));
        let c = config(
            &repo("examples/place/scenario.toml"),
            &repo("examples/place/candidates.toml"),
            k,
            out.clone(),
            false,
        );
        let e = run_shard(&c, Shard::new(1, 2).unwrap(), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--choose"), "{e}");
        assert!(!out.exists());
    }
}

/// Grid points × candidates above `MAX_TERMS` (10⁶ points × 2 candidates) is refused before the
/// first-order table is allocated, naming `--candidates` and the memory the table would need
/// (2·10⁶ entries × `BYTES_PER_TERM`), and nothing is written.
#[test]
fn place_refuses_points_times_candidates_above_the_bound() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("big.toml");
    std::fs::write(
        &scen,
        r#"seed = 1
samples = 100
[grid]
x_mm = [0.0, 999.0, 1000]
y_mm = [0.0, 999.0, 1000]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
position_mm = [-500.0, -500.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#,
    )
    .unwrap();
    let cands = tmp.path().join("cands.toml");
    std::fs::write(
        &cands,
        r#"[[candidate]]
name = "a"
position_mm = [1500.0, -500.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[candidate]]
name = "b"
position_mm = [-500.0, 1500.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#,
    )
    .unwrap();
    let out = tmp.path().join("out");
    let mut c = config(&scen, &cands, 1, out.clone(), false);
    c.samples = Some(100);
    let e = crashrig_place::run(&c, None).unwrap_err().to_string();
    let mib = (2_000_000 * crashrig_place::approx::Table::BYTES_PER_TERM) as f64 / 1048576.0;
    assert!(
        e.contains("--candidates")
            && e.contains("1000000 grid points × 2 candidates = 2000000")
            && e.contains(&format!("{mib:.0} MiB")),
        "{e}"
    );
    assert!(!out.exists());
    // The shard path checks the same bound.
    let e = run_shard(&c, Shard::new(1, 2).unwrap(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--candidates"), "{e}");
    assert!(!out.exists());
}

/// `unrank` lists the K-subsets in lexicographic order (against an independent enumeration),
/// and the shares of a sharded search, merged, give the unsharded search's board and count.
#[test]
fn search_shares_merge_to_the_unsharded_search() {
    use crashrig_place::search::{Board, items, search, search_share, unrank};
    let (n, k) = (6, 3);
    let mut expect = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                expect.push(vec![a, b, c]);
            }
        }
    }
    let got: Vec<Vec<usize>> = (0..expect.len()).map(|r| unrank(n, k, r as u128)).collect();
    assert_eq!(got, expect);

    let s = crashrig_mc::Scenario::from_path_for_placement(&repo("examples/place/scenario.toml"))
        .unwrap();
    let c = crashrig_mc::read_candidates(&repo("examples/place/candidates.toml"), &s).unwrap();
    let all = crashrig_place::layout(&s, &c);
    let study = crashrig_mc::GridStudy::new(&all, 100, 1).unwrap();
    let own = s.grid.as_ref().unwrap().observers.len();
    let table = crashrig_place::approx::Table::build(&study, own, None).unwrap();
    for k in [2, 3] {
        let whole = search(&table, k, 4);
        let total = items(c.len(), k);
        assert_eq!(whole.evaluated, total as u64);
        for parts in [1, 3, 7] {
            let mut board = Board::new(4);
            let mut evaluated = 0;
            for i in 1..=parts {
                let share = Shard::new(i, parts).unwrap().range(total);
                let f = search_share(&table, k, 4, share);
                evaluated += f.evaluated;
                board = board.merge(f.board);
            }
            assert_eq!(evaluated, whole.evaluated, "K = {k}, {parts} shares");
            assert_eq!(
                board.entries, whole.board.entries,
                "K = {k}, {parts} shares"
            );
        }
    }
}

#[test]
fn place_shard_merge_equals_whole_with_greedy_search() {
    // 40 candidates, K = 5: C(40, 5) = 658 008 subsets, above the exhaustive bound, so the
    // search is greedy + swap (one work item: one shard runs it, the others only check).
    assert_merge_is_whole(
        &repo("examples/place/scenario.toml"),
        &repo("examples/place/candidates40.toml"),
        5,
        false,
    );
}

/// A place merge with a monitor: one report per shard's board and one for the chosen layouts'
/// rows (monotone, ending at N + 1), the same placement as without; a monitor that cancels
/// stops it with `Error::Cancelled` and nothing written.
#[test]
fn place_merge_reports_and_cancels_without_writing() {
    use crashrig_stats::progress::Recorder;
    let tmp = tempfile::tempdir().unwrap();
    let (scenario, candidates) = (
        repo("examples/place/scenario.toml"),
        repo("examples/place/candidates.toml"),
    );
    let set = read_set(&two_shards(tmp.path(), &scenario, &candidates, 2)).unwrap();
    let plain = merge(&set, &tmp.path().join("plain"), false, None).unwrap();
    let m = Recorder::new();
    let watched = merge(&set, &tmp.path().join("watched"), false, Some(&m)).unwrap();
    assert_eq!(watched.placement, plain.placement);
    assert_eq!(m.seen(), vec![(1, 3), (2, 3), (3, 3)]);
    for after in [1, 3] {
        let out = tmp.path().join(format!("cancelled{after}"));
        let m = Recorder::cancelling_after(after);
        let e = merge(&set, &out, false, Some(&m)).unwrap_err();
        assert!(
            matches!(e, crashrig_place::Error::Cancelled(_)),
            "{after}: {e}"
        );
        assert_eq!(m.seen().len(), after);
        assert!(!out.exists(), "{after}");
    }
}
