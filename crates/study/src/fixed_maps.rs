//! Layouts with fixed observers (`aim = "fixed"`): which observer sees which point, the
//! coverage summary, and the field-of-view footprints drawn on the heat maps.
//!
//! The same rules as `crashrig grid` (visibility by [`crashrig_mc::footprint_margin_px`]:
//! in front, inside the image and back onto the same ray; footprints = its zero contour).

use crashrig_mc::{Aim, Grid, GridResult, Observer};
use crashrig_plot::{Outline, Overlay};
use nalgebra::Vector3;
use serde::Serialize;

/// Legend of the hatched (not measurable) cells.
pub const NOT_MEASURABLE: &str = "not measurable";

/// Whether any observer of `grid` is fixed.
pub fn has_fixed(grid: &Grid) -> bool {
    grid.observers.iter().any(|o| o.aim != Aim::Point)
}

/// Whether observer `o` sees `x` (an aimed observer sees every point).
pub fn sees(o: &Observer, x: &Vector3<f64>) -> bool {
    crashrig_mc::footprint_margin_px(o, x).is_none_or(|m| m >= 0.0)
}

/// One observer's coverage of the grid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coverage {
    /// Observer name.
    pub name: String,
    /// `"point"` (aimed at every point) or `"fixed"`.
    pub aim: &'static str,
    /// Fraction of the grid points it sees (1 for an aimed observer).
    pub fraction_seen: f64,
}

/// The coverage summary of a layout with fixed observers (`results.json` →
/// `layouts[].summary.fixed`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FixedSummary {
    /// Fraction of the grid points seen by two or more observers (measurable at all).
    pub fraction_measurable: f64,
    /// Per observer: the fraction of the grid it sees.
    pub observer_coverage: Vec<Coverage>,
}

impl FixedSummary {
    /// The coverage of `result` over `grid`.
    pub fn new(grid: &Grid, result: &GridResult) -> FixedSummary {
        let n = result.points.len().max(1) as f64;
        FixedSummary {
            fraction_measurable: result.fraction_measurable(),
            observer_coverage: grid
                .observers
                .iter()
                .map(|o| Coverage {
                    name: o.name.clone(),
                    aim: match o.aim {
                        Aim::Point => "point",
                        Aim::Fixed(_) => "fixed",
                    },
                    fraction_seen: result.points.iter().filter(|p| sees(o, &p.point)).count()
                        as f64
                        / n,
                })
                .collect(),
        }
    }
}

/// Line segments of one footprint outline (mm).
pub type Segments = Vec<((f64, f64), (f64, f64))>;

/// The field-of-view footprint of every fixed observer on the plane `z`: the zero contour of
/// its signed image margin sampled on a raster (≈ 240 cells across) covering `bounds`
/// (x0, x1, y0, y1; mm). Returns (label, segments) per fixed observer.
pub fn footprints(grid: &Grid, z: f64, bounds: (f64, f64, f64, f64)) -> Vec<(String, Segments)> {
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

/// The region the footprints are traced over: the grid padded by a quarter of its size (the
/// heat map clips to the grid; the padding lets outlines leave the map cleanly).
pub fn footprint_bounds(xs: &[f64], ys: &[f64]) -> (f64, f64, f64, f64) {
    let b = (xs[0], xs[xs.len() - 1], ys[0], ys[ys.len() - 1]);
    let pad = 0.25 * (b.1 - b.0).max(b.3 - b.2).max(1.0);
    (b.0 - pad, b.1 + pad, b.2 - pad, b.3 + pad)
}

/// Outlines borrowing `fp`.
pub fn outlines(fp: &[(String, Segments)]) -> Vec<Outline<'_>> {
    fp.iter()
        .map(|(label, segments)| Outline { label, segments })
        .collect()
}

/// The overlay of a map of a fixed-camera layout: hatched not-measurable cells, footprints and
/// optional per-cell labels.
pub fn overlay<'a>(outlines: &'a [Outline<'a>], labels: &'a [String]) -> Overlay<'a> {
    Overlay {
        missing_label: Some(NOT_MEASURABLE),
        outlines,
        cell_labels: labels,
    }
}
