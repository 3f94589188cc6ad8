//! Extras on a heat map: hatched "not measurable" cells with a legend, outlines (field-of-view
//! footprints) and per-cell labels (camera counts).

use crate::{Error, FONT, HeatGeom, HeatMap};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Fill of non-finite cells when the overlay names them (a legend entry is drawn).
pub(crate) const MISSING: RGBColor = RGBColor(222, 222, 222);
/// Hatch lines over non-finite cells.
const HATCH: RGBColor = RGBColor(120, 120, 120);
/// Outline colours, cycled.
const PALETTE: [RGBColor; 6] = [
    RGBColor(230, 25, 75),
    RGBColor(245, 130, 48),
    RGBColor(0, 200, 230),
    RGBColor(240, 50, 230),
    RGBColor(255, 255, 255),
    RGBColor(60, 180, 75),
];

/// A line segment `((x0, y0), (x1, y1))` in axis units.
pub type Segment = ((f64, f64), (f64, f64));

/// A polyline set drawn on the map in one colour, with a label at its first segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outline<'a> {
    /// Text next to the outline (e.g. the camera's name).
    pub label: &'a str,
    /// Segments `((x0, y0), (x1, y1))` in axis units (e.g. from [`crate::contour_segments`]).
    pub segments: &'a [Segment],
}

/// Optional extras of [`crate::heatmap_with`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Overlay<'a> {
    /// When set, non-finite cells are drawn light grey and hatched, with this text as a legend
    /// entry under the colour bar (e.g. "not measurable").
    pub missing_label: Option<&'a str>,
    /// Outlines drawn over the map (e.g. each camera's field-of-view footprint).
    pub outlines: &'a [Outline<'a>],
    /// A text per cell, row-major like `values` (e.g. the number of cameras); empty = none.
    pub cell_labels: &'a [String],
    /// Context drawn in dark grey under the markers (e.g. the car's outline), in axis units.
    pub context: &'a [Segment],
    /// Legend entry of [`Overlay::context`] under the colour bar (e.g. "car outline").
    pub context_label: Option<&'a str>,
    /// The values are counts: the colour bar has one band and one integer tick per count
    /// (from the rounded low to the rounded high end of the range), no fractional labels.
    pub integer_bar: bool,
}

/// Colour of the context lines.
const CONTEXT: RGBColor = RGBColor(60, 60, 60);

/// The context lines (the car's outline), clipped to the plot bounds.
pub(crate) fn draw_context<DB: DrawingBackend, E>(
    g: &HeatGeom<'_>,
    chart: &mut Chart<'_, DB>,
    e: &impl Fn(DrawingAreaErrorKind<DB::ErrorType>) -> E,
) -> Result<(), E> {
    let (x0, x1, y0, y1) = g.bounds;
    let clip = |p: (f64, f64)| (p.0.clamp(x0, x1), p.1.clamp(y0, y1));
    chart
        .draw_series(
            g.overlay
                .context
                .iter()
                .map(|&(a, b)| PathElement::new(vec![clip(a), clip(b)], CONTEXT.stroke_width(3))),
        )
        .map_err(e)?;
    Ok(())
}

pub(crate) fn check(figure: &'static str, map: &HeatMap<'_>, o: &Overlay<'_>) -> Result<(), Error> {
    if !o.cell_labels.is_empty() && o.cell_labels.len() != map.values.len() {
        return Err(Error::BadInput {
            figure,
            field: "cell_labels",
            problem: "length is neither 0 nor values.len()",
        });
    }
    Ok(())
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Hatching of non-finite cells and the cell labels.
pub(crate) fn draw_cells<DB: DrawingBackend, E>(
    g: &HeatGeom<'_>,
    chart: &mut Chart<'_, DB>,
    e: &impl Fn(DrawingAreaErrorKind<DB::ErrorType>) -> E,
) -> Result<(), E> {
    let map = g.map;
    let nx = map.xs.len();
    let (cx, cy) = &g.cells;
    if g.overlay.missing_label.is_some() {
        let hatch = map
            .values
            .iter()
            .enumerate()
            .filter(|(_, v)| !v.is_finite())
            .flat_map(|(k, _)| {
                let ((x0, x1), (y0, y1)) = (cx[k % nx], cy[k / nx]);
                [
                    PathElement::new(vec![(x0, y0), (x1, y1)], HATCH.stroke_width(1)),
                    PathElement::new(vec![(x0, y1), (x1, y0)], HATCH.stroke_width(1)),
                ]
            });
        chart.draw_series(hatch).map_err(e)?;
    }
    if !g.overlay.cell_labels.is_empty() {
        let style = (FONT, 13).into_font().color(&BLACK);
        chart
            .draw_series(g.overlay.cell_labels.iter().enumerate().map(|(k, t)| {
                let x = 0.5 * (cx[k % nx].0 + cx[k % nx].1);
                let y = 0.5 * (cy[k / nx].0 + cy[k / nx].1);
                EmptyElement::at((x, y)) + Text::new(t.clone(), (-4, -7), style.clone())
            }))
            .map_err(e)?;
    }
    Ok(())
}

/// The outlines, clipped to the plot bounds, each in its palette colour with its label.
pub(crate) fn draw_outlines<DB: DrawingBackend, E>(
    g: &HeatGeom<'_>,
    chart: &mut Chart<'_, DB>,
    e: &impl Fn(DrawingAreaErrorKind<DB::ErrorType>) -> E,
) -> Result<(), E> {
    let (x0, x1, y0, y1) = g.bounds;
    let inside = |p: &(f64, f64)| p.0 >= x0 && p.0 <= x1 && p.1 >= y0 && p.1 <= y1;
    for (i, o) in g.overlay.outlines.iter().enumerate() {
        let col = PALETTE[i % PALETTE.len()];
        let segs: Vec<_> = o
            .segments
            .iter()
            .filter(|(a, b)| inside(a) && inside(b))
            .collect();
        chart
            .draw_series(segs.iter().map(|&&(a, b)| {
                PathElement::new(vec![a, b], ShapeStyle::from(&col).stroke_width(2))
            }))
            .map_err(e)?;
        // Label at the segment closest to the plot centre, so it stays readable.
        let mid = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let d = |p: &(f64, f64)| (p.0 - mid.0).powi(2) + (p.1 - mid.1).powi(2);
        if let Some(((a, _), _)) = segs
            .iter()
            .map(|s| (**s, d(&s.0)))
            .min_by(|p, q| p.1.total_cmp(&q.1))
        {
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at(a)
                        + Text::new(
                            format!("{} FOV", o.label),
                            (4, 2),
                            (FONT, 13).into_font().color(&col),
                        ),
                ))
                .map_err(e)?;
        }
    }
    Ok(())
}

/// The legend entry of non-finite cells, under the colour bar.
pub(crate) fn draw_legend<DB: DrawingBackend, E>(
    g: &HeatGeom<'_>,
    bar: &DrawingArea<DB, Shift>,
    e: &impl Fn(DrawingAreaErrorKind<DB::ErrorType>) -> E,
) -> Result<(), E> {
    let (_, h) = bar.dim_in_pixel();
    if let Some(label) = g.overlay.context_label {
        let y = h as i32 - 20;
        bar.draw(&PathElement::new(
            vec![(8, y + 8), (24, y + 8)],
            CONTEXT.stroke_width(3),
        ))
        .map_err(e)?;
        bar.draw(&Text::new(
            label.to_string(),
            (30, y + 1),
            (FONT, 13).into_font().color(&BLACK),
        ))
        .map_err(e)?;
    }
    let Some(label) = g.overlay.missing_label else {
        return Ok(());
    };
    let y = h as i32 - 40;
    bar.draw(&Rectangle::new([(8, y), (24, y + 16)], MISSING.filled()))
        .map_err(e)?;
    bar.draw(&PathElement::new(
        vec![(8, y), (24, y + 16)],
        HATCH.stroke_width(1),
    ))
    .map_err(e)?;
    bar.draw(&PathElement::new(
        vec![(8, y + 16), (24, y)],
        HATCH.stroke_width(1),
    ))
    .map_err(e)?;
    bar.draw(&Text::new(
        label.to_string(),
        (30, y + 1),
        (FONT, 13).into_font().color(&BLACK),
    ))
    .map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Format, Marker, heatmap_with};

    fn map<'a>(values: &'a [f64], markers: &'a [Marker<'a>]) -> HeatMap<'a> {
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
            value_range: Some((0.0, 15.0)),
        }
    }

    #[test]
    fn overlay_nominal_legend_outline_and_labels() {
        let mut values: Vec<f64> = (0..12).map(|i| i as f64).collect();
        values[0] = f64::NAN;
        values[5] = f64::NAN;
        let segs = [
            ((0.0, -100.0), (300.0, 100.0)),
            ((300.0, 100.0), (0.0, 100.0)),
        ];
        let outlines = [Outline {
            label: "rear",
            segments: &segs,
        }];
        let labels: Vec<String> = (0..12).map(|i| format!("n{i}")).collect();
        let car = [((0.0, -120.0), (320.0, -120.0))];
        let overlay = Overlay {
            missing_label: Some("not measurable"),
            outlines: &outlines,
            cell_labels: &labels,
            context: &car,
            context_label: Some("car outline"),
            integer_bar: false,
        };
        let m = map(&values, &[]);
        let svg = String::from_utf8(heatmap_with(&m, &overlay, Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("not measurable"));
        assert!(svg.contains("rear FOV"));
        assert!(svg.contains("n11"));
        assert!(svg.contains("car outline") && svg.contains("#3C3C3C"));
        // The hatched fill is used in the map (and the legend) only with the overlay.
        let fill = "#DEDEDE";
        assert!(svg.contains(fill), "no hatched-cell fill");
        let plain = String::from_utf8(crate::heatmap(&m, Format::Svg).unwrap()).unwrap();
        assert!(!plain.contains(fill) && !plain.contains("not measurable"));
        let png = heatmap_with(&m, &overlay, Format::Png).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }

    #[test]
    fn overlay_rejects_wrong_label_count() {
        let values: Vec<f64> = (0..12).map(|i| i as f64).collect();
        let labels = vec!["1".to_string(); 3];
        let overlay = Overlay {
            cell_labels: &labels,
            ..Overlay::default()
        };
        assert!(matches!(
            heatmap_with(&map(&values, &[]), &overlay, Format::Svg),
            Err(Error::BadInput {
                field: "cell_labels",
                ..
            })
        ));
    }
}

#[cfg(test)]
mod integer_bar_tests {
    use super::*;
    use crate::{Format, heatmap_with};

    /// A count map's colour bar has integer ticks only (0, 1, 2, 3), never "0.5" or "2.0".
    #[test]
    fn integer_bar_has_integer_ticks_only() {
        let values = [0.0, 1.0, 2.0, 3.0, 2.0, 1.0];
        let map = HeatMap {
            xs: &[0.0, 100.0, 200.0],
            ys: &[0.0, 100.0],
            values: &values,
            title: "cameras seeing the point",
            x_label: "x [mm]",
            y_label: "y [mm]",
            colorbar_label: "cameras [-]",
            threshold: None,
            markers: &[],
            value_range: Some((0.0, 3.0)),
        };
        let overlay = Overlay {
            integer_bar: true,
            ..Overlay::default()
        };
        let svg = String::from_utf8(heatmap_with(&map, &overlay, Format::Svg).unwrap()).unwrap();
        let texts: Vec<&str> = svg
            .split("<text")
            .skip(1)
            .filter_map(|t| Some(t.split('>').nth(1)?.split('<').next()?.trim()))
            .collect();
        // The colour bar's texts follow its label: one per count, no fractional tick.
        let bar = texts
            .iter()
            .position(|t| *t == "cameras [-]")
            .expect("colour bar label");
        assert_eq!(texts[bar + 1..], ["0", "1", "2", "3"], "{texts:?}");
    }
}
