//! Coverage of a grid by its observers: which observer sees which point, the fraction of the
//! grid each one sees (`summary.json` → `observer_coverage` of `crashrig grid`, and the study's
//! layouts), and the signed image margin of every fixed observer sampled on a plane, whose zero
//! contour is its field-of-view footprint on the maps.
//!
//! An aimed observer ([`Aim::Point`]) sees every point; a fixed one sees a point when it is in
//! front, projects inside the image and back onto the same ray ([`footprint_margin_px`] ≥ 0).
//!
//! # Example
//! A pinhole camera 1000 mm behind the grid's line with a 90° field of view sees the points
//! with |x| < 1000 mm: 4 of the 6 points from −1500 to 1500 mm.
//! ```
//! use crashrig_mc::coverage::{self, Coverage};
//! use crashrig_mc::{GridStudy, RunOptions, Scenario};
//! use std::path::Path;
//!
//! let text = r#"
//! [grid]
//! x_mm = [-1500.0, 1500.0, 6]
//! y_mm = [0.0, 0.0, 1]
//! z_mm = [0.0, 0.0, 1]
//! [[grid.observer]]
//! name = "fixed"
//! aim = "fixed"
//! position_mm = [0.0, -1000.0, 0.0]
//! look_at_mm = [0.0, 0.0, 0.0]
//! camera = { model = "PINHOLE", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0] }
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! [[grid.observer]]
//! name = "aimed"
//! position_mm = [0.0, -1000.0, 500.0]
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! "#;
//! let scenario = Scenario::from_toml_str(text, Path::new("s.toml"))?;
//! let grid = scenario.grid.as_ref().expect("a grid");
//! let result = GridStudy::new(&scenario, 10, 1)?.run(&RunOptions::samples(10, 1), None)?;
//! assert!(coverage::has_fixed(grid));
//! let c = coverage::coverage(grid, &result);
//! assert_eq!(c[0], Coverage { name: "fixed".into(), aim: "fixed", fraction_seen: 4.0 / 6.0 });
//! assert_eq!(c[1].fraction_seen, 1.0);
//! // The footprint raster: the margin is ≥ 0 exactly inside the field of view.
//! let raster = coverage::footprint_raster(grid, 0.0, (-1500.0, 1500.0, -500.0, 500.0));
//! assert_eq!(raster.margins.len(), 1);
//! # Ok::<(), crashrig_mc::Error>(())
//! ```

use crate::model::{Aim, Grid, Observer};
use crate::result::GridResult;
use crate::view::footprint_margin_px;
use nalgebra::Vector3;
use serde::Serialize;

/// Whether any observer of `grid` is fixed (then a point may be seen by fewer than two).
pub fn has_fixed(grid: &Grid) -> bool {
    grid.observers.iter().any(|o| o.aim != Aim::Point)
}

/// Whether observer `o` sees the world point `x` (mm; an aimed observer sees every point).
pub fn sees(o: &Observer, x: &Vector3<f64>) -> bool {
    footprint_margin_px(o, x).is_none_or(|m| m >= 0.0)
}

/// One observer's coverage of a grid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coverage {
    /// Observer name.
    pub name: String,
    /// `"point"` (aimed at every point) or `"fixed"`.
    pub aim: &'static str,
    /// Fraction of the grid points it sees (1 for an aimed observer).
    pub fraction_seen: f64,
}

/// The coverage of every observer of `grid` over the points of `result`, in observer order.
pub fn coverage(grid: &Grid, result: &GridResult) -> Vec<Coverage> {
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

/// The signed image margins of the fixed observers sampled on a raster of one plane.
#[derive(Debug, Clone, PartialEq)]
pub struct FootprintRaster {
    /// Raster x coordinates (mm, ascending).
    pub xs: Vec<f64>,
    /// Raster y coordinates (mm, ascending).
    pub ys: Vec<f64>,
    /// Per fixed observer (in observer order): its name and the margin (px) at
    /// `(xs[i], ys[j])` stored at `j * xs.len() + i`; NaN where it has none.
    pub margins: Vec<(String, Vec<f64>)>,
}

/// The field-of-view footprint of every fixed observer on the plane `z` as a raster of its
/// signed image margin ([`footprint_margin_px`]) with ≈ 240 cells across `bounds`
/// (x0, x1, y0, y1; mm; the step is at least 1 µm, and at least 2 nodes per axis); the zero
/// contour of each margin is the footprint's outline.
pub fn footprint_raster(grid: &Grid, z: f64, bounds: (f64, f64, f64, f64)) -> FootprintRaster {
    let (x0, x1, y0, y1) = bounds;
    let step = ((x1 - x0).max(y1 - y0) / 240.0).max(1e-3);
    let nx = (((x1 - x0) / step).ceil() as usize + 1).max(2);
    let ny = (((y1 - y0) / step).ceil() as usize + 1).max(2);
    let xs: Vec<f64> = (0..nx).map(|i| x0 + step * i as f64).collect();
    let ys: Vec<f64> = (0..ny).map(|j| y0 + step * j as f64).collect();
    let margins = grid
        .observers
        .iter()
        .filter(|o| matches!(o.aim, Aim::Fixed(_)))
        .map(|o| {
            let margin: Vec<f64> = ys
                .iter()
                .flat_map(|&y| xs.iter().map(move |&x| Vector3::new(x, y, z)))
                .map(|p| footprint_margin_px(o, &p).unwrap_or(f64::NAN))
                .collect();
            (o.name.clone(), margin)
        })
        .collect();
    FootprintRaster { xs, ys, margins }
}

/// The region footprints are traced over: the grid's x and y extent (`xs`, `ys` ascending),
/// widened to include the positions of `observers` (pass none to keep the grid alone), then
/// padded on every side by a quarter of the larger side (at least 1 mm), so outlines leave a
/// map clipped to the grid cleanly. Returns (x0, x1, y0, y1) in mm.
pub fn footprint_bounds(xs: &[f64], ys: &[f64], observers: &[Observer]) -> (f64, f64, f64, f64) {
    let mut b = (xs[0], xs[xs.len() - 1], ys[0], ys[ys.len() - 1]);
    for o in observers {
        b.0 = b.0.min(o.position_mm.x);
        b.1 = b.1.max(o.position_mm.x);
        b.2 = b.2.min(o.position_mm.y);
        b.3 = b.3.max(o.position_mm.y);
    }
    let pad = 0.25 * (b.1 - b.0).max(b.3 - b.2).max(1.0);
    (b.0 - pad, b.1 + pad, b.2 - pad, b.3 + pad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;
    use std::path::Path;

    /// A pinhole (90° field of view) 1000 mm behind the line y = 0, looking along +y, and an
    /// aimed observer beside it (a grid needs two).
    const ONE_FIXED: &str = r#"
[grid]
x_mm = [-1500.0, 1500.0, 6]
y_mm = [0.0, 0.0, 1]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
name = "fixed"
aim = "fixed"
position_mm = [0.0, -1000.0, 0.0]
look_at_mm = [0.0, 0.0, 0.0]
camera = { model = "PINHOLE", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0] }
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
name = "aimed"
position_mm = [0.0, -1000.0, 500.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;

    fn grid() -> Grid {
        let s = Scenario::from_toml_str(ONE_FIXED, Path::new("s.toml")).unwrap();
        s.grid.unwrap()
    }

    #[test]
    fn bounds_pad_the_grid_and_the_observers_by_a_quarter() {
        let g = grid();
        // Grid alone: x −1500..1500, y 0..0 → larger side 3000, pad 750.
        assert_eq!(
            footprint_bounds(&[-1500.0, 1500.0], &[0.0, 0.0], &[]),
            (-2250.0, 2250.0, -750.0, 750.0)
        );
        // With the observers at y = −1000 the sides stay 3000 × 1000: pad 750, y from −1000.
        assert_eq!(
            footprint_bounds(&[-1500.0, 1500.0], &[0.0, 0.0], &g.observers),
            (-2250.0, 2250.0, -1750.0, 750.0)
        );
        // A single point: the pad is at least 1/4 mm.
        assert_eq!(
            footprint_bounds(&[2.0], &[3.0], &[]),
            (1.75, 2.25, 2.75, 3.25)
        );
    }

    /// On the line y = 0 at depth 1000 mm, the image margin of the point (x, 0, 0) is
    /// min(u, 1000 − u, v, 1000 − v) with u = 500 ± 0.5·x, v = 500: 500 − |x|/2 px, zero at
    /// |x| = 1000 mm (the 90° field of view); behind the camera there is no view.
    #[test]
    fn raster_margin_is_the_known_pinhole_margin() {
        let g = grid();
        let r = footprint_raster(&g, 0.0, (-1200.0, 1200.0, -1100.0, 0.0));
        // 2400 mm across / 240 = 10 mm steps: 241 × 111 nodes.
        assert_eq!((r.xs.len(), r.ys.len()), (241, 111));
        assert_eq!((r.xs[0], r.xs[240], r.ys[110]), (-1200.0, 1200.0, 0.0));
        let (name, m) = &r.margins[0];
        assert_eq!(name, "fixed");
        let row = 110 * r.xs.len();
        for (i, &x) in r.xs.iter().enumerate() {
            let want = 500.0 - 0.5 * x.abs();
            let got = m[row + i];
            if want >= 0.0 {
                assert!((got - want).abs() < 1e-9, "x = {x}: {got} vs {want}");
            } else {
                // Outside the image but in front: negative (min of the margins, or no view).
                assert!(got.is_nan() || got < 0.0, "x = {x}: {got}");
            }
        }
        // y = −1100 mm is behind the camera (at y = −1000): no point there is seen.
        assert!(m[..r.xs.len()].iter().all(|v| v.is_nan() || *v < 0.0));
    }
}
