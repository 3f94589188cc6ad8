//! `crashrig grid` with fixed observers: the `observers_seen` column, the coverage summary,
//! the not-measurable hatching, field-of-view footprints and camera-count heat maps.

use crashrig_mc::{Aim, Grid, GridResult, Observer};
use crashrig_plot::{Outline, Overlay};
use nalgebra::Vector3;
use serde::Serialize;

/// Legend of the hatched cells.
pub(super) const NOT_MEASURABLE: &str = "not measurable";

/// Whether any observer is fixed (then `grid.csv` has `observers_seen` and maps get overlays).
pub(super) fn has_fixed(grid: &Grid) -> bool {
    grid.observers.iter().any(|o| o.aim != Aim::Point)
}

/// One observer's coverage of the grid (`summary.json` → `"observer_coverage"`).
#[derive(Serialize)]
pub(super) struct Coverage {
    name: String,
    aim: &'static str,
    /// Fraction of grid points the observer sees (1 for aimed observers).
    fraction_seen: f64,
}

/// Coverage per observer. A fixed observer sees a point when the point is in front, projects
/// inside its image and back onto the same ray ([`crashrig_mc::footprint_margin_px`] ≥ 0).
pub(super) fn coverage(grid: &Grid, result: &GridResult) -> Vec<Coverage> {
    let n = result.points.len().max(1) as f64;
    grid.observers
        .iter()
        .map(|o| Coverage {
            name: o.name.clone(),
            aim: match o.aim {
                Aim::Point => "point",
                Aim::Fixed(_) => "fixed",
            },
            fraction_seen: result.points.iter().filter(|p| sees(o, &p.point)).count() as f64 / n,
        })
        .collect()
}

fn sees(o: &Observer, x: &Vector3<f64>) -> bool {
    crashrig_mc::footprint_margin_px(o, x).is_none_or(|m| m >= 0.0)
}

/// The field-of-view footprint of every fixed observer on the plane `z`: the zero contour of
/// its signed image margin sampled on a raster (≈ 240 cells across) covering `bounds`
/// (x0, x1, y0, y1; mm). Returns (label, segments) per fixed observer.
pub(super) type Segments = Vec<((f64, f64), (f64, f64))>;

pub(super) fn footprints(
    grid: &Grid,
    z: f64,
    bounds: (f64, f64, f64, f64),
) -> Vec<(String, Segments)> {
    let (x0, x1, y0, y1) = bounds;
    let step = ((x1 - x0).max(y1 - y0) / 240.0).max(1e-3);
    let nx = (((x1 - x0) / step).ceil() as usize + 1).max(2);
    let ny = (((y1 - y0) / step).ceil() as usize + 1).max(2);
    let xs: Vec<f64> = (0..nx).map(|i| x0 + step * i as f64).collect();
    let ys: Vec<f64> = (0..ny).map(|j| y0 + step * j as f64).collect();
    grid.observers
        .iter()
        .filter(|o| matches!(o.aim, Aim::Fixed(_)))
        .map(|o| {
            let margin: Vec<f64> = ys
                .iter()
                .flat_map(|&y| xs.iter().map(move |&x| Vector3::new(x, y, z)))
                .map(|p| crashrig_mc::footprint_margin_px(o, &p).unwrap_or(f64::NAN))
                .collect();
            let segs = crashrig_plot::contour_segments(&xs, &ys, &margin, 0.0);
            (o.name.clone(), segs)
        })
        .collect()
}

/// The region the footprints are traced over: the grid and the observers, padded by a quarter.
pub(super) fn footprint_bounds(grid: &Grid, xs: &[f64], ys: &[f64]) -> (f64, f64, f64, f64) {
    let mut b = (xs[0], xs[xs.len() - 1], ys[0], ys[ys.len() - 1]);
    for o in &grid.observers {
        b.0 = b.0.min(o.position_mm.x);
        b.1 = b.1.max(o.position_mm.x);
        b.2 = b.2.min(o.position_mm.y);
        b.3 = b.3.max(o.position_mm.y);
    }
    let pad = 0.25 * (b.1 - b.0).max(b.3 - b.2).max(1.0);
    (b.0 - pad, b.1 + pad, b.2 - pad, b.3 + pad)
}

/// Outlines borrowing `fp`.
pub(super) fn outlines(fp: &[(String, Segments)]) -> Vec<Outline<'_>> {
    fp.iter()
        .map(|(label, segments)| Outline { label, segments })
        .collect()
}

/// The overlay of a σ map of a fixed-camera grid.
pub(super) fn overlay<'a>(outlines: &'a [Outline<'a>], labels: &'a [String]) -> Overlay<'a> {
    Overlay {
        missing_label: Some(NOT_MEASURABLE),
        outlines,
        cell_labels: labels,
    }
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
