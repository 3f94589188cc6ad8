//! Layouts with fixed observers (`aim = "fixed"`): which observer sees which point, the
//! coverage summary, and the field-of-view footprints drawn on the heat maps.
//!
//! The numbers are [`crashrig_mc::coverage`]'s (visibility by
//! [`crashrig_mc::footprint_margin_px`]: in front, inside the image and back onto the same ray);
//! this module draws them: footprints = the zero contour of the margin raster, and the overlay
//! of the maps. `crashrig grid` draws its fixed-camera maps through this module too.

use crashrig_mc::coverage::{self, Coverage};
use crashrig_mc::{Grid, GridResult};
use crashrig_plot::{Outline, Overlay};
use serde::Serialize;

pub use crashrig_mc::coverage::{has_fixed, sees};

/// Legend of the hatched (not measurable) cells.
pub const NOT_MEASURABLE: &str = "not measurable";

/// The coverage summary of a layout with fixed observers (`results.json` →
/// `layouts[].summary.fixed`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FixedSummary {
    /// Fraction of the grid points seen by two or more observers (measurable at all).
    pub fraction_measurable: f64,
    /// Per observer: the fraction of the grid it sees ([`crashrig_mc::coverage::coverage`]).
    pub observer_coverage: Vec<Coverage>,
}

impl FixedSummary {
    /// The coverage of `result` over `grid`.
    pub fn new(grid: &Grid, result: &GridResult) -> FixedSummary {
        FixedSummary {
            fraction_measurable: result.fraction_measurable(),
            observer_coverage: coverage::coverage(grid, result),
        }
    }
}

/// Line segments of one footprint outline (mm).
pub type Segments = Vec<((f64, f64), (f64, f64))>;

/// The field-of-view footprint of every fixed observer on the plane `z`: the zero contour of
/// its signed image margin ([`crashrig_mc::coverage::footprint_raster`], ≈ 240 cells across
/// `bounds` = (x0, x1, y0, y1; mm)). Returns (label, segments) per fixed observer.
pub fn footprints(grid: &Grid, z: f64, bounds: (f64, f64, f64, f64)) -> Vec<(String, Segments)> {
    let r = coverage::footprint_raster(grid, z, bounds);
    r.margins
        .into_iter()
        .map(|(name, margin)| {
            let segs = crashrig_plot::contour_segments(&r.xs, &r.ys, &margin, 0.0);
            (name, segs)
        })
        .collect()
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
        ..Overlay::default()
    }
}
