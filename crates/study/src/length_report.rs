//! The length check of a study's measured sequence (`[measure] scale_bars`): its files under
//! `DIR/measure/` (`length_check.csv`, `length_check.png|svg`, written by the command's own
//! writers in [`crashrig_measure::output`]), the verdict box at the top of the report and the
//! "Length check" subsection, placed before the trajectories: per scale bar the error over the
//! epochs with its ±2σ band, the numbers behind the verdict and the verdict in words — what it
//! means for the σ printed elsewhere in the report.
//!
//! Every number is read from the typed [`crashrig_measure::length::LengthCheck`] that the
//! study's `[measure]` step returned (no file or JSON in between).

use crate::Error;
use crate::html::{Block, Report, Status, Table, Verdict};
use crate::measure_step::MeasureResult;
use crashrig_measure::length::{BarCheck, LengthCheck, Verdict as BarVerdict};
use crashrig_measure::output::{self as measure_output, MarkerPlot};
use std::path::Path;

/// Writes `length_check.csv` and `length_check.png|svg` below `d` (`DIR/measure/`); returns the
/// plot (`None` without scale bars or without a measured bar).
///
/// # Errors
/// [`Error::Write`], or [`Error::Plot`] for the figure.
pub fn write(d: &Path, m: &MeasureResult) -> Result<Option<MarkerPlot>, Error> {
    let ms = &m.measurement;
    let Some(csv) = measure_output::length_check_csv(ms) else {
        return Ok(None);
    };
    crate::files::write(d, measure_output::LENGTH_CHECK_CSV, csv.as_bytes())?;
    let plot = measure_output::length_check_plot(ms)
        .map_err(|e| crate::error::measure_plot_error(e, "length check"))?;
    if let Some(p) = &plot {
        crate::files::write(d, "length_check.png", &p.png)?;
        crate::files::write(d, "length_check.svg", &p.svg)?;
    }
    Ok(plot)
}

/// The verdict box "Do the σ hold on the test itself?" (`None` without scale bars).
pub fn verdict(m: &MeasureResult) -> Option<Verdict> {
    let lc = m.measurement.length_check.as_ref()?;
    let judged: Vec<&BarCheck> = lc
        .bars
        .iter()
        .filter(|b| b.stats.verdict.is_some())
        .collect();
    let failed: Vec<&str> = judged
        .iter()
        .filter(|b| b.stats.verdict != Some(BarVerdict::Consistent))
        .map(|b| b.bar.name.as_str())
        .collect();
    let (answer, status) = if judged.is_empty() {
        (
            "No scale bar was measured in any epoch: no check.".to_string(),
            Status::Info,
        )
    } else if failed.is_empty() {
        (
            format!(
                "Yes, as far as the scale bars can tell: all {} are consistent with their predicted σ.",
                judged.len()
            ),
            Status::Pass,
        )
    } else {
        (
            format!(
                "No: {} of {} scale bars are not consistent ({}).",
                failed.len(),
                judged.len(),
                failed.join(", ")
            ),
            Status::Fail,
        )
    };
    Some(Verdict {
        question: "Do the predicted σ hold on the test itself (scale bars)?".into(),
        answer,
        lines: lc.bars.iter().map(short_line).collect(),
        status,
    })
}

/// One bar in one line: its error, bias and scatter, and the verdict.
fn short_line(b: &BarCheck) -> String {
    let s = &b.stats;
    let f = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
    format!(
        "{} ({} mm, {} epochs): E = {} mm, bias_z {}, scatter ratio {}: {}",
        b.bar.name,
        b.bar.length_mm,
        b.epochs.len(),
        f(s.max_abs_error_mm, 3),
        f(s.bias_z, 2),
        f(s.scatter_ratio, 2),
        s.verdict.map_or("no verdict", BarVerdict::name)
    )
}

/// A bar's verdict in words: what it means for the σ printed elsewhere in the report.
pub fn verdict_words(b: &BarCheck) -> String {
    let s = &b.stats;
    let name = &b.bar.name;
    let Some(v) = s.verdict else {
        return format!(
            "{name}: no verdict — markers {} and {} are not both measured in any epoch, so this bar checks nothing.",
            b.bar.marker_1, b.bar.marker_2
        );
    };
    let num = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let band = s.scatter_band.map_or(String::new(), |(lo, hi)| {
        format!(" (99 % band {lo:.2} … {hi:.2})")
    });
    match v {
        BarVerdict::Consistent => format!(
            "{name}: consistent — its length error stays within what the σ predict (bias_z {:.2}, |z| ≤ 3; scatter ratio {}{band}). On this test the σ that the inward pair contributes to the positions, displacements and velocities in this report — the tie B_from_C and the pixel noise — hold; the bar cannot see A's pose, the link A_from_B or the model's scale (they move both markers together).",
            num(s.bias_z),
            s.scatter_ratio
                .map_or("— (one epoch)".to_string(), |r| format!("{r:.2}"))
        ),
        BarVerdict::Bias => format!(
            "{name}: bias — the whole sequence measures the bar {:+.3} mm off ({:.1} % of its length), {} its predicted σ of {:.3} mm: an error shared by every epoch that the σ do not include (the tie's baseline or rotation, the inward cameras' focal lengths or distortion, the bar's certificate). Positions, and displacements and velocities, measured by this camera pair carry an uncovered systematic error of about that relative size, beyond the σ printed in this report.",
            num(s.mean_error_mm),
            100.0 * num(s.mean_error_mm) / b.bar.length_mm,
            s.bias_z
                .map_or("far above".to_string(), |z| format!("{:.1} ×", z.abs())),
            num(s.mean_error_sigma_mm)
        ),
        BarVerdict::SigmaTooSmall => match (s.scatter_ratio, s.scatter_band) {
            (Some(r), Some((_, hi))) if r > hi => format!(
                "{name}: sigma_too_small — the bar's measured length scatters {r:.2} × as much from epoch to epoch as predicted{band}. The per-epoch σ in this report (positions, displacements, velocities) are too small for the part that comes from the pixels and whatever else changes between epochs — by about this factor; the pixel σ given is too optimistic, or an error the model leaves out (marker detection, cameras moving against each other) is present."
            ),
            (Some(r), Some(_)) => format!(
                "{name}: sigma_too_small (scatter below its band) — the bar's measured length scatters only {r:.2} × as much from epoch to epoch as predicted{band}: the scatter does not follow the prediction. The per-epoch σ in this report look conservative for the pixel part (the pixel σ given is larger than the images show), or the epochs are not independent measurements."
            ),
            _ => format!(
                "{name}: sigma_too_small — the bar's measured length changes from epoch to epoch although its predicted epoch-to-epoch σ is zero: the σ in this report leave out the pixel noise."
            ),
        },
    }
}

/// The "Length check" subsection (nothing without scale bars): what is compared, a table of
/// the bars' numbers, the verdicts in words and the plot of the errors with their ±2σ bands.
pub fn section(rep: &mut Report, m: &MeasureResult, plot: Option<&MarkerPlot>) {
    let Some(lc) = &m.measurement.length_check else {
        return;
    };
    rep.push(Block::SubHeading("Length check (scale bars)".into()));
    rep.push(Block::Paragraph(format!(
        "{} scale bar{} fixed to the car body: in every epoch where both markers of a bar are measured, the distance of their positions is compared with the certificate's length (an acceptance test in the spirit of VDI/VDE 2634 Part 1, run on the test's own images). The σ of each distance comes from the same Monte Carlo replicates as the trajectories — the distance is taken in every replicate, so the tie's one draw per test acts as it physically does — combined with the certificate's σ. bias_z is the mean error over the σ of the mean (the part every epoch shares; |bias_z| ≤ 3 passes); the scatter ratio is the spread of the measured length over the epochs over its predicted epoch-to-epoch σ, tested against the two-sided 99 % band of its sampling distribution. What a bar cannot see: errors common to both markers cancel in a distance — camera A's pose, the link A_from_B, the model's scale. Files: measure/length_check.csv, measure/length_check.png.",
        lc.bars.len(),
        if lc.bars.len() == 1 { "" } else { "s" }
    )));
    rep.push(Block::Table(table(lc)));
    rep.push(Block::List(lc.bars.iter().map(verdict_words).collect()));
    if let Some(p) = plot {
        rep.push(Block::Wide {
            caption: "Length check: measured − certificate length of each scale bar against time, with the ±2σ band of the measurement (grey line: zero error). A consistent bar's band covers zero in about 95 % of the epochs.".into(),
            png: p.png.clone(),
        });
    }
}

/// The bars' numbers (one row per bar).
fn table(lc: &LengthCheck) -> Table {
    let f = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
    let mut header: Vec<String> = [
        "bar",
        "length [mm]",
        "epochs",
        "E = max |error| [mm]",
        "mean error [mm]",
        "RMS error [mm]",
        "within ±2σ",
        "bias_z",
        "scatter ratio (99 % band)",
        "verdict",
    ]
    .map(String::from)
    .to_vec();
    if let Some(mpe) = lc.mpe_mm {
        header.push(format!("within MPE {mpe} mm"));
    }
    let rows = lc
        .bars
        .iter()
        .map(|b| {
            let s = &b.stats;
            let mut row = vec![
                b.bar.name.clone(),
                format!("{} ± {}", b.bar.length_mm, b.bar.sigma_mm),
                b.epochs.len().to_string(),
                f(s.max_abs_error_mm, 3),
                f(s.mean_error_mm, 3),
                f(s.rms_error_mm, 3),
                s.coverage_2sigma
                    .map_or("—".to_string(), |c| format!("{:.0} %", 100.0 * c)),
                f(s.bias_z, 2),
                match (s.scatter_ratio, s.scatter_band) {
                    (Some(r), Some((lo, hi))) => format!("{r:.2} ({lo:.2} … {hi:.2})"),
                    _ => "—".into(),
                },
                s.verdict.map_or("—", BarVerdict::name).to_string(),
            ];
            if lc.mpe_mm.is_some() {
                row.push(match b.within_mpe {
                    Some(true) => "yes".into(),
                    Some(false) => "no".into(),
                    None => "—".into(),
                });
            }
            row
        })
        .collect();
    Table {
        caption: "Scale bars: length measurement error E, mean and RMS error over the epochs, share of epochs within ±2σ, and the two tests behind the verdict".into(),
        header,
        rows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_measure::length::{BarNumbers, ScaleBar};

    fn check(measured: Vec<f64>, mean_sigma: f64, dev_var: f64) -> BarCheck {
        let n = measured.len();
        let stats = BarNumbers {
            length_mm: 500.0,
            certificate_sigma_mm: 0.0,
            measured_mm: measured,
            epoch_sigma_mm: vec![Some(1.0); n],
            mean_sigma_mm: Some(mean_sigma),
            deviation_variance_mm2: Some(vec![dev_var; n]),
            scatter_moments: None,
        }
        .statistics();
        BarCheck {
            bar: ScaleBar {
                name: "door".into(),
                marker_1: "d1".into(),
                marker_2: "d2".into(),
                length_mm: 500.0,
                sigma_mm: 0.0,
                line: 2,
            },
            epochs: (0..n).collect(),
            stats,
            draws: 10,
            within_mpe: None,
        }
    }

    #[test]
    fn words_name_the_verdict_and_what_it_means() {
        let ok = verdict_words(&check(vec![500.5, 499.5, 500.5, 499.5], 1.0, 0.25));
        assert!(
            ok.starts_with("door: consistent") && ok.contains("hold"),
            "{ok}"
        );
        let scatter = verdict_words(&check(vec![505.0, 495.0, 505.0, 495.0], 10.0, 0.25));
        assert!(
            scatter.starts_with("door: sigma_too_small —") && scatter.contains("too small"),
            "{scatter}"
        );
        let low = verdict_words(&check(vec![500.0; 4], 1.0, 1.0));
        assert!(
            low.contains("below its band") && low.contains("conservative"),
            "{low}"
        );
        let none = verdict_words(&check(Vec::new(), 1.0, 1.0));
        assert!(none.contains("checks nothing"), "{none}");
    }

    /// The words for a bar whose whole sequence is off by 9 mm, 5 × its predicted σ.
    #[test]
    fn a_shared_error_reads_as_bias() {
        let bar = ScaleBar {
            name: "roof".into(),
            marker_1: "r1".into(),
            marker_2: "r2".into(),
            length_mm: 900.0,
            sigma_mm: 0.0,
            line: 2,
        };
        let stats = BarNumbers {
            length_mm: 900.0,
            certificate_sigma_mm: 0.0,
            measured_mm: vec![909.0, 909.2, 908.8],
            epoch_sigma_mm: vec![Some(1.9); 3],
            mean_sigma_mm: Some(1.8),
            deviation_variance_mm2: Some(vec![0.04; 3]),
            scatter_moments: None,
        }
        .statistics();
        let check = BarCheck {
            bar,
            epochs: vec![0, 1, 2],
            stats,
            draws: 100,
            within_mpe: None,
        };
        let words = verdict_words(&check);
        assert!(words.starts_with("roof: bias"), "{words}");
        assert!(words.contains("1.0 %"), "{words}");
    }
}
