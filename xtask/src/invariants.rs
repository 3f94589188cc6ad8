//! The code-shape invariants of docs/ARCHITECTURE.md ("Invariants"), checked by `cargo xtask
//! tidy` and its tests: no function over [`MAX_FN_LINES`] lines outside tests, no environment
//! variable read in a library crate, every CLI command module under [`MAX_CMD_LINES`] lines,
//! no `json!` literal in a library crate outside tests (a JSON document is a serde struct of
//! the crate's `contract` module), and no import cycle between the top-level modules of a crate.
//!
//! The scanner reads rustfmt-formatted source line by line: a function runs from its `fn` line
//! to the `}` at the same indentation; a file's tests start at a top-level `#[cfg(test)]`.
//! Known exceptions are named in the allow-lists below, each with the reason; an entry that is
//! no longer needed is reported too, so the lists only shrink.

use anyhow::{Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Longest function allowed outside tests (lines, signature and closing brace included).
pub const MAX_FN_LINES: usize = 150;
/// Longest CLI command module (lines): arguments → config → one library call → print.
pub const MAX_CMD_LINES: usize = 150;

/// Functions over [`MAX_FN_LINES`] still to be split: `(file, function)`.
pub const LONG_FN_ALLOWED: &[(&str, &str)] = &[
    // Issue 23, not yet split.
    ("crates/study/src/study_file.rs", "from_toml_str"),
    ("crates/colmap/src/reconstruction.rs", "build"),
    ("crates/study/src/calibration.rs", "text_report"),
    ("crates/study/src/pipeline.rs", "run_study"),
];

/// Environment variables a library crate may read: test hooks that exist today.
pub const ENV_ALLOWED: &[(&str, &str)] = &[
    // Fault injection of the all-or-nothing writer, for the robustness tests.
    ("crates/outdir/src/lib.rs", "CRASHRIG_OUTDIR_FAULT"),
];

/// CLI command modules over [`MAX_CMD_LINES`] still to be moved into their libraries.
pub const CMD_ALLOWED: &[&str] = &["crates/cli/src/cmd/colmap.rs"];

/// Library files that still build a JSON document with `json!` instead of the structs of a
/// `contract` module (issue 23, step 4, not yet converted).
pub const JSON_ALLOWED: &[&str] = &[
    "crates/study/src/calibration.rs",
    "crates/study/src/pipeline.rs",
];

/// Crates whose top-level modules still import each other in a cycle: `mc` until its
/// restructuring (issue 23, arch-mc); `study`: `epochs` takes its error type from
/// `calibration`, which calls `epochs` (move `CalibrationError` down to break it).
pub const CYCLE_ALLOWED: &[&str] = &["study"];

/// Binary crates (may read the environment: they are the user interface).
const BINARIES: &[&str] = &["cli"];

/// Every check of this module.
pub fn check(root: &Path) -> Result<Vec<String>> {
    let mut p = check_function_length(root)?;
    p.extend(check_env_reads(root)?);
    p.extend(check_cli_commands(root)?);
    p.extend(check_json_literals(root)?);
    p.extend(check_module_cycles(root)?);
    Ok(p)
}

/// `crates/<name>/src/**.rs`, relative to `root`, by crate name.
fn crate_sources(root: &Path) -> Result<BTreeMap<String, Vec<PathBuf>>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(root.join("crates")).context("listing crates/")? {
        let dir = e?.path();
        if !dir.join("Cargo.toml").exists() {
            continue;
        }
        let name = dir
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("")
            .to_string();
        let mut files = Vec::new();
        collect(&dir.join("src"), &mut files)?;
        let files = files
            .into_iter()
            .map(|f| f.strip_prefix(root).map(Path::to_path_buf).unwrap_or(f))
            .collect();
        out.insert(name, files);
    }
    Ok(out)
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    if !dir.exists() {
        return Ok(());
    }
    for e in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let p = e?.path();
        if p.is_dir() {
            collect(&p, out)?;
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    Ok(())
}

/// The lines of a file before its tests (a top-level `#[cfg(test)]`).
fn code_lines(text: &str) -> Vec<&str> {
    text.lines()
        .take_while(|l| !l.starts_with("#[cfg(test)]"))
        .collect()
}

fn unix(p: &Path) -> String {
    p.to_string_lossy().replace('\\', "/")
}

/// The name of the function defined on `line`, if any.
fn fn_name(line: &str) -> Option<&str> {
    let t = line.trim_start();
    let t = t.strip_prefix("pub ").or_else(|| {
        t.strip_prefix("pub(")
            .and_then(|r| r.split_once(") ").map(|(_, rest)| rest))
    });
    let t = t.unwrap_or(line.trim_start());
    let t = ["const ", "async ", "unsafe ", "extern \"C\" "]
        .iter()
        .fold(t, |t, q| t.strip_prefix(q).unwrap_or(t));
    let rest = t.strip_prefix("fn ")?;
    let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    Some(&rest[..end])
}

/// Functions (name, first line, length) of `lines`.
fn functions<'a>(lines: &[&'a str]) -> Vec<(&'a str, usize, usize)> {
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let Some(name) = fn_name(l) else { continue };
        let indent = l.len() - l.trim_start().len();
        let close = format!("{}}}", " ".repeat(indent));
        // A declaration without a body (trait method) ends with `;` before any `{`.
        let Some(b) = lines[i..]
            .iter()
            .position(|x| x.contains('{') || x.trim_end().ends_with(';'))
        else {
            continue;
        };
        let body = lines[i + b];
        if !body.contains('{') {
            continue;
        }
        if body.matches('{').count() == body.matches('}').count() {
            out.push((name, i + 1, b + 1)); // `fn f() {}` on one line
            continue;
        }
        if let Some(end) = lines[i + b..].iter().position(|x| x.trim_end() == close) {
            out.push((name, i + 1, b + end + 1));
        }
    }
    out
}

/// No function over [`MAX_FN_LINES`] lines outside tests, except [`LONG_FN_ALLOWED`].
pub fn check_function_length(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for files in crate_sources(root)?.values() {
        for f in files {
            let text = std::fs::read_to_string(root.join(f))?;
            let rel = unix(f);
            for (name, line, len) in functions(&code_lines(&text)) {
                if len <= MAX_FN_LINES {
                    continue;
                }
                if let Some(a) = LONG_FN_ALLOWED
                    .iter()
                    .find(|(p, n)| *p == rel && *n == name)
                {
                    used.insert(*a);
                    continue;
                }
                problems.push(format!(
                    "{rel}:{line}: fn {name} is {len} lines (at most {MAX_FN_LINES} outside tests; split it)"
                ));
            }
        }
    }
    for a in LONG_FN_ALLOWED {
        if !used.contains(a) && root.join(a.0).exists() {
            problems.push(format!(
                "{}: fn {} is in LONG_FN_ALLOWED but no longer over {MAX_FN_LINES} lines: remove the entry",
                a.0, a.1
            ));
        }
    }
    Ok(problems)
}

/// No `std::env::var` / `var_os` in a library crate outside tests, except [`ENV_ALLOWED`].
pub fn check_env_reads(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for (krate, files) in crate_sources(root)? {
        if BINARIES.contains(&krate.as_str()) {
            continue;
        }
        for f in files {
            let text = std::fs::read_to_string(root.join(&f))?;
            let rel = unix(&f);
            let allowed = ENV_ALLOWED.iter().any(|(p, _)| *p == rel);
            for (i, l) in code_lines(&text).iter().enumerate() {
                let code = l.split("//").next().unwrap_or("");
                if (code.contains("env::var(") || code.contains("env::var_os(")) && !allowed {
                    problems.push(format!(
                        "{rel}:{}: a library reads an environment variable (take it as an argument)",
                        i + 1
                    ));
                }
            }
        }
    }
    Ok(problems)
}

/// Every `crates/cli/src/cmd/**.rs` under [`MAX_CMD_LINES`] lines, except [`CMD_ALLOWED`].
pub fn check_cli_commands(root: &Path) -> Result<Vec<String>> {
    let mut files = Vec::new();
    collect(&root.join("crates/cli/src/cmd"), &mut files)?;
    let mut problems = Vec::new();
    for f in files {
        let rel = unix(f.strip_prefix(root).unwrap_or(&f));
        let n = std::fs::read_to_string(&f)?.lines().count();
        let allowed = CMD_ALLOWED.contains(&rel.as_str());
        if n >= MAX_CMD_LINES && !allowed {
            problems.push(format!(
                "{rel}: {n} lines; a command is arguments → config → one library call → print (under {MAX_CMD_LINES})"
            ));
        } else if n < MAX_CMD_LINES && allowed {
            problems.push(format!(
                "{rel}: in CMD_ALLOWED but {n} lines: remove the entry"
            ));
        }
    }
    Ok(problems)
}

/// No `json!` in a library crate outside tests and doc comments, except [`JSON_ALLOWED`].
pub fn check_json_literals(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for (krate, files) in crate_sources(root)? {
        if BINARIES.contains(&krate.as_str()) {
            continue;
        }
        for f in files {
            let text = std::fs::read_to_string(root.join(&f))?;
            let rel = unix(&f);
            for (i, l) in code_lines(&text).iter().enumerate() {
                if !json_literal(l) {
                    continue;
                }
                if let Some(a) = JSON_ALLOWED.iter().find(|p| **p == rel) {
                    used.insert(*a);
                    continue;
                }
                problems.push(format!(
                    "{rel}:{}: a library builds JSON with `json!` (a serde struct in the crate's `contract` module)",
                    i + 1
                ));
            }
        }
    }
    for a in JSON_ALLOWED {
        if !used.contains(a) && root.join(a).exists() {
            problems.push(format!(
                "{a}: in JSON_ALLOWED but has no `json!`: remove the entry"
            ));
        }
    }
    Ok(problems)
}

/// Whether `line` uses the `json!` macro in code (not in a comment).
fn json_literal(line: &str) -> bool {
    let code = line.split("//").next().unwrap_or("");
    code.match_indices("json!").any(|(i, _)| {
        !code[..i]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
    })
}

/// The top-level module of a source file (`None` for the crate root).
fn top_module(rel_to_src: &Path) -> Option<String> {
    let first = rel_to_src.components().next()?.as_os_str().to_str()?;
    let m = first.strip_suffix(".rs").unwrap_or(first);
    (m != "lib" && m != "main").then(|| m.to_string())
}

/// No cycle among the top-level modules of a crate (edges: `crate::<module>` in code outside
/// tests), except the crates in [`CYCLE_ALLOWED`].
pub fn check_module_cycles(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for (krate, files) in crate_sources(root)? {
        let src = PathBuf::from("crates").join(&krate).join("src");
        let mods: BTreeSet<String> = files
            .iter()
            .filter_map(|f| top_module(f.strip_prefix(&src).ok()?))
            .collect();
        let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for f in &files {
            let Some(from) = f.strip_prefix(&src).ok().and_then(top_module) else {
                continue;
            };
            let text = std::fs::read_to_string(root.join(f))?;
            for l in code_lines(&text) {
                let code = l.split("//").next().unwrap_or("");
                for (pos, _) in code.match_indices("crate::") {
                    let before = code[..pos].chars().last();
                    if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                        continue; // `crashrig_x::` etc.
                    }
                    let rest = &code[pos + 7..];
                    let name: String = rest
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    let mut targets = vec![name];
                    // `use crate::{a, b::c}`
                    if let Some(list) = rest.strip_prefix('{') {
                        targets = list
                            .split([',', '}'])
                            .map(|s| s.trim().split("::").next().unwrap_or("").to_string())
                            .collect();
                    }
                    for t in targets {
                        if t != from && mods.contains(&t) {
                            edges.entry(from.clone()).or_default().insert(t);
                        }
                    }
                }
            }
        }
        if let Some(cycle) = find_cycle(&edges) {
            if !CYCLE_ALLOWED.contains(&krate.as_str()) {
                problems.push(format!(
                    "crates/{krate}: modules import each other in a cycle: {}",
                    cycle.join(" → ")
                ));
            }
        } else if CYCLE_ALLOWED.contains(&krate.as_str()) {
            problems.push(format!(
                "crates/{krate} is in CYCLE_ALLOWED but has no module cycle: remove the entry"
            ));
        }
    }
    Ok(problems)
}

/// One cycle of the graph (its nodes, the first repeated at the end), if any.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == n) {
            let mut c = path[i..].to_vec();
            c.push(n.to_string());
            return Some(c);
        }
        if done.contains(n) {
            return None;
        }
        path.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, edges, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(n.to_string());
        None
    }
    let mut done = BTreeSet::new();
    edges
        .keys()
        .find_map(|n| visit(n, edges, &mut Vec::new(), &mut done))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_invariants_hold() {
        let problems = check(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
    }

    #[test]
    fn fn_lengths_of_a_known_text() {
        let text = "fn a() {\n    x;\n}\n\npub(crate) fn b(\n    y: u8,\n) -> u8 {\n    y\n}\n    fn c();\n";
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(functions(&lines), vec![("a", 1, 3), ("b", 5, 5)]);
    }

    #[test]
    fn json_literals_in_code_not_in_comments() {
        assert!(json_literal("    let v = json!({\"a\": 1});"));
        assert!(json_literal("x(serde_json::json!([1]))"));
        assert!(!json_literal("//! let doc = serde_json::json!({});"));
        assert!(!json_literal("    f(); // json!(x) would be wrong"));
        assert!(!json_literal("    to_json!(x)"));
    }

    #[test]
    fn a_cycle_is_found_and_a_dag_is_not() {
        let mut e: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        e.entry("a".into()).or_default().insert("b".into());
        e.entry("b".into()).or_default().insert("c".into());
        assert_eq!(find_cycle(&e), None);
        e.entry("c".into()).or_default().insert("a".into());
        assert_eq!(find_cycle(&e).unwrap(), ["a", "b", "c", "a"]);
    }
}
