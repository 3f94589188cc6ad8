//! Error ellipses on a plan or side view: axes with ticks in mm, each 1σ ellipse magnified by a
//! stated factor, and a scale key (a circle of a stated σ drawn at the same magnification).

use crate::{Error, FONT, Format, Segment, draw_err, render};
use plotters::coord::Shift;
use plotters::prelude::*;

/// One 1σ error ellipse: its centre and the 2×2 covariance of the two plotted axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    /// Centre in axis units (mm).
    pub centre: (f64, f64),
    /// Covariance `[[s_uu, s_uv], [s_uv, s_vv]]` (mm²).
    pub covariance: [[f64; 2]; 2],
    /// Drawn red (e.g. at or above the threshold) instead of blue.
    pub flagged: bool,
}

/// The data and labels of an ellipse plot.
#[derive(Debug, Clone, Copy)]
pub struct EllipsePlot<'a> {
    /// The ellipses (non-finite ones are skipped).
    pub ellipses: &'a [Ellipse],
    /// Drawing scale: a σ of 1 mm is drawn `magnification` mm long on the axes.
    pub magnification: f64,
    /// σ of the key circle (mm), e.g. the threshold.
    pub key_sigma: f64,
    /// Title above the plot.
    pub title: &'a str,
    /// Label of the horizontal axis (with unit).
    pub x_label: &'a str,
    /// Label of the vertical axis (with unit).
    pub y_label: &'a str,
    /// Context lines (e.g. the car outline), axis units.
    pub context: &'a [Segment],
}

/// The semi-axes `(a ≥ b)` and the angle (rad, from the first axis) of a 2×2 covariance.
pub fn ellipse_axes(c: &[[f64; 2]; 2]) -> (f64, f64, f64) {
    let (saa, sbb, sab) = (c[0][0], c[1][1], c[0][1]);
    let tr = 0.5 * (saa + sbb);
    let det = (0.25 * (saa - sbb).powi(2) + sab * sab).sqrt();
    (
        (tr + det).max(0.0).sqrt(),
        (tr - det).max(0.0).sqrt(),
        0.5 * (2.0 * sab).atan2(saa - sbb),
    )
}

/// The outline of an ellipse with semi-axes `a`, `b` at `angle` around `c`, `n` points.
fn outline(c: (f64, f64), a: f64, b: f64, angle: f64, n: usize) -> Vec<(f64, f64)> {
    let (s, co) = angle.sin_cos();
    (0..=n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            let (u, v) = (a * t.cos(), b * t.sin());
            (c.0 + co * u - s * v, c.1 + s * u + co * v)
        })
        .collect()
}

/// Renders the ellipses with axes, ticks and the scale key, 1000 px wide.
///
/// Errors: no finite ellipse, a magnification or key σ that is not finite and positive, or a
/// backend failure.
pub fn ellipses(p: &EllipsePlot<'_>, format: Format) -> Result<Vec<u8>, Error> {
    const FIG: &str = "ellipses";
    if !(p.magnification.is_finite() && p.magnification > 0.0) {
        return Err(Error::BadInput {
            figure: FIG,
            field: "magnification",
            problem: "must be finite and positive",
        });
    }
    if !(p.key_sigma.is_finite() && p.key_sigma > 0.0) {
        return Err(Error::BadInput {
            figure: FIG,
            field: "key_sigma",
            problem: "must be finite and positive",
        });
    }
    let shapes: Vec<(Vec<(f64, f64)>, bool)> = p
        .ellipses
        .iter()
        .filter(|e| {
            e.centre.0.is_finite()
                && e.centre.1.is_finite()
                && e.covariance.iter().flatten().all(|v| v.is_finite())
        })
        .map(|e| {
            let (a, b, ang) = ellipse_axes(&e.covariance);
            let m = p.magnification;
            (outline(e.centre, a * m, b * m, ang, 48), e.flagged)
        })
        .collect();
    let all = shapes
        .iter()
        .flat_map(|s| s.0.iter().copied())
        .chain(p.context.iter().flat_map(|s| [s.0, s.1]));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if shapes.is_empty() || x1 <= x0 {
        return Err(Error::BadInput {
            figure: FIG,
            field: "ellipses",
            problem: "holds no finite ellipse",
        });
    }
    let pad = 0.05 * (x1 - x0).max(y1 - y0).max(1.0);
    let key_r = p.key_sigma * p.magnification;
    // Room for the key circle below the data.
    let d = Drawing {
        p,
        shapes: &shapes,
        bounds: (x0 - pad, x1 + pad, y0 - pad - 2.5 * key_r, y1 + pad),
        key_r,
    };
    let (w, h) = (d.bounds.1 - d.bounds.0, d.bounds.3 - d.bounds.2);
    let plot_w = 880.0;
    let plot_h = (plot_w * h / w).clamp(240.0, 900.0);
    render(
        FIG,
        (1000, plot_h as u32 + 120),
        format,
        |root| draw(&d, root),
        |root| draw(&d, root),
    )
}

struct Drawing<'a> {
    p: &'a EllipsePlot<'a>,
    shapes: &'a [(Vec<(f64, f64)>, bool)],
    bounds: (f64, f64, f64, f64),
    key_r: f64,
}

fn draw<DB: DrawingBackend>(d: &Drawing<'_>, root: DrawingArea<DB, Shift>) -> Result<(), Error> {
    let e = draw_err::<DrawingAreaErrorKind<DB::ErrorType>>("ellipses");
    let (x0, x1, y0, y1) = d.bounds;
    let mut chart = ChartBuilder::on(&root)
        .caption(d.p.title, (FONT, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(&e)?;
    chart
        .configure_mesh()
        .x_desc(d.p.x_label)
        .y_desc(d.p.y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(&e)?;
    chart
        .draw_series(
            d.p.context
                .iter()
                .map(|&(a, b)| PathElement::new(vec![a, b], RGBColor(60, 60, 60).stroke_width(2))),
        )
        .map_err(&e)?;
    let (blue, red) = (RGBColor(0, 102, 204), RGBColor(221, 34, 34));
    chart
        .draw_series(d.shapes.iter().map(|(pts, flagged)| {
            PathElement::new(
                pts.clone(),
                if *flagged { red } else { blue }.stroke_width(2),
            )
        }))
        .map_err(&e)?;
    // The key: a circle of key σ at the same magnification, bottom left.
    let c = (x0 + 1.5 * d.key_r + 0.02 * (x1 - x0), y0 + 1.25 * d.key_r);
    chart
        .draw_series(std::iter::once(PathElement::new(
            outline(c, d.key_r, d.key_r, 0.0, 64),
            BLACK.stroke_width(2),
        )))
        .map_err(&e)?;
    chart
        .draw_series(std::iter::once(
            EmptyElement::at((c.0 + 1.3 * d.key_r, c.1))
                + Text::new(
                    format!(
                        "key: sigma = {} mm (ellipses magnified x{:.0}; red: at or above it)",
                        d.p.key_sigma, d.p.magnification
                    ),
                    (0, -8),
                    (FONT, 15).into_font().color(&BLACK),
                ),
        ))
        .map_err(&e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_axes_known_answer() {
        // [[4, 3], [3, 4]]: eigenvalues 7 and 1 along the diagonals (45°).
        let (a, b, ang) = ellipse_axes(&[[4.0, 3.0], [3.0, 4.0]]);
        assert!((a - 7f64.sqrt()).abs() < 1e-12 && (b - 1.0).abs() < 1e-12);
        assert!((ang - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // The outline's farthest point from the centre is a away, along the angle.
        let o = outline((1.0, 2.0), a, b, ang, 8);
        let (dx, dy) = (o[0].0 - 1.0, o[0].1 - 2.0);
        assert!(((dx * dx + dy * dy).sqrt() - a).abs() < 1e-12 && (dx - dy).abs() < 1e-12);
    }

    #[test]
    fn ellipses_render_with_axes_and_key() {
        let e = [
            Ellipse {
                centre: (0.0, 0.0),
                covariance: [[4.0, 0.0], [0.0, 1.0]],
                flagged: false,
            },
            Ellipse {
                centre: (500.0, 200.0),
                covariance: [[36.0, 0.0], [0.0, 1.0]],
                flagged: true,
            },
        ];
        let p = EllipsePlot {
            ellipses: &e,
            magnification: 10.0,
            key_sigma: 5.0,
            title: "plan view",
            x_label: "x [mm]",
            y_label: "y [mm]",
            context: &[],
        };
        let svg = String::from_utf8(ellipses(&p, Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("x [mm]") && svg.contains("key: sigma = 5 mm"));
        assert!(svg.contains("#DD2222") && svg.contains("#0066CC"));
        let png = ellipses(&p, Format::Png).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let bad = EllipsePlot {
            magnification: 0.0,
            ..p
        };
        assert!(ellipses(&bad, Format::Svg).is_err());
    }
}
