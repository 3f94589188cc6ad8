//! The code-shape invariants of docs/ARCHITECTURE.md ("Invariants"), checked by `cargo xtask
//! tidy` and its tests, over every line of `crates/*/src/**.rs` and `xtask/src/**.rs` outside
//! tests: no function over [`MAX_FN_LINES`] lines (libraries, the CLI and xtask), no environment
//! variable read in a library crate, no library printing to the terminal, every CLI command
//! module under [`MAX_CMD_LINES`] lines, no `json!` literal in a library crate (a JSON document
//! is a serde struct of the crate's `contract` module), no import cycle between the modules of
//! a crate at any level of its module tree (the CLI and xtask included), and no library error
//! that shows its source in its own message while also returning it from `source()`.
//!
//! Each file is parsed with `syn` ([`crate::syntax`]): test code (an item under `#[cfg(test)]`
//! or `#[test]`, the file of an out-of-line `#[cfg(test)] mod x;`) is skipped by its span and
//! the rest of the file is read. Known exceptions are named in the allow-lists below, each with
//! the reason; an entry that is no longer needed is reported too, so the lists only shrink.

use crate::syntax::{self, Facts};
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

/// Modules whose child modules still import each other in a cycle: `crate` or `crate::module`
/// (the level of the module tree where the cycle is).
pub const CYCLE_ALLOWED: &[&str] = &[];

/// Error types that still show their source in their own message: `(file, Type::Variant)`.
pub const ERROR_SOURCE_ALLOWED: &[(&str, &str)] = &[];

/// Library crates' error enums besides their one `Error`: `(file, enum, why)`.
pub const ERROR_ENUM_ALLOWED: &[(&str, &str, &str)] = &[(
    "crates/camera/src/error.rs",
    "UndistortError",
    "the reject kind of a partial map (cam_from_img), as ProjectionReject is for img_from_cam",
)];

/// Binary crates (may read the environment and print: they are the user interface, and xtask
/// the contributors').
const BINARIES: &[&str] = &["cli", "xtask"];

/// Every check of this module, over the sources read once.
pub fn check(root: &Path) -> Result<Vec<String>> {
    let sources = crate_sources(root)?;
    let mut p = check_parsed(&sources);
    p.extend(check_function_length(root, &sources));
    p.extend(check_env_reads(&sources));
    p.extend(check_prints(&sources));
    p.extend(check_cli_commands(&sources));
    p.extend(check_json_literals(root, &sources));
    p.extend(check_module_cycles(root, &sources));
    p.extend(check_error_sources(root, &sources));
    p.extend(check_error_enums(root, &sources));
    Ok(p)
}

/// A source file of a crate under `crates/`: the one walker every check reads.
pub struct Source {
    /// The crate's directory name (`colmap`, `cli`, ...).
    krate: String,
    /// The path relative to the root, `/`-separated (as in the allow-lists).
    rel: String,
    /// The module path of the file (`src/cmd/merge.rs` is `["cmd", "merge"]`, `src/lib.rs` `[]`).
    module: Vec<String>,
    /// Number of lines.
    lines: usize,
    /// What the parser found, or its error.
    facts: std::result::Result<Facts, String>,
    /// Whether the whole file is test code (the file of a `#[cfg(test)] mod x;`).
    test_file: bool,
}

impl Source {
    /// Whether the file belongs to a library crate (binaries are the user interface).
    fn in_library(&self) -> bool {
        !BINARIES.contains(&self.krate.as_str())
    }

    /// The facts of the file's code outside tests (none for a test file or one that does not
    /// parse; [`check_parsed`] reports the latter).
    fn code(&self) -> Option<&Facts> {
        self.facts.as_ref().ok().filter(|_| !self.test_file)
    }
}

/// Every `crates/<name>/src/**.rs`, then every `xtask/src/**.rs` (crate `xtask`), read and
/// parsed, by crate name then path.
pub fn crate_sources(root: &Path) -> Result<Vec<Source>> {
    let mut out = Vec::new();
    let mut crates: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .context("listing crates/")?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<_>>()?;
    crates.sort();
    // xtask is checked as the crates are (it is a binary: it may read the environment and print).
    crates.push(root.join("xtask"));
    for dir in crates.into_iter().filter(|d| d.join("Cargo.toml").exists()) {
        let krate = dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let src = dir.join("src");
        let first = out.len();
        for f in rust_files(&src)? {
            let text =
                std::fs::read_to_string(&f).with_context(|| format!("reading {}", f.display()))?;
            let module = module_of(f.strip_prefix(&src).unwrap_or(&f));
            out.push(Source {
                krate: krate.to_string(),
                rel: unix(f.strip_prefix(root).unwrap_or(&f)),
                lines: text.lines().count(),
                facts: syntax::read(&text, &module).map_err(|e| {
                    let at = e.span().start();
                    format!("{}:{}: {e}", at.line, at.column + 1)
                }),
                module,
                test_file: false,
            });
        }
        // The files of out-of-line test modules, and the modules below them.
        let tests: Vec<Vec<String>> = out[first..]
            .iter()
            .filter_map(|s| s.facts.as_ref().ok())
            .flat_map(|f| f.test_modules.iter().cloned())
            .collect();
        for s in &mut out[first..] {
            s.test_file = tests.iter().any(|t| s.module.starts_with(t));
        }
    }
    Ok(out)
}

/// The module path of a file relative to its crate's `src/` (`lib.rs` and `main.rs` are the
/// root, `x/mod.rs` is `x`).
fn module_of(in_src: &Path) -> Vec<String> {
    let mut m: Vec<String> = in_src
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if let Some(last) = m.pop() {
        let stem = last.strip_suffix(".rs").unwrap_or(&last);
        let root = m.is_empty() && (stem == "lib" || stem == "main");
        if stem != "mod" && !root {
            m.push(stem.to_string());
        }
    }
    m
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

/// Every source file parses (a check that cannot read a file cannot vouch for it).
pub fn check_parsed(sources: &[Source]) -> Vec<String> {
    sources
        .iter()
        .filter_map(|s| s.facts.as_ref().err().map(|e| format!("{}:{e}", s.rel)))
        .collect()
}

/// No function over [`MAX_FN_LINES`] lines outside tests, except [`LONG_FN_ALLOWED`].
pub fn check_function_length(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for s in sources {
        let Some(facts) = s.code() else { continue };
        for f in facts.functions.iter().filter(|f| f.lines > MAX_FN_LINES) {
            let rel = s.rel.as_str();
            if let Some(a) = LONG_FN_ALLOWED
                .iter()
                .find(|(p, n)| *p == rel && *n == f.name)
            {
                used.insert(*a);
                continue;
            }
            problems.push(format!(
                "{rel}:{}: fn {} is {} lines (at most {MAX_FN_LINES} outside tests; split it)",
                f.line, f.name, f.lines
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

/// The library files' facts outside tests.
fn library_code(sources: &[Source]) -> impl Iterator<Item = (&Source, &Facts)> {
    sources
        .iter()
        .filter(|s| s.in_library())
        .filter_map(|s| Some((s, s.code()?)))
}

/// No `std::env::var` / `var_os` in a library crate outside tests, except [`ENV_ALLOWED`].
pub fn check_env_reads(sources: &[Source]) -> Vec<String> {
    library_code(sources)
        .filter(|(s, _)| !ENV_ALLOWED.iter().any(|(p, _)| *p == s.rel))
        .flat_map(|(s, f)| {
            f.env_reads.iter().map(move |line| {
                format!(
                    "{}:{line}: a library reads an environment variable (take it as an argument)",
                    s.rel
                )
            })
        })
        .collect()
}

/// No `print!` / `println!` / `eprint!` / `eprintln!` in a library crate outside tests, except
/// [`PRINT_ALLOWED`]: libraries return typed values and the bytes of their files, and only the
/// front ends (the CLI, Python) decide what reaches the terminal.
pub fn check_prints(sources: &[Source]) -> Vec<String> {
    library_code(sources)
        .filter(|(s, _)| !PRINT_ALLOWED.iter().any(|(p, _)| *p == s.rel))
        .flat_map(|(s, f)| {
            f.macros
                .iter()
                .filter(|(m, _)| matches!(m.as_str(), "print" | "println" | "eprint" | "eprintln"))
                .map(move |(_, line)| {
                    format!(
                        "{}:{line}: a library prints (return the text or a warning to the front end)",
                        s.rel
                    )
                })
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
        let (rel, n) = (&s.rel, s.lines);
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

/// No `json!` in a library crate outside tests, except [`JSON_ALLOWED`].
pub fn check_json_literals(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for (s, f) in library_code(sources) {
        for (_, line) in f.macros.iter().filter(|(m, _)| m == "json") {
            if let Some(a) = JSON_ALLOWED.iter().find(|p| **p == s.rel) {
                used.insert(*a);
                continue;
            }
            problems.push(format!(
                "{}:{line}: a library builds JSON with `json!` (a serde struct in the crate's `contract` module)",
                s.rel
            ));
        }
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

/// No import cycle between the modules of a crate, at every level of its module tree: for each
/// module, its child modules (with everything below them) import each other in a DAG. A path
/// named outside tests (`crate::`, `super::`, `self::`, `use` trees) from module `a::x` to an
/// item in module `b::y` is an edge `a → b` among the children of their common parent; a path
/// to a module's own ancestors (the parent's items) is not an edge. Except [`CYCLE_ALLOWED`].
pub fn check_module_cycles(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut by_crate: BTreeMap<&str, Vec<&Source>> = BTreeMap::new();
    for s in sources {
        by_crate.entry(&s.krate).or_default().push(s);
    }
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for (krate, files) in by_crate {
        let code: Vec<(&Source, &Facts)> =
            files.iter().filter_map(|s| Some((*s, s.code()?))).collect();
        let modules: BTreeSet<&[String]> = code
            .iter()
            .flat_map(|(s, f)| {
                std::iter::once(s.module.as_slice())
                    .chain(f.inline_modules.iter().map(Vec::as_slice))
            })
            .collect();
        // level (the common parent) → sibling → siblings it imports from
        let mut levels: BTreeMap<Vec<String>, Edges> = BTreeMap::new();
        for r in code.iter().flat_map(|(_, f)| &f.references) {
            let Some(to) = (0..=r.to.len())
                .rev()
                .map(|n| &r.to[..n])
                .find(|m| modules.contains(m))
            else {
                continue;
            };
            let common = r.from.iter().zip(to).take_while(|(a, b)| a == b).count();
            if common < r.from.len() && common < to.len() {
                let level = r.from[..common].to_vec();
                let name = |m: &[String]| m[..=common].join("::");
                levels
                    .entry(level)
                    .or_default()
                    .entry(name(&r.from))
                    .or_default()
                    .insert(name(to));
            }
        }
        for (level, edges) in levels {
            let Some(cycle) = find_cycle(&edges) else {
                continue;
            };
            let key = [krate.to_string()]
                .into_iter()
                .chain(level)
                .collect::<Vec<_>>()
                .join("::");
            if CYCLE_ALLOWED.contains(&key.as_str()) {
                used.insert(key);
                continue;
            }
            problems.push(format!(
                "{}: modules import each other in a cycle: {}",
                crate_dir(krate),
                cycle.join(" → ")
            ));
        }
    }
    for a in CYCLE_ALLOWED {
        let krate = a.split("::").next().unwrap_or(a);
        if !used.contains(*a) && root.join(crate_dir(krate)).exists() {
            problems.push(format!(
                "{a} is in CYCLE_ALLOWED but has no module cycle: remove the entry"
            ));
        }
    }
    problems
}

/// One error enum per library crate (thiserror's `derive(Error)` outside tests), except
/// [`ERROR_ENUM_ALLOWED`]: a caller matches one type, and a step's failure is one of its variants.
pub fn check_error_enums(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut by_crate: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    let mut used = BTreeSet::new();
    for (s, f) in library_code(sources) {
        for (name, line) in &f.error_enums {
            if let Some(a) = ERROR_ENUM_ALLOWED
                .iter()
                .find(|(p, n, _)| *p == s.rel && n == name)
            {
                used.insert(a.1);
                continue;
            }
            by_crate
                .entry(&s.krate)
                .or_default()
                .push(format!("{}:{line}: {name}", s.rel));
        }
    }
    let mut problems: Vec<String> = by_crate
        .into_iter()
        .filter(|(_, enums)| enums.len() > 1)
        .map(|(krate, enums)| {
            format!(
                "{}: {} error enums ({}); a library crate has one (fold them into its `Error`)",
                crate_dir(krate),
                enums.len(),
                enums.join(", ")
            )
        })
        .collect();
    for (file, name, _) in ERROR_ENUM_ALLOWED {
        if !used.contains(name) && root.join(file).exists() {
            problems.push(format!(
                "{file}: {name} is in ERROR_ENUM_ALLOWED but is no error enum there: remove the entry"
            ));
        }
    }
    problems
}

/// The directory of crate `krate` relative to the root: `crates/<krate>`, or `xtask`.
fn crate_dir(krate: &str) -> String {
    if krate == "xtask" {
        krate.to_string()
    } else {
        format!("crates/{krate}")
    }
}

/// A library error type shows its own context only: no `#[error(...)]` message that also
/// formats the field the type returns from `source()` (`#[source]`, `#[from]` or a field named
/// `source`): the front ends print the chain of sources, so a repeat would be printed twice.
/// `#[error(transparent)]` forwards both. Except [`ERROR_SOURCE_ALLOWED`].
pub fn check_error_sources(root: &Path, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for (s, f) in library_code(sources) {
        for (name, field, line) in &f.errors_showing_source {
            let rel = s.rel.as_str();
            if let Some(a) = ERROR_SOURCE_ALLOWED
                .iter()
                .find(|(p, n)| *p == rel && n == name)
            {
                used.insert(*a);
                continue;
            }
            problems.push(format!(
                "{rel}:{line}: {name} shows its source `{field}` in its message and returns it from source() (show its own context only, or #[error(transparent)])"
            ));
        }
    }
    for a in ERROR_SOURCE_ALLOWED {
        if !used.contains(a) && root.join(a.0).exists() {
            problems.push(format!(
                "{}: {} is in ERROR_SOURCE_ALLOWED but no longer shows its source: remove the entry",
                a.0, a.1
            ));
        }
    }
    problems
}

/// A module graph: module → the modules it imports from.
type Edges = BTreeMap<String, BTreeSet<String>>;

/// One cycle of the graph (its nodes, the first repeated at the end), if any.
fn find_cycle(edges: &Edges) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        edges: &Edges,
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
                let krate = path.ancestors().find(|a| {
                    a.parent().is_some_and(|p| p.ends_with("crates")) || a.ends_with("xtask")
                });
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
    fn a_long_function_is_caught_outside_tests_only_after_a_test_use_and_in_the_cli() {
        let long = |name: &str| {
            format!(
                "fn {name}() {{\n{}}}\n",
                "    x();\n".repeat(MAX_FN_LINES - 1)
            )
        };
        // A `#[cfg(test)] use` at the top no longer hides the rest of the file; a test module
        // inline and one out of line are skipped.
        let text = format!(
            "//! k\n#[cfg(test)]\nuse std::fmt;\n{}#[cfg(test)]\nmod tests {{\n{}}}\n#[cfg(test)]\nmod more;\n",
            long("a"),
            long("b")
        );
        let t = Tree::new(
            "fn",
            &[
                ("crates/k/src/lib.rs", &text),
                ("crates/k/src/more.rs", &format!("//! t\n{}", long("c"))),
                ("crates/cli/src/main.rs", &format!("//! d\n{}", long("d"))),
            ],
        );
        let n = MAX_FN_LINES + 1;
        assert_eq!(
            t.problems(),
            [
                format!(
                    "crates/cli/src/main.rs:2: fn d is {n} lines (at most {MAX_FN_LINES} outside tests; split it)"
                ),
                format!(
                    "crates/k/src/lib.rs:4: fn a is {n} lines (at most {MAX_FN_LINES} outside tests; split it)"
                ),
            ]
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
    fn a_second_error_enum_is_caught_in_a_library_not_in_tests_or_the_cli() {
        let two = "//! k\n#[derive(Debug, thiserror::Error)]\npub enum Error {}\n#[derive(Debug, Error)]\npub enum StepError {}\n#[cfg(test)]\nmod tests {\n    #[derive(Debug, thiserror::Error)]\n    enum T {}\n}\n";
        let t = Tree::new(
            "enums",
            &[
                ("crates/k/src/lib.rs", two),
                (
                    "crates/j/src/lib.rs",
                    "//! j\n#[derive(thiserror::Error)]\npub enum Error {}\n",
                ),
                ("crates/cli/src/main.rs", two),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/k: 2 error enums (crates/k/src/lib.rs:3: Error, crates/k/src/lib.rs:5: StepError); a library crate has one (fold them into its `Error`)"
            ]
        );
    }

    #[test]
    fn xtask_is_read_and_its_import_cycle_is_caught_as_a_binary() {
        // The circle `package.rs ↔ tidy.rs` issue 45 removed, in a tree of its own; xtask may
        // read the environment and print (it is a binary), but its modules form a DAG too.
        let t = Tree::new(
            "xtask",
            &[
                ("crates/k/src/lib.rs", "//! k\n"),
                (
                    "xtask/src/main.rs",
                    "//! x\nmod package;\nmod tidy;\nfn main() {\n    println!(\"{:?}\", std::env::var(\"X\"));\n}\n",
                ),
                ("xtask/src/package.rs", "//! p\nuse crate::tidy::LEAN;\n"),
                (
                    "xtask/src/tidy.rs",
                    "//! t\nfn f() { crate::package::metadata(); }\n",
                ),
            ],
        );
        assert_eq!(
            t.problems(),
            ["xtask: modules import each other in a cycle: package → tidy → package"]
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
    fn a_super_cycle_among_nested_modules_of_the_cli_is_caught_and_the_parent_is_no_node() {
        let t = Tree::new(
            "super",
            &[
                (
                    "crates/cli/src/main.rs",
                    "//! m\nmod cmd;\nuse cmd::grid;\n",
                ),
                // The parent's own items (`super::write`) are not a sibling: no cycle.
                (
                    "crates/cli/src/cmd/mod.rs",
                    "//! c\npub mod grid;\npub mod merge;\npub fn write() { merge::f(); }\n",
                ),
                (
                    "crates/cli/src/cmd/grid.rs",
                    "//! g\npub fn g() {\n    super::write();\n    let _ = super::merge::shards();\n}\n",
                ),
                (
                    "crates/cli/src/cmd/merge.rs",
                    "//! m\nuse super::{grid::{g, G}, write};\n#[cfg(test)]\nuse crate::cmd::grid::T;\n",
                ),
                // A cycle inside test code is none.
                (
                    "crates/k/src/lib.rs",
                    "//! k\nmod a;\nmod b;\nuse crate::a::x;\n",
                ),
                (
                    "crates/k/src/a.rs",
                    "//! a\n#[cfg(test)]\nuse super::b::y;\n",
                ),
                ("crates/k/src/b.rs", "//! b\nfn f() { super::a::x(); }\n"),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/cli: modules import each other in a cycle: cmd::grid → cmd::merge → cmd::grid"
            ]
        );
    }

    #[test]
    fn an_error_that_shows_its_source_is_caught_in_a_library() {
        let text = "//! k\n#[derive(Debug, thiserror::Error)]\npub enum Error {\n    #[error(\"{}: cannot read: {source}\", path.display())]\n    Read { path: String, source: std::io::Error },\n    #[error(\"{}: cannot read\", path.display())]\n    Own { path: String, source: std::io::Error },\n}\n";
        let t = Tree::new(
            "error",
            &[
                ("crates/k/src/error.rs", text),
                ("crates/cli/src/main.rs", text),
            ],
        );
        assert_eq!(
            t.problems(),
            [
                "crates/k/src/error.rs:5: Error::Read shows its source `source` in its message and returns it from source() (show its own context only, or #[error(transparent)])"
            ]
        );
    }

    #[test]
    fn a_file_that_does_not_parse_is_a_problem() {
        let t = Tree::new("parse", &[("crates/k/src/lib.rs", "//! k\nfn f( {\n")]);
        let p = t.problems();
        assert!(
            p.len() == 1 && p[0].starts_with("crates/k/src/lib.rs:"),
            "{p:?}"
        );
    }

    #[test]
    fn module_paths_of_files() {
        let m = |p: &str| module_of(Path::new(p)).join("::");
        assert_eq!(m("lib.rs"), "");
        assert_eq!(m("main.rs"), "");
        assert_eq!(m("cmd/mod.rs"), "cmd");
        assert_eq!(m("cmd/merge.rs"), "cmd::merge");
        assert_eq!(m("cmd/lib.rs"), "cmd::lib");
    }

    #[test]
    fn a_cycle_is_found_and_a_dag_is_not() {
        let mut e = Edges::new();
        e.entry("a".into()).or_default().insert("b".into());
        e.entry("b".into()).or_default().insert("c".into());
        assert_eq!(find_cycle(&e), None);
        e.entry("c".into()).or_default().insert("a".into());
        assert_eq!(find_cycle(&e).unwrap(), ["a", "b", "c", "a"]);
    }
}
