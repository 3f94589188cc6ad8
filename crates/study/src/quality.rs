//! Calibration quality: what lets a lab judge its calibration, as typed values computed with
//! the calibration ([`crate::calibration::CalibrationResult::reprojection`] and
//! [`crate::calibration::CalibrationResult::split_half`]).
//!
//! - [`reprojection`]: the reprojection residuals of camera A's and camera B's observations in
//!   the calibration model (COLMAP's camera models, the model's own poses and points): the
//!   pixel noise the bundle actually left, per camera.
//! - [`split_half`]: mrcal's cross-validation idea applied to the link: the mean link of the
//!   first half of the sequence and of the second half, each with its own σ of the mean; the
//!   halves agree when their difference is within 2 σ of the difference on every axis (a drift,
//!   a bumped rig or an underestimated σ shows up here).
//!
//! # Example
//! ```
//! use crashrig_study::quality::SplitHalf;
//! // A difference of 0.3 mm with σ 0.2 mm on each half: σ of the difference √0.08 ≈ 0.28 mm.
//! let s = SplitHalf::from_difference(10, 10, [0.3, 0.0, 0.0, 0.0, 0.0, 0.0], [0.04; 6], [0.04; 6]);
//! assert!((s.z[0] - 0.3 / 0.08f64.sqrt()).abs() < 1e-12);
//! assert!(s.agree);
//! ```

use crate::Study;
use crate::calibration::CalibrationResult;
use crate::html::{Block, Report, Status, Table, Verdict};
use crashrig_colmap::{CameraSelector, Reconstruction};
use crashrig_rig::{CalibrateOptions, Epoch};
use nalgebra::{Point3, Vector3};

/// Agreement bound of [`SplitHalf`]: |difference| ≤ `SPLIT_HALF_Z` × its σ on every axis.
pub const SPLIT_HALF_Z: f64 = 2.0;

/// The reprojection residuals of one camera of the calibration model.
#[derive(Debug, Clone, PartialEq)]
pub struct Reprojection {
    /// `A` or `B`.
    pub role: char,
    /// The camera selector of the study file (`camera_a` / `camera_b`).
    pub selector: String,
    /// Images of the camera with a pose.
    pub images: usize,
    /// The length of every residual (px), one per observation of a 3-D point.
    pub residuals_px: Vec<f64>,
    /// σ per image axis (px): `√(Σ (Δu² + Δv²) / (2 n))`, the pixel noise the bundle left.
    pub sigma_px: f64,
    /// Median residual length (px).
    pub median_px: f64,
    /// Largest residual length (px).
    pub max_px: f64,
}

/// The residuals of every observation of a 3-D point in the images of `selector`: observed
/// pixel minus the projection of the point through the image's pose and camera model.
/// Observations that do not project (behind the camera, a bad camera) are skipped.
pub fn reprojection(model: &Reconstruction, selector: &str, role: char) -> Reprojection {
    let sel = CameraSelector::parse(selector);
    let (mut images, mut sq, mut residuals) = (0usize, 0.0f64, Vec::new());
    for img in model.images().iter().filter(|i| sel.matches(i)) {
        let (Some(pose), Some(cam)) = (
            model.image_cam_from_world(img.image_id),
            model.camera(img.camera_id),
        ) else {
            continue;
        };
        images += 1;
        for p in &img.points2d {
            let Some(x) = p.point3d_id.and_then(|id| model.point3d(id)) else {
                continue;
            };
            let p_cam = pose * Point3::new(x.xyz[0], x.xyz[1], x.xyz[2]);
            let Ok(uv) = cam.camera.img_from_cam(&p_cam.coords) else {
                continue;
            };
            let d = Vector3::new(p.xy[0] - uv.x, p.xy[1] - uv.y, 0.0);
            sq += d.norm_squared();
            residuals.push(d.norm());
        }
    }
    let n = residuals.len();
    Reprojection {
        role,
        selector: selector.to_string(),
        images,
        sigma_px: if n > 0 {
            (sq / (2.0 * n as f64)).sqrt()
        } else {
            f64::NAN
        },
        median_px: crate::grids::median(&residuals),
        max_px: residuals.iter().copied().fold(f64::NAN, f64::max),
        residuals_px: residuals,
    }
}

/// The split-half check of the link.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitHalf {
    /// Epochs of the first half (in sequence order).
    pub n_first: usize,
    /// Epochs of the second half.
    pub n_second: usize,
    /// Second half's mean link minus the first's, tangent coordinates about the first
    /// (x y z in mm, θx θy θz in rad).
    pub difference: [f64; 6],
    /// σ of that difference: √(σ₁² + σ₂²) from each half's σ of the mean.
    pub sigma: [f64; 6],
    /// |difference| / σ per axis.
    pub z: [f64; 6],
    /// Every |z| ≤ [`SPLIT_HALF_Z`].
    pub agree: bool,
}

impl SplitHalf {
    /// The check from the difference and each half's variances of the mean (diagonals).
    pub fn from_difference(
        n_first: usize,
        n_second: usize,
        difference: [f64; 6],
        var_first: [f64; 6],
        var_second: [f64; 6],
    ) -> SplitHalf {
        let sigma: [f64; 6] = std::array::from_fn(|k| (var_first[k] + var_second[k]).sqrt());
        let z: [f64; 6] = std::array::from_fn(|k| {
            if sigma[k] > 0.0 {
                difference[k].abs() / sigma[k]
            } else if difference[k] == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        });
        SplitHalf {
            n_first,
            n_second,
            difference,
            sigma,
            z,
            agree: z.iter().all(|v| *v <= SPLIT_HALF_Z),
        }
    }
}

/// Calibrates the two halves of `epochs` separately (same options, no refinement) and
/// compares their mean links; `None` below 4 epochs or when a half cannot be calibrated.
pub fn split_half(
    epochs: &[Epoch],
    mm_per_unit: f64,
    options: &CalibrateOptions,
) -> Option<SplitHalf> {
    if epochs.len() < 4 {
        return None;
    }
    let h = epochs.len() / 2;
    let o = CalibrateOptions {
        refine: None,
        ..options.clone()
    };
    let a = crashrig_rig::calibrate(&epochs[..h], mm_per_unit, &o, None).ok()?;
    let b = crashrig_rig::calibrate(&epochs[h..], mm_per_unit, &o, None).ok()?;
    let d = a.link.tangent_of(&b.link.b_from_a);
    let diag = |c: &crashrig_geometry::Mat6| -> [f64; 6] { std::array::from_fn(|k| c[(k, k)]) };
    Some(SplitHalf::from_difference(
        h,
        epochs.len() - h,
        std::array::from_fn(|k| d[k]),
        diag(&a.link.covariance),
        diag(&b.link.covariance),
    ))
}

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

    #[test]
    fn split_half_agreement_bound() {
        let v = [1.0; 6];
        // σ of the difference √2: 2.8 / √2 = 1.98 agrees, 2.9 / √2 = 2.05 does not.
        let ok = SplitHalf::from_difference(5, 5, [2.8, 0.0, 0.0, 0.0, 0.0, -2.8], v, v);
        assert!(ok.agree, "{:?}", ok.z);
        let bad = SplitHalf::from_difference(5, 5, [0.0, 0.0, -2.9, 0.0, 0.0, 0.0], v, v);
        assert!(!bad.agree);
        assert!((bad.z[2] - 2.9 / 2f64.sqrt()).abs() < 1e-12);
        // A zero σ (rig-constrained model) with a zero difference agrees; with one, it does not.
        assert!(SplitHalf::from_difference(2, 2, [0.0; 6], [0.0; 6], [0.0; 6]).agree);
        assert!(
            !SplitHalf::from_difference(2, 2, [1e-9, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6], [0.0; 6])
                .agree
        );
    }
}
