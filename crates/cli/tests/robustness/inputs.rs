//! Issue 25 §3: inputs that are not regular files (`/dev/zero`, a FIFO, a directory) given
//! where a file is read, sizes a user can type beyond their documented bound (each would
//! have hung, aborted on a failed allocation or panicked before), and SIGINT right before a
//! study swaps its output in. Every case runs under the harness's per-run timeout.

use super::harness::{Case, Expect, args};
use std::path::{Path, PathBuf};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(rel)
}

fn err(needles: &[&str]) -> Expect {
    Expect::Error(needles.iter().map(|s| s.to_string()).collect())
}

/// Every file below a fixture directory (relative paths), sorted.
fn tree(rel: &str, prefix: &str) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, dir: &Path, prefix: &str, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).expect("fixture dir").flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, prefix, out);
            } else {
                let rel = p.strip_prefix(base).expect("below").to_string_lossy();
                out.push((format!("{prefix}{rel}"), std::fs::read(&p).expect("read")));
            }
        }
    }
    let mut v = Vec::new();
    let base = fixture(rel);
    walk(&base, &base, prefix, &mut v);
    v.sort();
    v
}

/// A FIFO nobody writes to (reading it would wait for ever) in `dir`, the caller's own
/// temporary directory (removed when the caller drops it; two tests of one process never share
/// a path). `None` without `mkfifo` (its output captured, never printed).
fn fifo(dir: &Path) -> Option<PathBuf> {
    let p = dir.join("fifo");
    if !p.exists() {
        let ok = std::process::Command::new("mkfifo")
            .arg(&p)
            .output()
            .is_ok_and(|o| o.status.success());
        if !ok {
            return None;
        }
    }
    Some(p)
}

/// Special inputs: `/dev/zero` (never ends), a FIFO in `dir` (never opened for writing), a
/// directory.
fn specials(dir: &Path) -> Vec<(String, &'static str)> {
    let mut v = vec![
        ("/dev/zero".to_string(), "not a regular file"),
        ("{in}".to_string(), "directory"),
    ];
    if let Some(f) = fifo(dir) {
        v.push((f.display().to_string(), "not a regular file"));
    }
    v
}

/// The measure fixture's arguments with `key`'s value replaced by `value`.
fn measure(key: &str, value: &str) -> Vec<std::ffi::OsString> {
    let f = |n: &str| format!("{{in}}/{n}");
    let mut v: Vec<String> = vec![
        "measure".into(),
        f("model"),
        "--camera-a".into(),
        "cam_out/".into(),
        "--camera-b".into(),
        "2".into(),
        "--camera-c".into(),
        "3".into(),
        "--link".into(),
        f("link.json"),
        "--tie".into(),
        f("tie.json"),
        "--observations".into(),
        f("observations.csv"),
        "--a-covariance".into(),
        f("a_covariance.json"),
        "--mm-per-unit".into(),
        "1000".into(),
        "--samples".into(),
        "20".into(),
        "--no-plots".into(),
        "--out".into(),
        "{out}".into(),
    ];
    let i = v.iter().position(|a| a == key).expect("key") + 1;
    v[i] = value.to_string();
    args(&v.iter().map(String::as_str).collect::<Vec<_>>())
}

/// Non-regular inputs of `propagate`, `grid`, `study` and `measure`: a clean error naming the
/// path, never a hang (FIFO) or an allocation abort (`/dev/zero`). The FIFO is made in `dir`,
/// which must outlive the cases' runs.
pub fn non_regular(dir: &Path) -> Vec<Case> {
    let class = "non-regular input";
    let seq = tree("measure/sequence", "");
    let mut out = Vec::new();
    for (path, what) in specials(dir) {
        for cmd in [
            vec!["propagate", path.as_str()],
            vec!["grid", path.as_str(), "--out", "{out}"],
            vec!["study", path.as_str(), "--out", "{out}"],
        ] {
            out.push(Case {
                class,
                inputs: vec![],
                old_out: vec![],
                args: args(&cmd),
                env: vec![],
                expect: err(&[&path, what]),
            });
        }
        for key in ["--observations", "--link", "--a-covariance"] {
            out.push(Case {
                class,
                inputs: seq.clone(),
                old_out: vec![],
                args: measure(key, &path),
                env: vec![],
                expect: err(&[&path, what]),
            });
        }
    }
    out
}

/// The own study with `edit` applied to its study file, run with 4 draws per point.
fn study_case(class: &'static str, edit: impl Fn(&str) -> String, expect: Expect) -> Case {
    let mut inputs = tree("study/own", "");
    for (name, bytes) in inputs.iter_mut() {
        if name == "study.toml" {
            *bytes = edit(std::str::from_utf8(bytes).expect("UTF-8")).into_bytes();
        }
    }
    Case {
        class,
        inputs,
        old_out: vec![],
        args: args(&[
            "study",
            "{in}/study.toml",
            "--out",
            "{out}",
            "--samples",
            "4",
            "--no-sensitivity",
        ]),
        env: vec![],
        expect,
    }
}

/// Sizes beyond their bound (before issue 25: a capacity-overflow panic, out-of-memory
/// aborts, hangs): each is an error naming the key and its line, or the flag, before any
/// allocation.
pub fn unbounded() -> Vec<Case> {
    let class = "unbounded size";
    let mut out = Vec::new();
    let text = std::fs::read_to_string(fixture("study/own/study.toml")).expect("study");
    let line = |text: &str, starts: &str| {
        text.lines()
            .position(|l| l.starts_with(starts))
            .expect("line")
            + 1
    };
    let cases: [(&str, &str, &str, &str); 7] = [
        (
            "iterations = 60",
            "iterations = 9223372036854775807",
            "iterations =",
            "`tie.iterations`",
        ),
        (
            "iterations = 60",
            "iterations = 1000000000000000",
            "iterations =",
            "`tie.iterations`",
        ),
        (
            "samples = 300",
            "samples = 10000001",
            "samples = 10000001",
            "`samples`",
        ),
        (
            "chain_samples = 20000",
            "chain_samples = 1000000000000000",
            "chain_samples",
            "`chain_samples`",
        ),
        (
            "z_mm = [0.0, 0.0, 1]",
            "z_mm = [0.0, 300.0, 10001]",
            "z_mm = [0.0, 300.0, 10001]",
            "`layout[0].z_mm`",
        ),
        (
            "x_mm = [400.0, 1800.0, 8]",
            "x_mm = [400.0, 1800.0, 10000]",
            "[[layout]]",
            "grid points exceed",
        ),
        (
            "frame_rate_hz = 1000.0",
            "frame_rate_hz = 1000.0\nsamples = 1000000000",
            "samples = 1000000000",
            "`measure.samples`",
        ),
    ];
    for (from, to, at, needle) in cases {
        let edit = move |t: &str| {
            let t = t.replacen(from, to, 1);
            if to.starts_with("x_mm") {
                t.replacen(
                    "y_mm = [-500.0, 500.0, 6]",
                    "y_mm = [-500.0, 500.0, 10000]",
                    1,
                )
            } else {
                t
            }
        };
        let l = line(&edit(&text), at);
        out.push(study_case(
            class,
            edit,
            err(&[&format!("study.toml:{l}:"), needle, "limit"]),
        ));
    }
    let seq = tree("measure/sequence", "");
    for n in ["1000000000", "10000001", "18446744073709551616"] {
        out.push(Case {
            class,
            inputs: seq.clone(),
            old_out: vec![],
            args: measure("--samples", n),
            env: vec![],
            expect: err(&["--samples"]),
        });
    }
    for flag in ["--samples", "--chain-samples", "--iterations"] {
        out.push(Case {
            class,
            inputs: vec![],
            old_out: vec![],
            args: args(&["paper", "--out", "{out}", flag, "1000000000000000"]),
            env: vec![],
            expect: err(&[flag]),
        });
    }
    out
}

/// SIGINT right before the study swaps its output in, over an older result: OUT is exactly
/// the old result and nothing (`*.crashrig-staging.<pid>.0`) is left beside it.
pub fn study_interrupted() -> Vec<Case> {
    let mut c = study_case(
        "interrupted study",
        |t| t.to_string(),
        Expect::Interrupted { sigint: true },
    );
    c.old_out = vec![
        ("results.json".into(), b"{\"old\": true}".to_vec()),
        ("report.html".into(), b"old".to_vec()),
    ];
    c.env = vec![("CRASHRIG_OUTDIR_FAULT".into(), "sigint-before-swap".into())];
    vec![c]
}
