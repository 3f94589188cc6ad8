//! `crashrig grid` with fixed observers: the `observers_seen` column, the coverage summary,
//! the not-measurable hatching, field-of-view footprints and camera-count heat maps. The
//! numbers are `crashrig_mc::coverage`'s, the drawing `crashrig_study::fixed_maps`' (the same
//! code the study's layouts use).

use crashrig_mc::Grid;

pub(super) use crashrig_mc::coverage::{Coverage, coverage, has_fixed};
#[cfg(test)]
use crashrig_study::fixed_maps::NOT_MEASURABLE;
pub(super) use crashrig_study::fixed_maps::{footprints, outlines, overlay};

/// The region the footprints are traced over: the grid and the observers, padded by a quarter.
pub(super) fn footprint_bounds(grid: &Grid, xs: &[f64], ys: &[f64]) -> (f64, f64, f64, f64) {
    crashrig_mc::coverage::footprint_bounds(xs, ys, &grid.observers)
}

#[cfg(test)]
mod tests {
    use super::super::{GridArgs, compute};
    use std::path::Path;

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

    fn run(dir: &Path, text: &str) -> anyhow::Result<serde_json::Value> {
        let scen = dir.join("fixed.toml");
        std::fs::write(&scen, text).unwrap();
        compute(
            &GridArgs {
                scenario: scen,
                out: dir.join("out"),
                samples: None,
                no_plots: false,
            },
            None,
        )
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
            assert!(svg.contains(super::NOT_MEASURABLE), "{stem}");
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
        let msg = format!("{:#}", run(tmp.path(), &text).unwrap_err());
        assert!(msg.contains("fixed.toml:22:"), "{msg}");
        assert!(msg.contains("grid.observer[1].camera"), "{msg}");
        assert!(msg.contains("PINHOL"), "{msg}");
        assert!(!tmp.path().join("out/grid.csv").exists());
    }
}
