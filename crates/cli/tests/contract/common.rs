//! Shared helpers: run the built `crashrig` binary and check its output against the contract.

use serde_json::Value;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What one run of the binary produced.
pub struct Run {
    /// Whether the process exited with code 0.
    pub success: bool,
    /// The exit code, if any.
    pub code: Option<i32>,
    /// Everything written to stdout.
    pub stdout: String,
    /// Everything written to stderr.
    pub stderr: String,
}

/// The repository root (fixtures live there).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A path under `fixtures/`.
pub fn fixture(rel: &str) -> PathBuf {
    root().join("fixtures").join(rel)
}

/// Runs `crashrig` with `args`, with `RUST_BACKTRACE=1` so that a panic would show a backtrace,
/// and `RAYON_NUM_THREADS` removed unless given in `env`.
pub fn run_env<I, S>(args: I, env: &[(&str, &str)]) -> Run
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_crashrig"));
    cmd.args(args)
        .env("RUST_BACKTRACE", "1")
        .env_remove("RAYON_NUM_THREADS");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd.output().expect("the crashrig binary runs");
    Run {
        success: out.status.success(),
        code: out.status.code(),
        stdout: String::from_utf8(out.stdout).expect("stdout is UTF-8"),
        stderr: String::from_utf8(out.stderr).expect("stderr is UTF-8"),
    }
}

/// Runs `crashrig` with `args` (see [`run_env`]).
pub fn run<I, S>(args: I) -> Run
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    run_env(args, &[])
}

/// Asserts success and parses stdout as exactly one JSON document (serde_json rejects
/// anything but whitespace after the document).
pub fn json_of(r: &Run) -> Value {
    assert!(
        r.success,
        "expected success, got {:?}; stderr:\n{}",
        r.code, r.stderr
    );
    serde_json::from_str(&r.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not exactly one JSON document ({e}):\n{}",
            r.stdout
        )
    })
}

/// Asserts the contract's error behaviour: non-zero exit, nothing on stdout, exactly one line
/// on stderr that starts with `error: ` and contains every `needle`, no panic, no backtrace.
pub fn assert_clean_error(r: &Run, needles: &[&str]) {
    assert!(
        !r.success,
        "expected a failure, got success; stdout:\n{}",
        r.stdout
    );
    assert!(
        r.code.is_some_and(|c| c != 0),
        "expected a non-zero exit code (not a signal), got {:?}",
        r.code
    );
    assert!(
        !r.stderr.contains("panicked") && !r.stderr.contains("stack backtrace"),
        "panic or backtrace on stderr:\n{}",
        r.stderr
    );
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "stderr must be exactly one line, got:\n{}",
        r.stderr
    );
    assert!(
        lines[0].starts_with("error: "),
        "stderr must start with `error: `, got: {}",
        lines[0]
    );
    for n in needles {
        assert!(
            lines[0].contains(n),
            "stderr does not name {n:?}: {}",
            lines[0]
        );
    }
    assert!(
        r.stdout.is_empty(),
        "nothing may be on stdout after an error, got:\n{}",
        r.stdout
    );
}

/// The field `key` of object `v`, which must exist.
pub fn field<'a>(v: &'a Value, key: &str) -> &'a Value {
    v.get(key)
        .unwrap_or_else(|| panic!("missing field {key:?} in {v}"))
}

/// A non-negative integer field.
pub fn uint(v: &Value, key: &str) -> u64 {
    field(v, key)
        .as_u64()
        .unwrap_or_else(|| panic!("{key:?} must be a non-negative integer, got {}", v[key]))
}

/// A number field.
pub fn num(v: &Value, key: &str) -> f64 {
    field(v, key)
        .as_f64()
        .unwrap_or_else(|| panic!("{key:?} must be a number, got {}", v[key]))
}

/// A string field.
pub fn string<'a>(v: &'a Value, key: &str) -> &'a str {
    field(v, key)
        .as_str()
        .unwrap_or_else(|| panic!("{key:?} must be a string, got {}", v[key]))
}

/// A boolean field.
pub fn boolean(v: &Value, key: &str) -> bool {
    field(v, key)
        .as_bool()
        .unwrap_or_else(|| panic!("{key:?} must be a boolean, got {}", v[key]))
}

/// An array of numbers of length `n`.
pub fn numbers(v: &Value, what: &str, n: usize) -> Vec<f64> {
    let a = v
        .as_array()
        .unwrap_or_else(|| panic!("{what} must be an array, got {v}"));
    assert_eq!(a.len(), n, "{what} must have {n} elements, got {v}");
    a.iter()
        .map(|x| {
            x.as_f64()
                .unwrap_or_else(|| panic!("{what}: {x} is not a number"))
        })
        .collect()
}

/// A field that is an array of 3 numbers.
pub fn arr3(v: &Value, key: &str) -> [f64; 3] {
    let a = numbers(field(v, key), key, 3);
    [a[0], a[1], a[2]]
}

/// A field that is an n×n matrix of numbers (array of n rows of n numbers).
pub fn matrix(v: &Value, key: &str, n: usize) -> Vec<Vec<f64>> {
    let rows = field(v, key)
        .as_array()
        .unwrap_or_else(|| panic!("{key:?} must be an array of rows, got {}", v[key]));
    assert_eq!(rows.len(), n, "{key:?} must have {n} rows");
    rows.iter()
        .enumerate()
        .map(|(i, r)| numbers(r, &format!("{key}[{i}]"), n))
        .collect()
}

/// A field shaped `[[lo, hi] × 3]` with lo ≤ hi.
pub fn intervals3(v: &Value, key: &str) -> [[f64; 2]; 3] {
    let rows = field(v, key)
        .as_array()
        .unwrap_or_else(|| panic!("{key:?} must be an array, got {}", v[key]));
    assert_eq!(
        rows.len(),
        3,
        "{key:?} must hold 3 intervals, got {}",
        v[key]
    );
    let mut out = [[0.0; 2]; 3];
    for (i, r) in rows.iter().enumerate() {
        let lh = numbers(r, &format!("{key}[{i}]"), 2);
        assert!(lh[0] <= lh[1], "{key}[{i}]: lo {} > hi {}", lh[0], lh[1]);
        out[i] = [lh[0], lh[1]];
    }
    out
}

/// Removes timing fields (and the worker count, which is an input) at any depth, so that
/// outputs of runs with different thread counts can be compared.
pub fn without_timing(mut v: Value) -> Value {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                for k in ["elapsed_s", "samples_per_second", "threads"] {
                    m.remove(k);
                }
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    v
}

/// Difference of two angles in degrees, wrapped to (−180°, 180°].
pub fn angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 { d - 360.0 } else { d }
}

/// Copies every file of directory `from` into a new directory `to`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create the copy");
    for e in std::fs::read_dir(from).expect("read the fixture folder") {
        let e = e.expect("directory entry");
        if e.file_type().expect("file type").is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).expect("copy a fixture file");
        }
    }
}

/// Reads a JSON file.
pub fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
