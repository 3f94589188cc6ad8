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
