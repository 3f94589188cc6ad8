//! The report of the calibration quality ([`crashrig_calibrate`]'s quality values, carried by
//! [`CalibrationResult`]): the calibration's verdict box ([`verdict`]) and the report section
//! "Calibration quality" (per-epoch link plots with the outliers marked, the drift statistics,
//! the split-half check, the reprojection residuals per camera and the pixel σ the study uses).

use crate::Study;
use crate::html::{Block, Report, Status, Table, Verdict};
use crashrig_calibrate::CalibrationResult;
use crashrig_calibrate::SPLIT_HALF_Z;

/// The axes of the link, in the tangent order of the split-half check.
const AXES: [&str; 6] = ["x [mm]", "y [mm]", "z [mm]", "θx [°]", "θy [°]", "θz [°]"];
/// The epoch series' parameters (the drift report's order).
const SERIES: [&str; 6] = ["x [mm]", "y [mm]", "z [mm]", "ω [°]", "φ [°]", "κ [°]"];

/// The calibration's verdict box: outliers, drift, split-half agreement.
pub fn verdict(c: &CalibrationResult) -> Verdict {
    let cal = &c.calibration;
    let outliers = cal.outliers.indices().len();
    let optimistic = cal.drift.as_ref().is_some_and(|d| d.any_optimistic());
    let mut lines = vec![format!(
        "{} epochs, {} flagged as outliers (robust z > {:.2})",
        c.n_epochs, outliers, cal.outliers.threshold
    )];
    lines.push(match &cal.drift {
        Some(d) if d.any_optimistic() => format!(
            "drift: the epoch series is autocorrelated on {} (σ of the mean widened: rule {})",
            (0..6)
                .filter(|&k| d.optimistic[k])
                .map(|k| SERIES[k])
                .collect::<Vec<_>>()
                .join(", "),
            c.sem_rule
        ),
        // The lag-1 band test and the σ-of-the-mean rule look at the series differently (the
        // rule fits slow drift mixed with noise, pooled over the six axes): never say "no drift"
        // beside a σ of the mean that the rule widened for drift.
        Some(_) if cal.sem.autocorrelated.iter().any(|&a| a) => {
            "drift: the lag-1 autocorrelations are within white noise's band, but the drift \
             model widens the σ of the mean (warning below)"
                .into()
        }
        Some(_) => "drift: no autocorrelation beyond white noise".into(),
        None => "drift: not assessed (fewer than three epochs)".into(),
    });
    match &c.split_half {
        Some(s) => lines.push(format!(
            "split-half: the two halves {} (largest |difference| / σ = {:.2}, bound {SPLIT_HALF_Z})",
            if s.agree { "agree within 2σ" } else { "do NOT agree within 2σ" },
            s.z.iter().copied().fold(0.0, f64::max)
        )),
        None => lines.push("split-half: not possible (fewer than 4 epochs)".into()),
    }
    for r in &c.reprojection {
        lines.push(if r.residuals_px.is_empty() {
            format!(
                "camera {}: the model holds no observation of a 3-D point (no reprojection statistics)",
                r.role
            )
        } else {
            format!(
                "camera {} reprojection σ {} px per axis ({} observations)",
                r.role,
                fmt(r.sigma_px, 3),
                r.residuals_px.len()
            )
        });
    }
    // The verdict names every warning it refers to ("with the warnings below").
    lines.extend(c.warnings.iter().map(|w| format!("warning: {w}")));
    let bad = c.split_half.as_ref().is_some_and(|s| !s.agree);
    let (answer, status) = if bad {
        (
            "Doubtful: the two halves of the sequence disagree beyond their σ.",
            Status::Fail,
        )
    } else if outliers > 0 || optimistic || !c.warnings.is_empty() {
        ("Usable, with the warnings below.", Status::Info)
    } else {
        ("Yes: no outlier, no drift, halves agree.", Status::Pass)
    };
    Verdict {
        question: "Can the calibration be trusted?".into(),
        answer: answer.into(),
        lines,
        status,
    }
}

/// A number with `d` decimals, or "—" when it is not finite (never "NaN" on the page).
fn fmt(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "—".into()
    }
}

/// The report section "Calibration quality": per-epoch link plots with the outliers marked,
/// the drift statistics, the split-half check, the reprojection residuals per camera and the
/// pixel σ the study uses with their source.
pub(crate) fn report_section(rep: &mut Report, study: &Study, c: &CalibrationResult) {
    let cal = &c.calibration;
    rep.push(Block::Heading(
        "Calibration quality: can the link be trusted?".into(),
    ));
    rep.push(Block::Paragraph(format!(
        "Judge the calibration here before trusting any σ below. Outliers: robust z-score (median / MAD) of each epoch above {:.2} on any parameter ({} of {} epochs flagged{}). The σ of the mean link that the chain uses follows rule {}.",
        cal.outliers.threshold,
        cal.outliers.indices().len(),
        c.n_epochs,
        if cal.outliers.indices().is_empty() {
            String::new()
        } else {
            format!(
                ": {}",
                cal.outliers
                    .indices()
                    .iter()
                    .map(|&i| cal.links[i].name.clone())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        c.sem_rule
    )));
    if let Some(png) = epoch_plot(c) {
        rep.push(Block::Wide {
            caption: "The link A_from_B of every epoch (base in mm, ω φ κ in degrees; red rings: epochs flagged as outliers)".into(),
            png,
        });
    }
    drift_table(rep, c);
    split_half_table(rep, c);
    reprojection_blocks(rep, study, c);
}

/// The per-epoch series of the six parameters, outliers marked.
fn epoch_plot(c: &CalibrationResult) -> Option<Vec<u8>> {
    let cal = &c.calibration;
    let series = crashrig_rig::stats::parameter_series(&cal.links).ok()?;
    let xs: Vec<f64> = (1..=cal.links.len()).map(|i| i as f64).collect();
    let ys: Vec<Vec<f64>> = (0..6)
        .map(|j| {
            let f = if j < 3 { 1.0 } else { 1f64.to_degrees() };
            series[j].iter().map(|v| v * f).collect()
        })
        .collect();
    let none = vec![f64::NAN; xs.len()];
    let panels: Vec<crashrig_plot::BandPanel> = ys
        .iter()
        .zip(SERIES)
        .map(|(ys, label)| crashrig_plot::BandPanel {
            y_label: label,
            ys,
            half_widths: &none,
        })
        .collect();
    crashrig_plot::banded_panels_marked(
        &xs,
        &panels,
        &cal.outliers.outlier,
        "rig link per epoch (red: outlier)",
        "epoch (sequence order)",
        crashrig_plot::Format::Png,
    )
    .ok()
}

fn drift_table(rep: &mut Report, c: &CalibrationResult) {
    let Some(d) = &c.calibration.drift else {
        rep.push(Block::Paragraph(
            "Drift statistics: not computed (fewer than three epochs).".into(),
        ));
        return;
    };
    rep.push(Block::Table(Table {
        caption: format!(
            "Drift: lag-1 autocorrelation of the epoch series (white-noise bound {:.3}), the effective number of epochs and the factor by which σ/√n would understate the σ of the mean",
            d.white_noise_band
        ),
        header: ["", "lag-1 r", "effective n", "σ/√n understated by", "autocorrelated"]
            .map(String::from)
            .to_vec(),
        rows: (0..6)
            .map(|k| {
                vec![
                    SERIES[k].to_string(),
                    d.autocorrelation[k].first().map_or("—".into(), |r| fmt(*r, 3)),
                    fmt(d.effective_n[k], 1),
                    format!("× {}", fmt(d.sem_inflation[k], 2)),
                    if d.optimistic[k] { "yes" } else { "no" }.into(),
                ]
            })
            .collect(),
    }));
}

fn split_half_table(rep: &mut Report, c: &CalibrationResult) {
    let Some(s) = &c.split_half else {
        rep.push(Block::Paragraph(
            "Split-half check: not possible with fewer than 4 epochs.".into(),
        ));
        return;
    };
    let k = |i: usize| if i < 3 { 1.0 } else { 1f64.to_degrees() };
    rep.push(Block::Table(Table {
        caption: format!(
            "Split-half check (cross-validation, as mrcal does for intrinsics): the mean link of epochs 1–{} against that of epochs {}–{}, each with its own σ of the mean. Verdict: {}",
            s.n_first,
            s.n_first + 1,
            s.n_first + s.n_second,
            if s.agree {
                "the halves agree within 2σ on every axis."
            } else {
                "the halves do NOT agree within 2σ: the link drifted or moved during the sequence, or its σ is too small; the σ below are optimistic."
            }
        ),
        header: ["axis", "second − first", "σ of the difference", "|difference| / σ"]
            .map(String::from)
            .to_vec(),
        rows: (0..6)
            .map(|i| {
                vec![
                    AXES[i].to_string(),
                    fmt(s.difference[i] * k(i), 4),
                    fmt(s.sigma[i] * k(i), 4),
                    fmt(s.z[i], 2),
                ]
            })
            .collect(),
    }));
}

/// Reprojection residuals per camera (table and histograms) and the pixel σ the study uses.
fn reprojection_blocks(rep: &mut Report, study: &Study, c: &CalibrationResult) {
    rep.push(Block::Table(Table {
        caption: "Reprojection residuals of the calibration model, per camera (observed pixel − projection of the model's 3-D point through the image's pose and camera model)".into(),
        header: ["camera", "selector", "images", "observations", "σ per axis [px]", "median [px]", "max [px]"]
            .map(String::from)
            .to_vec(),
        rows: c
            .reprojection
            .iter()
            .map(|r| {
                vec![
                    r.role.to_string(),
                    r.selector.clone(),
                    r.images.to_string(),
                    r.residuals_px.len().to_string(),
                    fmt(r.sigma_px, 3),
                    fmt(r.median_px, 3),
                    fmt(r.max_px, 3),
                ]
            })
            .collect(),
    }));
    for r in c.reprojection.iter().filter(|r| !r.residuals_px.is_empty()) {
        let title = format!(
            "camera {}: reprojection residual length, {} observations (line: sigma per axis {:.3} px)",
            r.role,
            r.residuals_px.len(),
            r.sigma_px
        );
        if let Ok(png) = crashrig_plot::histogram(
            &r.residuals_px,
            &[r.sigma_px],
            &title,
            "residual [px]",
            crashrig_plot::Format::Png,
        ) {
            rep.push(Block::Figure {
                caption: format!(
                    "Reprojection residuals of camera {} ({})",
                    r.role, r.selector
                ),
                png,
            });
        }
    }
    rep.push(Block::List(pixel_sigma_sources(study, c)));
}

/// Every pixel σ the study uses, with the key it comes from, beside the residual σ observed.
fn pixel_sigma_sources(study: &Study, c: &CalibrationResult) -> Vec<String> {
    let observed: Vec<String> = c
        .reprojection
        .iter()
        .map(|r| format!("camera {} {} px", r.role, fmt(r.sigma_px, 3)))
        .collect();
    let mut out = vec![format!(
        "Pixel σ observed in the calibration bundle: {} (for comparison with the σ used below).",
        observed.join(", ")
    )];
    if let Some(m) = &study.measure {
        out.push(format!(
            "Pixel σ used for the measured sequence: {} px, from the study file key measure.pixel_sigma_px.",
            m.pixel_sigma_px
        ));
    }
    for l in &study.layouts {
        if let Some((sigma, focal)) = l.pixel {
            out.push(format!(
                "Pixel σ used for layout {:?}: {sigma} px at a focal length of {focal} px, from the study file keys pixel_sigma_px and focal_px of that layout.",
                l.name
            ));
        }
    }
    if out.len() == 1 {
        out.push("The grid layouts use no pixel noise of their own (only the cameras' pose σ), unless a fixed camera names pixel_sigma_px (listed in its layout's observer table).".into());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_calibrate::{CalibrationConfig, Scale, calibrate};

    /// The report's calibration verdict names every warning it refers to ("Usable, with the
    /// warnings below" used to stand over a list without them, issue 29).
    #[test]
    fn calibration_verdict_lists_its_warnings() {
        let config = CalibrationConfig {
            model: std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../fixtures/rig/paper"),
            camera_a: "cam_out/".into(),
            camera_b: "cam_in/".into(),
            scale: Scale::ScaleBar {
                points: [1, 2],
                length_mm: 2000.0,
            },
            ..CalibrationConfig::default()
        };
        let r = calibrate(&config, None).unwrap();
        let v = verdict(&r);
        for w in &r.warnings {
            assert!(v.lines.contains(&format!("warning: {w}")), "{w}: {v:?}");
        }
        // The paper's sequence: no lag-1 autocorrelation beyond the band, but the σ-of-the-mean
        // rule widens some axes — the drift line must not say "no autocorrelation" then.
        let drift_line = |v: &Verdict| {
            v.lines
                .iter()
                .find(|l| l.starts_with("drift:"))
                .cloned()
                .unwrap()
        };
        assert!(!r.calibration.drift.as_ref().unwrap().any_optimistic());
        assert!(r.calibration.sem.autocorrelated.iter().any(|&a| a));
        assert!(
            drift_line(&v).contains("the drift model widens the σ of the mean"),
            "{v:?}"
        );
        let mut white = r.clone();
        white.calibration.sem.autocorrelated = [false; 6];
        assert_eq!(
            drift_line(&verdict(&white)),
            "drift: no autocorrelation beyond white noise"
        );
        let mut with = r.clone();
        with.warnings.push("a test warning".into());
        let v = verdict(&with);
        assert_eq!(v.answer, "Usable, with the warnings below.");
        assert_eq!(
            v.lines.last().map(String::as_str),
            Some("warning: a test warning")
        );
    }
}
