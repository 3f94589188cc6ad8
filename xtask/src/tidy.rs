//! Checks that must always hold: the dependency DAG, the lean builds a dependent may choose
//! (`crate::package`), packaging, module docs, one test binary per crate, and what
//! docs/ARCHITECTURE.md states that a program can check (its code map, its DAG block, its size).
//!
//! Run by `cargo xtask tidy` and, through the tests at the bottom, by plain `cargo test`.

use anyhow::{Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The normal-dependency edges between workspace packages (from → to), exactly: an edge not in
/// the table and an entry that is no edge are both errors. docs/ARCHITECTURE.md's DAG block
/// lists the same edges (checked); adding an edge is a reviewed change to both.
pub const ALLOWED: &[(&str, &[&str])] = &[
    ("crashrig-geometry", &[]),
    ("crashrig-camera", &[]),
    ("crashrig-stats", &[]),
    ("crashrig-plot", &[]),
    ("crashrig-outdir", &[]),
    ("crashrig-frames", &["crashrig-outdir"]),
    ("crashrig-input", &["crashrig-geometry"]),
    ("crashrig-rig", &["crashrig-geometry", "crashrig-stats"]),
    (
        "crashrig-pose",
        &["crashrig-geometry", "crashrig-camera", "crashrig-stats"],
    ),
    ("crashrig-bootstrap", &["crashrig-stats"]),
    ("crashrig-testkit", &["crashrig-geometry"]),
    (
        "crashrig-colmap",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-outdir",
            "crashrig-input",
        ],
    ),
    (
        "crashrig-mc",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-stats",
            "crashrig-input",
            "crashrig-colmap",
        ],
    ),
    (
        "crashrig-covariance",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-stats",
            "crashrig-input",
            "crashrig-colmap",
        ],
    ),
    (
        "crashrig-measure",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-colmap",
        ],
    ),
    (
        "crashrig-calibrate",
        &[
            "crashrig-geometry",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-rig",
            "crashrig-colmap",
        ],
    ),
    (
        "crashrig-tie",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-pose",
            "crashrig-bootstrap",
            "crashrig-colmap",
        ],
    ),
    (
        "crashrig-grid",
        &[
            "crashrig-geometry",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-mc",
        ],
    ),
    (
        "crashrig-study",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-rig",
            "crashrig-bootstrap",
            "crashrig-colmap",
            "crashrig-mc",
            "crashrig-covariance",
            "crashrig-measure",
            "crashrig-calibrate",
            "crashrig-tie",
            "crashrig-grid",
        ],
    ),
    (
        "crashrig-place",
        &[
            "crashrig-stats",
            "crashrig-outdir",
            "crashrig-mc",
            "crashrig-grid",
        ],
    ),
    (
        "crashrig-merge",
        &[
            "crashrig-stats",
            "crashrig-outdir",
            "crashrig-measure",
            "crashrig-grid",
            "crashrig-place",
        ],
    ),
    (
        "crashrig-cli",
        &[
            "crashrig-frames",
            "crashrig-geometry",
            "crashrig-stats",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-bootstrap",
            "crashrig-colmap",
            "crashrig-mc",
            "crashrig-covariance",
            "crashrig-measure",
            "crashrig-calibrate",
            "crashrig-tie",
            "crashrig-grid",
            "crashrig-study",
            "crashrig-place",
            "crashrig-merge",
            "crashrig-track",
        ],
    ),
    (
        "crashrig-track",
        &[
            "crashrig-frames",
            "crashrig-input",
            "crashrig-outdir",
            "crashrig-stats",
        ],
    ),
    (
        "crashrig-python",
        &[
            "crashrig-geometry",
            "crashrig-stats",
            "crashrig-outdir",
            "crashrig-input",
            "crashrig-bootstrap",
            "crashrig-colmap",
            "crashrig-mc",
            "crashrig-covariance",
            "crashrig-measure",
            "crashrig-calibrate",
            "crashrig-tie",
            "crashrig-grid",
            "crashrig-study",
            "crashrig-place",
            "crashrig-merge",
        ],
    ),
    (
        "crashrig-benches",
        &["crashrig-geometry", "crashrig-stats", "crashrig-mc"],
    ),
    ("xtask", &[]),
];

/// Runs every check and returns the problems found (empty = tidy).
pub fn check(root: &Path) -> Result<Vec<String>> {
    let mut problems = check_dag(root)?;
    problems.extend(crate::package::check_lean_builds(root)?);
    problems.extend(crate::package::check_packaging(root)?);
    problems.extend(check_module_docs(root)?);
    problems.extend(check_code_map(root)?);
    problems.extend(check_one_test_binary(root)?);
    problems.extend(crate::invariants::check(root)?);
    Ok(problems)
}

/// Workspace packages and their internal dependencies: name → (normal, dev).
type Edges = BTreeMap<String, (BTreeSet<String>, BTreeSet<String>)>;

fn workspace_edges(root: &Path) -> Result<Edges> {
    let meta = crate::package::metadata(root)?;
    let packages = meta["packages"]
        .as_array()
        .context("metadata without packages")?;
    let names: BTreeSet<String> = packages
        .iter()
        .filter_map(|p| p["name"].as_str().map(str::to_string))
        .collect();
    let mut edges = Edges::new();
    for p in packages {
        let name = p["name"].as_str().unwrap_or_default().to_string();
        let entry = edges.entry(name).or_default();
        for d in p["dependencies"].as_array().into_iter().flatten() {
            let dep = d["name"].as_str().unwrap_or_default().to_string();
            if !names.contains(&dep) {
                continue;
            }
            match d["kind"].as_str() {
                Some("dev") => entry.1.insert(dep),
                _ => entry.0.insert(dep),
            };
        }
    }
    Ok(edges)
}

/// Normal edges must be in [`ALLOWED`] and every edge of [`ALLOWED`] must be one (so the table,
/// and the DAG of docs/ARCHITECTURE.md that repeats it, is the graph); `crashrig-testkit` only as
/// a dev-dependency; dev edges must not create a cycle through normal edges (a dev-dependency on
/// a crate that depends on you).
pub fn check_dag(root: &Path) -> Result<Vec<String>> {
    let allowed: BTreeMap<&str, BTreeSet<&str>> = ALLOWED
        .iter()
        .map(|(k, v)| (*k, v.iter().copied().collect()))
        .collect();
    let edges = workspace_edges(root)?;
    let mut problems = Vec::new();
    for (from, (normal, dev)) in &edges {
        let Some(ok) = allowed.get(from.as_str()) else {
            problems.push(format!(
                "package `{from}` is not in the DAG table (xtask/src/tidy.rs, docs/ARCHITECTURE.md)"
            ));
            continue;
        };
        for to in normal {
            if !ok.contains(to.as_str()) {
                problems.push(format!(
                    "dependency edge `{from}` -> `{to}` is not in the DAG (docs/ARCHITECTURE.md)"
                ));
            }
        }
        for to in ok.iter().filter(|to| !normal.contains(**to)) {
            problems.push(format!(
                "`{from}` -> `{to}` is in the DAG table but not a dependency: remove it (xtask/src/tidy.rs, docs/ARCHITECTURE.md)"
            ));
        }
        if normal.contains("crashrig-testkit") {
            problems.push(format!(
                "`{from}` has crashrig-testkit as a normal dependency (dev-only)"
            ));
        }
        for to in dev {
            // testkit depends on the crates it serves by design; it is reached from tests only.
            if to != "crashrig-testkit" && reaches(&edges, to, from) {
                problems.push(format!("dev-dependency `{from}` -> `{to}` closes a cycle"));
            }
        }
    }
    Ok(problems)
}

/// Whether `from` reaches `target` through normal dependencies.
fn reaches(edges: &Edges, from: &str, target: &str) -> bool {
    if from == target {
        return false; // a crate's dev-dependency on a crate depending on it is checked via others
    }
    let mut stack = vec![from.to_string()];
    let mut seen = BTreeSet::new();
    while let Some(n) = stack.pop() {
        if n == target {
            return true;
        }
        if seen.insert(n.clone())
            && let Some((normal, _)) = edges.get(&n)
        {
            stack.extend(normal.iter().cloned());
        }
    }
    false
}

/// Every Rust source file under crates/, xtask/ and benches/ starts with a `//!` doc line.
pub fn check_module_docs(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for dir in ["crates", "xtask/src", "benches"] {
        for f in crate::invariants::rust_files(&root.join(dir))? {
            let text =
                std::fs::read_to_string(&f).with_context(|| format!("reading {}", f.display()))?;
            let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
            if !first.starts_with("//!") {
                let rel = f.strip_prefix(root).unwrap_or(&f);
                problems.push(format!(
                    "{}: first line must be a `//!` module doc",
                    rel.display()
                ));
            }
        }
    }
    Ok(problems)
}

/// One integration-test binary per crate (each binary links the whole dependency graph, so
/// fewer binaries make the test command quicker): a crate with a `tests/` directory declares
/// `autotests = false` and the one target `tests/tests.rs`, and every other `tests/*.rs` file
/// is a `mod` of it — a file that is not would silently never run.
pub fn check_one_test_binary(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for e in std::fs::read_dir(root.join("crates"))? {
        let dir = e?.path();
        let tests = dir.join("tests");
        if !dir.join("Cargo.toml").exists() || !tests.is_dir() {
            continue;
        }
        let rel = dir.strip_prefix(root).unwrap_or(&dir).display().to_string();
        let rs: Vec<String> = std::fs::read_dir(&tests)?
            .filter_map(|f| f.ok()?.file_name().into_string().ok())
            .filter(|n| n.ends_with(".rs"))
            .collect();
        if rs.is_empty() {
            continue;
        }
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml"))?;
        problems.extend(one_test_binary_problems(&rel, &manifest, &tests, &rs)?);
    }
    problems.sort();
    Ok(problems)
}

fn one_test_binary_problems(
    rel: &str,
    manifest: &str,
    tests: &Path,
    rs: &[String],
) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let compact: String = manifest.split_whitespace().collect();
    if !compact.contains("autotests=false") {
        problems.push(format!(
            "{rel}/Cargo.toml: integration tests need `autotests = false` and one [[test]] `tests/tests.rs`"
        ));
    }
    if compact.matches("[[test]]").count() != 1 || !compact.contains("path=\"tests/tests.rs\"") {
        problems.push(format!(
            "{rel}/Cargo.toml: exactly one [[test]] target, path = \"tests/tests.rs\""
        ));
    }
    let main = match std::fs::read_to_string(tests.join("tests.rs")) {
        Ok(t) => t,
        Err(_) => {
            problems.push(format!("{rel}/tests/tests.rs is missing"));
            return Ok(problems);
        }
    };
    let declared: BTreeSet<&str> = main
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mod ")?.strip_suffix(';'))
        .collect();
    for f in rs {
        let name = f.trim_end_matches(".rs");
        if name != "tests" && !declared.contains(name) {
            problems.push(format!(
                "{rel}/tests/{f} is not a `mod` of tests/tests.rs: it would never run"
            ));
        }
    }
    Ok(problems)
}

/// Largest size of docs/ARCHITECTURE.md (bytes): a map, not an API index (issue 45).
pub const ARCHITECTURE_MAX_BYTES: usize = 30_000;
/// Longest line of docs/ARCHITECTURE.md (characters; one sentence per line).
pub const ARCHITECTURE_MAX_LINE: usize = 400;

/// docs/ARCHITECTURE.md says what a program can check, and tidy checks it
/// ([`architecture_problems`] on the page, the crates under `crates/` and [`ALLOWED`]).
pub fn check_code_map(root: &Path) -> Result<Vec<String>> {
    let arch = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md"))
        .context("reading docs/ARCHITECTURE.md")?;
    let mut crates = BTreeSet::new();
    for e in std::fs::read_dir(root.join("crates"))? {
        let p = e?.path();
        if p.join("Cargo.toml").exists() {
            crates.insert(
                p.file_name()
                    .and_then(|n| n.to_str())
                    .unwrap_or_default()
                    .to_string(),
            );
        }
    }
    Ok(architecture_problems(&arch, &crates, ALLOWED))
}

/// What is wrong with the architecture page `arch`: every crate of `crates` has a code-map
/// section (`` ### `crates/<dir>` ``) and every section names a crate of `crates` or is a slot
/// marked `(slot)`; the fenced block after `## The dependency DAG` lists exactly the edges of
/// `allowed` (one line per package, `name -> dep, dep` with the `crashrig-` prefix left out,
/// an optional layer label in front); the page is at most [`ARCHITECTURE_MAX_BYTES`] with no
/// line over [`ARCHITECTURE_MAX_LINE`] characters; it cites no file outside the repository.
pub fn architecture_problems(
    arch: &str,
    crates: &BTreeSet<String>,
    allowed: &[(&str, &[&str])],
) -> Vec<String> {
    let page = "docs/ARCHITECTURE.md";
    let mut problems = Vec::new();
    for dir in crates {
        let needle = format!("### `crates/{dir}`");
        if !arch.lines().any(|l| l.starts_with(&needle)) {
            problems.push(format!("{page} has no code-map section `{needle}`"));
        }
    }
    for l in arch.lines().filter(|l| l.starts_with("### `crates/")) {
        let dir = l["### `crates/".len()..]
            .split('`')
            .next()
            .unwrap_or_default();
        if !crates.contains(dir) && !l.contains("(slot)") {
            problems.push(format!(
                "{page}: code-map section `{l}` names no crate under crates/ (mark a placeholder `(slot)`)"
            ));
        }
    }
    if arch.len() > ARCHITECTURE_MAX_BYTES {
        problems.push(format!(
            "{page} is {} bytes (at most {ARCHITECTURE_MAX_BYTES}: API detail belongs in the crate docs)",
            arch.len()
        ));
    }
    for (i, l) in arch.lines().enumerate() {
        let n = l.chars().count();
        if n > ARCHITECTURE_MAX_LINE {
            problems.push(format!(
                "{page}:{}: {n} characters (at most {ARCHITECTURE_MAX_LINE})",
                i + 1
            ));
        }
        if l.contains("shared/") {
            problems.push(format!(
                "{page}:{}: cites `shared/`, which the repository does not hold",
                i + 1
            ));
        }
    }
    let full = |n: &str| match n {
        "xtask" => n.to_string(),
        _ => format!("crashrig-{n}"),
    };
    let mut listed: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for l in dag_block(arch) {
        let Some((name, deps)) = l.split_once("->") else {
            problems.push(format!("{page}: DAG line `{l}` is not `name -> deps`"));
            continue;
        };
        let name = name.split_whitespace().last().unwrap_or_default();
        let deps = deps
            .split(',')
            .map(str::trim)
            .filter(|d| !d.is_empty())
            .map(full);
        listed.entry(full(name)).or_default().extend(deps);
    }
    let table: BTreeMap<String, BTreeSet<String>> = allowed
        .iter()
        .map(|(k, v)| (k.to_string(), v.iter().map(|d| d.to_string()).collect()))
        .collect();
    if listed != table {
        for (k, v) in &table {
            if listed.get(k) != Some(v) {
                problems.push(format!(
                    "{page}: the DAG block's line of `{k}` is not its ALLOWED edges {v:?} (it lists {:?})",
                    listed.get(k)
                ));
            }
        }
        for k in listed.keys().filter(|k| !table.contains_key(*k)) {
            problems.push(format!(
                "{page}: the DAG block lists `{k}`, which ALLOWED has not"
            ));
        }
    }
    problems
}

/// The non-empty lines of the first fenced block after the heading `## The dependency DAG`.
fn dag_block(arch: &str) -> Vec<&str> {
    let mut lines = arch
        .lines()
        .skip_while(|l| l.trim() != "## The dependency DAG")
        .skip_while(|l| !l.starts_with("```"))
        .skip(1);
    let mut out = Vec::new();
    for l in lines.by_ref() {
        if l.starts_with("```") {
            break;
        }
        if !l.trim().is_empty() {
            out.push(l);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_one_test_binary_catches_a_stray_file() {
        let problems = check_one_test_binary(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
        let tmp = std::env::temp_dir().join(format!("xtask-one-binary-{}", std::process::id()));
        std::fs::create_dir_all(&tmp).unwrap();
        std::fs::write(tmp.join("tests.rs"), "//! t\nmod a;\n").unwrap();
        let manifest =
            "[package]\nautotests = false\n[[test]]\nname = \"tests\"\npath = \"tests/tests.rs\"\n";
        let rs = [
            "tests.rs".to_string(),
            "a.rs".to_string(),
            "b.rs".to_string(),
        ];
        let found = one_test_binary_problems("crates/x", manifest, &tmp, &rs).unwrap();
        assert_eq!(
            found,
            ["crates/x/tests/b.rs is not a `mod` of tests/tests.rs: it would never run"]
        );
        let found = one_test_binary_problems("crates/x", "[package]\n", &tmp, &rs[..2]).unwrap();
        assert_eq!(found.len(), 2, "{found:#?}");
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn tidy_dag_has_only_allowed_edges() {
        let problems = check_dag(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
    }

    #[test]
    fn tidy_lean_builds_leave_out_their_forbidden_packages() {
        let problems = crate::package::check_lean_builds(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
        // The check sees what it forbids: the default build of mc holds toml.
        let out =
            std::process::Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
                .current_dir(crate::project_root())
                .args([
                    "tree",
                    "--offline",
                    "-e",
                    "normal",
                    "--prefix",
                    "none",
                    "-p",
                    "crashrig-mc",
                ])
                .output()
                .unwrap();
        assert!(
            String::from_utf8_lossy(&out.stdout)
                .lines()
                .any(|l| l.split_whitespace().next() == Some("toml"))
        );
    }

    #[test]
    fn tidy_every_module_has_a_doc_line() {
        let problems = check_module_docs(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
    }

    #[test]
    fn tidy_architecture_code_map_lists_every_crate() {
        let problems = check_code_map(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
    }

    #[test]
    fn tidy_architecture_page_that_goes_false_is_caught() {
        let crates: BTreeSet<String> = ["a", "b"].iter().map(|s| s.to_string()).collect();
        let allowed: &[(&str, &[&str])] = &[("crashrig-a", &[]), ("crashrig-b", &["crashrig-a"])];
        let good = "# A\n## The dependency DAG\n```\nL0  a ->\nL1  b -> a\n```\n### `crates/a`\n### `crates/b`\n### `crates/f` (slot)\n";
        assert_eq!(
            architecture_problems(good, &crates, allowed),
            Vec::<String>::new()
        );
        // An edge the table does not have, a crate without a section, a section without a
        // crate, a long line, a citation outside the repository.
        let bad = format!(
            "# A\n## The dependency DAG\n```\nL0  a -> b\nL1  b -> a\n```\n### `crates/a`\n### `crates/g`\nsee shared/x.md\n{}\n",
            "x".repeat(ARCHITECTURE_MAX_LINE + 1)
        );
        let found = architecture_problems(&bad, &crates, allowed);
        assert_eq!(found.len(), 5, "{found:#?}");
        assert!(
            found[0].contains("no code-map section `### `crates/b``"),
            "{found:#?}"
        );
        assert!(found[1].contains("`### `crates/g``"), "{found:#?}");
        assert!(found[2].contains("cites `shared/`"), "{found:#?}");
        assert!(found[3].contains(&format!("{} characters", ARCHITECTURE_MAX_LINE + 1)));
        assert!(found[4].contains("line of `crashrig-a`"), "{found:#?}");
        let big = format!("{good}{}", "y\n".repeat(ARCHITECTURE_MAX_BYTES / 2));
        assert_eq!(architecture_problems(&big, &crates, allowed).len(), 1);
    }

    #[test]
    fn tidy_dag_table_is_acyclic() {
        // The allowed table itself must be a DAG (a typo adding a back edge would hide a cycle).
        let table: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
        fn visit<'a>(
            n: &'a str,
            t: &BTreeMap<&'a str, &'a [&'a str]>,
            path: &mut Vec<&'a str>,
        ) -> bool {
            if path.contains(&n) {
                return false;
            }
            path.push(n);
            let ok = t
                .get(n)
                .into_iter()
                .flat_map(|v| v.iter())
                .all(|m| visit(m, t, path));
            path.pop();
            ok
        }
        for n in table.keys() {
            assert!(visit(n, &table, &mut Vec::new()), "cycle through {n}");
        }
    }
}
