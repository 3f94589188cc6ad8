//! The code-shape invariants of docs/ARCHITECTURE.md ("Invariants"), checked by `cargo xtask
//! tidy` and its tests: no function over [`MAX_FN_LINES`] lines outside tests, no environment
//! variable read in a library crate, no library printing to the terminal, every CLI command
//! module under [`MAX_CMD_LINES`] lines, no `json!` literal in a library crate outside tests (a
//! JSON document is a serde struct of the crate's `contract` module), and no import cycle
//! between the top-level modules of a crate.
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
pub const LONG_FN_ALLOWED: &[(&str, &str)] = &[];

/// Environment variables a library crate may read: test hooks that exist today.
pub const ENV_ALLOWED: &[(&str, &str)] = &[
    // Fault injection of the all-or-nothing writer, for the robustness tests.
    ("crates/outdir/src/lib.rs", "CRASHRIG_OUTDIR_FAULT"),
];

/// Library files that may print to the terminal: `(file, why)`.
pub const PRINT_ALLOWED: &[(&str, &str)] = &[
    // The signal thread's one line when an interrupted run removed its unfinished output.
    ("crates/outdir/src/lib.rs", "interrupted"),
];

/// CLI command modules over [`MAX_CMD_LINES`] still to be moved into their libraries.
pub const CMD_ALLOWED: &[&str] = &[];

/// Library files that still build a JSON document with `json!` instead of the structs of a
/// `contract` module (issue 23, step 4, not yet converted).
pub const JSON_ALLOWED: &[&str] = &[];

/// Crates whose top-level modules still import each other in a cycle (none left).
pub const CYCLE_ALLOWED: &[&str] = &[];

/// Binary crates (may read the environment: they are the user interface).
const BINARIES: &[&str] = &["cli"];

/// Every check of this module, over the sources read once.
pub fn check(root: &Path) -> Result<Vec<String>> {
    let sources = crate_sources(root)?;
    let mut p = check_function_length(root, &sources);
    p.extend(check_env_reads(&sources));
    p.extend(check_prints(&sources));
    p.extend(check_cli_commands(&sources));
    p.extend(check_json_literals(root, &sources));
    p.extend(check_module_cycles(&sources));
    Ok(p)
}

/// A source file of a crate under `crates/`: the one walker every check reads.
pub struct Source {
    /// The crate's directory name (`colmap`, `cli`, ...).
    krate: String,
    /// The path relative to the root, `/`-separated (as in the allow-lists).
    rel: String,
    /// The path relative to the crate's `src/`.
    in_src: PathBuf,
    text: String,
}

impl Source {
    /// The lines before the file's tests (a top-level `#[cfg(test)]`).
    fn code_lines(&self) -> Vec<&str> {
        self.text
            .lines()
            .take_while(|l| !l.starts_with("#[cfg(test)]"))
            .collect()
    }

    /// Whether the file belongs to a library crate (binaries are the user interface).
    fn in_library(&self) -> bool {
        !BINARIES.contains(&self.krate.as_str())
    }
}

/// Every `crates/<name>/src/**.rs`, read, by crate name then path.
pub fn crate_sources(root: &Path) -> Result<Vec<Source>> {
    let mut out = Vec::new();
    let mut crates: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .context("listing crates/")?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<_>>()?;
    crates.sort();
    for dir in crates.into_iter().filter(|d| d.join("Cargo.toml").exists()) {
        let krate = dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let src = dir.join("src");
        for f in rust_files(&src)? {
            let text =
                std::fs::read_to_string(&f).with_context(|| format!("reading {}", f.display()))?;
            out.push(Source {
                krate: krate.to_string(),
                rel: unix(f.strip_prefix(root).unwrap_or(&f)),
                in_src: f.strip_prefix(&src).unwrap_or(&f).to_path_buf(),
                text,
            });
        }
    }
    Ok(out)
}

/// Each code line of the library files outside tests (the part before a `//` comment), with
/// its file and 1-based line number.
fn library_code(sources: &[Source]) -> impl Iterator<Item = (&Source, usize, &str)> {
    sources.iter().filter(|s| s.in_library()).flat_map(|s| {
        s.code_lines()
            .into_iter()
            .enumerate()
            .map(move |(i, l)| (s, i + 1, l.split("//").next().unwrap_or("")))
    })
}

/// The `.rs` files below `dir`, sorted (none when `dir` does not exist; `target` and
/// `test_data` directories are skipped).
pub fn rust_files(dir: &Path) -> Result<Vec<PathBuf>> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
        for e in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
            let p = e?.path();
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if p.is_dir() && name != "target" && name != "test_data" {
                walk(&p, out)?;
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    if dir.exists() {
        walk(dir, &mut out)?;
    }
    out.sort();
    Ok(out)
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
pub fn check_function_length(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for s in sources {
        for (name, line, len) in functions(&s.code_lines()) {
            if len <= MAX_FN_LINES {
                continue;
            }
            let rel = s.rel.as_str();
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
    for a in LONG_FN_ALLOWED {
        if !used.contains(a) && root.join(a.0).exists() {
            problems.push(format!(
                "{}: fn {} is in LONG_FN_ALLOWED but no longer over {MAX_FN_LINES} lines: remove the entry",
                a.0, a.1
            ));
        }
    }
    problems
}

/// No `std::env::var` / `var_os` in a library crate outside tests, except [`ENV_ALLOWED`].
pub fn check_env_reads(sources: &[Source]) -> Vec<String> {
    library_code(sources)
        .filter(|(s, _, code)| {
            (code.contains("env::var(") || code.contains("env::var_os("))
                && !ENV_ALLOWED.iter().any(|(p, _)| *p == s.rel)
        })
        .map(|(s, line, _)| {
            format!(
                "{}:{line}: a library reads an environment variable (take it as an argument)",
                s.rel
            )
        })
        .collect()
}

/// No `print!` / `println!` / `eprint!` / `eprintln!` in a library crate outside tests, except
/// [`PRINT_ALLOWED`]: libraries return typed values and the bytes of their files, and only the
/// front ends (the CLI, Python) decide what reaches the terminal.
pub fn check_prints(sources: &[Source]) -> Vec<String> {
    let prints = |code: &str| {
        ["print!(", "println!(", "eprint!(", "eprintln!("]
            .iter()
            .any(|m| {
                code.match_indices(m).any(|(i, _)| {
                    i == 0 || !code[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_')
                })
            })
    };
    // A module file named `tests.rs` or `*_tests.rs` is a test module (`#[cfg(test)] mod
    // tests;` in its parent).
    let test_file = |s: &Source| {
        s.in_src
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n == "tests.rs" || n.ends_with("_tests.rs"))
    };
    library_code(sources)
        .filter(|(s, _, code)| {
            prints(code) && !test_file(s) && !PRINT_ALLOWED.iter().any(|(p, _)| *p == s.rel)
        })
        .map(|(s, line, _)| {
            format!(
                "{}:{line}: a library prints (return the text or a warning to the front end)",
                s.rel
            )
        })
        .collect()
}

/// Every `crates/cli/src/cmd/**.rs` under [`MAX_CMD_LINES`] lines, except [`CMD_ALLOWED`].
pub fn check_cli_commands(sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    for s in sources
        .iter()
        .filter(|s| s.rel.starts_with("crates/cli/src/cmd/"))
    {
        let (rel, n) = (&s.rel, s.text.lines().count());
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
    problems
}

/// No `json!` in a library crate outside tests and doc comments, except [`JSON_ALLOWED`].
pub fn check_json_literals(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for (s, line, _) in library_code(sources).filter(|(_, _, code)| json_literal(code)) {
        if let Some(a) = JSON_ALLOWED.iter().find(|p| **p == s.rel) {
            used.insert(*a);
            continue;
        }
        problems.push(format!(
            "{}:{line}: a library builds JSON with `json!` (a serde struct in the crate's `contract` module)",
            s.rel
        ));
    }
    for a in JSON_ALLOWED {
        if !used.contains(a) && root.join(a).exists() {
            problems.push(format!(
                "{a}: in JSON_ALLOWED but has no `json!`: remove the entry"
            ));
        }
    }
    problems
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
pub fn check_module_cycles(sources: &[Source]) -> Vec<String> {
    let mut by_crate: BTreeMap<&str, Vec<&Source>> = BTreeMap::new();
    for s in sources {
        by_crate.entry(&s.krate).or_default().push(s);
    }
    let mut problems = Vec::new();
    for (krate, files) in by_crate {
        let mods: BTreeSet<String> = files.iter().filter_map(|s| top_module(&s.in_src)).collect();
        let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for s in &files {
            let Some(from) = top_module(&s.in_src) else {
                continue;
            };
            for l in s.code_lines() {
                let code = l.split("//").next().unwrap_or("");
                for t in crate_imports(code) {
                    if t != from && mods.contains(&t) {
                        edges.entry(from.clone()).or_default().insert(t);
                    }
                }
            }
        }
        if let Some(cycle) = find_cycle(&edges) {
            if !CYCLE_ALLOWED.contains(&krate) {
                problems.push(format!(
                    "crates/{krate}: modules import each other in a cycle: {}",
                    cycle.join(" → ")
                ));
            }
        } else if CYCLE_ALLOWED.contains(&krate) {
            problems.push(format!(
                "crates/{krate} is in CYCLE_ALLOWED but has no module cycle: remove the entry"
            ));
        }
    }
    problems
}

/// The first path segments after each `crate::` of a code line (`use crate::{a, b::c}` gives
/// both `a` and `b`).
fn crate_imports(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (pos, _) in code.match_indices("crate::") {
        let before = code[..pos].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // `crashrig_x::` etc.
        }
        let rest = &code[pos + 7..];
        if let Some(list) = rest.strip_prefix('{') {
            out.extend(
                list.split([',', '}'])
                    .map(|s| s.trim().split("::").next().unwrap_or("").to_string()),
            );
        } else {
            out.push(
                rest.chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect(),
            );
        }
    }
    out
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

    /// A throw-away tree of crates under the system's temporary directory, removed on drop.
    struct Tree(PathBuf);

    impl Tree {
        /// `files`: (path below the root, text); every `crates/<name>/` gets a Cargo.toml.
        fn new(name: &str, files: &[(&str, &str)]) -> Tree {
            let root =
                std::env::temp_dir().join(format!("xtask-tidy-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&root);
            for (path, text) in files {
                let path = root.join(path);
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                std::fs::write(&path, text).unwrap();
                let krate = path
                    .ancestors()
                    .find(|a| a.parent().is_some_and(|p| p.ends_with("crates")));
                std::fs::write(krate.unwrap().join("Cargo.toml"), "").unwrap();
            }
            Tree(root)
        }

        /// Every problem `check` finds in the tree.
        fn problems(&self) -> Vec<String> {
            check(&self.0).unwrap()
        }
    }

    impl Drop for Tree {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn a_long_function_is_caught_outside_tests_only() {
        let long = |name: &str| {
            format!(
                "fn {name}() {{\n{}}}\n",
                "    x();\n".repeat(MAX_FN_LINES - 1)
            )
        };
        let text = format!(
            "//! k\n{}#[cfg(test)]\nmod tests {{\n{}}}\n",
            long("a"),
            long("b")
        );
        let t = Tree::new("fn", &[("crates/k/src/lib.rs", &text)]);
        let n = MAX_FN_LINES + 1;
        assert_eq!(
            t.problems(),
            [format!(
                "crates/k/src/lib.rs:2: fn a is {n} lines (at most {MAX_FN_LINES} outside tests; split it)"
            )]
        );
    }

    #[test]
    fn an_env_read_is_caught_in_a_library_not_in_the_cli() {
        let read = "//! k\nfn f() {\n    let _ = std::env::var(\"X\"); // and var_os\n}\n";
        let t = Tree::new(
            "env",
            &[
                ("crates/k/src/a.rs", read),
                ("crates/cli/src/main.rs", read),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/k/src/a.rs:3: a library reads an environment variable (take it as an argument)"
            ]
        );
    }

    #[test]
    fn a_print_is_caught_in_a_library_not_in_the_cli_nor_in_tests_or_docs() {
        let text = "//! k\n/// println!(\"doc\")\nfn f() {\n    eprintln!(\"x\");\n    my_println!(\"y\");\n}\n#[cfg(test)]\nmod tests {\n    fn t() { println!(\"t\"); }\n}\n";
        let t = Tree::new(
            "print",
            &[
                ("crates/k/src/a.rs", text),
                ("crates/cli/src/main.rs", text),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/k/src/a.rs:4: a library prints (return the text or a warning to the front end)"
            ]
        );
    }

    #[test]
    fn a_long_command_module_is_caught() {
        let text = "//! c\n".repeat(MAX_CMD_LINES);
        let t = Tree::new(
            "cmd",
            &[
                ("crates/cli/src/cmd/c.rs", &text),
                ("crates/cli/src/cmd/d.rs", "//! d\n"),
            ],
        );
        assert_eq!(
            t.problems(),
            [format!(
                "crates/cli/src/cmd/c.rs: {MAX_CMD_LINES} lines; a command is arguments → config → one library call → print (under {MAX_CMD_LINES})"
            )]
        );
    }

    #[test]
    fn a_json_literal_is_caught_in_library_code_only() {
        let text = "//! k\n//! serde_json::json!({})\nfn f() {\n    g(json!(1));\n}\n#[cfg(test)]\nmod tests {\n    fn t() { json!(2); }\n}\n";
        let t = Tree::new(
            "json",
            &[
                ("crates/k/src/lib.rs", text),
                ("crates/cli/src/main.rs", text),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/k/src/lib.rs:4: a library builds JSON with `json!` (a serde struct in the crate's `contract` module)"
            ]
        );
    }

    #[test]
    fn a_module_cycle_is_caught_and_an_import_list_counts() {
        let t = Tree::new(
            "cycle",
            &[
                ("crates/k/src/lib.rs", "//! k\nmod a;\nmod b;\nmod c;\n"),
                ("crates/k/src/a.rs", "//! a\nuse crate::b::X;\n"),
                ("crates/k/src/b.rs", "//! b\nuse crate::{c, lib};\n"),
                ("crates/k/src/c/mod.rs", "//! c\nuse crate::a::Y;\n"),
            ],
        );
        assert_eq!(
            t.problems(),
            ["crates/k: modules import each other in a cycle: a → b → c → a"]
        );
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
