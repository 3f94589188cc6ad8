//! The output files of a measurement, in the formats of `crashrig measure` (docs/MEASURE.md):
//! `trajectories.csv` (the contract's fixed header), `displacements.csv`, one trajectory plot
//! per marker (`plots/<marker>.png|svg`) and the numbers of `summary.json`.
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
//!         obs.push(Observation { epoch: e.name.clone(), camera, marker: "head".into(), pixel: Vector2::new(u, 500.0), line });
//!     }
//! }
//! let settings = Settings {
//!     samples: 50,
//!     seed: 1,
//!     pixel_sigma_px: 0.0,
//!     reference_epoch: None,
//!     frame_rate_hz: None,
//!     threshold_mm: 5.0,
//!     max_reprojection_px: None,
//! };
//! let m = measure(&epochs, &rig, &obs, &settings)?;
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
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// Header of `trajectories.csv` (fixed by the contract).
pub const TRAJECTORIES_HEADER: &str =
    "epoch,marker,x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,n_views";

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

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
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
    /// Frame rate (Hz), if given.
    pub frame_rate_hz: Option<f64>,
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
            median_sigma_max_mm: median(smax),
            max_displacement_sigma_mm: dmax.iter().copied().reduce(f64::max),
            median_displacement_sigma_max_mm: median(dmax),
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
    if !(dir.join("trajectories.csv").is_file() && dir.join("summary.json").is_file()) {
        return Err(bad(
            "exists and is not empty and not a previous `measure` output; choose another --out"
                .into(),
        ));
    }
    Ok(())
}

/// Top-level entries of an existing output directory that `measure` writes (directories end
/// with `/`).
fn replaceable(name: &str) -> bool {
    matches!(
        name,
        "trajectories.csv" | "displacements.csv" | "summary.json" | "plots/"
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

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(Vec::new()), None);
    }
}
