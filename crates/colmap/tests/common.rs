//! Shared helpers: fixture paths, golden JSON, directory copies.

use std::path::{Path, PathBuf};

/// `fixtures/colmap` of the workspace.
pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/colmap")
}

/// A fixture path below `fixtures/colmap`.
pub fn fixture(rel: &str) -> PathBuf {
    fixtures().join(rel)
}

/// Every model directory that has a `golden.json`.
pub fn golden_models() -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(fixtures()).expect("fixtures/colmap exists") {
        let dir = entry.expect("readable").path();
        if !dir.is_dir() {
            continue;
        }
        if dir.join("golden.json").is_file() {
            out.push(dir.clone());
        }
        for sub in std::fs::read_dir(&dir).expect("readable") {
            let sub = sub.expect("readable").path();
            if sub.join("golden.json").is_file() {
                out.push(sub);
            }
        }
    }
    out.sort();
    assert!(
        out.len() >= 10,
        "expected at least 10 golden models, found {}",
        out.len()
    );
    out
}

/// Parses a JSON file.
pub fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).expect("golden JSON readable");
    serde_json::from_str(&text).expect("golden JSON parses")
}

/// Copies the regular files of `src` into a fresh temporary directory.
pub fn copy_dir(src: &Path) -> tempfile::TempDir {
    let tmp = tempfile::tempdir().expect("temp dir");
    for entry in std::fs::read_dir(src).expect("readable") {
        let p = entry.expect("readable").path();
        if p.is_file() {
            std::fs::copy(&p, tmp.path().join(p.file_name().expect("file name"))).expect("copy");
        }
    }
    tmp
}

/// A JSON number as f64 (panics in tests only, on malformed golden files).
pub fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("number")
}

/// A JSON array of numbers.
pub fn fv(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(f).collect()
}

/// A JSON integer.
pub fn u(v: &serde_json::Value) -> u64 {
    v.as_u64().expect("unsigned integer")
}
