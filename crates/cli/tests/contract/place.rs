//! `crashrig place` (contract section "`crashrig place`"; docs/PLACE.md): the files and fields
//! of a run on the bundled example, and one clean error line — naming the flag or the file and
//! line — with nothing written for every kind of bad input.

use super::common::{assert_clean_error, num, read_json, root, run, string, uint};
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    root().join("examples/place").join(name)
}

fn place(candidates: &Path, choose: &str, out: &Path, extra: &[&str]) -> super::common::Run {
    let mut args: Vec<String> = vec![
        "place".into(),
        example("scenario.toml").display().to_string(),
        "--candidates".into(),
        candidates.display().to_string(),
        "--choose".into(),
        choose.into(),
        "--out".into(),
        out.display().to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    run(args)
}

#[test]
fn place_writes_placement_json_and_the_chosen_grid() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p");
    let r = place(
        &example("candidates.toml"),
        "2",
        &out,
        &["--samples", "300", "--seed", "3", "--no-plots", "--json"],
    );
    let v = super::common::json_of(&r);
    let file = read_json(&out.join("placement.json"));
    assert_eq!(v, file, "--json prints placement.json");
    let chosen = v["chosen"].as_array().expect("chosen is an array");
    assert_eq!(chosen.len(), 2);
    assert_ne!(chosen[0], chosen[1]);
    assert_eq!(uint(&v, "samples"), 300);
    assert_eq!(uint(&v, "seed"), 3);
    assert_eq!(string(&v, "method"), "exhaustive");
    assert_eq!(uint(&v, "evaluated"), 28, "C(8, 2) layouts");
    let share = num(&v, "share_below_threshold");
    assert!((0.0..=1.0).contains(&share));
    assert!(num(&v, "mean_sigma_max_mm") > 0.0);
    // The share is the Monte Carlo one of the grid written next to it (σ are continuous, so
    // `<` in grid's summary and `≤` here count the same points).
    let summary = read_json(&out.join("grid/summary.json"));
    assert_eq!(share, num(&summary, "fraction_below_threshold"));
    assert_eq!(
        uint(&summary, "observers"),
        3,
        "the scenario's own + 2 chosen"
    );
    let csv = std::fs::read_to_string(out.join("grid/grid.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 17 * 13);
    // Same seed, same answer; the old output is replaced as a whole.
    let again = place(
        &example("candidates.toml"),
        "2",
        &out,
        &["--samples", "300", "--seed", "3", "--no-plots", "--json"],
    );
    assert_eq!(super::common::json_of(&again), v);
}

/// Writes a candidates file made of the example's first two tables plus `extra`.
fn candidates_with(dir: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(example("candidates.toml")).unwrap();
    // The tables start a line ("[[candidate]]" also appears in the file's opening comment).
    let head: String = text
        .split("\n[[candidate]]")
        .take(3)
        .collect::<Vec<_>>()
        .join("\n[[candidate]]");
    let path = dir.join("cands.toml");
    std::fs::write(&path, format!("{head}\n{extra}")).unwrap();
    path
}

#[test]
fn place_bad_input_is_one_error_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let cands = example("candidates.toml");
    // K = 0 and K > candidates name the flag.
    for (k, needle) in [("0", "at least 1"), ("9", "exceeds the 8 candidates")] {
        let r = place(&cands, k, &out, &["--samples", "100"]);
        assert_clean_error(&r, &["--choose", needle]);
        assert!(!out.exists(), "nothing written for --choose {k}");
    }
    let r = place(&cands, "x", &out, &[]);
    assert_clean_error(&r, &["--choose"]);
    // A repeated name, a missing name, an unknown key: the candidates file and the line.
    let repeated = "[[candidate]]\nname = \"door right, row 2\"\nposition_mm = [900.0, -700.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n";
    let missing = "[[candidate]]\nposition_mm = [900.0, -700.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n";
    let unknown = "[[candidate]]\nname = \"new\"\nposition_mm = [900.0, -700.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\nfocal_lenght_px = 3.0\n";
    for (extra, needle, key) in [
        (
            repeated,
            "name = \"door right, row 2\"\nposition_mm = [900.0",
            "candidate[2].name",
        ),
        (missing, "position_mm = [900.0", "candidate[2].name"),
        (unknown, "focal_lenght_px", "focal_lenght_px"),
    ] {
        let path = candidates_with(dir.path(), extra);
        let text = std::fs::read_to_string(&path).unwrap();
        // The line of the offending table's key (for a missing name: its table header).
        let first = needle.lines().next().unwrap();
        let at = text.rfind(first).unwrap();
        let mut line = 1 + text[..at].matches('\n').count();
        if extra == missing {
            line = 1 + text[..text.rfind("[[candidate]]").unwrap()]
                .matches('\n')
                .count();
        }
        let r = place(&path, "2", &out, &["--samples", "100"]);
        let located = format!("{}:{line}", path.display());
        assert_clean_error(&r, &[&located, key]);
        assert!(!out.exists(), "nothing written for {key}");
    }
    // A missing candidates file names it.
    let r = place(&dir.path().join("absent.toml"), "2", &out, &[]);
    assert_clean_error(&r, &["absent.toml"]);
    assert!(!out.exists());
    // A user's directory is never replaced.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let r = place(&cands, "2", &out, &["--samples", "100", "--no-plots"]);
    assert_clean_error(&r, &["notes.txt"]);
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
}
