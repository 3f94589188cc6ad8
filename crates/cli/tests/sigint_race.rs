//! A real SIGINT at many moments of a study run (issue 25 §3: "SIGINT near the end of a study
//! sometimes leaves `*.crashrig-staging.<pid>.0` beside the output").
//!
//! The robustness suite interrupts at deterministic points through the `CRASHRIG_OUTDIR_FAULT`
//! hook; this test sends the signal from outside, as a user's Ctrl-C does, at delays spread over
//! the whole run and dense near its end (where the race was), half of the runs over an older
//! result. After every run exactly one of two things holds:
//! - exit 130 and "keeps its previous content": OUT is exactly what it was before (absent, or
//!   the older result);
//! - exit 0, or exit 130 and "holds the whole new result" (the signal came after the swap):
//!   OUT is the complete new result;
//!
//! and nothing named `*.crashrig-staging*` is left beside OUT. Any other exit status fails.
//! Slow (≈ 30 study runs): `cargo xtask test --slow`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn study_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own")
}

fn spawn_study(out: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .arg("study")
        .arg(study_dir().join("study.toml"))
        .arg("--out")
        .arg(out)
        .args(["--samples", "4", "--no-sensitivity"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn crashrig")
}

fn staging_left(parent: &Path) -> Vec<String> {
    std::fs::read_dir(parent)
        .expect("parent")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("crashrig-staging"))
        .collect()
}

fn write_old(out: &Path) {
    std::fs::create_dir_all(out).expect("old OUT");
    std::fs::write(out.join("results.json"), b"{\"old\": true}").expect("old results");
    std::fs::write(out.join("report.html"), b"old").expect("old report");
}

fn is_old(out: &Path) -> bool {
    let names: Vec<_> = std::fs::read_dir(out)
        .map(|d| d.flatten().map(|e| e.file_name()).collect())
        .unwrap_or_default();
    names.len() == 2
        && std::fs::read(out.join("results.json")).ok().as_deref() == Some(b"{\"old\": true}")
        && std::fs::read(out.join("report.html")).ok().as_deref() == Some(b"old")
}

fn is_complete_new(out: &Path) -> bool {
    let results = std::fs::read_to_string(out.join("results.json")).unwrap_or_default();
    let report = std::fs::read_to_string(out.join("report.html")).unwrap_or_default();
    results.trim_start().starts_with('{')
        && serde_json::from_str::<serde_json::Value>(&results).is_ok()
        && !results.contains("\"old\"")
        && report.contains("</html>")
}

#[test]
#[ignore = "slow: ≈ 30 study runs with a real SIGINT each; cargo xtask test --slow"]
fn sigint_at_any_moment_leaves_old_or_complete_output_and_no_staging() {
    let tmp = tempfile::tempdir().expect("tmp");

    // One run without a signal gives the run time T to spread the signals over.
    let t0 = Instant::now();
    let o = spawn_study(&tmp.path().join("reference"))
        .wait_with_output()
        .expect("run");
    let t = t0.elapsed();
    assert!(
        o.status.success(),
        "the unsignalled study failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );

    // 12 delays over the run, 18 over its last fifth and just past its end.
    let mut fractions: Vec<f64> = (0..12).map(|k| 0.05 + 0.07 * k as f64).collect();
    fractions.extend((0..18).map(|k| 0.80 + 0.015 * k as f64));

    let (mut interrupted, mut finished) = (0, 0);
    for (k, f) in fractions.iter().enumerate() {
        let parent = tmp.path().join(format!("run{k}"));
        std::fs::create_dir_all(&parent).expect("parent");
        let out = parent.join("out");
        let with_old = k % 2 == 1;
        if with_old {
            write_old(&out);
        }
        let mut child = spawn_study(&out);
        std::thread::sleep(Duration::from_secs_f64(t.as_secs_f64() * f));
        let _ = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status();
        let status = child.wait().expect("wait");
        let mut stderr = String::new();
        if let Some(mut e) = child.stderr.take() {
            use std::io::Read;
            let _ = e.read_to_string(&mut stderr);
        }
        let left = staging_left(&parent);
        assert!(
            left.is_empty(),
            "delay {f:.3}·T: staging left beside OUT: {left:?}"
        );
        match status.code() {
            // A signal after the swap: the new result is complete, and the message says so.
            Some(130) if stderr.contains("holds the whole new result") => {
                finished += 1;
                assert!(
                    is_complete_new(&out),
                    "delay {f:.3}·T: the message says the new result is complete, but it is not"
                );
            }
            Some(130) => {
                interrupted += 1;
                assert!(
                    stderr.contains("keeps its previous content"),
                    "delay {f:.3}·T: {stderr}"
                );
                if with_old {
                    assert!(
                        is_old(&out),
                        "delay {f:.3}·T: exit 130 but OUT is not the old result"
                    );
                } else {
                    assert!(!out.exists(), "delay {f:.3}·T: exit 130 but OUT exists");
                }
            }
            Some(0) => {
                finished += 1;
                assert!(
                    is_complete_new(&out),
                    "delay {f:.3}·T: exit 0 but OUT is not a complete new result"
                );
            }
            other => panic!("delay {f:.3}·T: exit {other:?}; stderr: {stderr}"),
        }
    }
    // The delays must actually have hit the run: most runs interrupted (the ones past the end
    // finish normally).
    assert!(
        interrupted >= 12,
        "only {interrupted} of {} runs were interrupted (run time {t:?}); finished {finished}",
        fractions.len()
    );
}
