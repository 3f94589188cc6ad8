//! `crashrig_grid::run_grid`, the library entry of `crashrig grid`: thread-count
//! independence, the contract's CSV header, the summary keys, fixed observers' coverage and
//! maps, and errors naming the file and key (moved here from the CLI with the code).

use crashrig_grid::fixed_maps::NOT_MEASURABLE;
use crashrig_grid::{GridConfig, run_grid};
use std::path::Path;

const SCENARIO: &str = r#"
seed = 5
samples = 300
[grid]
x_mm = [400.0, 800.0, 3]
y_mm = [-200.0, 200.0, 2]
z_mm = [0.0, 300.0, 2]
[[grid.observer]]
name = "rear"
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]
[[grid.observer]]
name = "door"
position_mm = [1300.0, -700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

fn args(dir: &Path, scenario: &Path, no_plots: bool) -> GridConfig {
    GridConfig {
        scenario: scenario.to_path_buf(),
        out: dir.to_path_buf(),
        samples: None,
        seed: None,
        plots: !no_plots,
    }
}

/// Runs the grid and returns `summary.json`'s content.
fn compute(config: &GridConfig) -> Result<serde_json::Value, crashrig_grid::Error> {
    let run = run_grid(config, None)?;
    Ok(serde_json::to_value(run.summary).unwrap())
}

#[test]
fn grid_compute_nominal_same_csv_for_one_and_two_threads() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("s.toml");
    std::fs::write(&scen, SCENARIO).unwrap();
    let run = |threads: usize, name: &str, plots: bool| {
        let out = tmp.path().join(name);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let summary = pool
            .install(|| compute(&args(&out, &scen, !plots)))
            .unwrap();
        (std::fs::read(out.join("grid.csv")).unwrap(), summary, out)
    };
    let (a, summary, out) = run(1, "one", true);
    let (b, _, _) = run(2, "two", false);
    assert_eq!(a, b, "grid.csv differs between 1 and 2 threads");
    let text = String::from_utf8(a).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm"
    );
    assert_eq!(lines.count(), 12);
    for key in [
        "points",
        "samples_per_point",
        "threshold_mm",
        "fraction_below_threshold",
        "max_sigma_mm",
        "median_sigma_max_mm",
        "elapsed_s",
        "samples_per_second",
    ] {
        assert!(summary.get(key).is_some(), "summary.json lacks {key}");
    }
    assert_eq!(summary["points"], 12);
    assert_eq!(summary["samples_per_point"], 300);
    // The worst-direction σ: last column of grid_detail.csv, never below σ_max, and summarised
    // in summary.json (median and maximum of the column).
    let detail = std::fs::read_to_string(out.join("grid_detail.csv")).unwrap();
    assert!(detail.lines().next().unwrap().ends_with(",sigma_worst_mm"));
    let mut worst: Vec<f64> = detail
        .lines()
        .skip(1)
        .zip(text.lines().skip(1))
        .map(|(d, g)| {
            let w: f64 = d.rsplit(',').next().unwrap().parse().unwrap();
            let smax: f64 = g.rsplit(',').next().unwrap().parse().unwrap();
            assert!(w >= smax * (1.0 - 1e-12), "σ_worst {w} < σ_max {smax}");
            w
        })
        .collect();
    worst.sort_by(f64::total_cmp);
    assert_eq!(worst.len(), 12);
    assert_eq!(summary["max_sigma_worst_mm"].as_f64().unwrap(), worst[11]);
    assert_eq!(
        summary["median_sigma_worst_mm"].as_f64().unwrap(),
        0.5 * (worst[5] + worst[6])
    );
    let t = summary["threshold_mm"].as_f64().unwrap();
    let below = worst.iter().filter(|w| **w < t).count() as f64 / 12.0;
    assert_eq!(
        summary["fraction_worst_below_threshold"].as_f64().unwrap(),
        below
    );
    // One PNG and one SVG per z level and map kind.
    for z in ["z00_0mm", "z01_300mm"] {
        for ext in ["png", "svg"] {
            assert!(out.join(format!("sigma_max_{z}.{ext}")).is_file());
        }
    }
}

#[test]
fn grid_compute_bad_scenario_names_file_and_key() {
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("bad.toml");
    std::fs::write(
        &scen,
        SCENARIO.replace("[2.53, 2.51, 2.55]", "[2.53, -2.51, 2.55]"),
    )
    .unwrap();
    let err = compute(&args(&tmp.path().join("o"), &scen, true)).unwrap_err();
    let msg = crashrig_input::message::error_line(&err);
    assert!(msg.contains("bad.toml"), "{msg}");
    assert!(msg.contains("grid.observer[1].sigma_position_mm"), "{msg}");
    assert!(!tmp.path().join("o").join("grid.csv").exists());
}

/// Two fixed cameras: "left" sees the whole grid, "right" only its right part.
const FIXED: &str = r#"
seed = 5
samples = 300
[grid]
x_mm = [1000.0, 1400.0, 5]
y_mm = [-100.0, 100.0, 2]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
name = "left"
aim = "fixed"
position_mm = [1200.0, -1500.0, 0.0]
look_at_mm = [1200.0, 0.0, 0.0]
camera = { model = "SIMPLE_RADIAL", width = 1000, height = 800, params = [600.0, 500.0, 400.0, -0.05] }
pixel_sigma_px = 0.5
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
name = "right"
aim = "fixed"
position_mm = [1400.0, 1500.0, 0.0]
look_at_mm = [1600.0, 0.0, 0.0]
camera = { model = "PINHOLE", width = 800, height = 600, params = [1500.0, 1500.0, 400.0, 300.0] }
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;

fn run(dir: &Path, text: &str) -> Result<serde_json::Value, crashrig_grid::Error> {
    let scen = dir.join("fixed.toml");
    std::fs::write(&scen, text).unwrap();
    compute(&args(&dir.join("out"), &scen, false))
}

#[test]
fn grid_fixed_csv_summary_and_maps() {
    let tmp = tempfile::tempdir().unwrap();
    let summary = run(tmp.path(), FIXED).unwrap();
    let out = tmp.path().join("out");
    let csv = std::fs::read_to_string(out.join("grid.csv")).unwrap();
    let mut lines = csv.lines();
    // The two cameras face each other across the grid: the points next to the line
    // between them are degenerate (rays nearly anti-parallel), so the degenerate columns
    // come before `observers_seen`.
    assert_eq!(
        lines.next().unwrap(),
        "x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,intersection_angle_deg,degenerate,observers_seen"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 10);
    let (mut one, mut two) = (0, 0);
    for r in &rows {
        match r[9] {
            "1" => {
                one += 1;
                assert!(r[3..7].iter().all(|c| c.is_empty()), "{r:?}");
                assert_eq!(
                    r[8], "false",
                    "a point seen once is not measurable, not degenerate"
                );
            }
            "2" => {
                two += 1;
                if r[8] == "true" {
                    assert!(r[3..7].iter().all(|c| c.is_empty()), "{r:?}");
                    assert!(r[7].parse::<f64>().unwrap() < 1.5);
                } else {
                    assert!(r[3..7].iter().all(|c| c.parse::<f64>().unwrap() > 0.0));
                }
            }
            other => panic!("observers_seen {other}"),
        }
    }
    assert!(one > 0 && two > 0, "{one} seen once, {two} twice");
    let frac = summary["fraction_measurable"].as_f64().unwrap();
    assert_eq!(frac, two as f64 / 10.0);
    assert!(summary["fraction_below_threshold"].as_f64().unwrap() <= frac);
    assert_eq!(summary["observer_coverage"][0]["fraction_seen"], 1.0);
    assert_eq!(summary["observer_coverage"][1]["aim"], "fixed");
    for stem in ["sigma_max", "observers_seen", "ratio_mc_linear"] {
        let svg = std::fs::read_to_string(out.join(format!("{stem}_z00_0mm.svg"))).unwrap();
        assert!(svg.contains(NOT_MEASURABLE), "{stem}");
        assert!(svg.contains("right FOV"), "{stem}: footprint label");
    }
}

#[test]
fn grid_fixed_nothing_measurable_still_writes_maps() {
    let tmp = tempfile::tempdir().unwrap();
    // Turn the right camera away from the grid.
    let text = FIXED.replace(
        "look_at_mm = [1600.0, 0.0, 0.0]",
        "look_at_mm = [1400.0, 3000.0, 0.0]",
    );
    let summary = run(tmp.path(), &text).unwrap();
    assert_eq!(summary["fraction_measurable"], 0.0);
    assert_eq!(summary["fraction_below_threshold"], 0.0);
    assert!(tmp.path().join("out/sigma_max_z00_0mm.png").is_file());
    assert!(tmp.path().join("out/ratio_mc_linear_z00_0mm.png").is_file());
}

#[test]
fn grid_fixed_bad_camera_names_file_key_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let text = FIXED.replace("\"PINHOLE\"", "\"PINHOL\"");
    let msg = crashrig_input::message::error_line(&run(tmp.path(), &text).unwrap_err());
    assert!(msg.contains("fixed.toml:22:"), "{msg}");
    assert!(msg.contains("grid.observer[1].camera"), "{msg}");
    assert!(msg.contains("PINHOL"), "{msg}");
    assert!(!tmp.path().join("out/grid.csv").exists());
}
