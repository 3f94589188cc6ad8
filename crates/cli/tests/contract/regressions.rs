//! Regression tests of five contract violations found by the contract review (issue 2/3/6
//! notes): scenario and text-model errors without a line, a failed grid leaving grid.csv,
//! multi-line usage errors, and a non-COLMAP SQLite file read as an empty database.

use crate::contract::common::{assert_clean_error, fixture, run};
use std::path::Path;

fn edited_scenario(dir: &Path, name: &str, from: &str, to: &str, out: &str) -> String {
    let text = std::fs::read_to_string(fixture(&format!("scenarios/{name}"))).expect("read");
    assert!(text.contains(from), "{from:?} in {name}");
    let p = dir.join(out);
    std::fs::write(&p, text.replacen(from, to, 1)).expect("write");
    p.display().to_string()
}

fn line_of(path: &str, needle: &str) -> usize {
    std::fs::read_to_string(path)
        .expect("read")
        .lines()
        .position(|l| l.contains(needle))
        .expect("needle")
        + 1
}

/// Contract: errors name the file "and line, for text". A scenario is a text (TOML) file.
#[test]
fn regression_scenario_semantic_errors_name_the_line() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let t = tmp.path();
    let chain = "paper_chain.toml";
    for (from, to, out, needle) in [
        (
            "position_mm = [61.98,",
            "position_mm = [nan,",
            "nan.toml",
            "[nan,",
        ),
        (
            "sigma_position_mm = [0.19,",
            "sigma_position_mm = [-0.19,",
            "neg.toml",
            "[-0.19,",
        ),
        (
            "parent = \"cam2\"",
            "parent = \"cam9\"",
            "parent.toml",
            "cam9",
        ),
    ] {
        let sc = edited_scenario(t, chain, from, to, out);
        let line = line_of(&sc, needle);
        let r = run(["propagate", sc.as_str(), "--samples", "4", "--json"]);
        assert_clean_error(&r, &[out]);
        assert!(
            r.stderr.contains(&format!("{out}:{line}"))
                || r.stderr.contains(&format!("line {line}")),
            "no line {line}: {}",
            r.stderr
        );
    }
}

/// Contract: "never a partially written output presented as complete". A grid run whose last
/// write fails must not leave grid.csv (and the heat maps) behind.
#[test]
fn regression_grid_failed_write_leaves_no_grid_csv() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    std::fs::create_dir_all(out.join("summary.json")).expect("mkdir");
    let sc = fixture("scenarios/three_cameras_z0.toml")
        .display()
        .to_string();
    let o = out.display().to_string();
    let r = run(["grid", sc.as_str(), "--out", o.as_str(), "--samples", "4"]);
    assert_clean_error(&r, &["summary.json"]);
    assert!(
        !out.join("grid.csv").exists(),
        "grid.csv left behind by a failed run"
    );
}

/// Contract: one `error: …` line, also for clap's usage errors (several lines by default).
#[test]
fn regression_usage_error_is_one_line() {
    let r = run(["calibrate", "somewhere"]);
    assert_clean_error(&r, &["--camera-a"]);
}

/// Contract: errors name "the file (and line, for text)", also for a cross-reference error in
/// a text model (it gave a record index).
#[test]
fn regression_text_model_reference_error_names_the_line() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().join("model");
    crate::contract::common::copy_dir(&fixture("colmap/rig_opencv/txt"), &dir);
    let p = dir.join("images.txt");
    let text = std::fs::read_to_string(&p).expect("read");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Line 5: IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME; point CAMERA_ID at a missing camera.
    let mut f: Vec<String> = lines[4].split(' ').map(str::to_string).collect();
    f[8] = "77".into();
    lines[4] = f.join(" ");
    std::fs::write(&p, lines.join("\n") + "\n").expect("write");
    let d = dir.display().to_string();
    let r = run(["colmap", "info", d.as_str(), "--json"]);
    assert_clean_error(&r, &["images.txt"]);
    assert!(
        r.stderr.contains("images.txt:5") || r.stderr.contains("line 5"),
        "no line: {}",
        r.stderr
    );
}

/// Contract: bad input ends with a non-zero exit. An SQLite file that is not a COLMAP
/// database was reported as an empty database.
#[test]
fn regression_non_colmap_sqlite_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    // A valid SQLite file with one unrelated table.
    let p = tmp.path().join("not_colmap.db");
    rusqlite::Connection::open(&p)
        .and_then(|c| c.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY)", []))
        .expect("sqlite file");
    let s = p.display().to_string();
    let r = run(["colmap", "info", s.as_str(), "--json"]);
    assert_clean_error(&r, &["not_colmap.db"]);
}
