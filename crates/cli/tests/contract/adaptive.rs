//! `[grid.adaptive]` (contract section "Adaptive Monte Carlo"): `grid.csv` adds `draws` and
//! `converged`, `summary.json` has `adaptive.unconverged_points`, and one `warning:` line says
//! how many points stopped at `max_samples`.

use crate::contract::common::{assert_clean_error, read_json, run};

/// Two observers 1 m apart looking at a 3 × 2 grid 1 m away, with 1 mm / 0.01° noise.
fn scenario(tolerance_mm: f64, max_samples: usize) -> String {
    scenario_with(&format!("tolerance_mm = {tolerance_mm}"), max_samples)
}

/// [`scenario`] with `tolerance` as the tolerance line(s) of `[grid.adaptive]` (line 8).
fn scenario_with(tolerance: &str, max_samples: usize) -> String {
    format!(
        r#"seed = 3
samples = 1000
[grid]
x_mm = [0.0, 400.0, 3]
y_mm = [900.0, 1100.0, 2]
z_mm = [0.0, 0.0, 1]
[grid.adaptive]
{tolerance}
batch = 1000
max_samples = {max_samples}
[[grid.observer]]
position_mm = [-300.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
position_mm = [700.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#
    )
}

fn run_grid(text: &str) -> (std::path::PathBuf, tempfile::TempDir, String) {
    let tmp = tempfile::tempdir().unwrap();
    let s = tmp.path().join("s.toml");
    std::fs::write(&s, text).unwrap();
    let out = tmp.path().join("out");
    let r = run([
        "grid",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(r.success, "{}", r.stderr);
    (out, tmp, r.stderr)
}

/// `(draws, converged)` of every row, checking the header.
fn rows(out: &std::path::Path) -> Vec<(u64, String)> {
    let csv = std::fs::read_to_string(out.join("grid.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,draws,converged"
    );
    lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[7].parse().unwrap(), c[8].to_string())
        })
        .collect()
}

#[test]
fn adaptive_unreachable_tolerance_flags_every_point_and_warns() {
    // A tolerance of 1e-6 mm cannot be met in 5 000 draws (the σ are ~1 mm, their batch
    // spread ~1 mm/√2000): every point stops at max_samples, unconverged.
    let (out, _tmp, stderr) = run_grid(&scenario(1e-6, 5000));
    let r = rows(&out);
    assert_eq!(r.len(), 6);
    assert!(r.iter().all(|(d, c)| *d == 5000 && c == "false"), "{r:?}");
    let s = read_json(&out.join("summary.json"));
    assert_eq!(s["adaptive"]["unconverged_points"], 6);
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].contains("6 of 6") && warnings[0].contains("max_samples"));
}

#[test]
fn adaptive_loose_tolerance_converges_after_four_batches() {
    // 1 mm tolerance: met at the first check (4 batches = 4 000 draws) everywhere.
    let (out, _tmp, stderr) = run_grid(&scenario(1.0, 100_000));
    let r = rows(&out);
    assert!(r.iter().all(|(d, c)| *d == 4000 && c == "true"), "{r:?}");
    let s = read_json(&out.join("summary.json"));
    assert_eq!(s["adaptive"]["unconverged_points"], 0);
    assert!(!stderr.contains("warning:"), "{stderr}");
}

#[test]
fn adaptive_ndig_is_accepted_and_reported() {
    // ndig = 1: δ = ½·10^l with σ = c·10^l, c one digit; the σ here are 1–3 mm, δ = 0.5 mm,
    // met at the first check (4 batches) everywhere.
    let (out, _tmp, stderr) = run_grid(&scenario_with("ndig = 1", 100_000));
    let r = rows(&out);
    assert_eq!(r.len(), 6);
    assert!(r.iter().all(|(d, c)| *d == 4000 && c == "true"), "{r:?}");
    let s = read_json(&out.join("summary.json"));
    assert_eq!(s["adaptive"]["ndig"], 1);
    assert!(s["adaptive"]["tolerance_mm"].is_null());
    assert_eq!(s["adaptive"]["unconverged_points"], 0);
    // Nothing on stderr: no warning, and no progress bar when stderr is not a terminal.
    assert!(stderr.is_empty(), "{stderr}");
    // An absolute tolerance reports tolerance_mm and a null ndig.
    let (out, _tmp, _) = run_grid(&scenario(1.0, 100_000));
    let s = read_json(&out.join("summary.json"));
    assert_eq!(s["adaptive"]["tolerance_mm"], 1.0);
    assert!(s["adaptive"]["ndig"].is_null());
}

#[test]
fn adaptive_tolerance_keys_exactly_one_else_one_error_line() {
    for (tolerance, line, key) in [
        (
            "tolerance_mm = 0.1\nndig = 2",
            ":9:",
            "`grid.adaptive.ndig`",
        ),
        ("# no tolerance", ":7:", "`grid.adaptive`"),
        ("ndig = 0", ":8:", "`grid.adaptive.ndig`"),
        ("ndig = 99", ":8:", "`grid.adaptive.ndig`"),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let s = tmp.path().join("s.toml");
        std::fs::write(&s, scenario_with(tolerance, 10_000)).unwrap();
        let out = tmp.path().join("out");
        let r = run([
            "grid",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
        ]);
        assert_clean_error(&r, &[&format!("s.toml{line}"), key]);
        assert!(!out.exists(), "{tolerance}: output written");
    }
}
