//! `--help` of every command exits 0 and documents the command's contract options.

use crate::common::run;

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
