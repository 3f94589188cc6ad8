//! The crates as another tool depends on them (issue 35): packaging metadata (a tidy check),
//! `cargo xtask package` (`cargo package` with its verification build), `cargo xtask features`
//! (every feature combination a dependent may choose, with `cargo hack`, and the lean builds'
//! dependency trees) and `cargo xtask consumer` (`examples/consumer/`, a tool outside the
//! workspace, built against the packaged `.crate` files and run).

use anyhow::{Context, Result, bail};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The crates.io category slugs a crate may name (crates.io ignores any other, with a warning
/// only at publish time, so the check is here).
const CATEGORIES: &[&str] = &[
    "algorithms",
    "command-line-utilities",
    "computer-vision",
    "data-structures",
    "filesystem",
    "mathematics",
    "multimedia::images",
    "parser-implementations",
    "science",
    "science::geo",
    "science::robotics",
    "simulation",
    "visualization",
];

/// The cargo-hack release `cargo xtask features` installs when it finds none (`--locked`).
const CARGO_HACK_VERSION: &str = "0.6.46";

fn cargo_in(root: &Path) -> Command {
    let mut c = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    c.current_dir(root);
    c
}

fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from)
}

/// `cargo metadata --no-deps` of the workspace (the one reader of it in xtask).
pub(crate) fn metadata(root: &Path) -> Result<serde_json::Value> {
    let out = cargo_in(root)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .output()
        .context("running cargo metadata")?;
    anyhow::ensure!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).context("parsing cargo metadata")
}

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

/// Every build of [`LEAN_BUILDS`] leaves its forbidden packages out of its normal dependency
/// tree (the tree cargo resolves for that package and those features, Cargo.lock offline).
pub fn check_lean_builds(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for (package, args, forbidden, invariant) in LEAN_BUILDS {
        let out = cargo_in(root)
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

/// Workspace packages, split into (publishable, `publish = false`), by name.
pub fn packages(root: &Path) -> Result<(Vec<String>, Vec<String>)> {
    let meta = metadata(root)?;
    let mut split = (Vec::new(), Vec::new());
    for p in meta["packages"].as_array().context("no packages")? {
        let name = p["name"].as_str().unwrap_or_default().to_string();
        match p["publish"].as_array() {
            Some(registries) if registries.is_empty() => split.1.push(name),
            _ => split.0.push(name),
        }
    }
    Ok(split)
}

/// What a publishable crate must carry: description, licence, rust-version, a README that
/// lists its features and is a doctest of the library, at most 5 keywords, valid categories,
/// no repository URL (there is none to name), and a version on every normal dependency that
/// is a path (a dev-dependency without one, the testkit, is dropped by packaging).
pub fn check_packaging(root: &Path) -> Result<Vec<String>> {
    let meta = metadata(root)?;
    let mut problems = Vec::new();
    let packages = meta["packages"].as_array().context("no packages")?;
    let unpublished: BTreeSet<&str> = packages
        .iter()
        .filter(|p| p["publish"].as_array().is_some_and(Vec::is_empty))
        .filter_map(|p| p["name"].as_str())
        .collect();
    for p in packages {
        let name = p["name"].as_str().unwrap_or_default();
        if unpublished.contains(name) {
            continue;
        }
        let mut bad = |what: String| problems.push(format!("{name}: {what} (packaging)"));
        for key in ["description", "license", "rust_version", "readme"] {
            if p[key].as_str().is_none_or(str::is_empty) {
                bad(format!("no `{key}` in Cargo.toml"));
            }
        }
        if !p["repository"].is_null() {
            bad("names a repository; there is no public one to name".into());
        }
        let keywords = p["keywords"].as_array().map_or(0, Vec::len);
        if keywords == 0 || keywords > 5 {
            bad(format!("{keywords} keywords (crates.io takes 1 to 5)"));
        }
        let categories = p["categories"].as_array().cloned().unwrap_or_default();
        if categories.is_empty() {
            bad("no categories".into());
        }
        for c in categories.iter().filter_map(|c| c.as_str()) {
            if !CATEGORIES.contains(&c) {
                bad(format!("category `{c}` is not a crates.io slug we know"));
            }
        }
        for d in p["dependencies"].as_array().into_iter().flatten() {
            let dep = d["name"].as_str().unwrap_or_default();
            let path_only = d["path"].is_string() && d["req"] == "*";
            if path_only && d["kind"].as_str() != Some("dev") {
                bad(format!("dependency `{dep}` has a path but no version"));
            }
            if d["kind"].as_str() != Some("dev") && unpublished.contains(dep) {
                bad(format!("normal dependency on the unpublished `{dep}`"));
            }
        }
        let manifest = PathBuf::from(p["manifest_path"].as_str().unwrap_or_default());
        let dir = manifest.parent().unwrap_or(root);
        problems.extend(check_readme(name, dir, p)?);
    }
    Ok(problems)
}

/// The README names every feature and, for a library, is included as a doctest; the crate
/// docs (lib.rs) name every feature too.
fn check_readme(name: &str, dir: &Path, p: &serde_json::Value) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap_or_default();
    if !readme.contains("## Features") {
        problems.push(format!("{name}: README.md has no `## Features` section"));
    }
    let lib = p["targets"].as_array().into_iter().flatten().find(|t| {
        t["kind"]
            .as_array()
            .is_some_and(|k| k.iter().any(|k| k == "lib"))
    });
    let lib_rs = match lib.and_then(|t| t["src_path"].as_str()) {
        Some(path) => std::fs::read_to_string(path).with_context(|| path.to_string())?,
        None => String::new(),
    };
    if lib.is_some() && !lib_rs.contains("#[doc = include_str!(\"../README.md\")]") {
        problems.push(format!(
            "{name}: lib.rs does not include README.md as a doctest"
        ));
    }
    let heading = |l: &str| l.starts_with("//! #") && l.to_lowercase().contains("features");
    if lib.is_some() && !lib_rs.lines().any(heading) {
        problems.push(format!("{name}: the crate docs do not list its features"));
    }
    let features = p["features"].as_object().cloned().unwrap_or_default();
    for f in features.keys().filter(|f| *f != "default") {
        let named = format!("`{f}`");
        if !readme.contains(&named) {
            problems.push(format!(
                "{name}: README.md does not name the feature {named}"
            ));
        }
        if lib.is_some() && !lib_rs.contains(&named) {
            problems.push(format!(
                "{name}: the crate docs do not name the feature {named}"
            ));
        }
    }
    Ok(problems)
}

/// `--exclude` of every `publish = false` package, for cargo and cargo hack.
fn excludes(root: &Path) -> Result<Vec<String>> {
    let (_, unpublished) = packages(root)?;
    Ok(unpublished
        .into_iter()
        .flat_map(|n| ["--exclude".to_string(), n])
        .collect())
}

/// The publishable crates that declare at least one feature.
fn with_features(root: &Path) -> Result<Vec<String>> {
    let (published, _) = packages(root)?;
    let meta = metadata(root)?;
    let mut out = Vec::new();
    for p in meta["packages"].as_array().context("no packages")? {
        let name = p["name"].as_str().unwrap_or_default().to_string();
        let has = p["features"].as_object().is_some_and(|f| !f.is_empty());
        if has && published.contains(&name) {
            out.push(name);
        }
    }
    if out.is_empty() {
        bail!("no publishable crate declares a feature: nothing for cargo hack to check");
    }
    Ok(out)
}

/// `cargo package --workspace` of the publishable crates; `verify`: with its verification
/// build (each `.crate` unpacked and built on its own against the others, as crates.io will).
///
/// The verification build takes each workspace dependency from a temporary registry
/// (`target/package/tmp-registry`) that overlays crates.io, and cargo unpacks its crates into
/// `$CARGO_HOME/registry/src/<that registry>/NAME-VERSION/` — skipping the unpacking when that
/// directory already holds a complete earlier copy. Our versions do not change between
/// commits, so a `$CARGO_HOME` kept from an earlier run (as CI keeps it) would verify a crate
/// against its dependencies' *old* sources (stop 50's CI: study against a measure without
/// `rules`). So every earlier unpacked copy of a workspace crate, and the temporary registry,
/// go first (none of our names is on crates.io).
pub fn package(root: &Path, verify: bool) -> Result<()> {
    let (publishable, _) = packages(root)?;
    let stale = stale_packaged_sources(&target_dir(root), cargo_home().as_deref(), &publishable)?;
    for dir in stale {
        std::fs::remove_dir_all(&dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    let mut c = cargo_in(root);
    c.args(["package", "--workspace", "--allow-dirty"])
        .args(excludes(root)?);
    if !verify {
        c.arg("--no-verify");
    }
    crate::run(c)
}

/// What [`package`] removes before it runs: `TARGET/package/tmp-registry` and every
/// `CARGO_HOME/registry/src/*/NAME-VERSION` of a publishable workspace crate (`NAME` in
/// `publishable`, any version), where cargo left an earlier verification's unpacked sources.
fn stale_packaged_sources(
    target: &Path,
    cargo_home: Option<&Path>,
    publishable: &[String],
) -> Result<Vec<PathBuf>> {
    let mut stale = Vec::new();
    let tmp = target.join("package/tmp-registry");
    if tmp.exists() {
        stale.push(tmp);
    }
    let Some(home) = cargo_home else {
        return Ok(stale);
    };
    let src = home.join("registry/src");
    let Ok(registries) = std::fs::read_dir(&src) else {
        return Ok(stale);
    };
    for registry in registries {
        let registry = registry?.path();
        let Ok(crates) = std::fs::read_dir(&registry) else {
            continue;
        };
        for krate in crates {
            let path = krate?.path();
            let name = path
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            if is_unpacked_copy_of(name, publishable) && path.is_dir() {
                stale.push(path);
            }
        }
    }
    stale.sort();
    Ok(stale)
}

/// `dir` is `NAME-VERSION` for one of `names` (the version: digits first, as cargo writes it).
fn is_unpacked_copy_of(dir: &str, names: &[String]) -> bool {
    names.iter().any(|n| {
        dir.strip_prefix(n.as_str())
            .and_then(|rest| rest.strip_prefix('-'))
            .is_some_and(|v| v.starts_with(|c: char| c.is_ascii_digit()))
    })
}

/// `$CARGO_HOME`, else `$HOME/.cargo` (cargo's own default).
fn cargo_home() -> Option<PathBuf> {
    std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
}

/// cargo-hack: `target/tools/bin/cargo-hack`, else on `PATH`, else installed into
/// `target/tools` (pinned, `--locked`; a later run finds it there).
fn cargo_hack(root: &Path) -> Result<PathBuf> {
    let tools = target_dir(root).join("tools");
    let local = tools.join("bin/cargo-hack");
    if local.is_file() {
        return Ok(local);
    }
    let on_path = Command::new("cargo-hack").arg("--version").output();
    if on_path.is_ok_and(|o| o.status.success()) {
        return Ok("cargo-hack".into());
    }
    let mut install = cargo_in(root);
    install
        .args(["install", "--locked", "cargo-hack", "--version"])
        .arg(CARGO_HACK_VERSION)
        .arg("--root")
        .arg(&tools);
    crate::run(install)?;
    Ok(local)
}

/// `cargo xtask features`: `cargo hack check --each-feature --no-dev-deps` over the publishable
/// crates that have features (each without default features, with each feature alone, and
/// with its defaults; a crate without features has one build, which the package verification
/// already makes on its own), then the lean builds' dependency trees ([`LEAN_BUILDS`]).
pub fn features(root: &Path) -> Result<()> {
    let hack = cargo_hack(root)?;
    let mut c = Command::new(hack);
    c.current_dir(root)
        .args(["hack", "check", "--each-feature", "--no-dev-deps"])
        .args(
            with_features(root)?
                .into_iter()
                .flat_map(|n| ["-p".to_string(), n]),
        );
    crate::run(c)?;
    let problems = check_lean_builds(root)?;
    if !problems.is_empty() {
        for p in &problems {
            eprintln!("features: {p}");
        }
        bail!("{} lean build(s) hold what they must not", problems.len());
    }
    println!("features: every feature combination builds; the lean builds are lean");
    Ok(())
}

/// Packages a dependent of `examples/consumer` reaches: its `crashrig-*` dependencies and
/// their non-optional normal dependencies inside the workspace (the consumer turns no
/// optional feature on), so that exactly those are patched.
fn consumer_closure(root: &Path, manifest: &str) -> Result<BTreeSet<String>> {
    let meta = metadata(root)?;
    let packages = meta["packages"].as_array().context("no packages")?;
    let mut todo: Vec<String> = manifest
        .lines()
        .filter_map(|l| l.split_once('=').map(|(k, _)| k.trim()))
        .filter(|k| k.starts_with("crashrig-") && *k != "crashrig-consumer")
        .map(str::to_string)
        .collect();
    let mut seen = BTreeSet::new();
    while let Some(name) = todo.pop() {
        if !seen.insert(name.clone()) {
            continue;
        }
        let p = packages
            .iter()
            .find(|p| p["name"] == name.as_str())
            .with_context(|| {
                format!("examples/consumer depends on `{name}`, not in the workspace")
            })?;
        for d in p["dependencies"].as_array().into_iter().flatten() {
            let dep = d["name"].as_str().unwrap_or_default();
            if d["path"].is_string() && d["kind"].is_null() && d["optional"] == false {
                todo.push(dep.to_string());
            }
        }
    }
    Ok(seen)
}

/// `cargo xtask consumer`: the publishable crates packaged (`--no-verify`: `cargo xtask
/// package` verifies them), each `.crate` unpacked into `target/consumer/packaged/`, and
/// `examples/consumer` (copied with the workspace's Cargo.lock into `target/consumer/app/`,
/// so it resolves the dependency versions the workspace is tested with) built with a
/// `[patch.crates-io]` per crate pointing at its unpacked package, then run on `fixtures/`.
/// Its normal dependency tree must hold no SQLite and no toml.
pub fn consumer(root: &Path) -> Result<()> {
    package(root, false)?;
    let target = target_dir(root);
    let work = target.join("consumer");
    if work.exists() {
        std::fs::remove_dir_all(&work).with_context(|| work.display().to_string())?;
    }
    let packaged = work.join("packaged");
    let app = work.join("app");
    std::fs::create_dir_all(&packaged)?;
    std::fs::create_dir_all(app.join("src"))?;
    let src = root.join("examples/consumer");
    // Not a workspace member, so `cargo fmt --all` does not see it.
    let mut fmt = Command::new("rustfmt");
    fmt.args(["--edition", "2024", "--check"])
        .arg(src.join("src/main.rs"));
    crate::run(fmt)?;
    let manifest = std::fs::read_to_string(src.join("Cargo.toml"))?;
    std::fs::write(app.join("Cargo.toml"), &manifest)?;
    std::fs::copy(src.join("src/main.rs"), app.join("src/main.rs"))?;
    std::fs::copy(root.join("Cargo.lock"), app.join("Cargo.lock"))?;

    let version = env!("CARGO_PKG_VERSION");
    let mut patches = Vec::new();
    for name in consumer_closure(root, &manifest)? {
        let file = target.join(format!("package/{name}-{version}.crate"));
        let mut tar = Command::new("tar");
        tar.arg("-xzf").arg(&file).arg("-C").arg(&packaged);
        crate::run(tar)?;
        let dir = packaged.join(format!("{name}-{version}"));
        anyhow::ensure!(
            dir.join("Cargo.toml").is_file(),
            "{}: not unpacked",
            dir.display()
        );
        patches.push(format!(
            "patch.crates-io.{name}.path={:?}",
            dir.to_string_lossy()
        ));
    }
    let with_patches = |c: &mut Command| {
        for p in &patches {
            c.arg("--config").arg(p);
        }
    };
    let app_manifest = app.join("Cargo.toml");
    let mut tree = cargo_in(&app);
    tree.args([
        "tree",
        "-e",
        "normal",
        "--prefix",
        "none",
        "--manifest-path",
    ])
    .arg(&app_manifest);
    with_patches(&mut tree);
    let out = tree.output().context("cargo tree of the consumer")?;
    anyhow::ensure!(
        out.status.success(),
        "cargo tree of the consumer failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    for line in tree.lines() {
        let mut words = line.split_whitespace();
        let (name, source) = (words.next().unwrap_or(""), line);
        if ["rusqlite", "libsqlite3-sys", "toml"].contains(&name) {
            bail!("the consumer's dependency tree holds `{name}` (its lean builds must not)");
        }
        if name.starts_with("crashrig-")
            && name != "crashrig-consumer"
            && !source.contains("target/consumer/packaged")
        {
            bail!("the consumer resolved `{line}`, not the packaged crate");
        }
    }
    // The workspace's target directory: the dependencies the verification build of `cargo
    // package` compiled (the same default dev profile) are reused.
    let mut run = cargo_in(&app);
    run.args(["run", "--manifest-path"])
        .arg(&app_manifest)
        .arg("--target-dir")
        .arg(&target);
    with_patches(&mut run);
    run.arg("--").arg(root.join("fixtures"));
    crate::run(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_publishable_crates_carry_their_packaging_metadata() {
        let problems = check_packaging(&crate::project_root()).unwrap();
        assert!(problems.is_empty(), "{problems:#?}");
    }

    /// Only an unpacked copy of one of our crates is taken for stale.
    #[test]
    fn stale_unpacked_copies_are_ours_only() {
        let names = ["crashrig-measure".to_string(), "crashrig-mc".to_string()];
        assert!(is_unpacked_copy_of("crashrig-measure-0.1.0", &names));
        assert!(is_unpacked_copy_of("crashrig-mc-0.2.0-rc.1", &names));
        // A longer name that starts with ours, and crates.io's crates, are left alone.
        assert!(!is_unpacked_copy_of("crashrig-measure-extra-0.1.0", &names));
        assert!(!is_unpacked_copy_of("crashrig-mcx-0.1.0", &names));
        assert!(!is_unpacked_copy_of("serde-1.0.229", &names));
        assert!(!is_unpacked_copy_of("crashrig-measure", &names));
    }

    /// The copies cargo's overlay registry left under a kept `$CARGO_HOME` (the layout of
    /// stop 50's CI log: `registry/src/-22c3805da5a543b4/crashrig-measure-0.1.0`) are found,
    /// crates.io's are not.
    #[test]
    fn a_stale_unpacked_copy_is_found_under_cargo_home() {
        let scratch = std::env::temp_dir().join(format!("xtask-stale-{}", std::process::id()));
        let (home, target) = (scratch.join("cargo"), scratch.join("target"));
        let overlay = home.join("registry/src/-22c3805da5a543b4");
        let crates_io = home.join("registry/src/index.crates.io-1949cf8c6b5b557f");
        for d in [
            overlay.join("crashrig-measure-0.1.0"),
            crates_io.join("serde-1.0.229"),
            target.join("package/tmp-registry"),
        ] {
            std::fs::create_dir_all(d).unwrap();
        }
        std::fs::write(overlay.join("crashrig-mc-0.1.0"), "a file, not a copy").unwrap();
        let names = ["crashrig-measure".to_string(), "crashrig-mc".to_string()];
        let found = stale_packaged_sources(&target, Some(&home), &names).unwrap();
        let without_home = stale_packaged_sources(&target, None, &names).unwrap();
        std::fs::remove_dir_all(&scratch).unwrap();
        assert_eq!(
            found,
            vec![
                overlay.join("crashrig-measure-0.1.0"),
                target.join("package/tmp-registry"),
            ]
        );
        assert_eq!(without_home, vec![target.join("package/tmp-registry")]);
    }

    /// The check sees what it forbids, in a throw-away workspace: a crate without readme,
    /// keywords or categories, with an invented repository, a path dependency without a
    /// version and a feature its docs do not name.
    #[test]
    fn packaging_check_catches_a_bare_crate() {
        let dir = std::env::temp_dir().join(format!("xtask-packaging-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (krate, deps) in [("a", "b = { path = \"../b\" }"), ("b", "")] {
            std::fs::create_dir_all(dir.join(krate).join("src")).unwrap();
            std::fs::write(dir.join(krate).join("src/lib.rs"), "//! A crate.\n").unwrap();
            std::fs::write(
                dir.join(krate).join("Cargo.toml"),
                format!(
                    "[package]\nname = \"{krate}\"\nversion = \"0.1.0\"\nedition = \"2024\"\n\
                     repository = \"https://example.invalid/x\"\n\
                     [features]\nfast = []\n[dependencies]\n{deps}\n"
                ),
            )
            .unwrap();
        }
        std::fs::write(
            dir.join("Cargo.toml"),
            "[workspace]\nresolver = \"3\"\nmembers = [\"a\", \"b\"]\n",
        )
        .unwrap();
        let problems = check_packaging(&dir).unwrap().join("\n");
        std::fs::remove_dir_all(&dir).unwrap();
        for want in [
            "a: no `description`",
            "a: no `readme`",
            "a: names a repository",
            "a: 0 keywords",
            "a: no categories",
            "a: dependency `b` has a path but no version",
            "a: README.md has no `## Features` section",
            "a: lib.rs does not include README.md as a doctest",
            "a: the crate docs do not list its features",
            "a: README.md does not name the feature `fast`",
        ] {
            assert!(problems.contains(want), "missing {want:?} in:\n{problems}");
        }
    }
}
