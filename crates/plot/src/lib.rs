//! Figures for crashrig reports: heat maps, histograms and line series, as PNG or SVG bytes.
//!
//! Every figure is rendered in memory and returned as bytes, so callers decide where and how to
//! write it (the CLI writes atomically). Text is drawn with the DejaVu Sans font embedded in the
//! binary (`dejavu` crate): no system font or fontconfig is needed.
//!
//! # Conventions
//! - Axes are in the caller's units, which the caller names in the labels (mm for the grid
//!   heat maps, degrees at the interface edge).
//! - A heat map's `values` are row-major over `(ys, xs)`: `values[iy * xs.len() + ix]` is the
//!   value at `(xs[ix], ys[iy])`, the *centre* of a cell. Non-finite values are drawn grey.
//! - The threshold contour is traced by marching squares on the cell centres with linear
//!   interpolation between neighbours.
//!
//! # Entry points
//! - [`heatmap`] with [`HeatMap`] and [`Marker`]: a colour map with colour bar, threshold
//!   contour and marked points (observers).
//! - [`histogram`]: a histogram of values with vertical lines (e.g. mean ± 1σ).
//! - [`series`]: a line series `ys` against `xs`.
//! - [`banded_panels`] with [`BandPanel`]: stacked line panels with shaded bands (e.g. ±3σ);
//!   [`banded_panels_with`] adds marked x positions and a reference line ([`BandOptions`]).
//! - [`ellipses`] with [`EllipsePlot`]: magnified 1σ error ellipses with axes, ticks and a
//!   scale key.
//! - [`Overlay`]: hatched missing cells, outlines, cell labels, context lines (a car outline)
//!   and an integer colour bar for counts.
//! - [`ply`]: a PLY 1.0 (binary little-endian) writer for point clouds with scalar properties.
//! - [`Format`]: PNG or SVG; [`Format::from_path`] picks it from a file extension.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_plot::{Format, HeatMap, Marker, heatmap, histogram};
//!
//! let xs = [0.0, 100.0, 200.0];
//! let ys = [0.0, 100.0];
//! let values = [1.0, 3.0, 6.0, 2.0, 4.0, 8.0];
//! let map = HeatMap {
//!     xs: &xs,
//!     ys: &ys,
//!     values: &values,
//!     title: "sigma_max at z = 0 mm",
//!     x_label: "x [mm]",
//!     y_label: "y [mm]",
//!     colorbar_label: "sigma_max [mm]",
//!     threshold: Some(5.0),
//!     markers: &[Marker { x: 250.0, y: 50.0, label: "cam2" }],
//!     value_range: None,
//! };
//! let svg = heatmap(&map, Format::Svg)?;
//! assert!(String::from_utf8(svg).unwrap().contains("sigma_max"));
//! let png = histogram(&[1.0, 2.0, 2.5, 3.0], &[1.5, 2.6], "base x", "x [mm]", Format::Png)?;
//! assert_eq!(&png[1..4], b"PNG");
//! # Ok::<(), crashrig_plot::Error>(())
//! ```
#![deny(missing_docs)]

mod contour;
mod ellipses;
mod error;
mod overlay;
pub mod ply;

pub use contour::contour_segments;
pub use ellipses::{Ellipse, EllipsePlot, ellipse_axes, ellipses};
pub use error::Error;
pub use overlay::{Outline, Overlay, Segment};

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// The font family name the embedded font is registered under.
const FONT: &str = "sans-serif";

/// Output file format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// 8-bit RGB PNG.
    Png,
    /// SVG 1.1 text.
    Svg,
}

impl Format {
    /// The format named by a path's extension (`.png` or `.svg`, case-insensitive).
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "png" => Some(Self::Png),
            "svg" => Some(Self::Svg),
            _ => None,
        }
    }
}

/// A point drawn on a heat map (for instance an observing camera), with a text label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker<'a> {
    /// x coordinate in axis units.
    pub x: f64,
    /// y coordinate in axis units.
    pub y: f64,
    /// Text written next to the marker.
    pub label: &'a str,
}

/// The data and labels of one heat map.
#[derive(Debug, Clone, Copy)]
pub struct HeatMap<'a> {
    /// Cell-centre x coordinates, strictly increasing.
    pub xs: &'a [f64],
    /// Cell-centre y coordinates, strictly increasing.
    pub ys: &'a [f64],
    /// Row-major values: `values[iy * xs.len() + ix]`.
    pub values: &'a [f64],
    /// Title above the map.
    pub title: &'a str,
    /// Label of the x axis (with unit).
    pub x_label: &'a str,
    /// Label of the y axis (with unit).
    pub y_label: &'a str,
    /// Label of the colour bar (with unit).
    pub colorbar_label: &'a str,
    /// Level of the contour line drawn on the map and marked on the colour bar.
    pub threshold: Option<f64>,
    /// Points to mark (drawn even outside the grid: the axes grow to include them).
    pub markers: &'a [Marker<'a>],
    /// Colour range `(low, high)`; `None` = the range of the finite values.
    pub value_range: Option<(f64, f64)>,
}

fn register_font() -> Result<(), Error> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok { Ok(()) } else { Err(Error::Font) }
}

fn draw_err<E: std::fmt::Debug>(figure: &'static str) -> impl Fn(E) -> Error {
    move |e| Error::Draw {
        figure,
        message: format!("{e:?}"),
    }
}

/// Renders with `draw` on a backend of the chosen format and returns the file bytes.
fn render(
    figure: &'static str,
    size: (u32, u32),
    format: Format,
    draw: impl Fn(DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), Error>,
    draw_svg: impl Fn(DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), Error>,
) -> Result<Vec<u8>, Error> {
    register_font()?;
    match format {
        Format::Png => {
            let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err(figure))?;
                draw(root.clone())?;
                root.present().map_err(draw_err(figure))?;
            }
            encode_png(figure, size, &buf)
        }
        Format::Svg => {
            let mut s = String::new();
            {
                let root = SVGBackend::with_string(&mut s, size).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err(figure))?;
                draw_svg(root.clone())?;
                root.present().map_err(draw_err(figure))?;
            }
            Ok(s.into_bytes())
        }
    }
}

fn encode_png(figure: &'static str, size: (u32, u32), rgb: &[u8]) -> Result<Vec<u8>, Error> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|source| Error::Png { figure, source })?;
        w.write_image_data(rgb)
            .map_err(|source| Error::Png { figure, source })?;
        w.finish().map_err(|source| Error::Png { figure, source })?;
    }
    Ok(out)
}

/// Viridis-like colour for `t` in [0, 1] (clamped), piecewise linear through 6 stops.
fn colour(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 6] = [
        (68, 1, 84),
        (65, 68, 135),
        (42, 120, 142),
        (34, 168, 132),
        (122, 209, 81),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

fn finite_range(values: &[f64]) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &v in values.iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo.is_finite() {
        if hi - lo <= 0.0 {
            let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.05 };
            Some((lo - pad, hi + pad))
        } else {
            Some((lo, hi))
        }
    } else {
        None
    }
}

fn check_axis(figure: &'static str, field: &'static str, v: &[f64]) -> Result<(), Error> {
    if v.is_empty() {
        return Err(Error::BadInput {
            figure,
            field,
            problem: "is empty",
        });
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(Error::BadInput {
            figure,
            field,
            problem: "holds a non-finite value",
        });
    }
    if v.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::BadInput {
            figure,
            field,
            problem: "is not strictly increasing",
        });
    }
    Ok(())
}

/// Half cell widths of an axis of cell centres (a single cell gets a width of 1 unit).
fn half_steps(v: &[f64]) -> Vec<(f64, f64)> {
    let n = v.len();
    (0..n)
        .map(|i| {
            let left = if i > 0 {
                (v[i] - v[i - 1]) / 2.0
            } else if n > 1 {
                (v[1] - v[0]) / 2.0
            } else {
                0.5
            };
            let right = if i + 1 < n {
                (v[i + 1] - v[i]) / 2.0
            } else if n > 1 {
                (v[n - 1] - v[n - 2]) / 2.0
            } else {
                0.5
            };
            (v[i] - left, v[i] + right)
        })
        .collect()
}

/// Renders a heat map with colour bar, threshold contour and markers.
///
/// The figure size follows the data's aspect ratio so that a millimetre is as long on both
/// axes. Errors: empty or non-increasing axes, `values.len() != xs.len() * ys.len()`, no
/// finite value, or a backend failure.
pub fn heatmap(map: &HeatMap<'_>, format: Format) -> Result<Vec<u8>, Error> {
    heatmap_with(map, &Overlay::default(), format)
}

/// [`heatmap`] with an [`Overlay`]: non-finite cells hatched with a legend entry (e.g. "not
/// measurable"), outlines (e.g. each camera's field-of-view footprint) and a text per cell
/// (e.g. the number of cameras that see the point).
///
/// Errors: those of [`heatmap`], and `cell_labels` neither empty nor one per value.
pub fn heatmap_with(
    map: &HeatMap<'_>,
    overlay: &Overlay<'_>,
    format: Format,
) -> Result<Vec<u8>, Error> {
    const FIG: &str = "heatmap";
    check_axis(FIG, "xs", map.xs)?;
    check_axis(FIG, "ys", map.ys)?;
    if map.values.len() != map.xs.len() * map.ys.len() {
        return Err(Error::BadInput {
            figure: FIG,
            field: "values",
            problem: "length is not xs.len() * ys.len()",
        });
    }
    let range = match map.value_range {
        // Counts: one band per integer, centred on it.
        Some((lo, hi)) if overlay.integer_bar && lo.is_finite() && hi.is_finite() && hi >= lo => {
            (lo.round() - 0.5, hi.round().max(lo.round() + 1.0) + 0.5)
        }
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && hi > lo => (lo, hi),
        Some(_) => {
            return Err(Error::BadInput {
                figure: FIG,
                field: "value_range",
                problem: "must be finite with high > low",
            });
        }
        None => finite_range(map.values).ok_or(Error::BadInput {
            figure: FIG,
            field: "values",
            problem: "holds no finite value",
        })?,
    };
    let cx = half_steps(map.xs);
    let cy = half_steps(map.ys);
    let mut x0 = cx[0].0;
    let mut x1 = cx[cx.len() - 1].1;
    let mut y0 = cy[0].0;
    let mut y1 = cy[cy.len() - 1].1;
    for m in map
        .markers
        .iter()
        .filter(|m| m.x.is_finite() && m.y.is_finite())
    {
        x0 = x0.min(m.x);
        x1 = x1.max(m.x);
        y0 = y0.min(m.y);
        y1 = y1.max(m.y);
    }
    // The context (a car outline) is drawn whole: the axes grow to include it.
    for &(x, y) in overlay
        .context
        .iter()
        .flat_map(|s| [s.0, s.1])
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect::<Vec<_>>()
        .iter()
    {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let pad = 0.04 * (x1 - x0).max(y1 - y0);
    let (x0, x1, y0, y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
    // Plot area 760 px wide; height by aspect ratio, clamped to a readable range.
    let plot_w = 760.0;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(220.0, 900.0);
    let size = (plot_w as u32 + 260, plot_h as u32 + 130);
    overlay::check(FIG, map, overlay)?;
    let geom = HeatGeom {
        map,
        overlay,
        range,
        cells: (cx, cy),
        bounds: (x0, x1, y0, y1),
    };
    render(
        FIG,
        size,
        format,
        |root| draw_heatmap(&geom, root),
        |root| draw_heatmap(&geom, root),
    )
}

/// The extent `(low, high)` of one cell along one axis.
type Span = (f64, f64);

struct HeatGeom<'a> {
    map: &'a HeatMap<'a>,
    overlay: &'a Overlay<'a>,
    range: (f64, f64),
    /// Cell extents `(low, high)` along x and along y.
    cells: (Vec<Span>, Vec<Span>),
    bounds: (f64, f64, f64, f64),
}

fn draw_heatmap<DB: DrawingBackend>(
    g: &HeatGeom<'_>,
    root: DrawingArea<DB, Shift>,
) -> Result<(), Error> {
    const FIG: &str = "heatmap";
    let e = draw_err::<DrawingAreaErrorKind<DB::ErrorType>>(FIG);
    let map = g.map;
    let (w, _) = root.dim_in_pixel();
    let (main, bar) = root.split_horizontally(w.saturating_sub(170));
    let (x0, x1, y0, y1) = g.bounds;
    let (lo, hi) = g.range;
    let mut chart = ChartBuilder::on(&main)
        .caption(map.title, (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(&e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(map.x_label)
        .y_desc(map.y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(&e)?;
    let nx = map.xs.len();
    let (cx, cy) = &g.cells;
    chart
        .draw_series(map.values.iter().enumerate().map(|(k, &v)| {
            let (ix, iy) = (k % nx, k / nx);
            let fill = if v.is_finite() {
                colour(colour_position(v, lo, hi, g.overlay.integer_bar)).filled()
            } else if g.overlay.missing_label.is_some() {
                overlay::MISSING.filled()
            } else {
                RGBColor(180, 180, 180).filled()
            };
            Rectangle::new([(cx[ix].0, cy[iy].0), (cx[ix].1, cy[iy].1)], fill)
        }))
        .map_err(&e)?;
    overlay::draw_cells(g, &mut chart, &e)?;
    if let Some(t) = map.threshold {
        let segs = contour_segments(map.xs, map.ys, map.values, t);
        chart
            .draw_series(segs.iter().map(|&(a, b)| {
                PathElement::new(vec![a, b], ShapeStyle::from(&WHITE).stroke_width(3))
            }))
            .map_err(&e)?;
        chart
            .draw_series(
                segs.iter()
                    .map(|&(a, b)| PathElement::new(vec![a, b], BLACK.stroke_width(1))),
            )
            .map_err(&e)?;
    }
    overlay::draw_context(g, &mut chart, &e)?;
    overlay::draw_outlines(g, &mut chart, &e)?;
    for m in map
        .markers
        .iter()
        .filter(|m| m.x.is_finite() && m.y.is_finite())
    {
        let label = m.label.to_string();
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((m.x, m.y))
                    + TriangleMarker::new((0, 0), 9, RED.filled())
                    + Text::new(label, (10, -18), (FONT, 15).into_font().color(&RED)),
            ))
            .map_err(&e)?;
    }
    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(45)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(0)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(&e)?;
    let integer = g.overlay.integer_bar;
    // Counts: one tick per integer (bands between the half-integers).
    let counts = (hi - lo).round().max(1.0) as usize;
    let mut mesh = cb.configure_mesh();
    mesh.disable_mesh()
        .disable_x_axis()
        .y_desc(map.colorbar_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16));
    if integer {
        // No fractional ticks: each band is labelled with its count below.
        mesh.y_labels(0);
    }
    mesh.draw().map_err(&e)?;
    let steps = if integer { counts } else { 128 };
    cb.draw_series((0..steps).map(|i| {
        let a = lo + (hi - lo) * i as f64 / steps as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / steps as f64;
        let t = if integer {
            colour_position(0.5 * (a + b), lo, hi, true)
        } else {
            (i as f64 + 0.5) / steps as f64
        };
        Rectangle::new([(0.0, a), (1.0, b)], colour(t).filled())
    }))
    .map_err(&e)?;
    if integer {
        cb.draw_series((0..steps).map(|i| {
            let c = lo + 0.5 + i as f64;
            let ink = if colour_position(c, lo, hi, true) > 0.6 {
                BLACK
            } else {
                WHITE
            };
            EmptyElement::at((0.5, c))
                + Text::new(
                    format!("{c:.0}"),
                    (-5, -8),
                    (FONT, 15).into_font().color(&ink),
                )
        }))
        .map_err(&e)?;
    }
    if let Some(t) = map.threshold.filter(|t| *t >= lo && *t <= hi) {
        cb.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, t), (1.0, t)],
            BLACK.stroke_width(2),
        )))
        .map_err(&e)?;
    }
    overlay::draw_legend(g, &bar, &e)?;
    Ok(())
}

/// Position in [0, 1] of `v` on the colour scale `lo..hi`; counts (`integer`) take the colour
/// of their integer's band, evenly spread from the first to the last colour.
fn colour_position(v: f64, lo: f64, hi: f64, integer: bool) -> f64 {
    if integer {
        let bands = (hi - lo).round().max(1.0);
        if bands <= 1.0 {
            return 0.5;
        }
        ((v - lo - 0.5).round() / (bands - 1.0)).clamp(0.0, 1.0)
    } else {
        (v - lo) / (hi - lo)
    }
}

/// Renders a histogram of `values` with vertical dashed-looking marker lines at `lines`
/// (for instance mean − σ and mean + σ).
///
/// The number of bins is √n rounded, between 5 and 60. Non-finite values are ignored; at
/// least one finite value is required.
pub fn histogram(
    values: &[f64],
    lines: &[f64],
    title: &str,
    x_label: &str,
    format: Format,
) -> Result<Vec<u8>, Error> {
    const FIG: &str = "histogram";
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let (mut lo, mut hi) = finite_range(&finite).ok_or(Error::BadInput {
        figure: FIG,
        field: "values",
        problem: "holds no finite value",
    })?;
    for &l in lines.iter().filter(|l| l.is_finite()) {
        lo = lo.min(l);
        hi = hi.max(l);
    }
    let nbins = ((finite.len() as f64).sqrt().round() as usize).clamp(5, 60);
    let width = (hi - lo) / nbins as f64;
    let mut counts = vec![0u64; nbins];
    for v in &finite {
        let i = (((v - lo) / width).floor() as usize).min(nbins - 1);
        counts[i] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.08;
    let data = HistData {
        counts: &counts,
        lo,
        width,
        top,
        lines,
        title,
        x_label,
    };
    render(
        FIG,
        (800, 500),
        format,
        |root| draw_histogram(&data, root),
        |root| draw_histogram(&data, root),
    )
}

struct HistData<'a> {
    counts: &'a [u64],
    lo: f64,
    width: f64,
    top: f64,
    lines: &'a [f64],
    title: &'a str,
    x_label: &'a str,
}

fn draw_histogram<DB: DrawingBackend>(
    d: &HistData<'_>,
    root: DrawingArea<DB, Shift>,
) -> Result<(), Error> {
    let e = draw_err::<DrawingAreaErrorKind<DB::ErrorType>>("histogram");
    let n = d.counts.len();
    let hi = d.lo + d.width * n as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(d.title, (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(d.lo..hi, 0.0..d.top)
        .map_err(&e)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc(d.x_label)
        .y_desc("count")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(&e)?;
    chart
        .draw_series(d.counts.iter().enumerate().map(|(i, &c)| {
            let a = d.lo + d.width * i as f64;
            Rectangle::new([(a, 0.0), (a + d.width, c as f64)], BLUE.mix(0.6).filled())
        }))
        .map_err(&e)?;
    for &l in d.lines.iter().filter(|l| l.is_finite()) {
        // Dashed: short segments along the height.
        let segs = 20;
        chart
            .draw_series((0..segs).step_by(2).map(|k| {
                let y0 = d.top * k as f64 / segs as f64;
                let y1 = d.top * (k + 1) as f64 / segs as f64;
                PathElement::new(vec![(l, y0), (l, y1)], BLACK.stroke_width(2))
            }))
            .map_err(&e)?;
    }
    Ok(())
}

/// Renders `ys` against `xs` as a line with point markers.
///
/// Errors: different lengths, empty input, or no finite pair. Pairs with a non-finite
/// coordinate are skipped.
pub fn series(
    xs: &[f64],
    ys: &[f64],
    title: &str,
    x_label: &str,
    y_label: &str,
    format: Format,
) -> Result<Vec<u8>, Error> {
    const FIG: &str = "series";
    if xs.len() != ys.len() {
        return Err(Error::BadInput {
            figure: FIG,
            field: "ys",
            problem: "length differs from xs",
        });
    }
    let pts: Vec<(f64, f64)> = xs
        .iter()
        .zip(ys)
        .map(|(&x, &y)| (x, y))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let xr = finite_range(&pts.iter().map(|p| p.0).collect::<Vec<_>>());
    let yr = finite_range(&pts.iter().map(|p| p.1).collect::<Vec<_>>());
    let (Some(xr), Some(yr)) = (xr, yr) else {
        return Err(Error::BadInput {
            figure: FIG,
            field: "xs",
            problem: "holds no finite (x, y) pair",
        });
    };
    let ypad = 0.05 * (yr.1 - yr.0);
    let data = SeriesData {
        pts: &pts,
        xr,
        yr: (yr.0 - ypad, yr.1 + ypad),
        title,
        x_label,
        y_label,
    };
    render(
        FIG,
        (800, 500),
        format,
        |root| draw_series(&data, root),
        |root| draw_series(&data, root),
    )
}

struct SeriesData<'a> {
    pts: &'a [(f64, f64)],
    xr: (f64, f64),
    yr: (f64, f64),
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
}

fn draw_series<DB: DrawingBackend>(
    d: &SeriesData<'_>,
    root: DrawingArea<DB, Shift>,
) -> Result<(), Error> {
    let e = draw_err::<DrawingAreaErrorKind<DB::ErrorType>>("series");
    let mut chart = ChartBuilder::on(&root)
        .caption(d.title, (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(d.xr.0..d.xr.1, d.yr.0..d.yr.1)
        .map_err(&e)?;
    chart
        .configure_mesh()
        .x_desc(d.x_label)
        .y_desc(d.y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(&e)?;
    chart
        .draw_series(LineSeries::new(d.pts.iter().copied(), BLUE.stroke_width(2)))
        .map_err(&e)?;
    if d.pts.len() <= 200 {
        chart
            .draw_series(d.pts.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))
            .map_err(&e)?;
    }
    Ok(())
}

/// One panel of [`banded_panels`]: a line `ys` with a shaded band `ys ± half_widths`.
#[derive(Debug, Clone, Copy)]
pub struct BandPanel<'a> {
    /// Axis label of the panel (with its unit).
    pub y_label: &'a str,
    /// Values, one per x (non-finite: not drawn).
    pub ys: &'a [f64],
    /// Half-width of the band at each x (non-finite: no band there).
    pub half_widths: &'a [f64],
}

/// Renders panels stacked vertically over a shared x axis, each a line with a shaded band
/// (e.g. a coordinate of a trajectory with ±3σ).
///
/// Errors: no panel, a panel whose `ys` or `half_widths` length differs from `xs`, or a panel
/// with no finite value.
pub fn banded_panels(
    xs: &[f64],
    panels: &[BandPanel<'_>],
    title: &str,
    x_label: &str,
    format: Format,
) -> Result<Vec<u8>, Error> {
    banded_panels_marked(xs, panels, &[], title, x_label, format)
}

/// [`banded_panels`] with some x positions marked in every panel (a red ring and cross, e.g.
/// the epochs flagged as outliers): `marked` is empty or one flag per x.
///
/// Errors: those of [`banded_panels`], and `marked` neither empty nor `xs.len()` long.
pub fn banded_panels_marked(
    xs: &[f64],
    panels: &[BandPanel<'_>],
    marked: &[bool],
    title: &str,
    x_label: &str,
    format: Format,
) -> Result<Vec<u8>, Error> {
    let options = BandOptions {
        marked,
        reference_y: None,
    };
    banded_panels_with(xs, panels, &options, title, x_label, format)
}

/// What [`banded_panels_with`] adds to the panels.
#[derive(Debug, Clone, Copy, Default)]
pub struct BandOptions<'a> {
    /// Empty, or one flag per x: the x positions marked in every panel (a red ring and cross).
    pub marked: &'a [bool],
    /// A horizontal reference line drawn across every panel (e.g. zero error); each panel's y
    /// range includes it.
    pub reference_y: Option<f64>,
}

/// [`banded_panels`] with marked x positions and a reference line ([`BandOptions`]).
///
/// Errors: those of [`banded_panels`], `marked` neither empty nor `xs.len()` long, and a
/// reference that is not finite.
pub fn banded_panels_with(
    xs: &[f64],
    panels: &[BandPanel<'_>],
    options: &BandOptions<'_>,
    title: &str,
    x_label: &str,
    format: Format,
) -> Result<Vec<u8>, Error> {
    const FIG: &str = "banded_panels";
    let marked = options.marked;
    if options.reference_y.is_some_and(|y| !y.is_finite()) {
        return Err(Error::BadInput {
            figure: FIG,
            field: "reference_y",
            problem: "is not finite",
        });
    }
    if !marked.is_empty() && marked.len() != xs.len() {
        return Err(Error::BadInput {
            figure: FIG,
            field: "marked",
            problem: "length is neither 0 nor xs.len()",
        });
    }
    if panels.is_empty() {
        return Err(Error::BadInput {
            figure: FIG,
            field: "panels",
            problem: "is empty",
        });
    }
    let xr = finite_range(xs).ok_or(Error::BadInput {
        figure: FIG,
        field: "xs",
        problem: "holds no finite value",
    })?;
    let mut ranges = Vec::with_capacity(panels.len());
    for p in panels {
        if p.ys.len() != xs.len() || p.half_widths.len() != xs.len() {
            return Err(Error::BadInput {
                figure: FIG,
                field: "panels",
                problem: "a panel's length differs from xs",
            });
        }
        let mut ext = Vec::with_capacity(3 * xs.len() + 1);
        ext.extend(options.reference_y);
        for (&y, &h) in p.ys.iter().zip(p.half_widths) {
            ext.push(y);
            if h.is_finite() {
                ext.push(y - h);
                ext.push(y + h);
            }
        }
        let yr = finite_range(&ext).ok_or(Error::BadInput {
            figure: FIG,
            field: "panels",
            problem: "a panel holds no finite value",
        })?;
        let pad = 0.05 * (yr.1 - yr.0);
        ranges.push((yr.0 - pad, yr.1 + pad));
    }
    let height = 60 + 260 * panels.len() as u32;
    render(
        FIG,
        (900, height),
        format,
        |root| draw_bands(xs, panels, options, &ranges, xr, title, x_label, root),
        |root| draw_bands(xs, panels, options, &ranges, xr, title, x_label, root),
    )
}

#[allow(clippy::too_many_arguments)] // one private drawer shared by the PNG and SVG backends
fn draw_bands<DB: DrawingBackend>(
    xs: &[f64],
    panels: &[BandPanel<'_>],
    options: &BandOptions<'_>,
    ranges: &[(f64, f64)],
    xr: (f64, f64),
    title: &str,
    x_label: &str,
    root: DrawingArea<DB, Shift>,
) -> Result<(), Error> {
    let e = draw_err::<DrawingAreaErrorKind<DB::ErrorType>>("banded_panels");
    let root = root.titled(title, (FONT, 22)).map_err(&e)?;
    let areas = root.split_evenly((panels.len(), 1));
    for ((p, area), yr) in panels.iter().zip(areas).zip(ranges) {
        let mut chart = ChartBuilder::on(&area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
            .map_err(&e)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(p.y_label)
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 15))
            .draw()
            .map_err(&e)?;
        if let Some(y) = options.reference_y {
            chart
                .draw_series(LineSeries::new(
                    [(xr.0, y), (xr.1, y)],
                    BLACK.mix(0.6).stroke_width(1),
                ))
                .map_err(&e)?;
        }
        // The band: one quadrilateral per interval where both ends have a finite band.
        let band = |i: usize| {
            let (x, y, h) = (xs[i], p.ys[i], p.half_widths[i]);
            (x.is_finite() && y.is_finite() && h.is_finite()).then_some((x, y, h))
        };
        chart
            .draw_series((1..xs.len()).filter_map(|i| {
                let (x0, y0, h0) = band(i - 1)?;
                let (x1, y1, h1) = band(i)?;
                Some(Polygon::new(
                    vec![(x0, y0 - h0), (x1, y1 - h1), (x1, y1 + h1), (x0, y0 + h0)],
                    BLUE.mix(0.25).filled(),
                ))
            }))
            .map_err(&e)?;
        let pts: Vec<(f64, f64)> = xs
            .iter()
            .zip(p.ys)
            .map(|(&x, &y)| (x, y))
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), BLUE.stroke_width(2)))
            .map_err(&e)?;
        if pts.len() <= 200 {
            chart
                .draw_series(pts.iter().map(|&q| Circle::new(q, 2, BLUE.filled())))
                .map_err(&e)?;
        }
        let flagged = xs
            .iter()
            .zip(p.ys)
            .zip(options.marked)
            .filter(|((x, y), m)| **m && x.is_finite() && y.is_finite());
        chart
            .draw_series(flagged.map(|((&x, &y), _)| {
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 7, RED.stroke_width(2))
                    + Cross::new((0, 0), 5, RED.stroke_width(2))
            }))
            .map_err(&e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_map<'a>(values: &'a [f64], markers: &'a [Marker<'a>]) -> HeatMap<'a> {
        const XS: [f64; 4] = [0.0, 100.0, 200.0, 300.0];
        const YS: [f64; 3] = [-100.0, 0.0, 100.0];
        HeatMap {
            xs: &XS,
            ys: &YS,
            values,
            title: "sigma_max z = 0 mm",
            x_label: "x [mm]",
            y_label: "y [mm]",
            colorbar_label: "sigma_max [mm]",
            threshold: Some(5.0),
            markers,
            value_range: None,
        }
    }

    #[test]
    fn banded_panels_png_and_svg() {
        let xs = [0.0, 1.0, 2.0, 3.0];
        let ys = [1.0, 2.0, f64::NAN, 4.0];
        let hw = [0.1, 0.2, 0.3, f64::NAN];
        let panels = [
            BandPanel {
                y_label: "x [mm]",
                ys: &ys,
                half_widths: &hw,
            },
            BandPanel {
                y_label: "y [mm]",
                ys: &ys,
                half_widths: &hw,
            },
        ];
        let png = banded_panels(&xs, &panels, "marker m", "t [s]", Format::Png).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let svg = String::from_utf8(
            banded_panels(&xs, &panels, "marker m", "t [s]", Format::Svg).unwrap(),
        )
        .unwrap();
        assert!(svg.contains("y [mm]") && svg.contains("marker m"));
        let bad = [BandPanel {
            y_label: "x",
            ys: &ys[..2],
            half_widths: &hw,
        }];
        assert!(banded_panels(&xs, &bad, "m", "t", Format::Png).is_err());
        assert!(banded_panels(&xs, &[], "m", "t", Format::Png).is_err());
        // A reference line: drawn, and a non-finite one refused.
        let zero = BandOptions {
            marked: &[],
            reference_y: Some(0.0),
        };
        let svg = banded_panels_with(&xs, &panels, &zero, "m", "t", Format::Svg).unwrap();
        let plain = banded_panels(&xs, &panels, "m", "t", Format::Svg).unwrap();
        assert!(svg.len() > plain.len());
        let nan = BandOptions {
            reference_y: Some(f64::NAN),
            ..zero
        };
        assert!(banded_panels_with(&xs, &panels, &nan, "m", "t", Format::Png).is_err());
    }

    #[test]
    fn heatmap_nominal_png_and_svg() {
        let values: Vec<f64> = (0..12).map(|i| i as f64).collect();
        let markers = [Marker {
            x: 350.0,
            y: 0.0,
            label: "obs0",
        }];
        let map = sample_map(&values, &markers);
        let png = heatmap(&map, Format::Png).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let svg = String::from_utf8(heatmap(&map, Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("x [mm]"));
        assert!(svg.contains("sigma_max [mm]"));
        assert!(svg.contains("obs0"));
    }

    #[test]
    fn heatmap_png_has_dark_text_pixels() {
        // Text renders only if the embedded font is found: the caption area (top rows) must
        // contain near-black pixels.
        let values: Vec<f64> = (0..12).map(|i| i as f64).collect();
        let map = sample_map(&values, &[]);
        let png = heatmap(&map, Format::Png).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(png));
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut buf).unwrap();
        let row = info.width as usize * 3;
        let caption = &buf[..row * 35];
        let dark = caption
            .chunks(3)
            .filter(|p| p[0] < 80 && p[1] < 80 && p[2] < 80)
            .count();
        assert!(dark > 50, "only {dark} dark pixels in the caption band");
    }

    #[test]
    fn heatmap_rejects_bad_lengths() {
        let values = [1.0, 2.0];
        let map = sample_map(&values, &[]);
        assert!(matches!(
            heatmap(&map, Format::Svg),
            Err(Error::BadInput {
                field: "values",
                ..
            })
        ));
    }

    #[test]
    fn heatmap_all_nan_is_error() {
        let values = [f64::NAN; 12];
        let map = sample_map(&values, &[]);
        assert!(matches!(
            heatmap(&map, Format::Png),
            Err(Error::BadInput {
                field: "values",
                ..
            })
        ));
    }

    #[test]
    fn histogram_nominal() {
        let values: Vec<f64> = (0..500).map(|i| ((i * 37) % 101) as f64 / 10.0).collect();
        let png = histogram(&values, &[2.0, 8.0], "base x", "x [mm]", Format::Png).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let svg = histogram(&values, &[2.0, 8.0], "base x", "x [mm]", Format::Svg).unwrap();
        assert!(String::from_utf8(svg).unwrap().contains("base x"));
    }

    #[test]
    fn histogram_empty_is_error() {
        assert!(matches!(
            histogram(&[], &[], "t", "x", Format::Png),
            Err(Error::BadInput { .. })
        ));
    }

    #[test]
    fn series_nominal_and_mismatch() {
        let xs = [1.0, 2.0, 3.0];
        let ys = [0.5, 0.25, 0.2];
        let svg = series(
            &xs,
            &ys,
            "sigma vs draws",
            "draws",
            "sigma [mm]",
            Format::Svg,
        )
        .unwrap();
        assert!(String::from_utf8(svg).unwrap().contains("sigma vs draws"));
        assert!(matches!(
            series(&xs, &ys[..2], "t", "x", "y", Format::Png),
            Err(Error::BadInput { field: "ys", .. })
        ));
    }

    #[test]
    fn format_from_path_nominal() {
        assert_eq!(Format::from_path(Path::new("a/b.PNG")), Some(Format::Png));
        assert_eq!(Format::from_path(Path::new("b.svg")), Some(Format::Svg));
        assert_eq!(Format::from_path(Path::new("b.txt")), None);
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
