//! Layouts → grids: the typed summary of a grid study and its files (`grid.csv`,
//! `summary.json`, heat maps of σ_max and of σx σy σz per z level).

use crate::Error;
use crashrig_mc::{Grid, GridResult};
use serde::Serialize;
use std::path::Path;

/// Median of the finite values (NaN when there is none).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Whether σ_max is at or above the threshold (a NaN σ counts as not below).
pub fn not_below(sigma_mm: f64, threshold_mm: f64) -> bool {
    sigma_mm.partial_cmp(&threshold_mm) != Some(std::cmp::Ordering::Less)
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
        };
        let n = result.points.len().max(1) as f64;
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
            median_sigma_max_mm: median(&sm),
            median_sigma_mm: [axis(0), axis(1), axis(2)],
            linear_fraction_below_threshold: lsm.iter().filter(|s| **s < t).count() as f64 / n,
            linear_median_sigma_max_mm: median(&lsm),
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
/// writes it) when the layout has fixed observers; a point seen by fewer than two has blank σ.
pub fn layout_csv(grid: &Grid, result: &GridResult) -> String {
    let base = grid_csv(result);
    if !crate::fixed_maps::has_fixed(grid) {
        return base;
    }
    let mut s = String::with_capacity(base.len() + 4 * result.points.len());
    for (i, line) in base.lines().enumerate() {
        s.push_str(line);
        if i == 0 {
            s.push_str(",observers_seen\n");
        } else {
            s.push_str(&format!(",{}\n", result.points[i - 1].observers_seen));
        }
    }
    s
}

/// One heat map of a layout: file stem, z index and its PNG.
pub struct HeatMapPng {
    /// `sigma_max`, `sigma_x`, `sigma_y` or `sigma_z`.
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
}

/// The study's layouts: σ_max and σx σy σz on one colour scale.
pub const LAYOUT_STYLE: MapStyle = MapStyle {
    x_label: "x [mm] (vehicle frame)",
    label_observer_z: false,
    footprints_include_observers: false,
};

/// Heat maps of σ_max and σx σy σz per z level, one colour scale (0 to 3× the threshold,
/// larger values saturate) with the threshold contour and the observers marked.
///
/// # Errors
/// [`Error::Plot`] when a figure cannot be drawn.
pub fn heat_maps(grid: &Grid, result: &GridResult) -> Result<Vec<HeatMapPng>, Error> {
    let top = 3.0 * grid.threshold_mm;
    let bar = format!(
        "sigma [mm] (>= {top} saturated; white line: {} mm threshold)",
        grid.threshold_mm
    );
    type Pick = fn(&crashrig_mc::PointStats) -> f64;
    let picks: [(&'static str, Pick); 4] = [
        ("sigma_max", |p| p.sigma_max_mm),
        ("sigma_x", |p| p.sigma_mm.x),
        ("sigma_y", |p| p.sigma_mm.y),
        ("sigma_z", |p| p.sigma_mm.z),
    ];
    let specs: Vec<MapSpec> = picks
        .into_iter()
        .map(|(stem, value)| MapSpec {
            stem,
            title: format!("Monte Carlo {stem}"),
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
        let markers: Vec<crashrig_plot::Marker> = grid
            .observers
            .iter()
            .zip(&labels)
            .map(|(o, l)| crashrig_plot::Marker {
                x: o.position_mm.x,
                y: o.position_mm.y,
                label: l,
            })
            .collect();
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
        let overlay = if with_fixed {
            crate::fixed_maps::overlay(&outlines, &[])
        } else {
            crashrig_plot::Overlay::default()
        };
        let seen_labels: Vec<String> = pts.iter().map(|p| p.observers_seen.to_string()).collect();
        let seen_overlay = crate::fixed_maps::overlay(&outlines, &seen_labels);
        for spec in specs.iter().chain(with_fixed.then_some(&seen_spec)) {
            let values: Vec<f64> = pts.iter().map(spec.value).collect();
            let all_missing = values.iter().all(|v| !v.is_finite());
            let title = format!("{} at z = {z} mm", spec.title);
            let map = crashrig_plot::HeatMap {
                xs: &xs,
                ys: &ys,
                values: &values,
                title: &title,
                x_label: style.x_label,
                y_label: "y [mm]",
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
            let png = draw(crashrig_plot::Format::Png)?;
            let svg = draw(crashrig_plot::Format::Svg)?;
            out.push(HeatMapPng {
                stem: spec.stem,
                z_mm: *z,
                file: format!("{}_z{iz:02}_{z}mm.png", spec.stem),
                png,
                svg,
            });
        }
    }
    Ok(out)
}

/// Writes `bytes` to `dir/name` (creating `dir`).
pub(crate) fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let path = dir.join(name);
    std::fs::write(&path, bytes).map_err(|source| Error::Write { path, source })
}
