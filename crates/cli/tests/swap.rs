//! Signals at every point of an output directory's swap (issue 36 §4: interrupts around the
//! final swap over an older complete result mixed old and new files, and the message said
//! "removed the unfinished output" when the new result was already in place).
//!
//! Each command that writes a directory (`grid`, `colmap convert` to bin and to txt, `study`
//! with its study file inside `--out`, `calibrate --plots`, `bootstrap --plots`) runs over an
//! older complete result with the test hook `CRASHRIG_OUTDIR_FAULT=stop-POINT` (`crashrig_outdir`):
//! the process stops itself (SIGSTOP) right after each file, before the swap, inside the swap
//! (after the exchange; with `no-exchange`, between the two renames of the fallback) and after it.
//! At that instant the test looks at `OUT`, then sends SIGINT, SIGTERM or SIGKILL to the process
//! group (the child runs in its own group, with SIGINT at its default disposition, as a shell's
//! Ctrl-C finds it) and SIGCONT. The promise:
//! - at the stop, `OUT` is the whole old result or the whole new one (absent only between the
//!   two renames of the fallback swap);
//! - SIGINT / SIGTERM: exit 128 + signal (or 0 when the command had finished); `OUT` is the
//!   whole old result and the message says it "keeps its previous content", or the whole new
//!   one and the message says so; no staging directory is left;
//! - SIGKILL: `OUT` is the old or the new result (absent only between the fallback's
//!   renames); the next run cleans up (puts a moved-aside old result back first) and leaves
//!   the complete new result and no hidden directory.
//!
//! A second test sends SIGINT to `study` in the first 0.15 s of its run, where a staging
//! directory could be created after the clean-up had looked for it.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

type Snapshot = BTreeMap<String, Vec<u8>>;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// The children start with SIGINT at its default disposition: a caught signal is reset to the
/// default by `exec`, an ignored one (a test run from a non-interactive shell's background job)
/// would stay ignored. So this test process catches SIGINT (it only sets a flag).
fn sigint_default_in_children() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        signal_hook::flag::register(
            signal_hook::consts::SIGINT,
            Arc::new(AtomicBool::new(false)),
        )
        .expect("catch SIGINT in the test process");
    });
}

/// Every entry below `dir` (relative path → bytes; directories end with `/`), or `None` when
/// `dir` does not exist.
fn snapshot(dir: &Path) -> Option<Snapshot> {
    fn walk(base: &Path, dir: &Path, out: &mut Snapshot) {
        let mut entries: Vec<_> = std::fs::read_dir(dir).expect("list").flatten().collect();
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let p = e.path();
            let rel = p.strip_prefix(base).unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                out.insert(format!("{rel}/"), Vec::new());
                walk(base, &p, out);
            } else {
                out.insert(rel, std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    if !dir.exists() {
        return None;
    }
    let mut s = Snapshot::new();
    walk(dir, dir, &mut s);
    Some(s)
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for e in std::fs::read_dir(from).expect("list").flatten() {
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if src.is_dir() {
            copy_tree(&src, &dst);
        } else {
            std::fs::copy(&src, &dst).expect("copy");
        }
    }
}

/// The hidden directories this crate's swap leaves beside `OUT` when something went wrong.
fn hidden_left(parent: &Path) -> Vec<String> {
    std::fs::read_dir(parent)
        .expect("parent")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("crashrig-staging"))
        .collect()
}

/// One command that writes a directory.
struct Case {
    name: &'static str,
    /// The arguments, given `OUT`.
    args: fn(&Path) -> Vec<OsString>,
    /// How many files it writes through `Staged::write` (the `after-file:K` points).
    files: usize,
    /// Its inputs live inside `OUT`: SIGKILL between the two renames of the fallback swap
    /// leaves `OUT` absent, so the next run cannot read them (the promise cannot hold there).
    inputs_inside: bool,
    /// Places the older complete result (and inputs that live inside it) at `OUT`.
    old: Box<dyn Fn(&Path)>,
    /// The files compared byte for byte with the reference run, after `OUT`'s path is replaced
    /// by `{out}` (the others — timings — must exist with the same names).
    exact: fn(&str) -> bool,
}

fn os(v: &[&str]) -> Vec<OsString> {
    v.iter().map(OsString::from).collect()
}

fn grid_case(template: PathBuf) -> Case {
    Case {
        name: "grid",
        args: |out| {
            let mut a = os(&["grid"]);
            a.push(
                fixtures()
                    .join("scenarios/three_cameras_z0.toml")
                    .into_os_string(),
            );
            a.extend(os(&["--samples", "200", "--out"]));
            a.push(out.as_os_str().to_owned());
            a
        },
        // 2 CSVs, 3 maps × (PNG, SVG) of the one z level, summary.json.
        files: 9,
        inputs_inside: false,
        old: Box::new(move |out| copy_tree(&template, out)),
        exact: |name| name.ends_with(".csv"),
    }
}

fn convert_case(to: &'static str) -> Case {
    Case {
        name: if to == "bin" {
            "colmap convert --to bin"
        } else {
            "colmap convert --to txt"
        },
        args: if to == "bin" {
            |out| convert_args(out, "bin")
        } else {
            |out| convert_args(out, "txt")
        },
        files: 5,
        inputs_inside: false,
        // An older model of another rig: none of its files may survive beside the new one.
        old: Box::new(|out| {
            std::fs::create_dir_all(out).expect("old OUT");
            let model = fixtures().join("colmap/simple_radial/bin");
            for e in std::fs::read_dir(model).expect("old model").flatten() {
                if e.file_name().to_string_lossy().ends_with(".bin") {
                    std::fs::copy(e.path(), out.join(e.file_name())).expect("copy");
                }
            }
        }),
        exact: |_| true,
    }
}

fn convert_args(out: &Path, to: &str) -> Vec<OsString> {
    let mut a = os(&["colmap", "convert"]);
    a.push(fixtures().join("colmap/rig_opencv/bin").into_os_string());
    a.push(out.as_os_str().to_owned());
    a.extend(os(&["--to", to]));
    a
}

fn study_args(out: &Path) -> Vec<OsString> {
    let mut a = os(&["study"]);
    a.push(out.join("inputs/study.toml").into_os_string());
    a.push("--out".into());
    a.push(out.as_os_str().to_owned());
    a.extend(os(&["--samples", "4", "--no-sensitivity"]));
    a
}

/// `study` whose study file lies inside `--out` (`OUT/inputs/`, as `paper` lays it out).
fn study_case(template: PathBuf) -> Case {
    Case {
        name: "study (study file inside --out)",
        args: study_args,
        files: 0,
        inputs_inside: true,
        old: Box::new(move |out| copy_tree(&template, out)),
        exact: |name| {
            name.ends_with(".csv") || name == "results.json" || name.starts_with("inputs/")
        },
    }
}

fn spawn(args: &[OsString], fault: Option<&str>, stderr: &Path) -> Child {
    sigint_default_in_children();
    use std::os::unix::process::CommandExt;
    let mut c = Command::new(env!("CARGO_BIN_EXE_crashrig"));
    c.args(args)
        .env_remove("CRASHRIG_OUTDIR_FAULT")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(stderr).expect("stderr file"))
        .process_group(0);
    if let Some(f) = fault {
        c.env("CRASHRIG_OUTDIR_FAULT", f);
    }
    c.spawn().expect("spawn crashrig")
}

/// Sends `sig` (`INT`, `TERM`, `KILL`, `CONT`) to the process group `pgid`.
fn signal_group(sig: &str, pgid: u32) {
    let ok = Command::new("kill")
        .args([format!("-{sig}"), "--".into(), format!("-{pgid}")])
        .status()
        .expect("kill");
    assert!(ok.success(), "kill -{sig} -{pgid}");
}

/// Waits until the child has stopped itself (`true`) or exited (`false`).
fn wait_stopped(child: &mut Child) -> bool {
    let stat = format!("/proc/{}/stat", child.id());
    let start = Instant::now();
    loop {
        if child.try_wait().expect("try_wait").is_some() {
            return false;
        }
        let state = std::fs::read_to_string(&stat)
            .ok()
            .and_then(|s| s.rsplit_once(") ").map(|(_, r)| r.chars().next()))
            .flatten();
        if state == Some('T') {
            return true;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the child neither stopped nor exited"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn wait_exit(child: &mut Child) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(s) = child.try_wait().expect("try_wait") {
            return s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no exit within 120 s"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// What `OUT` holds: the old result, the complete new one, nothing, or a mix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Old,
    New,
    Absent,
    Mixed,
}

struct Judge<'a> {
    case: &'a Case,
    old: Snapshot,
    new: Snapshot,
    new_out: PathBuf,
}

impl Judge<'_> {
    fn state(&self, out: &Path) -> State {
        let Some(s) = snapshot(out) else {
            return State::Absent;
        };
        if s == self.old {
            return State::Old;
        }
        let same_names = s.keys().eq(self.new.keys());
        let norm = |b: &[u8], dir: &Path| {
            String::from_utf8_lossy(b).replace(&dir.display().to_string(), "{out}")
        };
        let same_bytes = s.iter().all(|(k, v)| {
            !(self.case.exact)(k) || norm(v, out) == norm(&self.new[k], &self.new_out)
        });
        if same_names && same_bytes {
            State::New
        } else {
            State::Mixed
        }
    }
}

/// One interrupted run: stops at `point`, checks `OUT`, sends `sig`, checks the outcome.
fn interrupt(judge: &Judge<'_>, dir: &Path, point: &str, fallback: bool, sig: &str) {
    let case = judge.case;
    let what = format!(
        "{}: {sig} at {point}{}",
        case.name,
        if fallback { " (two-rename swap)" } else { "" }
    );
    let parent = dir.join(format!(
        "{}-{point}-{sig}-{fallback}",
        case.name
            .split_whitespace()
            .take(2)
            .collect::<Vec<_>>()
            .join("_")
    ));
    std::fs::create_dir_all(&parent).expect("parent");
    let out = parent.join("out");
    (case.old)(&out);
    let fault = if fallback {
        format!("stop-{point},no-exchange")
    } else {
        format!("stop-{point}")
    };
    let err_path = parent.join("stderr");
    let mut child = spawn(&(case.args)(&out), Some(&fault), &err_path);
    assert!(
        wait_stopped(&mut child),
        "{what}: the run ended before the point; stderr: {}",
        std::fs::read_to_string(&err_path).unwrap_or_default()
    );
    // The instant of the stop.
    let at_stop = judge.state(&out);
    let absent_ok = point == "between-renames";
    assert!(
        matches!(at_stop, State::Old | State::New) || (absent_ok && at_stop == State::Absent),
        "{what}: at the stop OUT is {at_stop:?}"
    );
    signal_group(sig, child.id());
    if sig != "KILL" {
        signal_group("CONT", child.id());
    }
    let status = wait_exit(&mut child);
    let stderr = std::fs::read_to_string(&err_path).unwrap_or_default();
    let last = stderr.lines().last().unwrap_or("").to_string();
    let end = judge.state(&out);
    use std::os::unix::process::ExitStatusExt;
    if sig == "KILL" {
        assert_eq!(status.signal(), Some(9), "{what}: {status:?}");
        assert!(
            matches!(end, State::Old | State::New) || (absent_ok && end == State::Absent),
            "{what}: after SIGKILL OUT is {end:?}"
        );
        // The next run cleans up and leaves exactly the new result.
        let err2 = parent.join("stderr2");
        let status = wait_exit(&mut spawn(&(case.args)(&out), None, &err2));
        assert!(
            status.success(),
            "{what}: rerun failed: {}",
            std::fs::read_to_string(&err2).unwrap_or_default()
        );
        assert_eq!(judge.state(&out), State::New, "{what}: after the rerun");
        assert_eq!(
            hidden_left(&parent),
            Vec::<String>::new(),
            "{what}: after the rerun"
        );
        return;
    }
    let code = if sig == "INT" { 130 } else { 143 };
    assert_eq!(
        hidden_left(&parent),
        Vec::<String>::new(),
        "{what}: hidden directory left; {last}"
    );
    match status.code() {
        Some(0) => assert_eq!(end, State::New, "{what}: exit 0"),
        Some(c) if c == code => match end {
            State::Old => assert!(
                last.contains("removed the unfinished output")
                    && last.contains("keeps its previous content"),
                "{what}: OUT is the old result, but: {last}"
            ),
            State::New => assert!(
                last.contains("holds the whole new result"),
                "{what}: OUT is the new result, but: {last}"
            ),
            other => panic!("{what}: OUT is {other:?}; {last}"),
        },
        other => panic!("{what}: exit {other:?}; {stderr}"),
    }
}

fn calibrate_args(out: &Path, mm_per_unit: &str) -> Vec<OsString> {
    let mut a = os(&["calibrate"]);
    a.push(fixtures().join("rig/paper").into_os_string());
    a.extend(os(&[
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "cam_in/",
        "--mm-per-unit",
        mm_per_unit,
        "--plots",
    ]));
    a.push(out.as_os_str().to_owned());
    a
}

fn bootstrap_args(out: &Path, seed: &str) -> Vec<OsString> {
    let mut a = os(&["bootstrap"]);
    a.push(
        fixtures()
            .join("paper/twoview/database.db")
            .into_os_string(),
    );
    a.push("--model".into());
    a.push(fixtures().join("paper/twoview/model").into_os_string());
    a.extend(os(&[
        "--image-a",
        "cam_in/000001.png",
        "--image-b",
        "cam_door/000001.png",
        "--iterations",
        "40",
        "--mm-per-unit",
        "1000",
        "--seed",
        seed,
        "--plots",
    ]));
    a.push(out.as_os_str().to_owned());
    a
}

/// `calibrate --plots OUT` (36 files) or `bootstrap --plots OUT` (12) over an earlier run's
/// plots (another scale, another seed: other bytes). The fault points after the first two files
/// stand for the rest (each is the same `Staged::write`); the swap's points are all taken.
fn plots_case(name: &'static str, args: fn(&Path) -> Vec<OsString>, template: PathBuf) -> Case {
    Case {
        name,
        args,
        files: 2,
        inputs_inside: false,
        old: Box::new(move |out| copy_tree(&template, out)),
        exact: |_| true,
    }
}

/// Runs `case` without a signal into `dir/reference/out` (over its old result) for the
/// reference of "new", then interrupts it at every point with each signal.
fn every_point(case: &Case, dir: &Path, signals: &[&str]) -> usize {
    let reference = dir.join("reference").join(case.name.replace(' ', "_"));
    let new_out = reference.join("out");
    (case.old)(&new_out);
    let old = snapshot(&new_out).expect("old result");
    let err = reference.join("stderr");
    let status = wait_exit(&mut spawn(&(case.args)(&new_out), None, &err));
    assert!(
        status.success(),
        "{}: reference run: {}",
        case.name,
        std::fs::read_to_string(&err).unwrap_or_default()
    );
    let judge = Judge {
        case,
        old,
        new: snapshot(&new_out).expect("new result"),
        new_out,
    };
    assert_ne!(judge.old, judge.new);
    let mut points: Vec<(String, bool)> = (1..=case.files)
        .map(|k| (format!("after-file:{k}"), false))
        .collect();
    points.extend([
        ("before-swap".to_string(), false),
        ("after-swap".to_string(), false),
        ("between-renames".to_string(), true),
        ("after-swap".to_string(), true),
    ]);
    let mut runs = 0;
    for (point, fallback) in &points {
        for sig in signals {
            if case.inputs_inside && *sig == "KILL" && point == "between-renames" {
                continue;
            }
            interrupt(&judge, dir, point, *fallback, sig);
            runs += 1;
        }
    }
    runs
}

/// An older complete result of `args` (another scenario, another seed) in `dir`.
fn template(dir: &Path, prepare: impl Fn(&Path), args: &[OsString]) -> PathBuf {
    prepare(dir);
    let err = dir.with_extension("stderr");
    let status = wait_exit(&mut spawn(args, None, &err));
    assert!(
        status.success(),
        "making the old result: {}",
        std::fs::read_to_string(&err).unwrap_or_default()
    );
    dir.to_path_buf()
}

#[test]
fn grid_and_convert_interrupted_at_every_point_of_the_swap() {
    let tmp = tempfile::tempdir().expect("tmp");
    let old_grid = tmp.path().join("old_grid");
    let mut args = os(&["grid"]);
    args.push(
        fixtures()
            .join("scenarios/four_cameras_z300.toml")
            .into_os_string(),
    );
    args.extend(os(&["--samples", "200", "--out"]));
    args.push(old_grid.clone().into_os_string());
    let old_grid = template(&old_grid, |_| {}, &args);
    let all = ["INT", "TERM", "KILL"];
    let mut runs = every_point(&grid_case(old_grid), tmp.path(), &all);
    runs += every_point(&convert_case("bin"), tmp.path(), &all);
    runs += every_point(&convert_case("txt"), tmp.path(), &["INT", "KILL"]);
    assert_eq!(runs, (9 + 4) * 3 + (5 + 4) * 3 + (5 + 4) * 2);
}

/// The plot directories of `calibrate` and `bootstrap` are replaced as a whole, too: never
/// one run's plots beside another's.
#[test]
fn calibrate_and_bootstrap_plots_interrupted_at_every_point_of_the_swap() {
    let tmp = tempfile::tempdir().expect("tmp");
    let old_cal = tmp.path().join("old_calibrate");
    let old_cal = template(&old_cal, |_| {}, &calibrate_args(&old_cal, "1"));
    let old_boot = tmp.path().join("old_bootstrap");
    let old_boot = template(&old_boot, |_| {}, &bootstrap_args(&old_boot, "1"));
    let calibrate = plots_case("calibrate --plots", |o| calibrate_args(o, "1000"), old_cal);
    let bootstrap = plots_case("bootstrap --plots", |o| bootstrap_args(o, "2"), old_boot);
    let mut runs = every_point(&calibrate, tmp.path(), &["INT", "KILL"]);
    runs += every_point(&bootstrap, tmp.path(), &["INT", "KILL"]);
    assert_eq!(runs, (2 + 4) * 2 * 2);
}

#[test]
fn study_with_its_file_inside_out_interrupted_at_every_point_of_the_swap() {
    let tmp = tempfile::tempdir().expect("tmp");
    let old = tmp.path().join("old_study");
    let mut args = study_args(&old);
    args.extend(os(&["--seed", "5"]));
    let old = template(
        &old,
        |d| copy_tree(&fixtures().join("study/own"), &d.join("inputs")),
        &args,
    );
    let runs = every_point(&study_case(old), tmp.path(), &["INT", "TERM", "KILL"]);
    assert_eq!(runs, 4 * 3 - 1);
}

/// SIGINT in the first 0.15 s of `study` (issue 36 §4: 2 of 158 such interrupts left
/// `.out.crashrig-staging.<pid>.0`): no hidden directory may outlive the run, and `OUT` is
/// untouched.
#[test]
fn study_interrupted_at_its_start_leaves_no_staging_directory() {
    let tmp = tempfile::tempdir().expect("tmp");
    let study = fixtures().join("study/own/study.toml");
    let mut interrupted = 0;
    for k in 0..16u32 {
        let parent = tmp.path().join(format!("run{k}"));
        std::fs::create_dir_all(&parent).expect("parent");
        let out = parent.join("out");
        std::fs::create_dir_all(&out).expect("old OUT");
        std::fs::write(out.join("results.json"), b"{\"old\": true}").expect("old");
        let mut args = os(&["study"]);
        args.push(study.clone().into_os_string());
        args.push("--out".into());
        args.push(out.clone().into_os_string());
        args.extend(os(&["--samples", "4", "--no-sensitivity"]));
        let err = parent.join("stderr");
        let mut child = spawn(&args, None, &err);
        std::thread::sleep(Duration::from_millis(10 * u64::from(k)));
        signal_group("INT", child.id());
        let status = wait_exit(&mut child);
        use std::os::unix::process::ExitStatusExt;
        // Before the signal thread exists SIGINT has its default action (the process dies of
        // it, nothing staged yet); afterwards the thread cleans up and exits with 130.
        assert!(
            status.signal() == Some(2) || status.code() == Some(130),
            "run {k}: {status:?}: {}",
            std::fs::read_to_string(&err).unwrap_or_default()
        );
        interrupted += 1;
        assert_eq!(hidden_left(&parent), Vec::<String>::new(), "run {k}");
        assert_eq!(
            std::fs::read(out.join("results.json")).expect("old OUT kept"),
            b"{\"old\": true}",
            "run {k}"
        );
    }
    assert_eq!(interrupted, 16);
}
