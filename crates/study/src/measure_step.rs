//! The study's `[measure]` step: a crash-test sequence measured with the study's own calibrated
//! link (and tie), through the measurement library ([`crashrig_measure::measure`]).
//!
//! The link `A_from_B` is the calibration step's typed [`UncertainPose`] (mean link with its
//! SEM covariance) and the tie `B_from_C` the bootstrap's (with the replicates' covariance):
//! exactly what `crashrig measure --link calibrate.json --tie bootstrap.json` reads from those
//! commands' JSON, without the text round trip. The files below `DIR/measure/` have the
//! command's formats (`trajectories.csv` with the contract header, `displacements.csv`,
//! `plots/<marker>.png|svg`, `summary.json`).

use crate::Error;
use crate::study_file::{MeasureANoise, MeasureSection, Study};
use crashrig_colmap::CameraSelector;
use crashrig_geometry::{UncertainPose, Vec3};
use crashrig_measure::engine::{Epoch, Measurement, Rig, Row, Settings};
use crashrig_measure::input::{self, CameraNames};
use crashrig_measure::sequence;
use serde::Serialize;
use std::fmt::Write as _;

/// The measured sequence of a study.
#[derive(Debug, Clone)]
pub struct MeasureResult {
    /// The rows, epochs and markers (typed).
    pub measurement: Measurement,
    /// Summary (`DIR/measure/summary.json`, `results.json` → `"measure"`).
    pub summary: MeasureSummary,
    /// Epochs of the observations without a pose of camera A (skipped; one warning each).
    pub warnings: Vec<String>,
}

/// The summary of the study's measured sequence: the fields of `crashrig measure`'s
/// `summary.json` that do not depend on timing or file names.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeasureSummary {
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

impl MeasureSummary {
    fn new(m: &Measurement, s: &MeasureSection, seed: u64, has_c: bool) -> MeasureSummary {
        let smax: Vec<f64> = m.rows.iter().filter_map(Row::sigma_max_mm).collect();
        let dmax: Vec<f64> = m
            .rows
            .iter()
            .filter(|r| r.epoch != m.reference_epoch)
            .filter_map(|r| r.displacement_sigma_mm.map(|v| v.max()))
            .collect();
        let count = |f: &dyn Fn(&Row) -> bool| m.rows.iter().filter(|r| f(r)).count();
        MeasureSummary {
            epochs: m.epochs.len(),
            markers: m.markers.len(),
            rows: m.rows.len(),
            samples_per_point: m.samples,
            threshold_mm: s.threshold_mm,
            fraction_below_threshold: m.fraction_below(s.threshold_mm),
            seed,
            reference_epoch: m.epochs[m.reference_epoch].name.clone(),
            frame_rate_hz: s.frame_rate_hz,
            pixel_sigma_px: s.pixel_sigma_px,
            max_reprojection_px: m.reprojection_limit_px,
            mm_per_unit: s.mm_per_unit,
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

/// Measures the study's sequence with the calibrated link `a_from_b` and the tie `b_from_c`
/// (required when the section names `camera_c`), `samples` replicates per row and `seed`.
///
/// # Errors
/// [`Error::Step`] naming the study file and `[measure]` with the measurement library's
/// message (which names the data file).
pub fn run_measure(
    study: &Study,
    s: &MeasureSection,
    a_from_b: UncertainPose,
    b_from_c: Option<UncertainPose>,
    samples: usize,
    seed: u64,
) -> Result<MeasureResult, Error> {
    let step = |e: &dyn std::fmt::Display| study.step_error("measure", 0, e.to_string());
    let model = crashrig_colmap::Reconstruction::read(&s.model).map_err(|e| step(&e))?;
    let seq = sequence::a_sequence(&model, &CameraSelector::parse(&s.camera_a), s.mm_per_unit)
        .map_err(|e| step(&e))?;
    let (b_id, camera_b) =
        sequence::inward_camera(&model, &CameraSelector::parse(&s.camera_b), 'B')
            .map_err(|e| step(&e))?;
    let c = match (&s.camera_c, b_from_c) {
        (Some(sel), Some(tie)) => {
            let (id, cam) = sequence::inward_camera(&model, &CameraSelector::parse(sel), 'C')
                .map_err(|e| step(&e))?;
            Some((id, tie, cam))
        }
        (Some(_), None) => return Err(step(&"camera_c needs a [tie] section (the link B_from_C)")),
        (None, _) => None,
    };
    let names = CameraNames {
        b_id: Some(b_id),
        c_id: c.as_ref().map(|(id, _, _)| *id),
        has_c: c.is_some(),
    };
    let observations = input::read_observations(&s.observations, &names).map_err(|e| step(&e))?;
    let a_cov = match &s.a_noise {
        MeasureANoise::File(p) => Some(input::read_a_covariance(p).map_err(|e| step(&e))?),
        MeasureANoise::Sigmas(..) => None,
    };
    let mut epochs = Vec::with_capacity(seq.poses.len());
    for p in &seq.poses {
        let world_from_a = match (&a_cov, &s.a_noise) {
            (Some(cov), _) => {
                let m = cov.for_epoch(&[&p.key, &p.name]).ok_or_else(|| {
                    step(&format!(
                        "{}: epochs: no covariance for epoch `{}` and no default covariance_tangent",
                        cov.path.display(),
                        p.name
                    ))
                })?;
                UncertainPose::from_covariance_deg(p.world_from_a, m)
                    .map_err(|e| step(&format!("{}: {e}", cov.path.display())))?
            }
            (None, MeasureANoise::Sigmas(pos, ang)) => {
                UncertainPose::from_sigmas(p.world_from_a, *pos, ang.map(f64::to_radians))
            }
            (None, MeasureANoise::File(_)) => unreachable!("read above"),
        };
        epochs.push(Epoch {
            key: p.key.clone(),
            name: p.name.clone(),
            world_from_a,
        });
    }
    let settings = Settings {
        samples,
        seed,
        pixel_sigma_px: s.pixel_sigma_px,
        reference_epoch: s.reference_epoch.clone(),
        frame_rate_hz: s.frame_rate_hz,
        threshold_mm: s.threshold_mm,
        max_reprojection_px: s.max_reprojection_px,
    };
    let has_c = c.is_some();
    let rig = Rig {
        a_from_b,
        camera_b,
        c: c.map(|(_, tie, cam)| (tie, cam)),
    };
    let measurement =
        crashrig_measure::measure(&epochs, &rig, &observations, &settings).map_err(|e| step(&e))?;
    let warnings = measurement
        .skipped
        .iter()
        .map(|k| {
            format!(
                "epoch `{}` has no pose of camera A ({}) in {}: its {} observation(s) are skipped",
                k.epoch,
                s.camera_a,
                s.model.display(),
                k.observations
            )
        })
        .collect();
    let summary = MeasureSummary::new(&measurement, s, seed, has_c);
    Ok(MeasureResult {
        measurement,
        summary,
        warnings,
    })
}

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

/// `trajectories.csv` (the contract's header), as `crashrig measure` writes it.
pub fn trajectories_csv(m: &Measurement) -> String {
    let mut s = String::from(
        "epoch,marker,x_mm,y_mm,z_mm,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_max_mm,n_views\n",
    );
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

/// Header of `displacements.csv` (as `crashrig measure`).
pub const DISPLACEMENTS_HEADER: &str = "epoch,marker,time_s,dx_mm,dy_mm,dz_mm,sigma_dx_mm,sigma_dy_mm,sigma_dz_mm,sigma_dmax_mm,vx_mm_s,vy_mm_s,vz_mm_s,sigma_vx_mm_s,sigma_vy_mm_s,sigma_vz_mm_s,reprojection_px,flags";

/// `displacements.csv`, as `crashrig measure` writes it.
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

/// File-name-safe version of a marker name (other characters become `_`), made unique.
fn stems(markers: &[String]) -> Vec<String> {
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

/// One trajectory plot per marker: x, y, z against time (or sequence index) with ±3σ bands.
pub struct MarkerPlot {
    /// Marker name.
    pub marker: String,
    /// File stem (`plots/<stem>.png`).
    pub stem: String,
    /// PNG bytes.
    pub png: Vec<u8>,
    /// SVG bytes.
    pub svg: Vec<u8>,
}

/// The per-marker trajectory plots (markers never measured have none).
///
/// # Errors
/// [`Error::Plot`].
pub fn plots(m: &Measurement) -> Result<Vec<MarkerPlot>, Error> {
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
    let stems = stems(&m.markers);
    let mut out = Vec::new();
    for (k, name) in m.markers.iter().enumerate() {
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
            continue;
        }
        let labels = ["x [mm] (±3σ)", "y [mm] (±3σ)", "z [mm] (±3σ)"];
        let panels: Vec<crashrig_plot::BandPanel<'_>> = (0..3)
            .map(|c| crashrig_plot::BandPanel {
                y_label: labels[c],
                ys: &ys[c],
                half_widths: &hw[c],
            })
            .collect();
        let title = format!("marker {name} (world frame)");
        let draw = |f| {
            crashrig_plot::banded_panels(&xs, &panels, &title, x_label, f).map_err(|source| {
                Error::Plot {
                    what: format!("trajectory of marker {name}"),
                    source,
                }
            })
        };
        out.push(MarkerPlot {
            marker: name.clone(),
            stem: stems[k].clone(),
            png: draw(crashrig_plot::Format::Png)?,
            svg: draw(crashrig_plot::Format::Svg)?,
        });
    }
    Ok(out)
}
