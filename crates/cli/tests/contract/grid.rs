//! `crashrig grid --out DIR`: grid.csv, summary.json, heat maps, determinism.

use crate::contract::common::{
    fixture, json_of, num, read_json, run, run_env, uint, without_timing,
};
use approx::assert_abs_diff_eq;
use std::path::{Path, PathBuf};

/// The contract's exact header of grid.csv.
const HEADER: &str = "x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm";

/// Runs `grid SCENARIO --out OUT --samples N --seed S [--threads T]` and expects success.
fn grid(scenario: &Path, out: &Path, samples: usize, seed: u64, threads: Option<usize>) {
    grid_env(scenario, out, samples, seed, threads, &[]);
}

/// [`grid`] with extra environment variables.
fn grid_env(
    scenario: &Path,
    out: &Path,
    samples: usize,
    seed: u64,
    threads: Option<usize>,
    env: &[(&str, &str)],
) {
    let mut a: Vec<String> = vec![
        "grid".into(),
        scenario.display().to_string(),
        "--out".into(),
        out.display().to_string(),
        "--samples".into(),
        samples.to_string(),
        "--seed".into(),
        seed.to_string(),
    ];
    if let Some(t) = threads {
        a.push("--threads".into());
        a.push(t.to_string());
    }
    let r = run_env(&a, env);
    assert!(r.success, "grid failed: {}", r.stderr);
}

/// Reads grid.csv: checks the exact header and returns the rows as 7 numbers each.
fn read_csv(out: &Path) -> Vec<[f64; 7]> {
    let text = std::fs::read_to_string(out.join("grid.csv")).expect("grid.csv exists");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER), "grid.csv header");
    lines
        .enumerate()
        .map(|(i, l)| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| {
                    x.parse()
                        .unwrap_or_else(|_| panic!("grid.csv row {i}: {x:?} is not a number"))
                })
                .collect();
            assert_eq!(v.len(), 7, "grid.csv row {i}: 7 columns");
            [v[0], v[1], v[2], v[3], v[4], v[5], v[6]]
        })
        .collect()
}

/// `count` equally spaced values from `start` to `stop`, both included.
fn linspace(start: f64, stop: f64, count: usize) -> Vec<f64> {
    if count == 1 {
        return vec![start];
    }
    (0..count)
        .map(|i| start + (stop - start) * i as f64 / (count - 1) as f64)
        .collect()
}

/// Image files of `out` with extension `ext`, sorted.
fn files_with_ext(out: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(out)
        .expect("output dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

/// Every PNG is a PNG, has an SVG twin of the same stem, and every SVG is an SVG.
fn check_heat_maps(out: &Path) -> usize {
    let pngs = files_with_ext(out, "png");
    for p in &pngs {
        let bytes = std::fs::read(p).expect("png");
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{} is not a PNG",
            p.display()
        );
        let svg = p.with_extension("svg");
        let text = std::fs::read_to_string(&svg)
            .unwrap_or_else(|_| panic!("{} has no SVG twin", p.display()));
        assert!(text.contains("<svg"), "{} is not an SVG", svg.display());
    }
    assert_eq!(
        files_with_ext(out, "svg").len(),
        pngs.len(),
        "one SVG per PNG"
    );
    pngs.len()
}

/// A copy of `three_cameras_z0.toml` with `z_mm` replaced by `z`, written into `dir`.
fn scenario_with_z(dir: &Path, z: &str) -> PathBuf {
    let text =
        std::fs::read_to_string(fixture("scenarios/three_cameras_z0.toml")).expect("scenario");
    assert!(text.contains("z_mm = [0.0, 0.0, 1]"));
    let p = dir.join("levels.toml");
    std::fs::write(
        &p,
        text.replace("z_mm = [0.0, 0.0, 1]", &format!("z_mm = {z}")),
    )
    .expect("write scenario");
    p
}

#[test]
fn grid_nominal() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    grid(
        &fixture("scenarios/three_cameras_z0.toml"),
        &out,
        20,
        5,
        None,
    );
    // The scenario's grid: x 400..2000 (17), y −600..600 (13), z 0 (1).
    let rows = read_csv(&out);
    assert_eq!(rows.len(), 17 * 13, "one row per grid point");
    let mut want: Vec<[f64; 3]> = Vec::new();
    for x in linspace(400.0, 2000.0, 17) {
        for y in linspace(-600.0, 600.0, 13) {
            want.push([x, y, 0.0]);
        }
    }
    for w in &want {
        // 1e-9 mm: grid coordinates are a handful of f64 operations on round numbers.
        let n = rows
            .iter()
            .filter(|r| (0..3).all(|k| (r[k] - w[k]).abs() < 1e-9))
            .count();
        assert_eq!(n, 1, "grid point {w:?} appears exactly once");
    }
    for r in &rows {
        assert!(r[3..].iter().all(|s| *s >= 0.0), "σ ≥ 0 in {r:?}");
        // sigma_max is the max of the three σ (exactly: a max of the same numbers).
        assert_eq!(r[6], r[3].max(r[4]).max(r[5]), "sigma_max of {r:?}");
    }

    let s = read_json(&out.join("summary.json"));
    assert_eq!(uint(&s, "points"), rows.len() as u64);
    assert_eq!(uint(&s, "samples_per_point"), 20);
    assert_eq!(num(&s, "threshold_mm"), 5.0);
    for k in ["elapsed_s", "samples_per_second"] {
        assert!(num(&s, k) >= 0.0, "{k} ≥ 0");
    }
    // The summary is a function of grid.csv: recompute it (CSV floats are printed in full
    // precision, so 1e-12 relative covers only the decimal round trip).
    let sig: Vec<f64> = rows.iter().map(|r| r[6]).collect();
    let below = sig.iter().filter(|s| **s < 5.0).count() as f64 / sig.len() as f64;
    assert_abs_diff_eq!(num(&s, "fraction_below_threshold"), below, epsilon = 1e-12);
    let max = sig.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_abs_diff_eq!(num(&s, "max_sigma_mm"), max, epsilon = 1e-12 * max);
    let mut sorted = sig.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2]; // 221 points: the middle one
    assert_abs_diff_eq!(
        num(&s, "median_sigma_max_mm"),
        median,
        epsilon = 1e-12 * median
    );

    assert!(
        check_heat_maps(&out) >= 1,
        "at least one heat map for the z level"
    );
}

#[test]
fn grid_heat_map_per_z_level() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let one = scenario_with_z(tmp.path(), "[0.0, 0.0, 1]");
    let out1 = tmp.path().join("one");
    grid(&one, &out1, 10, 1, None);
    let two_dir = tmp.path().join("two_levels");
    std::fs::create_dir_all(&two_dir).expect("mkdir");
    let two = scenario_with_z(&two_dir, "[0.0, 300.0, 2]");
    let out2 = tmp.path().join("two");
    grid(&two, &out2, 10, 1, None);
    assert_eq!(read_csv(&out2).len(), 2 * 17 * 13, "one row per grid point");
    let (n1, n2) = (check_heat_maps(&out1), check_heat_maps(&out2));
    assert!(n1 >= 1);
    assert_eq!(n2, 2 * n1, "the heat maps are per z level");
}

#[test]
fn grid_same_seed_any_thread_count() {
    // Contract: bit-identical grid.csv whatever the thread count; summary.json too once the
    // timing fields (and the worker count itself) are dropped.
    let tmp = tempfile::tempdir().expect("temp dir");
    for name in ["three_cameras_z0.toml", "three_cameras_correlated.toml"] {
        let sc = fixture(&format!("scenarios/{name}"));
        let (a, b, c) = (
            tmp.path().join(format!("{name}_1")),
            tmp.path().join(format!("{name}_2")),
            tmp.path().join(format!("{name}_env")),
        );
        grid(&sc, &a, 16, 9, Some(1));
        grid(&sc, &b, 16, 9, Some(2));
        grid_env(&sc, &c, 16, 9, None, &[("RAYON_NUM_THREADS", "2")]);
        let csv = |d: &Path| std::fs::read(d.join("grid.csv")).expect("grid.csv");
        assert!(
            csv(&a) == csv(&b),
            "{name}: grid.csv differs for 1 vs 2 threads"
        );
        assert!(
            csv(&a) == csv(&c),
            "{name}: grid.csv differs with RAYON_NUM_THREADS=2"
        );
        let summary = |d: &Path| without_timing(read_json(&d.join("summary.json")));
        let (sa, sb) = (summary(&a), summary(&b));
        assert!(sa == sb, "{name}: summary.json differs for 1 vs 2 threads");
    }
}

#[test]
fn grid_json_stdout_is_one_document() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    let sc = fixture("scenarios/three_cameras_z0.toml");
    let r = run([
        "grid".as_ref(),
        sc.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--samples".as_ref(),
        "4".as_ref(),
        "--json".as_ref(),
    ]);
    let v = json_of(&r);
    assert!(v.is_object(), "grid --json prints an object, got {v}");
}
