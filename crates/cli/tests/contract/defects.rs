//! Issue 47 items 2 and 3, end to end: a grid axis that is reversed or has start = stop with a
//! count above 1 is refused at its key's line before any work (scenario and study), and a text
//! input that is not UTF-8 (scenario, candidates, study, CSV) is refused naming
//! `FILE:LINE:COLUMN` of its first bad byte. Each: exit ≠ 0, one `error:` line, nothing written.

use super::common::{assert_clean_error, fixture, root, run};
use std::path::{Path, PathBuf};

/// `text` with the line holding `from` replaced by `to`; the 1-based line number.
fn edit_line(text: &str, from: &str, to: &str) -> (String, usize) {
    let line = text
        .lines()
        .position(|l| l.contains(from))
        .unwrap_or_else(|| panic!("{from:?} not in the file"));
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[line] = lines[line].replace(from, to);
    (lines.join("\n") + "\n", line + 1)
}

/// `bytes` with the byte 0xff inserted at `at`; the 1-based (line, column) of that byte.
fn insert_bad_byte(bytes: &[u8], at: usize) -> (Vec<u8>, usize, usize) {
    let before = &bytes[..at];
    let line = before.iter().filter(|b| **b == b'\n').count() + 1;
    let column = at
        - before
            .iter()
            .rposition(|b| *b == b'\n')
            .map_or(0, |p| p + 1)
        + 1;
    let mut out = before.to_vec();
    out.push(0xff);
    out.extend_from_slice(&bytes[at..]);
    (out, line, column)
}

fn nothing_written(out: &Path) {
    assert!(!out.exists(), "{} was written", out.display());
    let parent = out.parent().expect("parent");
    let hidden: Vec<_> = std::fs::read_dir(parent)
        .expect("parent")
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains("crashrig-staging"))
        .collect();
    assert!(hidden.is_empty(), "a staging directory was left");
}

const BAD_AXES: [(&str, &str); 3] = [
    ("[2000.0, 400.0, 17]", "stop must not be below start"),
    ("[400.0, 400.0, 17]", "start = stop needs a count of 1"),
    // A step below the rounding of the numbers: the values would repeat.
    ("[1e6, 1.000000000000001e6, 17]", "not strictly increasing"),
];

#[test]
fn scenario_grid_axis_reversed_or_without_span_is_refused_at_its_line() {
    let tmp = tempfile::tempdir().expect("tmp");
    let text =
        std::fs::read_to_string(fixture("scenarios/three_cameras_z0.toml")).expect("scenario");
    for (value, needle) in BAD_AXES {
        let (edited, line) = edit_line(
            &text,
            "x_mm = [400.0, 2000.0, 17]",
            &format!("x_mm = {value}"),
        );
        let path = tmp.path().join("s.toml");
        std::fs::write(&path, edited).expect("write");
        let out = tmp.path().join("out");
        let r = run([
            "grid".as_ref(),
            path.as_os_str(),
            "--samples".as_ref(),
            "20".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        assert_clean_error(&r, &[&format!("s.toml:{line}: `grid.x_mm`: "), needle]);
        nothing_written(&out);
    }
    // A count of 1 with start = stop is one value: fine.
    let (edited, _) = edit_line(
        &text,
        "x_mm = [400.0, 2000.0, 17]",
        "x_mm = [400.0, 400.0, 1]",
    );
    let path = tmp.path().join("one.toml");
    std::fs::write(&path, edited).expect("write");
    let out = tmp.path().join("one");
    let r = run([
        "grid".as_ref(),
        path.as_os_str(),
        "--samples".as_ref(),
        "20".as_ref(),
        "--no-plots".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert!(r.success, "{}", r.stderr);
}

/// The bundled own-data study copied into `dir` (its relative paths stay valid).
fn own_study(dir: &Path) -> PathBuf {
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
    copy_tree(&fixture("study/own"), dir);
    dir.join("study.toml")
}

fn study(path: &Path, out: &Path) -> super::common::Run {
    run([
        "study".as_ref(),
        path.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--samples".as_ref(),
        "4".as_ref(),
        "--no-sensitivity".as_ref(),
    ])
}

#[test]
fn study_layout_axis_reversed_or_without_span_is_refused_at_its_line() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = own_study(&tmp.path().join("own"));
    let text = std::fs::read_to_string(&path).expect("study");
    for (value, needle) in BAD_AXES {
        let (edited, line) = edit_line(
            &text,
            "x_mm = [400.0, 1800.0, 8]",
            &format!("x_mm = {value}"),
        );
        let bad = tmp.path().join("own/bad.toml");
        std::fs::write(&bad, edited).expect("write");
        let out = tmp.path().join("out");
        let r = study(&bad, &out);
        assert_clean_error(
            &r,
            &[&format!("bad.toml:{line}: `layout[0].x_mm`: "), needle],
        );
        nothing_written(&out);
    }
}

/// Runs `args(path)` on `bytes` with a bad byte at several places of `file`'s text and checks
/// the one error line names `NAME:LINE:COLUMN: not valid UTF-8 text`.
fn non_utf8_is_located(file: &Path, name: &str, args: impl Fn(&Path, &Path) -> Vec<PathBuf>) {
    let tmp = tempfile::tempdir().expect("tmp");
    let bytes = std::fs::read(file).expect("input");
    let dir = file.parent().expect("dir");
    // Inside the first line, at the start of a line, and deep inside the file.
    let second = bytes.iter().position(|b| *b == b'\n').expect("two lines") + 1;
    for at in [3, second, bytes.len() * 2 / 3] {
        let (bad, line, column) = insert_bad_byte(&bytes, at);
        let path = dir.join(name);
        std::fs::write(&path, bad).expect("write");
        let out = tmp.path().join("out");
        let r = run(args(&path, &out));
        assert_clean_error(
            &r,
            &[&format!("{name}:{line}:{column}: not valid UTF-8 text")],
        );
        assert!(!r.stderr.contains("byte "), "{}", r.stderr);
        nothing_written(&out);
        std::fs::remove_file(&path).expect("rm");
    }
}

#[test]
fn non_utf8_scenario_names_line_and_column() {
    let tmp = tempfile::tempdir().expect("tmp");
    let copy = tmp.path().join("s.toml");
    std::fs::copy(fixture("scenarios/three_cameras_z0.toml"), &copy).expect("copy");
    non_utf8_is_located(&copy, "bad.toml", |p, out| {
        vec!["grid".into(), p.into(), "--out".into(), out.into()]
    });
}

#[test]
fn non_utf8_candidates_name_line_and_column() {
    let tmp = tempfile::tempdir().expect("tmp");
    let examples = root().join("examples/place");
    let copy = tmp.path().join("candidates.toml");
    std::fs::copy(examples.join("candidates.toml"), &copy).expect("copy");
    let scenario = examples.join("scenario.toml");
    non_utf8_is_located(&copy, "bad.toml", |p, out| {
        vec![
            "place".into(),
            scenario.clone(),
            "--candidates".into(),
            p.into(),
            "--choose".into(),
            "2".into(),
            "--out".into(),
            out.into(),
        ]
    });
}

#[test]
fn non_utf8_study_names_line_and_column() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = own_study(&tmp.path().join("own"));
    non_utf8_is_located(&path, "bad.toml", |p, out| {
        vec![
            "study".into(),
            p.into(),
            "--out".into(),
            out.into(),
            "--samples".into(),
            "4".into(),
        ]
    });
}

#[test]
fn non_utf8_csv_names_line_and_column() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = fixture("measure/sequence");
    let copy = tmp.path().join("observations.csv");
    std::fs::copy(seq.join("observations.csv"), &copy).expect("copy");
    let p = |n: &str| seq.join(n);
    non_utf8_is_located(&copy, "bad.csv", |obs, out| {
        vec![
            "measure".into(),
            p("model"),
            "--camera-a".into(),
            "cam_out/".into(),
            "--camera-b".into(),
            "2".into(),
            "--camera-c".into(),
            "3".into(),
            "--link".into(),
            p("link.json"),
            "--tie".into(),
            p("tie.json"),
            "--observations".into(),
            obs.into(),
            "--a-covariance".into(),
            p("a_covariance.json"),
            "--mm-per-unit".into(),
            "1000".into(),
            "--samples".into(),
            "20".into(),
            "--out".into(),
            out.into(),
        ]
    });
}
