//! The robustness suite: generated hostile inputs for every command, checked against the
//! promise of the contract (`docs/USER_GUIDE.md#guarantees`):
//!
//! - bad input → non-zero exit, exactly one `error:` line naming the file (and line for text)
//!   or the option, nothing on stdout; never a panic, an abort, a backtrace (runs use
//!   `RUST_BACKTRACE=1`), a hang (120 s per run), or a raw control character on stderr;
//! - fuzzed inputs that may stay valid → success, or the clean error above;
//! - the input files are unchanged and no file appears beside them (no `-shm`, no temporaries);
//! - a failed run leaves OUT untouched; an interrupted write (the `CRASHRIG_OUTDIR_FAULT` hook:
//!   abort or SIGINT after the k-th file or right before the swap) leaves exactly the old OUT,
//!   and a rerun leaves exactly the files of a fresh run.
//!
//! Classes: wrong-length arrays, huge counts, extreme and non-finite values, control bytes,
//! non-UTF-8, truncated scenarios, deep nesting, degenerate geometry, truncated and bit-flipped
//! models and databases, huge arguments, interrupted writes; and (issue 25) inputs that are not
//! regular files (`/dev/zero`, a FIFO, a directory), sizes beyond their bound in a study, and
//! SIGINT right before a study's swap.
//!
//! `cargo test -p crashrig-cli --test tests robustness::` runs a fast subset (every 25th case plus all
//! degenerate-geometry, non-regular-input, unbounded-size and interrupted-study cases and one
//! of each interruption kind); the whole suite (≥ 1 000 cases) is
//! `cargo test -p crashrig-cli --test tests robustness:: -- --ignored` (or `cargo xtask test --slow`).

#[path = "robustness/harness.rs"]
mod harness;

#[path = "robustness/cases.rs"]
mod cases;

#[path = "robustness/inputs.rs"]
mod inputs;

use harness::{Case, Expect, run_case};

/// Every case, and the temporary directory holding the FIFO of the non-regular inputs (keep it
/// until the cases have run; dropping it removes it).
fn all_cases() -> (Vec<Case>, tempfile::TempDir) {
    let specials = tempfile::tempdir().expect("temp dir");
    let mut v = cases::scenarios();
    v.extend(cases::models());
    v.extend(cases::databases());
    v.extend(cases::arguments());
    v.extend(cases::interruptions());
    v.extend(inputs::non_regular(specials.path()));
    v.extend(inputs::unbounded());
    v.extend(inputs::study_interrupted());
    (v, specials)
}

/// Runs `cases` on a few worker threads and panics with every broken promise, after printing
/// the per-class summary.
fn run_all(cases: &[Case]) {
    let tmp = tempfile::tempdir().expect("temp dir");
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..3 {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(case) = cases.get(i) else { break };
                    if let Err(e) = run_case(case, tmp.path(), i) {
                        failures.lock().unwrap().push((case.class, e));
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    let mut classes: std::collections::BTreeMap<&str, (usize, usize)> = Default::default();
    for c in cases {
        classes.entry(c.class).or_default().0 += 1;
    }
    for (class, _) in &failures {
        classes.entry(class).or_default().1 += 1;
    }
    eprintln!(
        "robustness: {} cases, {} failures",
        cases.len(),
        failures.len()
    );
    for (class, (n, f)) in &classes {
        eprintln!("  {class:<22} {n:>5} cases {f:>4} failures");
    }
    let shown: Vec<String> = failures.iter().take(30).map(|(_, e)| e.clone()).collect();
    assert!(
        failures.is_empty(),
        "{} broken promises:\n{}",
        failures.len(),
        shown.join("\n")
    );
}

#[test]
fn robustness_generates_at_least_1000_cases_over_every_class() {
    let (cases, _specials) = all_cases();
    assert!(cases.len() >= 1000, "{} cases", cases.len());
    let classes: std::collections::BTreeSet<&str> = cases.iter().map(|c| c.class).collect();
    assert_eq!(classes.len(), 17, "{classes:?}");
}

#[test]
fn robustness_fast_subset() {
    let (cases, _specials) = all_cases();
    let mut seen_interrupt = std::collections::BTreeSet::new();
    let subset: Vec<Case> = cases
        .into_iter()
        .enumerate()
        .filter(|(i, c)| {
            i % 25 == 0
                || c.class == "degenerate geometry"
                || c.class == "non-regular input"
                || c.class == "unbounded size"
                || c.class == "interrupted study"
                || match &c.expect {
                    Expect::Interrupted { sigint } => {
                        seen_interrupt.insert((*sigint, c.args[0].clone()))
                    }
                    _ => false,
                }
        })
        .map(|(_, c)| c)
        .collect();
    run_all(&subset);
}

#[test]
#[ignore = "slow: the full generated suite (≥ 1 000 runs of the binary)"]
fn robustness_full_suite() {
    let (cases, _specials) = all_cases();
    run_all(&cases);
}
