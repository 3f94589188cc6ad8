//! The kinematics of a study's measured sequence (`[measure]` with `cfc`): its files under
//! `DIR/measure/` (`kinematics.csv`, `plots/<marker>_kinematics.png|svg`, written by the
//! command's own writers in [`crashrig_measure::output`]) and its report subsection — the
//! filter named, the σ of the filtered displacement, velocity and acceleration per marker, the
//! share of each σ that comes from camera A's trigger offset, and one plot per marker with
//! ±2σ bands.
//!
//! Every number is read from the typed [`crashrig_measure::Measurement`] and
//! [`crashrig_measure::output::Summary`] that the study's `[measure]` step returned (no file or
//! JSON in between).

use crate::Error;
use crate::html::{Block, Report, Table};
use crate::measure_step::MeasureResult;
use crashrig_geometry::Vec3;
use crashrig_measure::Measurement;
use crashrig_measure::kinematics::KinRow;
use crashrig_measure::output::{self as measure_output, MarkerPlot};
use crashrig_stats::summary::median;
use std::path::Path;

/// Median and largest of a set of values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Median.
    pub median: f64,
    /// Largest.
    pub max: f64,
}

impl Spread {
    /// The median and maximum of the finite values of `v`; `None` without any.
    pub fn of(v: Vec<f64>) -> Option<Spread> {
        let v: Vec<f64> = v.into_iter().filter(|x| x.is_finite()).collect();
        let max = v.iter().copied().reduce(f64::max)?;
        Some(Spread {
            median: median(&v).unwrap_or(f64::NAN),
            max,
        })
    }
}

/// One marker's filtered kinematics σ over its epochs (each epoch's σ is the largest of the
/// three axes).
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerKinematics {
    /// Marker name.
    pub marker: String,
    /// Epochs of the marker with kinematics.
    pub rows: usize,
    /// σ of the filtered displacement (mm).
    pub displacement_sigma_mm: Option<Spread>,
    /// σ of the velocity (m/s).
    pub velocity_sigma_m_s: Option<Spread>,
    /// σ of the acceleration (m/s²).
    pub acceleration_sigma_m_s2: Option<Spread>,
    /// Largest |velocity| over the epochs and axes (m/s).
    pub peak_velocity_m_s: Option<f64>,
    /// Largest |acceleration| over the epochs and axes (m/s²).
    pub peak_acceleration_m_s2: Option<f64>,
}

/// Per marker (in marker order) the σ of its filtered kinematics; empty without kinematics.
pub fn per_marker(m: &Measurement) -> Vec<MarkerKinematics> {
    let Some(k) = &m.kinematics else {
        return Vec::new();
    };
    (0..m.markers.len())
        .map(|mk| {
            let rows: Vec<&KinRow> = m
                .rows
                .iter()
                .zip(&k.rows)
                .filter(|(r, kr)| r.marker == mk && kr.displacement_mm.is_some())
                .map(|(_, kr)| kr)
                .collect();
            let sd = |f: fn(&KinRow) -> Option<Vec3>| {
                Spread::of(rows.iter().filter_map(|r| f(r).map(|v| v.max())).collect())
            };
            let peak = |f: fn(&KinRow) -> Option<Vec3>| {
                rows.iter()
                    .filter_map(|r| f(r).map(|v| v.amax()))
                    .reduce(f64::max)
            };
            MarkerKinematics {
                marker: m.markers[mk].clone(),
                rows: rows.len(),
                displacement_sigma_mm: sd(|r| r.displacement_sigma_mm),
                velocity_sigma_m_s: sd(|r| r.velocity_sigma_m_s),
                acceleration_sigma_m_s2: sd(|r| r.acceleration_sigma_m_s2),
                peak_velocity_m_s: peak(|r| r.velocity_m_s),
                peak_acceleration_m_s2: peak(|r| r.acceleration_m_s2),
            }
        })
        .collect()
}

/// The share of σ (not of the variance) that a variance share `v` (0…1) stands for: σ without
/// the source is `σ·√(1 − v)`, so the source adds `1 − √(1 − v)` of σ.
pub fn sigma_share(v: f64) -> f64 {
    1.0 - (1.0 - v.clamp(0.0, 1.0)).sqrt()
}

/// Writes `kinematics.csv` and the kinematics plots into `d` (nothing without kinematics);
/// returns the plots for the report.
///
/// # Errors
/// [`Error::Write`], [`Error::Plot`].
pub fn write(d: &Path, m: &MeasureResult) -> Result<Vec<MarkerPlot>, Error> {
    let ms = &m.measurement;
    let Some(csv) = measure_output::kinematics_csv(ms) else {
        return Ok(Vec::new());
    };
    crate::files::write(d, "kinematics.csv", csv.as_bytes())?;
    let plots = measure_output::kinematics_plots(ms)
        .map_err(|e| crate::error::measure_plot_error(e, "kinematics"))?;
    for p in &plots {
        crate::files::write(&d.join("plots"), &format!("{}.png", p.stem), &p.png)?;
        crate::files::write(&d.join("plots"), &format!("{}.svg", p.stem), &p.svg)?;
    }
    Ok(plots)
}

/// The report subsection of the measured sequence's kinematics (nothing without `cfc`).
pub fn section(rep: &mut Report, m: &MeasureResult, plots: &[MarkerPlot]) {
    let (Some(k), Some(ks)) = (&m.measurement.kinematics, &m.summary.kinematics) else {
        return;
    };
    rep.push(Block::SubHeading(format!(
        "Kinematics: CFC {} ({})",
        ks.cfc,
        standard_title(ks.standard)
    )));
    rep.push(Block::Paragraph(format!(
        "Filter: {}, at {} frames/s. It is applied to each marker's displacement from the reference epoch inside every Monte Carlo replicate, and velocity and acceleration are central differences of the filtered displacement in that replicate, so each σ below is the spread of the filtered quantity over the replicates (a filtered σ is not the raw σ). A marker's series is filtered per unbroken run of frames ({} runs, {} of {} rows with kinematics; runs shorter than {} frames get none). File: measure/kinematics.csv (world axes; displacement mm, velocity m/s, acceleration m/s²).",
        ks.filter,
        k.filter.frame_rate_hz(),
        ks.runs,
        ks.rows_with_kinematics,
        m.summary.rows,
        crashrig_measure::filter::MIN_SAMPLES
    )));
    let spread = |s: Option<Spread>, d: usize| {
        s.map_or("—".to_string(), |s| {
            format!("{:.d$} / {:.d$}", s.median, s.max)
        })
    };
    let peak = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}"));
    rep.push(Block::Table(Table {
        caption: "σ of the filtered kinematics per marker (median / largest over the epochs; each epoch's σ is the largest of x, y, z) and the peak values".into(),
        header: [
            "marker",
            "epochs",
            "σ displacement [mm]",
            "σ velocity [m/s]",
            "σ acceleration [m/s²]",
            "peak |v| [m/s]",
            "peak |a| [m/s²]",
        ]
        .map(String::from)
        .to_vec(),
        rows: per_marker(&m.measurement)
            .into_iter()
            .map(|r| {
                vec![
                    r.marker,
                    r.rows.to_string(),
                    spread(r.displacement_sigma_mm, 3),
                    spread(r.velocity_sigma_m_s, 4),
                    spread(r.acceleration_sigma_m_s2, 2),
                    peak(r.peak_velocity_m_s),
                    peak(r.peak_acceleration_m_s2),
                ]
            })
            .collect(),
    }));
    match &m.summary.sync_offset {
        Some(s) => {
            rep.push(Block::Table(Table {
                caption: format!(
                    "How much of each σ comes from camera A's trigger offset (σ {} ms, drawn once per replicate; A's pose interpolated to the shifted time): the measurement repeated on the same random numbers without the offset; share of the variance and the part of σ it adds, 1 − √(1 − share) (median / largest over the rows)",
                    s.sigma_ms
                ),
                header: ["quantity", "share of the variance", "part of σ"]
                    .map(String::from)
                    .to_vec(),
                rows: s
                    .variance_share
                    .iter()
                    .map(|(q, v)| {
                        vec![
                            q.replace('_', " "),
                            format!("{:.1} % / {:.1} %", 100.0 * v.median, 100.0 * v.max),
                            format!(
                                "{:.1} % / {:.1} %",
                                100.0 * sigma_share(v.median),
                                100.0 * sigma_share(v.max)
                            ),
                        ]
                    })
                    .collect(),
            }));
        }
        None => rep.push(Block::Paragraph(
            "Trigger offset: not modelled (measure.sync_sigma_ms absent or 0): camera A and the inward cameras are taken as triggered together, and no part of these σ comes from an offset between them.".into(),
        )),
    }
    for p in plots {
        rep.push(Block::Wide {
            caption: format!(
                "marker {}: filtered displacement, velocity and acceleration (x, y, z; world axes) against time, CFC {} ({}), ±2σ bands",
                p.marker,
                ks.cfc,
                standard_title(ks.standard)
            ),
            png: p.png.clone(),
        });
    }
}

/// The `crashrig measure` flags of `[measure]`'s kinematics keys (each with a leading space;
/// empty without them), for the report's command that regenerates the sequence.
pub fn flags(m: &crate::study_file::MeasureSection) -> String {
    let mut s = String::new();
    if let Some(c) = m.cfc {
        s.push_str(&format!(
            " --cfc {} --cfc-standard {}",
            c.class,
            c.standard.name()
        ));
    }
    if m.sync_sigma_ms > 0.0 {
        s.push_str(&format!(" --sync-sigma-ms {}", m.sync_sigma_ms));
    }
    s
}

/// `SAE J211-1` or `ISO 6487` for the summary's standard name.
fn standard_title(name: &str) -> &'static str {
    match name {
        "iso6487" => "ISO 6487",
        _ => "SAE J211-1",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_and_sigma_share_known_values() {
        assert_eq!(Spread::of(vec![]), None);
        assert_eq!(Spread::of(vec![f64::NAN]), None);
        let s = Spread::of(vec![4.0, f64::NAN, 1.0, 2.0, 3.0]).unwrap();
        assert_eq!((s.median, s.max), (2.5, 4.0));
        assert_eq!(sigma_share(0.0), 0.0);
        assert_eq!(sigma_share(1.0), 1.0);
        // 75 % of the variance: σ halves without the source.
        assert!((sigma_share(0.75) - 0.5).abs() < 1e-15);
        // A quarter of the variance from the offset: without it σ would be √(1 − 0.25) ≈ 0.866
        // of itself, so the offset accounts for 13.4 % of σ.
        assert!((sigma_share(0.25) - (1.0 - 0.75f64.sqrt())).abs() < 1e-15);
        let s = Spread::of(vec![3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median, s.max), (2.0, 3.0));
    }
}
