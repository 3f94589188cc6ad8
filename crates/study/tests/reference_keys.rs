//! docs/REFERENCE.md's study-file tables against the parser: every documented key is accepted,
//! and every key the parser accepts is documented (the parser's "unknown field" error lists them).

use crashrig_study::Study;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Section header in the study file (`""` = top level) → documented (key, type column).
fn documented() -> BTreeMap<String, Vec<(String, String)>> {
    let doc = std::fs::read_to_string(root().join("docs/REFERENCE.md")).expect("REFERENCE.md");
    let body = doc
        .split("## Study file")
        .nth(1)
        .expect("a Study file section")
        .split("\n## ")
        .next()
        .expect("section body");
    let mut out: BTreeMap<String, Vec<(String, String)>> = BTreeMap::new();
    let mut section: Option<String> = None;
    for line in body.lines() {
        if let Some(h) = line.strip_prefix("### ") {
            section = Some(if h.starts_with("Top level") {
                String::new()
            } else {
                h.split('`')
                    .nth(1)
                    .expect("a `[section]` in the heading")
                    .to_string()
            });
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if let (Some(s), true) = (&section, cells.len() > 3 && cells[1].starts_with('`')) {
            let key = cells[1].trim_matches('`').to_string();
            out.entry(s.clone())
                .or_default()
                .push((key, cells[2].to_string()));
        }
    }
    out
}

/// A value of the documented type.
fn sample(ty: &str) -> String {
    if ty.contains("bool") {
        "true".into()
    } else if ty.contains("path (directory)") {
        "\"calibration\"".into()
    } else if ty.contains("path (file)") {
        "\"tie/database.db\"".into()
    } else if ty.contains("[start, stop, count]") {
        "[0.0, 100.0, 2]".into()
    } else if ty.contains("6×6") {
        let rows: Vec<String> = (0..6)
            .map(|i| {
                format!(
                    "[{}]",
                    (0..6)
                        .map(|j| if i == j { "1.0" } else { "0.0" })
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
            .collect();
        format!("[{}]", rows.join(", "))
    } else if ty.contains("[id, id]") {
        "[1, 2]".into()
    } else if ty.starts_with('[') {
        "[0.0, 0.0, 0.0]".into()
    } else if ty.starts_with('`') {
        ty.split('`').nth(1).expect("a literal").to_string()
    } else if ty.contains("integer") {
        "10".into()
    } else if ty.contains("string") {
        "\"x\"".into()
    } else {
        "1.0".into()
    }
}

fn study_path() -> PathBuf {
    root().join("fixtures/study/own/study.toml")
}

/// `text` with `line` inserted after the first header `[section]`/`[[section]]` (top level:
/// at the start).
fn insert(text: &str, section: &str, line: &str) -> String {
    if section.is_empty() {
        return format!("{line}\n{text}");
    }
    let header = format!("{section}\n");
    let i = text
        .find(&header)
        .unwrap_or_else(|| panic!("{section} in the study file"))
        + header.len();
    format!("{}{line}\n{}", &text[..i], &text[i..])
}

/// The keys of `section` present in the own study file (so not inserted twice).
fn present(text: &str, section: &str) -> Vec<String> {
    let start = if section.is_empty() {
        0
    } else {
        text.find(&format!("{section}\n")).expect("section") + section.len() + 1
    };
    text[start..]
        .lines()
        .take_while(|l| !l.starts_with('['))
        .filter_map(|l| l.split_once('=').map(|(k, _)| k.trim().to_string()))
        .collect()
}

#[test]
fn every_documented_study_key_is_accepted() {
    let text = std::fs::read_to_string(study_path()).expect("study");
    let doc = documented();
    assert_eq!(doc.len(), 7, "seven key tables: {:?}", doc.keys());
    for (section, keys) in &doc {
        let there = present(&text, section);
        for (key, ty) in keys {
            if there.contains(key) {
                continue;
            }
            let t = insert(&text, section, &format!("{key} = {}", sample(ty)));
            if let Err(e) = Study::from_toml_str(&t, &study_path()) {
                let m = e.to_string();
                assert!(
                    !m.contains("unknown field"),
                    "documented {section} `{key}` is refused: {m}"
                );
            }
        }
    }
}

#[test]
fn every_accepted_study_key_is_documented() {
    let text = std::fs::read_to_string(study_path()).expect("study");
    let doc = documented();
    for (section, keys) in &doc {
        let t = insert(&text, section, "zz_not_a_key = 1");
        let m = Study::from_toml_str(&t, &study_path())
            .expect_err("unknown key")
            .to_string();
        let expected = m
            .split("expected")
            .nth(1)
            .unwrap_or_else(|| panic!("serde lists the fields: {m}"));
        for accepted in expected.split('`').skip(1).step_by(2) {
            // A sub-table is documented by its own heading (`[tie]`, `[[layout.observer]]`).
            let sub = |name: String| {
                doc.contains_key(&format!("[{name}]")) || doc.contains_key(&format!("[[{name}]]"))
            };
            let inner = section.trim_matches(|c| c == '[' || c == ']');
            let nested = if inner.is_empty() {
                accepted.to_string()
            } else {
                format!("{inner}.{accepted}")
            };
            assert!(
                keys.iter().any(|(k, _)| k == accepted) || sub(nested),
                "{section} `{accepted}` is accepted but not documented in docs/REFERENCE.md"
            );
        }
    }
}
