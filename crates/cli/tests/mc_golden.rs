//! The Monte Carlo engine's outputs are pinned byte for byte (`fixtures/mc/golden/`, written by
//! the binary of `main` before the mc crate was restructured; provenance in
//! `fixtures/mc/README.md`): `grid.csv` of three layouts (independent aimed observers, observers
//! drawn jointly from the chain, fixed lenses with pixel noise) and `propagate --json`. A change
//! of the random numbers, of the order of an arithmetic operation or of the formatting fails.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn crashrig(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_crashrig"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("run crashrig");
    assert!(
        out.status.success(),
        "crashrig {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn grid_csv_is_byte_identical_to_the_golden() {
    for name in [
        "three_cameras_correlated",
        "four_cameras_z300",
        "fixed_three_cameras",
    ] {
        let dir =
            std::env::temp_dir().join(format!("crashrig_mc_golden_{}_{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let scenario = format!("fixtures/scenarios/{name}.toml");
        crashrig(&[
            "grid",
            &scenario,
            "--out",
            dir.to_str().expect("utf-8 temp dir"),
            "--no-plots",
            "--samples",
            "2000",
            "--seed",
            "7",
            "--threads",
            "2",
        ]);
        let got = std::fs::read(dir.join("grid.csv")).expect("grid.csv written");
        let want = std::fs::read(root().join(format!("fixtures/mc/golden/{name}.grid.csv")))
            .expect("golden");
        let _ = std::fs::remove_dir_all(&dir);
        assert!(
            got == want,
            "{name}: grid.csv differs from fixtures/mc/golden/{name}.grid.csv"
        );
    }
}

/// `propagate --json` byte for byte except the line of its run time (`elapsed_s`).
#[test]
fn propagate_json_is_byte_identical_to_the_golden() {
    let out = crashrig(&[
        "propagate",
        "fixtures/scenarios/paper_chain.toml",
        "--json",
        "--samples",
        "20000",
        "--seed",
        "7",
        "--threads",
        "2",
    ]);
    let strip = |text: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(text)
            .lines()
            .filter(|l| !l.trim_start().starts_with("\"elapsed_s\""))
            .map(str::to_owned)
            .collect()
    };
    let want = std::fs::read(root().join("fixtures/mc/golden/paper_chain.propagate.json"))
        .expect("golden");
    let (got, want) = (strip(&out.stdout), strip(&want));
    assert_eq!(
        got.len() + 1,
        String::from_utf8_lossy(&out.stdout).lines().count()
    );
    assert!(got == want, "propagate --json differs from the golden");
}
