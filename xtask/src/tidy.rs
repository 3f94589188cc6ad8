//! Checks that must always hold: the dependency DAG, the lean builds a dependent may choose,
//! module docs, the ARCHITECTURE code map.
//!
//! Run by `cargo xtask tidy` and, through the tests at the bottom, by plain `cargo test`.

use anyhow::{Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// Allowed normal-dependency edges between workspace packages (from → to). This table is the
/// DAG of docs/ARCHITECTURE.md; adding an edge is a reviewed change to both.
pub const ALLOWED: &[(&str, &[&str])] = &[
    ("crashrig-geometry", &[]),
    ("crashrig-stats", &[]),
    ("crashrig-plot", &[]),
    ("crashrig-camera", &[]),
    ("crashrig-outdir", &[]),
    ("crashrig-input", &["crashrig-geometry"]),
    (
        "crashrig-colmap",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-input",
            "crashrig-outdir",
        ],
    ),
    ("crashrig-rig", &["crashrig-geometry", "crashrig-stats"]),
    (
        "crashrig-pose",
        &["crashrig-geometry", "crashrig-camera", "crashrig-stats"],
    ),
    ("crashrig-bootstrap", &["crashrig-stats"]),
    (
        "crashrig-mc",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-input",
            "crashrig-stats",
        ],
    ),
    ("crashrig-testkit", &["crashrig-geometry"]),
    (
        "crashrig-covariance",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-input",
            "crashrig-stats",
        ],
    ),
    (
        "crashrig-measure",
        &[
            "crashrig-geometry",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-input",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
        ],
    ),
    (
        "crashrig-grid",
        &[
            "crashrig-geometry",
            "crashrig-input",
            "crashrig-mc",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
        ],
    ),
    (
        "crashrig-study",
        &[
            "crashrig-geometry",
            "crashrig-grid",
            "crashrig-input",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-rig",
            "crashrig-pose",
            "crashrig-bootstrap",
            "crashrig-mc",
            "crashrig-measure",
            "crashrig-stats",
            "crashrig-plot",
            "crashrig-outdir",
            "crashrig-covariance",
        ],
    ),
    (
        "crashrig-place",
        &[
            "crashrig-mc",
            "crashrig-stats",
            "crashrig-grid",
            "crashrig-outdir",
        ],
    ),
    (
        "crashrig-merge",
        &[
            "crashrig-grid",
            "crashrig-measure",
            "crashrig-place",
            "crashrig-outdir",
            "crashrig-stats",
        ],
    ),
    (
        "crashrig-cli",
        &[
            "crashrig-merge",
            "crashrig-place",
            "crashrig-geometry",
            "crashrig-grid",
            "crashrig-input",
            "crashrig-stats",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-rig",
            "crashrig-pose",
            "crashrig-bootstrap",
            "crashrig-mc",
            "crashrig-plot",
            "crashrig-study",
            "crashrig-measure",
            "crashrig-outdir",
            "crashrig-covariance",
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
            "crashrig-grid",
            "crashrig-input",
            "crashrig-stats",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-bootstrap",
            "crashrig-mc",
            "crashrig-study",
            "crashrig-measure",
            "crashrig-covariance",
            "crashrig-outdir",
            "crashrig-place",
            "crashrig-merge",
        ],
    ),
    (
        "crashrig-benches",
        &[
            "crashrig-geometry",
            "crashrig-stats",
            "crashrig-camera",
            "crashrig-colmap",
            "crashrig-pose",
            "crashrig-bootstrap",
            "crashrig-mc",
        ],
    ),
    ("xtask", &[]),
];

/// Builds a dependent may choose and the packages their normal dependency tree must not hold
/// (`cargo tree -e normal`): (package, cargo arguments, forbidden packages, the invariant of
/// docs/ARCHITECTURE.md it keeps).
pub const LEAN_BUILDS: &[(&str, &[&str], &[&str], &str)] = &[
    (
        "crashrig-mc",
        &["--no-default-features"],
        &[
            "toml",
            "serde_json",
            "crashrig-colmap",
            "crashrig-input",
            "rusqlite",
            "libsqlite3-sys",
        ],
        "the engine alone builds without its scenario reader",
    ),
    (
        "crashrig-colmap",
        &["--no-default-features"],
        &["rusqlite", "libsqlite3-sys"],
        "the model reader builds without SQLite",
    ),
    (
        "crashrig-geometry",
        &[],
        &["serde_json", "toml", "csv", "rusqlite", "crashrig-input"],
        "geometry knows no file format",
    ),
    (
        "crashrig-input",
        &["--no-default-features"],
        &["serde_json", "crashrig-geometry"],
        "the edge helpers without `json` are std and thiserror alone",
    ),
];

/// Runs every check and returns the problems found (empty = tidy).
pub fn check(root: &Path) -> Result<Vec<String>> {
    let mut problems = check_dag(root)?;
    problems.extend(check_lean_builds(root)?);
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

/// Normal edges must be in [`ALLOWED`]; `crashrig-testkit` only as a dev-dependency; dev edges
/// must not create a cycle through normal edges (a dev-dependency on a crate that depends on you).
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

/// Every build of [`LEAN_BUILDS`] leaves its forbidden packages out of its normal dependency
/// tree (the tree cargo resolves for that package and those features, Cargo.lock offline).
pub fn check_lean_builds(root: &Path) -> Result<Vec<String>> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut problems = Vec::new();
    for (package, args, forbidden, invariant) in LEAN_BUILDS {
        let out = Command::new(&cargo)
            .current_dir(root)
            .args([
                "tree",
                "--offline",
                "-e",
                "normal",
                "--prefix",
                "none",
                "-p",
                package,
            ])
            .args(*args)
            .output()
            .with_context(|| format!("running cargo tree -p {package}"))?;
        anyhow::ensure!(
            out.status.success(),
            "cargo tree -p {package} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let tree = String::from_utf8_lossy(&out.stdout);
        let names: BTreeSet<&str> = tree
            .lines()
            .filter_map(|l| l.split_whitespace().next())
            .collect();
        for f in forbidden.iter().filter(|f| names.contains(*f)) {
            problems.push(format!(
                "`cargo tree -p {package} {}` holds `{f}`: {invariant} (docs/ARCHITECTURE.md)",
                args.join(" ")
            ));
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

/// Every crate under crates/ has a section in docs/ARCHITECTURE.md's code map.
pub fn check_code_map(root: &Path) -> Result<Vec<String>> {
    let arch = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md"))
        .context("reading docs/ARCHITECTURE.md")?;
    let mut problems = Vec::new();
    for e in std::fs::read_dir(root.join("crates"))? {
        let p = e?.path();
        if p.join("Cargo.toml").exists() {
            let dir = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            let needle = format!("### `crates/{dir}`");
            if !arch.contains(&needle) {
                problems.push(format!(
                    "docs/ARCHITECTURE.md has no code-map section `{needle}`"
                ));
            }
        }
    }
    Ok(problems)
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
        let problems = check_lean_builds(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
        // The check sees what it forbids: the default build of mc holds toml.
        let out = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
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
