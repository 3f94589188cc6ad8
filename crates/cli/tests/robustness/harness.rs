//! Runs one generated case in its own directory and checks the promise of the contract.

use std::ffi::OsString;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a case must do.
#[derive(Clone)]
pub enum Expect {
    /// Fail cleanly: non-zero exit, exactly one `error:` line containing every needle.
    Error(Vec<String>),
    /// Either succeed, or fail cleanly naming the needle (fuzzed inputs that may stay valid).
    Either(String),
    /// Succeed; then run the check on the output directory.
    Ok(fn(&Path) -> Result<(), String>),
    /// Stopped by the fault hook (`abort` or `sigint`): OUT must be exactly the old result;
    /// a rerun without the hook must succeed and leave a complete new OUT with nothing old.
    Interrupted { sigint: bool },
}

/// One generated case.
#[derive(Clone)]
pub struct Case {
    /// The class (for the summary).
    pub class: &'static str,
    /// Files placed under `in/` (relative path, bytes).
    pub inputs: Vec<(String, Vec<u8>)>,
    /// An old result placed at `out/` before the run (relative path, bytes).
    pub old_out: Vec<(String, Vec<u8>)>,
    /// Arguments; `{in}` and `{out}` are replaced by the absolute `in/` and `out` paths.
    pub args: Vec<OsString>,
    /// Extra environment.
    pub env: Vec<(String, String)>,
    /// What must happen.
    pub expect: Expect,
}

/// Builds an argument list from strings.
pub fn args(v: &[&str]) -> Vec<OsString> {
    v.iter().map(OsString::from).collect()
}

/// Every file under `dir` (relative path → bytes), sorted; hidden entries included.
pub fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        for e in rd.flatten() {
            let p = e.path();
            let rel = p.strip_prefix(base).unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                out.push((format!("{rel}/"), Vec::new()));
                walk(base, &p, out);
            } else {
                out.push((rel, std::fs::read(&p).unwrap_or_default()));
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

fn place(dir: &Path, files: &[(String, Vec<u8>)]) {
    for (rel, bytes) in files {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
}

struct Outcome {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Per-run limit: a run that takes longer counts as a hang.
const TIMEOUT: Duration = Duration::from_secs(120);

fn exec(case_args: &[OsString], env: &[(String, String)], logs: &Path) -> Result<Outcome, String> {
    let out_f = std::fs::File::create(logs.join("stdout")).unwrap();
    let err_f = std::fs::File::create(logs.join("stderr")).unwrap();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_crashrig"));
    cmd.args(case_args)
        .env("RUST_BACKTRACE", "1")
        .env_remove("RAYON_NUM_THREADS")
        .env_remove("CRASHRIG_OUTDIR_FAULT")
        .stdin(Stdio::null())
        .stdout(out_f)
        .stderr(err_f);
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().map_err(|e| format!("spawn: {e}"))?;
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("hang: no exit within {TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let read = |n: &str| {
        String::from_utf8(std::fs::read(logs.join(n)).unwrap())
            .map_err(|_| format!("{n} is not UTF-8"))
    };
    Ok(Outcome {
        code: status.code(),
        stdout: read("stdout")?,
        stderr: read("stderr")?,
    })
}

/// The clean-error promise; `Ok(())` when it holds.
fn clean_error(o: &Outcome, needles: &[String]) -> Result<(), String> {
    if o.code == Some(0) {
        return Err(format!(
            "expected a failure, got success; stderr: {}",
            o.stderr
        ));
    }
    if o.code.is_none() {
        return Err(format!("killed by a signal (abort?); stderr: {}", o.stderr));
    }
    check_error_stderr(&o.stderr)?;
    if !o.stdout.is_empty() {
        return Err(format!("stdout not empty on failure: {}", o.stdout));
    }
    let errors: Vec<&str> = o
        .stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    if errors.len() != 1 {
        return Err(format!(
            "expected exactly one `error:` line, got: {}",
            o.stderr
        ));
    }
    for n in needles {
        if !errors[0].contains(n.as_str()) {
            return Err(format!("error line lacks `{n}`: {}", errors[0]));
        }
    }
    Ok(())
}

/// No panic, no backtrace, no raw control characters (logs of a successful run may be any
/// text; see [`check_error_stderr`] for a failed one).
fn check_stderr(stderr: &str) -> Result<(), String> {
    if stderr.contains("panicked") || stderr.contains("stack backtrace") {
        return Err(format!("panic or backtrace: {stderr}"));
    }
    if stderr.chars().any(|c| c.is_control() && c != '\n') {
        return Err(format!("raw control character on stderr: {stderr:?}"));
    }
    Ok(())
}

/// [`check_stderr`], and every line is an `error:` or `warning:` line.
fn check_error_stderr(stderr: &str) -> Result<(), String> {
    if stderr.contains("panicked") || stderr.contains("stack backtrace") {
        return Err(format!("panic or backtrace: {stderr}"));
    }
    if stderr.chars().any(|c| c.is_control() && c != '\n') {
        return Err(format!("raw control character on stderr: {stderr:?}"));
    }
    for l in stderr.lines() {
        if !(l.starts_with("error: ") || l.starts_with("warning: ") || l.starts_with("  ")) {
            return Err(format!("unexpected stderr line: {l:?}"));
        }
    }
    Ok(())
}

fn substitute(a: &[OsString], inp: &Path, out: &Path) -> Vec<OsString> {
    a.iter()
        .map(|s| match s.to_str() {
            Some(t) if t.contains("{in}") || t.contains("{out}") => OsString::from(
                t.replace("{in}", &inp.to_string_lossy())
                    .replace("{out}", &out.to_string_lossy()),
            ),
            _ => s.clone(),
        })
        .collect()
}

/// Entries of `dir` (names), sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Runs `case` in a fresh directory under `root`; `Err` describes a broken promise.
pub fn run_case(case: &Case, root: &Path, index: usize) -> Result<(), String> {
    let dir = root.join(format!("case{index:05}"));
    let logs = root.join(format!("logs{index:05}"));
    std::fs::create_dir_all(dir.join("in")).unwrap();
    std::fs::create_dir_all(&logs).unwrap();
    let inp = dir.join("in");
    let out = dir.join("out");
    place(&inp, &case.inputs);
    if !case.old_out.is_empty() {
        std::fs::create_dir_all(&out).unwrap();
        place(&out, &case.old_out);
    }
    let inputs_before = snapshot(&inp);
    let out_before = snapshot(&out);
    let argv = substitute(&case.args, &inp, &out);
    let needle = |s: &String| {
        s.replace("{in}", &inp.to_string_lossy())
            .replace("{out}", &out.to_string_lossy())
    };
    let o = exec(&argv, &case.env, &logs)?;
    let result = (|| -> Result<(), String> {
        match &case.expect {
            Expect::Error(needles) => {
                let needles: Vec<String> = needles.iter().map(needle).collect();
                clean_error(&o, &needles)?;
                if snapshot(&out) != out_before {
                    return Err("OUT changed by a failed run".into());
                }
            }
            Expect::Either(n) => {
                if o.code == Some(0) {
                    check_stderr(&o.stderr)?;
                } else {
                    clean_error(&o, &[needle(n)])?;
                    if snapshot(&out) != out_before {
                        return Err("OUT changed by a failed run".into());
                    }
                }
            }
            Expect::Ok(check) => {
                if o.code != Some(0) {
                    return Err(format!("expected success, got {:?}: {}", o.code, o.stderr));
                }
                check_stderr(&o.stderr)?;
                check(&out)?;
            }
            Expect::Interrupted { sigint } => {
                match (sigint, o.code) {
                    (true, Some(130)) | (false, None) => {}
                    (_, c) => return Err(format!("unexpected exit {c:?}: {}", o.stderr)),
                }
                if snapshot(&out) != out_before {
                    return Err("OUT is not exactly the old result after the interruption".into());
                }
                let left: Vec<String> = names(&dir);
                let staging = left.iter().filter(|n| n.starts_with(".out.")).count();
                if *sigint && staging > 0 {
                    return Err(format!("SIGINT left a staging directory: {left:?}"));
                }
                // The rerun finishes the job and removes anything a killed run left.
                let o2 = exec(&argv, &[], &logs)?;
                if o2.code != Some(0) {
                    return Err(format!("rerun failed: {}", o2.stderr));
                }
                if names(&dir) != ["in", "out"] {
                    return Err(format!("rerun left {:?}", names(&dir)));
                }
                // OUT holds exactly the files of a fresh run into a new directory.
                let fresh = dir.join("fresh");
                let o3 = exec(&substitute(&case.args, &inp, &fresh), &[], &logs)?;
                if o3.code != Some(0) {
                    return Err(format!("fresh run failed: {}", o3.stderr));
                }
                let (now, want) = (names(&out), names(&fresh));
                std::fs::remove_dir_all(&fresh).map_err(|e| e.to_string())?;
                if now != want {
                    return Err(format!(
                        "after the rerun OUT holds {now:?}, a fresh run writes {want:?}"
                    ));
                }
                for (rel, _) in &case.old_out {
                    if rel.contains("stale") && now.contains(rel) {
                        return Err(format!("stale `{rel}` survived the rerun"));
                    }
                }
            }
        }
        if snapshot(&inp) != inputs_before {
            return Err("the input files changed (or new files appeared beside them)".into());
        }
        let mut allowed = vec!["in".to_string(), "out".to_string()];
        if matches!(case.expect, Expect::Interrupted { .. }) {
            allowed.clear();
        }
        let extra: Vec<String> = names(&dir)
            .into_iter()
            .filter(|n| !allowed.is_empty() && !allowed.contains(n))
            .collect();
        if !extra.is_empty() {
            return Err(format!("new files beside the inputs: {extra:?}"));
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&logs);
    result.map_err(|e| {
        format!(
            "[{}] crashrig {:?}{}: {e}",
            case.class,
            argv,
            if case.env.is_empty() {
                String::new()
            } else {
                format!(" env {:?}", case.env)
            }
        )
    })
}
