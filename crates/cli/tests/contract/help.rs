//! `--help` of every command exits 0 and documents the command's contract options.

use crate::contract::common::{root, run};

/// Runs `crashrig <cmd…> --help` and checks exit 0, text on stdout and every `option` named.
fn check_help(cmd: &[&str], options: &[&str]) {
    let mut args: Vec<&str> = cmd.to_vec();
    args.push("--help");
    let r = run(&args);
    assert!(r.success, "{cmd:?} --help failed: {}", r.stderr);
    assert!(
        r.stdout.contains("Usage:"),
        "{cmd:?} --help has no usage line:\n{}",
        r.stdout
    );
    for o in options {
        assert!(
            r.stdout.contains(o),
            "{cmd:?} --help does not document {o}:\n{}",
            r.stdout
        );
    }
}

#[test]
fn help_nominal() {
    check_help(
        &[],
        &[
            "colmap",
            "calibrate",
            "bootstrap",
            "propagate",
            "grid",
            "paper",
        ],
    );
}

#[test]
fn help_measure() {
    check_help(
        &["measure"],
        &[
            "--camera-a",
            "--link",
            "--observations",
            "--cfc",
            "--scale-bars",
            "--mpe-mm",
            "--shard",
        ],
    );
}

#[test]
fn help_colmap() {
    check_help(&["colmap"], &["info", "convert"]);
    check_help(&["colmap", "info"], &["--json"]);
    check_help(&["colmap", "convert"], &["--to"]);
}

#[test]
fn help_calibrate() {
    check_help(
        &["calibrate"],
        &[
            "--camera-a",
            "--camera-b",
            "--scale-points",
            "--scale-length-mm",
            "--mm-per-unit",
            "--json",
        ],
    );
}

#[test]
fn help_bootstrap() {
    check_help(
        &["bootstrap"],
        &[
            "--model",
            "--image-a",
            "--image-b",
            "--method",
            "--iterations",
            "--seed",
            "--mm-per-unit",
            "--json",
            "--threads",
        ],
    );
}

#[test]
fn help_propagate() {
    check_help(
        &["propagate"],
        &["--samples", "--seed", "--json", "--threads"],
    );
}

#[test]
fn help_grid() {
    check_help(&["grid"], &["--out", "--samples", "--seed", "--threads"]);
}

#[test]
fn help_paper() {
    check_help(&["paper"], &["--out"]);
}

/// The command names `crashrig --help` lists (the subcommand table), `help` left out.
fn commands_of(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// Every command `crashrig --help` lists is in the README's command table and in
/// `docs/REFERENCE.md`'s command table (a row whose first cell starts with `crashrig CMD`).
#[test]
fn every_command_is_in_the_readme_and_reference_tables() {
    let r = run(["--help"]);
    assert!(r.success, "{}", r.stderr);
    let cmds = commands_of(&r.stdout);
    assert!(cmds.len() >= 8, "too few commands parsed: {cmds:?}");
    for doc in ["README.md", "docs/REFERENCE.md"] {
        let text = std::fs::read_to_string(root().join(doc)).expect(doc);
        let rows: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("| `crashrig "))
            .collect();
        let missing: Vec<&String> = cmds
            .iter()
            .filter(|c| {
                let p = format!("| `crashrig {c}");
                !rows
                    .iter()
                    .any(|l| l.starts_with(&p) && l[p.len()..].starts_with([' ', '`']))
            })
            .collect();
        assert!(
            missing.is_empty(),
            "{doc}: commands of `crashrig --help` missing from its command table: {missing:?}"
        );
    }
}

/// The README's `cargo run` commands select the package `cargo xtask paper` builds
/// (`--package crashrig-cli`), so running them after it reuses that release build: a
/// workspace-wide selection unifies features differently and recompiles a dozen crates.
#[test]
fn readme_cargo_run_commands_reuse_the_paper_build() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let xtask = std::fs::read_to_string(root().join("xtask/src/main.rs")).expect("xtask");
    let paper = &xtask[xtask.find("fn paper(").expect("xtask's paper")..];
    let paper = &paper[..paper.find("\n}\n").expect("its end")];
    assert!(
        paper.contains("\"--package\",\n        \"crashrig-cli\","),
        "xtask paper builds --package crashrig-cli"
    );
    let runs: Vec<&str> = readme
        .lines()
        .filter(|l| l.trim_start().starts_with("cargo run"))
        .collect();
    assert!(runs.len() >= 2, "{runs:?}");
    for l in runs {
        assert!(
            l.contains("--release -p crashrig-cli --bin crashrig"),
            "README: `{l}` does not select the package `cargo xtask paper` builds"
        );
    }
}

#[test]
fn help_commands_are_parsed() {
    let help =
        "Usage: crashrig\n\nCommands:\n  colmap  x\n  grid    y\n  help    z\n\nOptions:\n  -h\n";
    assert_eq!(commands_of(help), ["colmap", "grid"]);
}
