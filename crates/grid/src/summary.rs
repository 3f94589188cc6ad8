//! Layouts → grids: the typed summary of a grid study and its files (`grid.csv`,
//! `summary.json`, heat maps of σ_max and of σx σy σz per z level).

use crate::Error;
use crashrig_mc::{Grid, GridResult};
use crashrig_stats::summary::median;
use rayon::prelude::*;
use serde::Serialize;

/// Whether σ_max is at or above the threshold (a NaN σ counts as not below).
pub fn not_below(sigma_mm: f64, threshold_mm: f64) -> bool {
    sigma_mm.partial_cmp(&threshold_mm) != Some(std::cmp::Ordering::Less)
}

/// The worst-direction σ of a grid (√ of the largest eigenvalue of each point's covariance,
/// [`crashrig_mc::PointStats::sigma_worst_mm`]) summarised against a threshold: the numbers of
/// the study's layout summaries and of `crashrig grid`'s `summary.json`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorstDirection {
    /// Share of all points whose worst-direction σ is below the threshold (a blank σ — not
    /// measurable or degenerate — counts as not below).
    pub fraction_below_threshold: f64,
    /// Median over the points with a finite σ (mm; NaN when there is none).
    pub median_mm: f64,
    /// Largest finite value (mm; NaN when there is none).
    pub max_mm: f64,
}

impl WorstDirection {
    /// Summarises the worst-direction σ of `result`'s points against `threshold_mm`.
    pub fn new(result: &GridResult, threshold_mm: f64) -> WorstDirection {
        let worst: Vec<f64> = result.points.iter().map(|p| p.sigma_worst_mm()).collect();
        let n = worst.len().max(1) as f64;
        WorstDirection {
            fraction_below_threshold: worst.iter().filter(|s| **s < threshold_mm).count() as f64
                / n,
            median_mm: median(&worst).unwrap_or(f64::NAN),
            max_mm: worst
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(f64::NAN, f64::max),
        }
    }
}

/// Where the worst part of a layout's grid lies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WorstRegion {
    /// The grid point with the largest σ_max (mm, vehicle frame).
    pub max_point_mm: [f64; 3],
    /// Its σ_max (mm).
    pub max_sigma_mm: f64,
    /// Number of points at or above the threshold.
    pub points_above_threshold: usize,
    /// Bounding box of the points at or above the threshold: `[[x_lo, x_hi], [y_lo, y_hi],
    /// [z_lo, z_hi]]` (mm); `None` when every point is below.
    pub above_threshold_box_mm: Option<[[f64; 2]; 3]>,
}

/// The summary of one grid study: the fields of `grid`'s `summary.json` that do not depend
/// on timing (so a study's `results.json` is reproducible bit for bit), plus per-axis medians
/// and the worst region.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GridSummary {
    /// Grid points.
    pub points: usize,
    /// Monte Carlo draws per point.
    pub samples_per_point: u64,
    /// Threshold on σ_max (mm).
    pub threshold_mm: f64,
    /// Fraction of points with σ_max below the threshold.
    pub fraction_below_threshold: f64,
    /// Largest σ_max (mm).
    pub max_sigma_mm: f64,
    /// Median σ_max (mm).
    pub median_sigma_max_mm: f64,
    /// Median σx, σy, σz (mm).
    pub median_sigma_mm: [f64; 3],
    /// Fraction of points whose worst-direction σ (√ of the largest eigenvalue of the point's
    /// covariance, [`crashrig_mc::PointStats::sigma_worst_mm`]) is below the threshold: the
    /// threshold met in every direction, not only along x, y and z.
    pub fraction_worst_below_threshold: f64,
    /// Median worst-direction σ (mm).
    pub median_sigma_worst_mm: f64,
    /// Largest worst-direction σ (mm).
    pub max_sigma_worst_mm: f64,
    /// First-order (linear) counterpart: fraction below the threshold.
    pub linear_fraction_below_threshold: f64,
    /// First-order median σ_max (mm).
    pub linear_median_sigma_max_mm: f64,
    /// Where the worst region is.
    pub worst: WorstRegion,
    /// Points whose rays are nearly parallel (intersection angle below
    /// `crashrig_mc::degenerate::MIN_INTERSECTION_ANGLE_DEG`): blank σ, left out of the medians,
    /// the maximum and the worst region, counted as not below the threshold.
    pub degenerate_points: usize,
    /// Layouts with fixed observers only: the fraction of points seen by two or more
    /// observers and each observer's coverage (not-measurable points have blank σ, are left out
    /// of the medians and count as not below the threshold).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fixed: Option<crate::fixed_maps::FixedSummary>,
}

impl GridSummary {
    /// Summarises `result` over `grid`.
    pub fn new(grid: &Grid, result: &GridResult) -> GridSummary {
        let t = grid.threshold_mm;
        let sm: Vec<f64> = result.points.iter().map(|p| p.sigma_max_mm).collect();
        let lsm: Vec<f64> = result
            .points
            .iter()
            .map(|p| p.linear_sigma_max_mm())
            .collect();
        let axis = |k: usize| {
            median(
                &result
                    .points
                    .iter()
                    .map(|p| p.sigma_mm[k])
                    .collect::<Vec<_>>(),
            )
            .unwrap_or(f64::NAN)
        };
        let n = result.points.len().max(1) as f64;
        let worst = WorstDirection::new(result, t);
        let (imax, max) =
            sm.iter()
                .copied()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |(bi, bv), (i, v)| {
                    if v > bv { (i, v) } else { (bi, bv) }
                });
        let above: Vec<_> = result
            .points
            .iter()
            .filter(|p| p.sigma_max_mm.is_finite() && not_below(p.sigma_max_mm, t))
            .collect();
        let bbox = (!above.is_empty()).then(|| {
            let mut b = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
            for p in &above {
                for (bk, v) in b.iter_mut().zip(p.point.iter()) {
                    bk[0] = bk[0].min(*v);
                    bk[1] = bk[1].max(*v);
                }
            }
            b
        });
        GridSummary {
            points: result.points.len(),
            samples_per_point: result.points.iter().map(|p| p.count).max().unwrap_or(0),
            threshold_mm: t,
            fraction_below_threshold: result.fraction_below(t),
            max_sigma_mm: max,
            median_sigma_max_mm: median(&sm).unwrap_or(f64::NAN),
            median_sigma_mm: [axis(0), axis(1), axis(2)],
            fraction_worst_below_threshold: worst.fraction_below_threshold,
            median_sigma_worst_mm: worst.median_mm,
            max_sigma_worst_mm: worst.max_mm,
            linear_fraction_below_threshold: lsm.iter().filter(|s| **s < t).count() as f64 / n,
            linear_median_sigma_max_mm: median(&lsm).unwrap_or(f64::NAN),
            degenerate_points: result
                .points
                .iter()
                .filter(|p| p.sigma_max_mm.is_nan() && p.is_measurable())
                .count(),
            fixed: crate::fixed_maps::has_fixed(grid)
                .then(|| crate::fixed_maps::FixedSummary::new(grid, result)),
            worst: WorstRegion {
                max_point_mm: result
                    .points
                    .get(imax)
                    .map_or([f64::NAN; 3], |p| p.point.into()),
                max_sigma_mm: max,
                points_above_threshold: above.len(),
                above_threshold_box_mm: bbox,
            },
        }
    }
}

/// The `grid.csv` of the contract (`x_mm,…,sigma_max_mm`), one row per point.
pub fn grid_csv(result: &GridResult) -> String {
    let mut s = String::from("x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm\n");
    for p in &result.points {
        let c = |v: f64| {
            if v.is_nan() {
                String::new()
            } else {
                v.to_string()
            }
        };
        s.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            p.point.x,
            p.point.y,
            p.point.z,
            c(p.sigma_mm.x),
            c(p.sigma_mm.y),
            c(p.sigma_mm.z),
            c(p.sigma_max_mm)
        ));
    }
    s
}

/// A layout's `grid.csv`: [`grid_csv`], plus the column `observers_seen` (as `crashrig grid`
/// writes it) when the layout has fixed observers (a point seen by fewer than two has blank σ),
/// then, always last, `sigma_worst_mm` (worst-direction σ, blank where σ_max is blank).
pub fn layout_csv(grid: &Grid, result: &GridResult) -> String {
    let base = grid_csv(result);
    let seen = crate::fixed_maps::has_fixed(grid);
    let mut s = String::with_capacity(base.len() + 24 * result.points.len());
    for (i, line) in base.lines().enumerate() {
        s.push_str(line);
        if i == 0 {
            s.push_str(if seen {
                ",observers_seen,sigma_worst_mm\n"
            } else {
                ",sigma_worst_mm\n"
            });
            continue;
        }
        let p = &result.points[i - 1];
        if seen {
            s.push_str(&format!(",{}", p.observers_seen));
        }
        let w = p.sigma_worst_mm();
        if w.is_nan() {
            s.push_str(",\n");
        } else {
            s.push_str(&format!(",{w}\n"));
        }
    }
    s
}

/// `grid.ply` (PLY 1.0, binary little-endian; docs/REFERENCE.md): one vertex per grid point in
/// the order of `grid.csv`, `double x y z` (mm) and `float sigma_x sigma_y sigma_z sigma_max
/// sigma_worst` (mm) — the values of `grid.csv` rounded to `f32`, NaN where its cell is blank
/// (a point not measurable or degenerate).
pub fn grid_ply(result: &GridResult) -> Vec<u8> {
    use crashrig_plot::ply::{PlyType, PlyVertices};
    let f = PlyType::Float;
    let mut ply = PlyVertices::new(&[
        ("x", PlyType::Double),
        ("y", PlyType::Double),
        ("z", PlyType::Double),
        ("sigma_x", f),
        ("sigma_y", f),
        ("sigma_z", f),
        ("sigma_max", f),
        ("sigma_worst", f),
    ]);
    ply.comment("crashrig grid points (mm): sigma_* = Monte Carlo standard uncertainty, sigma_worst = along the worst direction; NaN = not measurable");
    for p in &result.points {
        let m = |v: f64| if p.is_measurable() { v } else { f64::NAN };
        ply.push(&[
            p.point.x,
            p.point.y,
            p.point.z,
            m(p.sigma_mm.x),
            m(p.sigma_mm.y),
            m(p.sigma_mm.z),
            m(p.sigma_max_mm),
            m(p.sigma_worst_mm()),
        ]);
    }
    ply.to_bytes()
}

/// One heat map of a layout: file stem, z index and its PNG.
pub struct HeatMapPng {
    /// `sigma_max`, `sigma_worst`, `sigma_x`, `sigma_y`, `sigma_z` or `observers_seen`.
    pub stem: &'static str,
    /// The z level (mm).
    pub z_mm: f64,
    /// File name (`<stem>_z<ii>_<z>mm.png`).
    pub file: String,
    /// The PNG bytes.
    pub png: Vec<u8>,
    /// The same map as SVG.
    pub svg: Vec<u8>,
}

/// The colour scale shared by every σ map of a study (so that compared layouts read alike):
/// 0 to `top_mm`, chosen from the data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapScale {
    /// Upper end of the colour bar (mm); larger values saturate.
    pub top_mm: f64,
}

/// The smallest of 1, 2, 2.5, 5 × 10ᵏ at or above `v` (> 0).
pub fn nice_ceil(v: f64) -> f64 {
    if !(v.is_finite() && v > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(v.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|c| *c >= v * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

impl MapScale {
    /// One scale for `results` (every layout of a study): the 90th percentile of the
    /// worst-direction σ over all measurable points (the worst tenth saturates instead of
    /// flattening the rest into one colour), at least 1.2 × the largest threshold so that the
    /// threshold is on the bar, rounded up by [`nice_ceil`].
    pub fn shared<'a>(results: impl IntoIterator<Item = (&'a Grid, &'a GridResult)>) -> MapScale {
        let mut v = Vec::new();
        let mut threshold = 0.0f64;
        for (g, r) in results {
            threshold = threshold.max(g.threshold_mm);
            v.extend(
                r.points
                    .iter()
                    .map(|p| p.sigma_worst_mm())
                    .filter(|s| s.is_finite()),
            );
        }
        v.sort_by(f64::total_cmp);
        let p90 = if v.is_empty() {
            0.0
        } else {
            v[((v.len() - 1) as f64 * 0.9).round() as usize]
        };
        MapScale {
            top_mm: nice_ceil(p90.max(1.2 * threshold)),
        }
    }
}

/// The schematic car of the plan views (vehicle frame, mm): from the trunk opening at x = 0 to
/// 300 mm beyond the front-most grid point or camera, 150 mm wider than the grid and cameras
/// on each side, with chamfered front corners. A sketch for orientation, not a vehicle model.
pub fn car_outline(grid: &Grid) -> Vec<crashrig_plot::Segment> {
    let pts = grid.points();
    let xs = pts
        .iter()
        .map(|p| p.x)
        .chain(grid.observers.iter().map(|o| o.position_mm.x));
    let front = xs.fold(0.0f64, f64::max) + 300.0;
    let half = pts
        .iter()
        .map(|p| p.y.abs())
        .chain(grid.observers.iter().map(|o| o.position_mm.y.abs()))
        .fold(0.0f64, f64::max)
        + 150.0;
    let c = 0.25 * half;
    let poly = [
        (0.0, -half),
        (front - c, -half),
        (front, -half + c),
        (front, half - c),
        (front - c, half),
        (0.0, half),
        (0.0, -half),
    ];
    poly.windows(2).map(|w| (w[0], w[1])).collect()
}

/// Legend of [`car_outline`] on the maps.
pub const CAR_LABEL: &str = "car (sketch)";

/// One kind of heat map: what it shows and how it is coloured.
#[derive(Debug, Clone)]
pub struct MapSpec {
    /// File stem (`sigma_max`, `ratio_mc_linear`, …).
    pub stem: &'static str,
    /// Title before ` at z = … mm`.
    pub title: String,
    /// Colour-bar label.
    pub bar: String,
    /// Threshold contour (mm), if any.
    pub threshold: Option<f64>,
    /// Colour range; `None`: the data range.
    pub range: Option<(f64, f64)>,
    /// The value of a point.
    pub value: fn(&crashrig_mc::PointStats) -> f64,
}

/// How a family of maps is labelled (the two map families, `crashrig grid`'s and the
/// study's layouts', differ only in these).
#[derive(Debug, Clone, Copy)]
pub struct MapStyle {
    /// x-axis label.
    pub x_label: &'static str,
    /// Observers off the map's plane (more than 0.5 mm) are labelled with their z.
    pub label_observer_z: bool,
    /// The field-of-view footprints are traced over the grid padded to include the observers
    /// (`true`) or over the padded grid alone.
    pub footprints_include_observers: bool,
    /// The study's plan views: the car sketch ([`car_outline`]), the outward camera A behind
    /// the rear-most observer, and an integer colour bar on the count map.
    pub sketch: bool,
}

/// The study's layouts: σ_max, the worst-direction σ and σx σy σz on the study's shared
/// colour scale, with the car sketch.
pub const LAYOUT_STYLE: MapStyle = MapStyle {
    x_label: "x [mm] (vehicle frame, forwards from the trunk opening)",
    label_observer_z: false,
    footprints_include_observers: false,
    sketch: true,
};

/// Heat maps per z level of σ_max, the worst-direction σ, σx σy σz and (fixed observers) the
/// number of cameras seeing each point: one colour scale for every σ map (`scale`, shared by
/// the study's layouts) with the threshold contour and its mark on the bar, the schematic car,
/// the interior cameras and the outward camera A marked; the count map has an integer legend.
///
/// # Errors
/// [`Error::Plot`] when a figure cannot be drawn.
pub fn heat_maps(
    grid: &Grid,
    result: &GridResult,
    scale: &MapScale,
) -> Result<Vec<HeatMapPng>, Error> {
    let top = scale.top_mm;
    let bar = format!("sigma [mm] (shared scale; >= {top} saturated)");
    type Pick = fn(&crashrig_mc::PointStats) -> f64;
    let picks: [(&'static str, &str, Pick); 5] = [
        ("sigma_max", "sigma_max (largest of x, y, z)", |p| {
            p.sigma_max_mm
        }),
        (
            "sigma_worst",
            "worst-direction sigma (largest eigen-axis)",
            |p| p.sigma_worst_mm(),
        ),
        ("sigma_x", "sigma_x", |p| p.sigma_mm.x),
        ("sigma_y", "sigma_y", |p| p.sigma_mm.y),
        ("sigma_z", "sigma_z", |p| p.sigma_mm.z),
    ];
    let specs: Vec<MapSpec> = picks
        .into_iter()
        .map(|(stem, title, value)| MapSpec {
            stem,
            title: format!("Monte Carlo {title}"),
            bar: bar.clone(),
            threshold: Some(grid.threshold_mm),
            range: Some((0.0, top)),
            value,
        })
        .collect();
    level_maps(grid, result, &specs, &LAYOUT_STYLE)
}

/// The maps `specs` per z level (PNG and SVG), and with fixed observers also the map of the
/// number of cameras that see each point (`observers_seen`); fixed observers add their
/// field-of-view footprints and hatch the not-measurable cells. A map without any finite
/// value (all degenerate or not measurable) still renders, all hatched.
///
/// # Errors
/// [`Error::Plot`] when a figure cannot be drawn.
pub fn level_maps(
    grid: &Grid,
    result: &GridResult,
    specs: &[MapSpec],
    style: &MapStyle,
) -> Result<Vec<HeatMapPng>, Error> {
    let xs = grid.x.values();
    let ys = grid.y.values();
    let zs = grid.z.values();
    let per_z = xs.len() * ys.len();
    let with_fixed = crate::fixed_maps::has_fixed(grid);
    let seen_spec = MapSpec {
        stem: "observers_seen",
        title: "Cameras seeing the point".into(),
        bar: "observers seeing the point [-]".into(),
        threshold: None,
        range: Some((0.0, (grid.observers.len() as f64).max(1.0))),
        value: |p| p.observers_seen as f64,
    };
    let bound_observers: &[crashrig_mc::Observer] = if style.footprints_include_observers {
        &grid.observers
    } else {
        &[]
    };
    let car = if style.sketch {
        car_outline(grid)
    } else {
        Vec::new()
    };
    let rear = grid
        .observers
        .iter()
        .map(|o| o.position_mm)
        .min_by(|a, b| a.x.total_cmp(&b.x));
    let mut out = Vec::new();
    for (iz, z) in zs.iter().enumerate() {
        let pts = &result.points[iz * per_z..(iz + 1) * per_z];
        let labels: Vec<String> = grid
            .observers
            .iter()
            .map(|o| {
                if style.label_observer_z && (o.position_mm.z - z).abs() > 0.5 {
                    format!("{} (z {:.0})", o.name, o.position_mm.z)
                } else {
                    o.name.clone()
                }
            })
            .collect();
        let mut markers: Vec<crashrig_plot::Marker> = grid
            .observers
            .iter()
            .zip(&labels)
            .map(|(o, l)| crashrig_plot::Marker {
                x: o.position_mm.x,
                y: o.position_mm.y,
                label: l,
            })
            .collect();
        // The outward camera A: behind the rear-most interior camera, looking out of the trunk.
        if let Some(r) = rear.filter(|_| style.sketch) {
            markers.push(crashrig_plot::Marker {
                x: r.x - 120.0,
                y: r.y,
                label: "A",
            });
        }
        let fp = if with_fixed {
            crate::fixed_maps::footprints(
                grid,
                *z,
                crashrig_mc::coverage::footprint_bounds(&xs, &ys, bound_observers),
            )
        } else {
            Vec::new()
        };
        let outlines = crate::fixed_maps::outlines(&fp);
        let mut overlay = if with_fixed {
            crate::fixed_maps::overlay(&outlines, &[])
        } else {
            crashrig_plot::Overlay::default()
        };
        let seen_labels: Vec<String> = pts.iter().map(|p| p.observers_seen.to_string()).collect();
        let mut seen_overlay = crate::fixed_maps::overlay(&outlines, &seen_labels);
        if style.sketch {
            for o in [&mut overlay, &mut seen_overlay] {
                o.context = &car;
                o.context_label = Some(CAR_LABEL);
            }
            seen_overlay.integer_bar = true;
        }
        // The maps of one z are independent: rendered and encoded in parallel (each file's
        // bytes are its own rendering's), collected in the order of the specs.
        let layer: Vec<&MapSpec> = specs
            .iter()
            .chain(with_fixed.then_some(&seen_spec))
            .collect();
        let maps = layer
            .par_iter()
            .map(|spec| {
                let values: Vec<f64> = pts.iter().map(spec.value).collect();
                let all_missing = values.iter().all(|v| !v.is_finite());
                let title = format!("{} at z = {z} mm", spec.title);
                let map = crashrig_plot::HeatMap {
                    xs: &xs,
                    ys: &ys,
                    values: &values,
                    title: &title,
                    x_label: style.x_label,
                    y_label: if style.sketch {
                        "y [mm] (left)"
                    } else {
                        "y [mm]"
                    },
                    colorbar_label: &spec.bar,
                    threshold: spec.threshold,
                    markers: &markers,
                    value_range: spec.range.or(all_missing.then_some((0.0, 1.0))),
                };
                let ov = if spec.stem == "observers_seen" {
                    &seen_overlay
                } else {
                    &overlay
                };
                let draw = |f| {
                    crashrig_plot::heatmap_with(&map, ov, f).map_err(|source| Error::Plot {
                        what: format!("heat map {} at z = {z} mm", spec.stem),
                        source,
                    })
                };
                let (png, svg) = rayon::join(
                    || draw(crashrig_plot::Format::Png),
                    || draw(crashrig_plot::Format::Svg),
                );
                Ok(HeatMapPng {
                    stem: spec.stem,
                    z_mm: *z,
                    file: format!("{}_z{iz:02}_{z}mm.png", spec.stem),
                    png: png?,
                    svg: svg?,
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        out.extend(maps);
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crashrig_mc::PointStats;
    use nalgebra::{Matrix3, Vector3};

    /// A measured point at `x` mm with sample covariance `cov` (mm²): σ per axis and σ_max
    /// from its diagonal, as the Monte Carlo fills them.
    pub(crate) fn point(x: f64, cov: Matrix3<f64>) -> PointStats {
        let sigma = Vector3::new(cov[(0, 0)], cov[(1, 1)], cov[(2, 2)]).map(f64::sqrt);
        PointStats {
            point: Vector3::new(x, 0.0, 0.0),
            count: 100,
            mean_mm: Vector3::new(x, 0.0, 0.0),
            covariance: cov,
            sigma_mm: sigma,
            sigma_max_mm: sigma.max(),
            linear_covariance: cov,
            observers_seen: 2,
            converged: None,
        }
    }

    /// Three points against a 5 mm threshold: covariance [[4,3,0],[3,4,0],[0,0,1]] has the
    /// eigenvalues 7, 1, 1 (σ_worst = √7 ≈ 2.65 mm, σ_max = 2 mm); [[16,12,0],[12,16,0],[0,0,4]]
    /// has 28, 4, 4 (σ_worst = 2√7 ≈ 5.29 mm above the threshold although σ_max = 4 mm is
    /// below); a NaN point (not measurable) counts as not below and is left out of the median.
    pub(crate) fn known_grid() -> GridResult {
        let a = Matrix3::new(4.0, 3.0, 0.0, 3.0, 4.0, 0.0, 0.0, 0.0, 1.0);
        let mut nan = point(2.0, Matrix3::from_element(f64::NAN));
        nan.observers_seen = 1;
        GridResult {
            points: vec![point(0.0, a), point(1.0, 4.0 * a), nan],
            observer_sigma: Vec::new(),
            observer_covariance: Vec::new(),
            correlated: false,
        }
    }

    #[test]
    fn worst_direction_known_answer() {
        let r = known_grid();
        let w = WorstDirection::new(&r, 5.0);
        let s7 = 7f64.sqrt();
        assert_eq!(w.fraction_below_threshold, 1.0 / 3.0);
        assert!((w.median_mm - 1.5 * s7).abs() < 1e-12, "{}", w.median_mm);
        assert!((w.max_mm - 2.0 * s7).abs() < 1e-12, "{}", w.max_mm);
        // σ_max alone would pass two of the three points.
        assert_eq!(r.fraction_below(5.0), 2.0 / 3.0);
    }

    #[test]
    fn nice_ceil_known_values() {
        for (v, c) in [
            (0.7, 1.0),
            (1.0, 1.0),
            (1.01, 2.0),
            (2.2, 2.5),
            (3.0, 5.0),
            (6.0, 10.0),
            (12.0, 20.0),
        ] {
            assert_eq!(nice_ceil(v), c, "nice_ceil({v})");
        }
    }
}
