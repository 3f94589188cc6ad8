//! The output files of a measurement, in the formats of `crashrig measure` (docs/MEASURE.md):
//! `trajectories.csv` (the contract's fixed header), `displacements.csv`, one trajectory plot
//! per marker (`plots/<marker>.png|svg`), the numbers of `summary.json` and, with scale bars,
//! `length_check.csv` and its plot `length_check.png|svg`.
//!
//! `crashrig measure` and the study's `[measure]` step both write through these functions, so
//! the two outputs have one format. Numbers are written with Rust's shortest round-trip
//! formatting (`{}` of `f64`); a missing value is an empty field; text fields are quoted when
//! CSV needs it.
//!
//! # Example
//! One marker seen by B and C in two epochs; the files as `crashrig measure` writes them.
//! ```
//! use crashrig_camera::{Camera, ModelId};
//! use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
//! use crashrig_measure::engine::{Epoch, Rig, Settings, measure};
//! use crashrig_measure::input::{Inward, Observation};
//! use crashrig_measure::output::{self, Summary};
//! use nalgebra::Vector2;
//!
//! let pinhole = Camera::new(ModelId::Pinhole, 1000, 1000, vec![1000.0, 1000.0, 500.0, 500.0])?;
//! let exact = |p| UncertainPose::from_sigmas(p, Vec3::zeros(), Vec3::zeros());
//! let rig = Rig {
//!     a_from_b: exact(Rigid3::identity()),
//!     camera_b: pinhole.clone(),
//!     c: Some((exact(Rigid3::translation(500.0, 0.0, 0.0)), pinhole)),
//! };
//! let epochs: Vec<Epoch> = ["0001", "0002"]
//!     .iter()
//!     .map(|n| Epoch { key: n.to_string(), name: n.to_string(), world_from_a: exact(Rigid3::identity()) })
//!     .collect();
//! // The marker at (250, 0, 2000) mm: u = 625 px in B, 375 px in C.
//! let mut obs = Vec::new();
//! for e in &epochs {
//!     for (camera, u) in [(Inward::B, 625.0), (Inward::C, 375.0)] {
//!         let line = 2 + obs.len() as u64;
//!         obs.push(Observation { epoch: e.name.clone(), camera, marker: "head".into(), pixel: Vector2::new(u, 500.0), sigma: None, line });
//!     }
//! }
//! let settings = Settings {
//!     samples: 50,
//!     seed: 1,
//!     pixel_sigma_px: 0.0,
//!     reference_epoch: None,
//!     frame_rate_hz: None,
//!     frame_times: None,
//!     threshold_mm: 5.0,
//!     max_reprojection_px: None,
//!     cfc: None,
//!     sync_sigma_ms: 0.0,
//! };
//! let m = measure(&epochs, None, &rig, &obs, None, &settings)?;
//! let csv = output::trajectories_csv(&m);
//! let mut lines = csv.lines();
//! assert_eq!(lines.next(), Some(output::TRAJECTORIES_HEADER));
//! // No noise anywhere: σ = 0 and the position is exact (to rounding), seen by both cameras.
//! let row: Vec<&str> = lines.next().unwrap().split(',').collect();
//! assert_eq!((row[0], row[1], &row[5..]), ("0001", "head", &["0", "0", "0", "0", "2"][..]));
//! let x: f64 = row[2].parse()?;
//! assert!((x - 250.0).abs() < 1e-9);
//! assert!(output::displacements_csv(&m).starts_with(output::DISPLACEMENTS_HEADER));
//! let plots = output::marker_plots(&m)?;
//! assert_eq!((plots.len(), plots[0].stem.as_str()), (1, "head"));
//! let s = Summary::new(&m, &settings, 1.0, true);
//! assert_eq!((s.rows, s.rows_measured, s.fraction_below_threshold), (2, 2, 1.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::Error;
use crate::engine::{Measurement, Row, Settings};
use crashrig_geometry::Vec3;
use crashrig_plot::{BandPanel, Format};
use crashrig_stats::summary::median;
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// Header of `trajectories.csv` (fixed by the contract).
pub const TRAJECTORIES_HEADER: &str =
    "epoch,marker,x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,n_views";

/// Header of `kinematics.csv` (fixed by the contract).
pub const KINEMATICS_HEADER: &str = "epoch,marker,time_s,dx_mm,dy_mm,dz_mm,sigma_dx_mm,sigma_dy_mm,sigma_dz_mm,vx_m_s,vy_m_s,vz_m_s,sigma_vx_m_s,sigma_vy_m_s,sigma_vz_m_s,ax_m_s2,ay_m_s2,az_m_s2,sigma_ax_m_s2,sigma_ay_m_s2,sigma_az_m_s2";

/// Header of `displacements.csv`.
pub const DISPLACEMENTS_HEADER: &str = "epoch,marker,time_s,dx_mm,dy_mm,dz_mm,sigma_dx_mm,sigma_dy_mm,sigma_dz_mm,sigma_dmax_mm,vx_mm_s,vy_mm_s,vz_mm_s,sigma_vx_mm_s,sigma_vy_mm_s,sigma_vz_mm_s,reprojection_px,flags";

fn num(x: f64) -> String {
    format!("{x}")
}

fn opt3(v: Option<Vec3>) -> [String; 3] {
    match v {
        Some(v) => [num(v.x), num(v.y), num(v.z)],
        None => Default::default(),
    }
}

/// Quotes a text field when CSV needs it.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// `trajectories.csv`: [`TRAJECTORIES_HEADER`], then one line per row of `m` (position and σ
/// in mm, blank when the row has fewer than two views).
pub fn trajectories_csv(m: &Measurement) -> String {
    let mut s = format!("{TRAJECTORIES_HEADER}\n");
    for r in &m.rows {
        let [x, y, z] = opt3(r.position_mm);
        let [sx, sy, sz] = opt3(r.sigma_mm);
        let smax = r.sigma_max_mm().map(num).unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{x},{y},{z},{sx},{sy},{sz},{smax},{}",
            csv_field(&m.epochs[r.epoch].name),
            csv_field(&m.markers[r.marker]),
            r.n_views
        );
    }
    s
}

/// `trajectories.ply` (PLY 1.0, binary little-endian; docs/REFERENCE.md): one vertex per row of
/// `trajectories.csv`, in its order: `double x y z` (mm), `float sigma_x sigma_y sigma_z
/// sigma_max` (mm; NaN where the CSV cell is blank), `int epoch_index marker_index`; comment
/// lines `markers [...]` and `epochs [...]` name them in index order (JSON arrays).
pub fn trajectories_ply(m: &Measurement) -> Vec<u8> {
    use crashrig_plot::ply::{PlyType, PlyVertices};
    let (d, f, i) = (PlyType::Double, PlyType::Float, PlyType::Int);
    let mut ply = PlyVertices::new(&[
        ("x", d),
        ("y", d),
        ("z", d),
        ("sigma_x", f),
        ("sigma_y", f),
        ("sigma_z", f),
        ("sigma_max", f),
        ("epoch_index", i),
        ("marker_index", i),
    ]);
    ply.comment(
        "crashrig measured marker positions (mm) and their Monte Carlo sigma; NaN = not measured",
    );
    let names = |v: Vec<&str>| serde_json::to_string(&v).unwrap_or_default();
    ply.comment(&format!(
        "markers {}",
        names(m.markers.iter().map(String::as_str).collect())
    ));
    ply.comment(&format!(
        "epochs {}",
        names(m.epochs.iter().map(|e| e.name.as_str()).collect())
    ));
    let nan3 = |v: Option<Vec3>| v.map_or([f64::NAN; 3], |v| [v.x, v.y, v.z]);
    for r in &m.rows {
        let [x, y, z] = nan3(r.position_mm);
        let [sx, sy, sz] = nan3(r.sigma_mm);
        let smax = r.sigma_max_mm().unwrap_or(f64::NAN);
        ply.push(&[x, y, z, sx, sy, sz, smax, r.epoch as f64, r.marker as f64]);
    }
    ply.to_bytes()
}

/// `displacements.csv`: [`DISPLACEMENTS_HEADER`], then one line per row of `m` (time,
/// displacement from the reference epoch, velocity, their σ, the largest reprojection residual
/// and the flags joined by `;`).
pub fn displacements_csv(m: &Measurement) -> String {
    let mut s = format!("{DISPLACEMENTS_HEADER}\n");
    for r in &m.rows {
        let ep = &m.epochs[r.epoch];
        let t = ep.time_s.map(num).unwrap_or_default();
        let [dx, dy, dz] = opt3(r.displacement_mm);
        let [sdx, sdy, sdz] = opt3(r.displacement_sigma_mm);
        let sdmax = r
            .displacement_sigma_mm
            .map(|v| num(v.max()))
            .unwrap_or_default();
        let [vx, vy, vz] = opt3(r.velocity_mm_s);
        let [svx, svy, svz] = opt3(r.velocity_sigma_mm_s);
        let rep = r.reprojection_px.map(num).unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{t},{dx},{dy},{dz},{sdx},{sdy},{sdz},{sdmax},{vx},{vy},{vz},{svx},{svy},{svz},{rep},{}",
            csv_field(&ep.name),
            csv_field(&m.markers[r.marker]),
            r.flags.names().join(";")
        );
    }
    s
}

/// `kinematics.csv` of a measurement with kinematics ([`KINEMATICS_HEADER`], one line per row
/// of `m`, blank where the row is not in a filtered run); `None` without kinematics.
pub fn kinematics_csv(m: &Measurement) -> Option<String> {
    let k = m.kinematics.as_ref()?;
    let mut s = format!("{KINEMATICS_HEADER}\n");
    for (r, kr) in m.rows.iter().zip(&k.rows) {
        let ep = &m.epochs[r.epoch];
        let t = ep.time_s.map(num).unwrap_or_default();
        let cols = [
            kr.displacement_mm,
            kr.displacement_sigma_mm,
            kr.velocity_m_s,
            kr.velocity_sigma_m_s,
            kr.acceleration_m_s2,
            kr.acceleration_sigma_m_s2,
        ]
        .map(|v| opt3(v).join(","));
        let _ = writeln!(
            s,
            "{},{},{t},{}",
            csv_field(&ep.name),
            csv_field(&m.markers[r.marker]),
            cols.join(",")
        );
    }
    Some(s)
}

/// Header of `length_check.csv` (fixed by the contract).
pub const LENGTH_CHECK_HEADER: &str = "epoch,bar,length_mm,measured_mm,error_mm,sigma_mm,z";

/// The length check's table in the output directory.
pub const LENGTH_CHECK_CSV: &str = "length_check.csv";

/// `length_check.csv` of a measurement with scale bars ([`LENGTH_CHECK_HEADER`]): one line per
/// (epoch, bar) in which both markers of the bar have a position, epochs in sequence order,
/// bars in file order; `sigma_mm` (the replicates' σ of the distance combined with the
/// certificate's) and `z` are blank where the Monte Carlo gives none. `None` without scale
/// bars.
pub fn length_check_csv(m: &Measurement) -> Option<String> {
    let lc = m.length_check.as_ref()?;
    let mut lines: Vec<(usize, usize, String)> = Vec::new();
    for (b, bar) in lc.bars.iter().enumerate() {
        for (&e, k) in bar.epochs.iter().zip(&bar.stats.epochs) {
            let line = format!(
                "{},{},{},{},{},{},{}",
                csv_field(&m.epochs[e].name),
                csv_field(&bar.bar.name),
                num(bar.bar.length_mm),
                num(k.measured_mm),
                num(k.error_mm),
                k.sigma_mm.map(num).unwrap_or_default(),
                k.z.map(num).unwrap_or_default()
            );
            lines.push((e, b, line));
        }
    }
    lines.sort_by_key(|(e, b, _)| (*e, *b));
    let mut s = format!("{LENGTH_CHECK_HEADER}\n");
    for (_, _, line) in lines {
        s.push_str(&line);
        s.push('\n');
    }
    Some(s)
}

/// The length check's plot (`length_check.png|svg`): one panel per scale bar measured in at
/// least one epoch, its error (measured − certificate length, mm) against time in ms (or the
/// sequence index) with the ±2σ band and a line at zero. `None` without scale bars or without
/// a measured bar.
///
/// # Errors
/// [`Error::Plot`] (`marker` names the length check).
pub fn length_check_plot(m: &Measurement) -> Result<Option<MarkerPlot>, Error> {
    let Some(lc) = m.length_check.as_ref() else {
        return Ok(None);
    };
    let xs: Vec<f64> = m
        .epochs
        .iter()
        .enumerate()
        .map(|(i, e)| e.time_s.map_or(i as f64, |t| t * 1000.0))
        .collect();
    let x_label = if m.epochs.iter().all(|e| e.time_s.is_some()) {
        "t [ms]"
    } else {
        "epoch (sequence index)"
    };
    let measured: Vec<_> = lc.bars.iter().filter(|b| !b.epochs.is_empty()).collect();
    if measured.is_empty() {
        return Ok(None);
    }
    let mut series = Vec::with_capacity(measured.len());
    for bar in &measured {
        let mut ys = vec![f64::NAN; xs.len()];
        let mut hw = vec![f64::NAN; xs.len()];
        for (&e, k) in bar.epochs.iter().zip(&bar.stats.epochs) {
            ys[e] = k.error_mm;
            hw[e] = k.sigma_mm.map_or(f64::NAN, |s| 2.0 * s);
        }
        let label = format!("{} error [mm]", bar.bar.name);
        series.push((label, ys, hw));
    }
    let panels: Vec<BandPanel<'_>> = series
        .iter()
        .map(|(label, ys, hw)| BandPanel {
            y_label: label,
            ys,
            half_widths: hw,
        })
        .collect();
    let options = crashrig_plot::BandOptions {
        marked: &[],
        reference_y: Some(0.0),
    };
    let title = "length check: measured − certificate length per epoch, ±2σ";
    let draw = |f| {
        crashrig_plot::banded_panels_with(&xs, &panels, &options, title, x_label, f).map_err(
            |source| Error::Plot {
                marker: "length check".into(),
                source,
            },
        )
    };
    Ok(Some(MarkerPlot {
        marker: "length check".into(),
        stem: "length_check".into(),
        png: draw(Format::Png)?,
        svg: draw(Format::Svg)?,
    }))
}

/// File stems of the markers: characters other than ASCII letters, digits, `-` and `_` become
/// `_`; a stem already taken gets `_<marker index>` appended.
fn marker_stems(markers: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(markers.len());
    for (i, name) in markers.iter().enumerate() {
        let mut stem: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if out.contains(&stem) {
            stem = format!("{stem}_{i}");
        }
        out.push(stem);
    }
    out
}

/// One marker's trajectory plot: x, y, z against time (or sequence index) with ±3σ bands.
#[derive(Debug, Clone)]
pub struct MarkerPlot {
    /// Marker name.
    pub marker: String,
    /// File stem (`plots/<stem>.png`, `plots/<stem>.svg`).
    pub stem: String,
    /// PNG bytes.
    pub png: Vec<u8>,
    /// SVG bytes.
    pub svg: Vec<u8>,
}

/// The trajectory plot of every marker with at least one measured position, in marker order
/// (drawn in parallel; the bytes do not depend on the thread count). The x axis is the time in
/// ms when every epoch has one, else the sequence index.
///
/// # Errors
/// [`Error::Plot`] naming the marker.
pub fn marker_plots(m: &Measurement) -> Result<Vec<MarkerPlot>, Error> {
    let xs: Vec<f64> = m
        .epochs
        .iter()
        .enumerate()
        .map(|(i, e)| e.time_s.map_or(i as f64, |t| t * 1000.0))
        .collect();
    let x_label = if m.epochs.iter().all(|e| e.time_s.is_some()) {
        "t [ms]"
    } else {
        "epoch (sequence index)"
    };
    let stems = marker_stems(&m.markers);
    let per_marker: Vec<Result<Option<MarkerPlot>, Error>> = (0..m.markers.len())
        .into_par_iter()
        .map(|k| {
            let mut ys = vec![vec![f64::NAN; xs.len()]; 3];
            let mut hw = vec![vec![f64::NAN; xs.len()]; 3];
            let mut any = false;
            for r in m.rows.iter().filter(|r| r.marker == k) {
                if let Some(p) = r.position_mm {
                    any = true;
                    for c in 0..3 {
                        ys[c][r.epoch] = p[c];
                        hw[c][r.epoch] = r.sigma_mm.map_or(f64::NAN, |s| 3.0 * s[c]);
                    }
                }
            }
            if !any {
                return Ok(None);
            }
            let labels = ["x [mm] (±3σ)", "y [mm] (±3σ)", "z [mm] (±3σ)"];
            let panels: Vec<BandPanel<'_>> = (0..3)
                .map(|c| BandPanel {
                    y_label: labels[c],
                    ys: &ys[c],
                    half_widths: &hw[c],
                })
                .collect();
            let name = &m.markers[k];
            let title = format!("marker {name} (world frame)");
            let draw = |f| {
                crashrig_plot::banded_panels(&xs, &panels, &title, x_label, f).map_err(|source| {
                    Error::Plot {
                        marker: name.clone(),
                        source,
                    }
                })
            };
            Ok(Some(MarkerPlot {
                marker: name.clone(),
                stem: stems[k].clone(),
                png: draw(Format::Png)?,
                svg: draw(Format::Svg)?,
            }))
        })
        .collect();
    let mut out = Vec::new();
    for p in per_marker {
        out.extend(p?);
    }
    Ok(out)
}

/// One kinematics plot per marker with kinematics (`plots/<stem>_kinematics.png|svg`): filtered
/// displacement (mm), velocity (m/s) and acceleration (m/s²) per axis against time, ±2σ bands;
/// in marker order, drawn in parallel.
///
/// # Errors
/// [`Error::Plot`] naming the marker.
pub fn kinematics_plots(m: &Measurement) -> Result<Vec<MarkerPlot>, Error> {
    let Some(k) = m.kinematics.as_ref() else {
        return Ok(Vec::new());
    };
    let xs: Vec<f64> = m
        .epochs
        .iter()
        .enumerate()
        .map(|(i, e)| e.time_s.map_or(i as f64, |t| t * 1000.0))
        .collect();
    let stems = marker_stems(&m.markers);
    let title_filter = format!("CFC {} ({})", k.filter.class(), k.filter.standard().name());
    let per_marker: Vec<Result<Option<MarkerPlot>, Error>> = (0..m.markers.len())
        .into_par_iter()
        .map(|mk| {
            let mut ys = vec![vec![f64::NAN; xs.len()]; 9];
            let mut hw = vec![vec![f64::NAN; xs.len()]; 9];
            let mut any = false;
            for (r, kr) in m.rows.iter().zip(&k.rows).filter(|(r, _)| r.marker == mk) {
                let q = [
                    (kr.displacement_mm, kr.displacement_sigma_mm),
                    (kr.velocity_m_s, kr.velocity_sigma_m_s),
                    (kr.acceleration_m_s2, kr.acceleration_sigma_m_s2),
                ];
                for (j, (v, sd)) in q.iter().enumerate() {
                    if let Some(v) = v {
                        any = true;
                        for c in 0..3 {
                            ys[3 * j + c][r.epoch] = v[c];
                            hw[3 * j + c][r.epoch] = sd.map_or(f64::NAN, |s| 2.0 * s[c]);
                        }
                    }
                }
            }
            if !any {
                return Ok(None);
            }
            let labels = [
                "dx [mm]",
                "dy [mm]",
                "dz [mm]",
                "vx [m/s]",
                "vy [m/s]",
                "vz [m/s]",
                "ax [m/s²]",
                "ay [m/s²]",
                "az [m/s²]",
            ];
            let panels: Vec<BandPanel<'_>> = (0..9)
                .map(|c| BandPanel {
                    y_label: labels[c],
                    ys: &ys[c],
                    half_widths: &hw[c],
                })
                .collect();
            let name = &m.markers[mk];
            let title = format!("marker {name}: {title_filter}, ±2σ (world axes)");
            let draw = |f| {
                crashrig_plot::banded_panels(&xs, &panels, &title, "t [ms]", f).map_err(|source| {
                    Error::Plot {
                        marker: name.clone(),
                        source,
                    }
                })
            };
            Ok(Some(MarkerPlot {
                marker: name.clone(),
                stem: format!("{}_kinematics", stems[mk]),
                png: draw(Format::Png)?,
                svg: draw(Format::Svg)?,
            }))
        })
        .collect();
    let mut out = Vec::new();
    for p in per_marker {
        out.extend(p?);
    }
    Ok(out)
}

/// The kinematics part of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KinematicsSummary {
    /// Channel frequency class.
    pub cfc: u32,
    /// `j211` or `iso6487`.
    pub standard: &'static str,
    /// The variant in words (constant and end handling).
    pub filter: String,
    /// Unbroken runs filtered.
    pub runs: usize,
    /// Rows with kinematics.
    pub rows_with_kinematics: usize,
    /// Largest filtered-displacement σ (mm, any axis).
    pub max_displacement_sigma_mm: Option<f64>,
    /// Largest velocity σ (m/s).
    pub max_velocity_sigma_m_s: Option<f64>,
    /// Largest acceleration σ (m/s²).
    pub max_acceleration_sigma_m_s2: Option<f64>,
}

/// One quantity's share of variance from the trigger offset (fractions).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShareSummary {
    /// Median over the rows.
    pub median: f64,
    /// Largest.
    pub max: f64,
}

/// The trigger-offset part of `summary.json`: per quantity, the share of the variance that the
/// offset contributes ([`crate::engine::SyncShare`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SyncSummary {
    /// σ of the offset (ms).
    pub sigma_ms: f64,
    /// Per quantity (`position`, `displacement`, `velocity`, `filtered_displacement`,
    /// `filtered_velocity`, `acceleration`): median and largest share over the rows.
    pub variance_share: std::collections::BTreeMap<&'static str, ShareSummary>,
}

impl SyncSummary {
    fn new(s: &crate::engine::SyncShare) -> SyncSummary {
        let mut variance_share = std::collections::BTreeMap::new();
        for (name, q) in [
            ("position", s.position),
            ("displacement", s.displacement),
            ("velocity", s.velocity),
            ("filtered_displacement", s.filtered_displacement),
            ("filtered_velocity", s.filtered_velocity),
            ("acceleration", s.acceleration),
        ] {
            if let Some(q) = q {
                variance_share.insert(
                    name,
                    ShareSummary {
                        median: q.median,
                        max: q.max,
                    },
                );
            }
        }
        SyncSummary {
            sigma_ms: s.sigma_ms,
            variance_share,
        }
    }

    /// The report line: how much of each σ's variance the offset contributes.
    pub fn line(&self) -> String {
        let parts: Vec<String> = self
            .variance_share
            .iter()
            .map(|(k, v)| format!("{k} {:.0} % (max {:.0} %)", 100.0 * v.median, 100.0 * v.max))
            .collect();
        format!(
            "trigger offset σ {} ms: share of the variance (median over rows) — {}",
            self.sigma_ms,
            parts.join(", ")
        )
    }
}

fn kinematics_summary(m: &Measurement) -> Option<KinematicsSummary> {
    let k = m.kinematics.as_ref()?;
    let max = |f: fn(&crate::kinematics::KinRow) -> Option<Vec3>| {
        k.rows
            .iter()
            .filter_map(|r| f(r).map(|v| v.max()))
            .reduce(f64::max)
    };
    let std = k.filter.standard();
    Some(KinematicsSummary {
        cfc: k.filter.class(),
        standard: std.name(),
        filter: match std {
            crate::filter::Standard::J211 => "SAE J211-1 Appendix C: 4-pole phaseless Butterworth (2-pole forward and backward), corner 2.0775·CFC, each pass started at rest on its first value".into(),
            crate::filter::Standard::Iso6487 => "ISO 6487 Annex A: 4-pole phaseless Butterworth (2-pole forward and backward), corner 1.25·5/3·CFC, ends extended by point reflection over max(10 ms, 100 samples), ten-value start means".into(),
        },
        runs: k.runs,
        rows_with_kinematics: k.rows_with_kinematics,
        max_displacement_sigma_mm: max(|r| r.displacement_sigma_mm),
        max_velocity_sigma_m_s: max(|r| r.velocity_sigma_m_s),
        max_acceleration_sigma_m_s2: max(|r| r.acceleration_sigma_m_s2),
    })
}

/// One scale bar of `summary.json`'s `length_check` ([`crate::length`]; the contract's fields
/// and, beyond them, the bar's markers and certificate σ, the σ of the mean error, the scatter
/// band and its degrees of freedom).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BarSummary {
    /// The bar's name.
    pub name: String,
    /// Its first marker.
    pub marker_1: String,
    /// Its second marker.
    pub marker_2: String,
    /// The certificate's length (mm).
    pub length_mm: f64,
    /// The certificate's σ (mm).
    pub sigma_mm: f64,
    /// Epochs in which both markers have a position.
    pub epochs: usize,
    /// Mean error over those epochs (mm).
    pub mean_error_mm: Option<f64>,
    /// RMS error (mm).
    pub rms_error_mm: Option<f64>,
    /// The length measurement error E: the largest |error| (mm).
    pub max_abs_error_mm: Option<f64>,
    /// Share of the epochs with |z| ≤ 2.
    pub coverage_2sigma: Option<f64>,
    /// σ of the mean error (replicates and certificate; mm).
    pub mean_error_sigma_mm: Option<f64>,
    /// Mean error over its σ: the part of the error every epoch shares.
    pub bias_z: Option<f64>,
    /// Spread of the measured distance over the epochs over the RMS of its predicted
    /// epoch-to-epoch σ.
    pub scatter_ratio: Option<f64>,
    /// The two-sided 99 % band of `scatter_ratio` under honest σ.
    pub scatter_band_99: Option<[f64; 2]>,
    /// Its effective degrees of freedom.
    pub scatter_dof: Option<f64>,
    /// `consistent`, `sigma_too_small` or `bias` (`null` without epochs).
    pub verdict: Option<&'static str>,
    /// `max_abs_error_mm ≤ --mpe-mm` (only with `--mpe-mm`; `null` without epochs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub within_mpe: Option<Option<bool>>,
}

impl BarSummary {
    /// The bar in one line (what `crashrig measure` prints): its error, bias and scatter with
    /// their limits, the maximum permissible error and the verdict.
    pub fn line(&self) -> String {
        let f = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
        let band = self
            .scatter_band_99
            .map_or("—".to_string(), |[lo, hi]| format!("{lo:.2} … {hi:.2}"));
        let mpe = match self.within_mpe {
            Some(Some(true)) => ", within the MPE",
            Some(Some(false)) => ", ABOVE the MPE",
            _ => "",
        };
        format!(
            "length check {} ({} mm, {} epochs): E = {} mm, mean error {} mm, bias_z {} (|z| ≤ 3), scatter ratio {} (99 % band {band}){mpe}: {}",
            self.name,
            self.length_mm,
            self.epochs,
            f(self.max_abs_error_mm, 3),
            f(self.mean_error_mm, 3),
            f(self.bias_z, 2),
            f(self.scatter_ratio, 2),
            self.verdict.unwrap_or("no verdict")
        )
    }

    fn new(b: &crate::length::BarCheck, mpe_given: bool) -> BarSummary {
        let s = &b.stats;
        BarSummary {
            name: b.bar.name.clone(),
            marker_1: b.bar.marker_1.clone(),
            marker_2: b.bar.marker_2.clone(),
            length_mm: b.bar.length_mm,
            sigma_mm: b.bar.sigma_mm,
            epochs: b.epochs.len(),
            mean_error_mm: s.mean_error_mm,
            rms_error_mm: s.rms_error_mm,
            max_abs_error_mm: s.max_abs_error_mm,
            coverage_2sigma: s.coverage_2sigma,
            mean_error_sigma_mm: s.mean_error_sigma_mm,
            bias_z: s.bias_z,
            scatter_ratio: s.scatter_ratio,
            scatter_band_99: s.scatter_band.map(|(lo, hi)| [lo, hi]),
            scatter_dof: s.scatter_dof,
            verdict: s.verdict.map(crate::length::Verdict::name),
            within_mpe: mpe_given.then_some(b.within_mpe),
        }
    }
}

/// The numbers of `summary.json` that depend only on the measurement and its settings (no
/// timing, no file names): `crashrig measure` adds those, the study writes these alone.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Measured epochs.
    pub epochs: usize,
    /// Markers.
    pub markers: usize,
    /// Rows (epoch × marker observed).
    pub rows: usize,
    /// Monte Carlo replicates per row.
    pub samples_per_point: usize,
    /// Threshold on σ_max (mm).
    pub threshold_mm: f64,
    /// Fraction of rows with σ_max below the threshold (rows without σ count as not below).
    pub fraction_below_threshold: f64,
    /// Seed.
    pub seed: u64,
    /// Reference epoch of the displacements.
    pub reference_epoch: String,
    /// Frame rate (Hz), if given (with frame times: the rate of their mean interval).
    pub frame_rate_hz: Option<f64>,
    /// The frame times' time axis (with `--frame-times`; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_times: Option<FrameTimesSummary>,
    /// σ of each pixel coordinate (px).
    pub pixel_sigma_px: f64,
    /// Reprojection limit used for the outlier flag (px).
    pub max_reprojection_px: Option<f64>,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// Inward cameras used (`B`, and `C` with a tie).
    pub cameras: Vec<&'static str>,
    /// Rows with a position and σ.
    pub rows_measured: usize,
    /// Rows seen by fewer than two cameras.
    pub rows_fewer_than_two_views: usize,
    /// Rows with σ_max above the threshold.
    pub rows_above_threshold: usize,
    /// Rows whose reprojection residual is an outlier.
    pub rows_reprojection_outlier: usize,
    /// Rows with any flag.
    pub rows_flagged: usize,
    /// Largest position σ_max (mm).
    pub max_sigma_mm: Option<f64>,
    /// Median position σ_max (mm).
    pub median_sigma_max_mm: Option<f64>,
    /// Largest displacement σ_max (mm), reference epoch excluded.
    pub max_displacement_sigma_mm: Option<f64>,
    /// Median displacement σ_max (mm), reference epoch excluded.
    pub median_displacement_sigma_max_mm: Option<f64>,
    /// The filter and the kinematics' σ (with `--cfc`; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kinematics: Option<KinematicsSummary>,
    /// The trigger offset's share of the variance (with `--sync-sigma-ms`; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sync_offset: Option<SyncSummary>,
    /// The length check, one entry per scale bar (with `--scale-bars`; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_check: Option<Vec<BarSummary>>,
    /// The pixel σ checked on the sequence's own residuals ([`crate::pixel_check`]; with B
    /// and C; absent otherwise). Set by [`crate::run`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_sigma_check: Option<PixelCheckSummary>,
    /// The pixel σ the Monte Carlo used instead of the stated one (with `--pixel-sigma-px
    /// estimate`; absent otherwise). Set by [`crate::run`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_sigma_estimate: Option<EstimateSummary>,
}

/// `summary.json` → `pixel_sigma_estimate` / its `B` and `C`: one camera's estimate as used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateCameraSummary {
    /// The factor the camera's stated σ (each observation's own, else `pixel_sigma_px`) was
    /// multiplied by: its `sigma_ratio`.
    pub scale: f64,
    /// The estimated pixel σ (px).
    pub estimate_px: f64,
    /// Its 95 % interval (px), `[low, high]`.
    pub estimate_95_px: [f64; 2],
    /// The redundancy behind it.
    pub redundancy: f64,
}

/// `summary.json` → `pixel_sigma_estimate` ([`crate::pixel_check::PixelSigmaFrom::Estimate`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateSummary {
    /// `true`: each camera its own estimate (`pixel_sigma_check.per_camera`); `false`: the
    /// common one for both.
    pub per_camera: bool,
    /// Camera B.
    #[serde(rename = "B")]
    pub b: EstimateCameraSummary,
    /// Camera C.
    #[serde(rename = "C")]
    pub c: EstimateCameraSummary,
}

impl EstimateSummary {
    /// The summary of `u`.
    pub fn new(u: &crate::pixel_check::EstimateUsed) -> EstimateSummary {
        let cam = |i: usize| EstimateCameraSummary {
            scale: u.scale[i],
            estimate_px: u.estimate_px[i],
            estimate_95_px: [u.estimate_95_px[i].0, u.estimate_95_px[i].1],
            redundancy: u.redundancy[i],
        };
        EstimateSummary {
            per_camera: u.per_camera,
            b: cam(0),
            c: cam(1),
        }
    }
}

/// `summary.json` → `frame_times`: the time axis of `--frame-times`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameTimesSummary {
    /// The file.
    pub file: String,
    /// Frames in the file.
    pub frames: usize,
    /// The first frame's time (s).
    pub first_time_s: f64,
    /// The mean interval (s): `frame_rate_hz` is its inverse.
    pub mean_interval_s: f64,
    /// The largest deviation of an interval from the mean, relative to it.
    pub max_interval_deviation: f64,
}

impl FrameTimesSummary {
    fn new(f: &crate::input::FrameTimes) -> FrameTimesSummary {
        FrameTimesSummary {
            file: f.path.display().to_string(),
            frames: f.frames.len(),
            first_time_s: f.frames[0].1,
            mean_interval_s: f.mean_interval_s().unwrap_or(f64::NAN),
            max_interval_deviation: f.largest_deviation().map_or(0.0, |d| d.0),
        }
    }
}

/// `summary.json` → `pixel_sigma_check` (or one camera's part of it under `per_camera`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SigmaRatioSummary {
    /// Degrees of freedom: `N − r` (common; an integer), or the effective ν per camera.
    pub redundancy: f64,
    /// The residuals' size against the stated σ's prediction (1 on honest σ).
    pub sigma_ratio: f64,
    /// Its two-sided 99 % band for this redundancy, `[low, high]`.
    pub sigma_ratio_band_99: [f64; 2],
    /// The true pixel σ (px): `sigma_ratio` × the stated σ.
    pub estimate_px: f64,
    /// Its 95 % interval (px), `[low, high]`.
    pub estimate_95_px: [f64; 2],
    /// The stated σ the ratio refers to (px; the RMS of per-observation σ).
    pub stated_px: f64,
    /// `consistent`, `sigma_too_small` or `sigma_too_large`.
    pub verdict: &'static str,
}

impl SigmaRatioSummary {
    fn new(r: &crate::pixel_check::SigmaRatio) -> SigmaRatioSummary {
        SigmaRatioSummary {
            redundancy: r.redundancy,
            sigma_ratio: r.sigma_ratio,
            sigma_ratio_band_99: [r.sigma_ratio_band_99.0, r.sigma_ratio_band_99.1],
            estimate_px: r.estimate_px,
            estimate_95_px: [r.estimate_95_px.0, r.estimate_95_px.1],
            stated_px: r.stated_px,
            verdict: r.verdict.name(),
        }
    }
}

/// B's and C's own checks (`per_camera`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PerCameraSummary {
    /// Camera B.
    #[serde(rename = "B")]
    pub b: SigmaRatioSummary,
    /// Camera C.
    #[serde(rename = "C")]
    pub c: SigmaRatioSummary,
}

/// `summary.json` → `pixel_sigma_check` ([`crate::pixel_check`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PixelCheckSummary {
    /// The common check over both cameras.
    #[serde(flatten)]
    pub common: SigmaRatioSummary,
    /// Marker-epochs seen by B and C.
    pub marker_epochs: usize,
    /// Directions of the tie's effect projected out.
    pub tie_directions: usize,
    /// Where the stated σ came from: `pixel_sigma_px`, `observations` (every observation its
    /// own), `observations_and_pixel_sigma_px` (some).
    pub stated_from: &'static str,
    /// Per camera, where the geometry separates them; `null` otherwise.
    pub per_camera: Option<PerCameraSummary>,
    /// Why `per_camera` is `null`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_camera_note: Option<String>,
}

impl PixelCheckSummary {
    /// The summary of `c`; `stated_from` as [`PixelCheckSummary::stated_from`].
    pub fn new(
        c: &crate::pixel_check::PixelSigmaCheck,
        stated_from: &'static str,
    ) -> PixelCheckSummary {
        PixelCheckSummary {
            common: SigmaRatioSummary::new(&c.common),
            marker_epochs: c.marker_epochs,
            tie_directions: c.tie_directions,
            stated_from,
            per_camera: c.per_camera.as_ref().map(|[b, cc]| PerCameraSummary {
                b: SigmaRatioSummary::new(b),
                c: SigmaRatioSummary::new(cc),
            }),
            per_camera_note: c.per_camera_note.clone(),
        }
    }
}

impl Summary {
    /// The summary of `m`, measured with `settings` (threshold, seed, frame rate, pixel σ) on a
    /// model in units of `mm_per_unit` mm, with a tied-in camera C when `has_c`.
    pub fn new(m: &Measurement, settings: &Settings, mm_per_unit: f64, has_c: bool) -> Summary {
        let smax: Vec<f64> = m.rows.iter().filter_map(Row::sigma_max_mm).collect();
        let dmax: Vec<f64> = m
            .rows
            .iter()
            .filter(|r| r.epoch != m.reference_epoch)
            .filter_map(|r| r.displacement_sigma_mm.map(|v| v.max()))
            .collect();
        let count = |f: &dyn Fn(&Row) -> bool| m.rows.iter().filter(|r| f(r)).count();
        Summary {
            epochs: m.epochs.len(),
            markers: m.markers.len(),
            rows: m.rows.len(),
            samples_per_point: m.samples,
            threshold_mm: settings.threshold_mm,
            fraction_below_threshold: m.fraction_below(settings.threshold_mm),
            seed: settings.seed,
            reference_epoch: m.epochs[m.reference_epoch].name.clone(),
            frame_rate_hz: settings.frame_rate_hz,
            frame_times: settings.frame_times.as_ref().map(FrameTimesSummary::new),
            pixel_sigma_px: settings.pixel_sigma_px,
            max_reprojection_px: m.reprojection_limit_px,
            mm_per_unit,
            cameras: if has_c { vec!["B", "C"] } else { vec!["B"] },
            rows_measured: smax.len(),
            rows_fewer_than_two_views: count(&|r| r.flags.fewer_than_two_views),
            rows_above_threshold: count(&|r| r.flags.sigma_above_threshold),
            rows_reprojection_outlier: count(&|r| r.flags.reprojection_outlier),
            rows_flagged: count(&|r| r.flags.any()),
            max_sigma_mm: smax.iter().copied().reduce(f64::max),
            median_sigma_max_mm: median(&smax),
            max_displacement_sigma_mm: dmax.iter().copied().reduce(f64::max),
            median_displacement_sigma_max_mm: median(&dmax),
            kinematics: kinematics_summary(m),
            sync_offset: m.sync_share.as_ref().map(SyncSummary::new),
            length_check: m.length_check.as_ref().map(|lc| {
                lc.bars
                    .iter()
                    .map(|b| BarSummary::new(b, lc.mpe_mm.is_some()))
                    .collect()
            }),
            pixel_sigma_check: None,
            pixel_sigma_estimate: None,
        }
    }
}

/// An epoch of the observations without a pose of camera A (skipped).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// The epoch as the observations name it.
    pub epoch: String,
    /// Its observations.
    pub observations: usize,
}

/// `summary.json` of `crashrig measure` (and its `--json` output): the measurement's numbers
/// ([`Summary`]), then the skipped epochs, names, files and timing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SummaryDocument {
    /// The numbers (flattened into the document).
    #[serde(flatten)]
    pub numbers: Summary,
    /// Epochs of the observations without a pose of camera A.
    pub skipped_epochs: Vec<Skipped>,
    /// Measured epochs in sequence order.
    pub epoch_names: Vec<String>,
    /// Markers in order.
    pub marker_names: Vec<String>,
    /// The run's warnings (skipped epochs, scale bars that are not `consistent`), without the
    /// `warning: ` prefix; absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Files written, relative to the output directory (empty when nothing was written).
    pub files: Vec<String>,
    /// Wall-clock time of the run (s).
    pub elapsed_s: f64,
}

/// Pretty JSON with a final newline (the form of every JSON file `crashrig` writes).
pub(crate) fn json_pretty(v: &impl Serialize) -> Result<Vec<u8>, Error> {
    let mut json = serde_json::to_vec_pretty(v)
        .map_err(|e| Error::Input(format!("serializing summary.json: {e}")))?;
    json.push(b'\n');
    Ok(json)
}

/// A directory `measure` may replace: absent, empty, or a previous `measure` output (it holds
/// `trajectories.csv` and `summary.json`). Anything else is refused before any work is done.
pub(crate) fn check_out_dir(dir: &Path) -> Result<(), Error> {
    let bad = |problem: String| Error::OutDir {
        path: dir.to_path_buf(),
        problem,
    };
    if !dir.exists() {
        return Ok(());
    }
    if !dir.is_dir() {
        return Err(bad("exists and is not a directory".into()));
    }
    let mut entries = std::fs::read_dir(dir).map_err(|e| bad(format!("cannot list: {e}")))?;
    if entries.next().is_none() {
        return Ok(());
    }
    let previous_shard =
        dir.join(SHARD_MOMENTS).is_file() && dir.join(crashrig_outdir::shard::MANIFEST).is_file();
    let previous = dir.join("trajectories.csv").is_file() && dir.join("summary.json").is_file();
    if !(previous || previous_shard) {
        return Err(bad(
            "exists and is not empty and not a previous `measure` output; choose another --out"
                .into(),
        ));
    }
    Ok(())
}

/// The options file of a `measure --shard` directory (`crate::shard::OPTIONS`).
pub(crate) const SHARD_OPTIONS: &str = "measure_shard.json";
/// The moments file of a `measure --shard` directory (`crate::shard::MOMENTS`).
pub(crate) const SHARD_MOMENTS: &str = "moments.csv";

/// Top-level entries of an existing output directory that `measure` writes (directories end
/// with `/`).
fn replaceable(name: &str) -> bool {
    matches!(
        name,
        "trajectories.csv"
            | "trajectories.ply"
            | "displacements.csv"
            | "kinematics.csv"
            | LENGTH_CHECK_CSV
            | "length_check.png"
            | "length_check.svg"
            | "summary.json"
            | "plots/"
            | crashrig_outdir::shard::MANIFEST
            | SHARD_OPTIONS
            | SHARD_MOMENTS
    )
}

/// Writes `files` (paths relative to `dir`) as one unit through `crashrig-outdir`: into a
/// staging directory beside `dir`, swapped in whole (a previous output is replaced, never
/// mixed; SIGINT/SIGTERM remove the staging directory). This is the only function that writes
/// the output directory.
pub(crate) fn write_dir(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<(), Error> {
    check_out_dir(dir)?;
    let mut staged = crashrig_outdir::Staged::new(dir, replaceable)?;
    for (name, bytes) in files {
        staged.write(name, bytes)?;
    }
    staged.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_replace_unsafe_characters_and_stay_unique() {
        let markers = ["a b", "a_b", "knee/L", "x-1"].map(String::from);
        assert_eq!(marker_stems(&markers), ["a_b", "a_b_1", "knee_L", "x-1"]);
    }

    #[test]
    fn csv_fields_are_quoted_only_when_needed() {
        assert_eq!(csv_field("head"), "head");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
