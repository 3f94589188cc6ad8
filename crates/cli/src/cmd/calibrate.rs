//! `crashrig calibrate`: rig calibration from an epoch sequence.
//!
//! Reads a COLMAP model, pairs the images of camera A and B into epochs, converts model units
//! to mm (scale bar or `--mm-per-unit`), and reports the statistics of `A_from_B` over the
//! epochs like the paper's Tables 1–2, with outliers, drift, and the rig-constrained
//! refinement side by side. Library values are in radians; this module converts to degrees.

use crate::Global;
use anyhow::Context;
use crashrig_colmap::Reconstruction;
use crashrig_geometry::{Mat6, Vec3};
use crashrig_rig::colmap::{
    CameraSelector, EpochSet, ScaleBar, epochs_from_model, scale_from_points,
};
use crashrig_rig::{
    CalibrateOptions, Calibration, DriftReport, Error as RigError, LinkStatistics,
    OUTLIER_THRESHOLD, RefineOptions, Refinement, calibrate, check_scale,
};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `crashrig calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// COLMAP model directory (bundle without a rig constraint).
    pub model: PathBuf,
    /// Camera A (outward): an image-name prefix such as `cam_out/`, or a camera id.
    #[arg(long = "camera-a", value_name = "A")]
    pub camera_a: String,
    /// Camera B (inward): an image-name prefix or a camera id.
    #[arg(long = "camera-b", value_name = "B")]
    pub camera_b: String,
    /// Two point3D ids a known distance apart (scale bar).
    #[arg(long = "scale-points", num_args = 2, value_names = ["ID1", "ID2"],
          requires = "scale_length_mm", conflicts_with = "mm_per_unit")]
    pub scale_points: Option<Vec<u64>>,
    /// Known distance between the scale points, in mm.
    #[arg(
        long = "scale-length-mm",
        value_name = "L",
        requires = "scale_points",
        allow_negative_numbers = true
    )]
    pub scale_length_mm: Option<f64>,
    /// Millimetres per model unit (default 1).
    #[arg(long = "mm-per-unit", value_name = "F", allow_negative_numbers = true, value_parser = crate::limits::parse_mm_per_unit)]
    pub mm_per_unit: Option<f64>,
    /// Directory for plots (per-epoch series, histograms), PNG and SVG.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Largest lag of the autocorrelation report.
    #[arg(long = "max-lag", value_name = "K", default_value_t = 10)]
    pub max_lag: usize,
    /// Skip the rig-constrained refinement.
    #[arg(long = "no-refine")]
    pub no_refine: bool,
}

/// Names of the six parameters, in the library's order.
const PARAMS: [&str; 6] = ["x", "y", "z", "omega", "phi", "kappa"];
/// Axis labels of the six parameters.
const LABELS: [&str; 6] = [
    "base X [mm]",
    "base Y [mm]",
    "base Z [mm]",
    "omega [deg]",
    "phi [deg]",
    "kappa [deg]",
];

/// Where the scale came from.
enum Scale {
    Bar(ScaleBar),
    Given(f64),
    Default,
}

impl Scale {
    fn mm_per_unit(&self) -> f64 {
        match self {
            Scale::Bar(b) => b.mm_per_unit,
            Scale::Given(f) => *f,
            Scale::Default => 1.0,
        }
    }
}

/// A finished calibration, not yet printed (for `crashrig paper` and other in-process callers).
pub struct CalibrationRun {
    /// The library result (mm, rad).
    pub calibration: Calibration,
    /// The contract's JSON document (mm, deg), with the extension fields.
    pub json: Value,
    /// The text report (Tables 1–2 and the rest).
    pub text: String,
    /// Warnings for stderr (unpaired images, autocorrelated series), one line each.
    pub warnings: Vec<String>,
}

/// Reads the model, pairs, scales and calibrates as `crashrig calibrate` does, without output.
pub fn compute(a: &CalibrateArgs) -> anyhow::Result<CalibrationRun> {
    // The COLMAP reader's errors name the file already.
    let model = Reconstruction::read(&a.model)?;
    let sel_a = CameraSelector::parse(&a.camera_a);
    let sel_b = CameraSelector::parse(&a.camera_b);
    let set = epochs_from_model(&model, &sel_a, &sel_b)?;
    let scale = match (&a.scale_points, a.scale_length_mm, a.mm_per_unit) {
        (Some(ids), Some(len), _) => Scale::Bar(scale_from_points(&model, ids[0], ids[1], len)?),
        (_, _, Some(f)) => Scale::Given(check_scale(f)?),
        _ => Scale::Default,
    };
    let mut warnings = unpaired_warnings(&set);
    let options = CalibrateOptions {
        max_lag: a.max_lag,
        refine: (!a.no_refine).then(RefineOptions::default),
    };
    let cal = match calibrate(&set.epochs, scale.mm_per_unit(), &options) {
        Ok(c) => c,
        // The epoch statistics do not depend on the refinement: report them without it.
        Err(e @ (RigError::NoConvergence { .. } | RigError::SingularNormalMatrix { .. })) => {
            warnings.push(format!("rig-constrained refinement skipped: {e}"));
            let plain = CalibrateOptions {
                refine: None,
                ..options
            };
            calibrate(&set.epochs, scale.mm_per_unit(), &plain)
                .with_context(|| format!("{}: calibration failed", a.model.display()))?
        }
        Err(e) => {
            return Err(e).with_context(|| format!("{}: calibration failed", a.model.display()));
        }
    };
    if let Some(d) = &cal.drift
        && d.any_optimistic()
    {
        warnings.push(format!(
            "the epoch series is autocorrelated ({}); σ/√n is likely optimistic",
            optimistic_list(d)
        ));
    }
    Ok(CalibrationRun {
        json: to_json(a, &set, &scale, &cal),
        text: text_report(a, &set, &scale, &cal),
        calibration: cal,
        warnings,
    })
}

/// Runs `crashrig calibrate`.
pub fn run(a: CalibrateArgs, g: &Global) -> anyhow::Result<()> {
    let r = compute(&a)?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(dir) = &a.plots {
        write_plots(dir, &r.calibration)?;
    }
    if g.json {
        return crate::output::print_json(&r.json);
    }
    print!("{}", r.text);
    Ok(())
}

fn unpaired_warnings(set: &EpochSet) -> Vec<String> {
    let mut out = Vec::new();
    for (what, v) in [
        ("image(s) of camera A have no partner in B", &set.unpaired_a),
        ("image(s) of camera B have no partner in A", &set.unpaired_b),
        (
            "paired image(s) have no pose (epoch skipped)",
            &set.without_pose,
        ),
    ] {
        if !v.is_empty() {
            let shown: Vec<&str> = v.iter().take(10).map(String::as_str).collect();
            let more = if v.len() > 10 { ", …" } else { "" };
            out.push(format!("{} {what}: {}{more}", v.len(), shown.join(", ")));
        }
    }
    out
}

fn optimistic_list(d: &DriftReport) -> String {
    (0..6)
        .filter(|&j| d.optimistic[j])
        .map(|j| {
            format!(
                "{}: lag-1 r = {:.2}, n_eff ≈ {:.0}, SEM × {:.2}",
                PARAMS[j], d.autocorrelation[j][0], d.effective_n[j], d.sem_inflation[j]
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn deg3(v: &Vec3) -> [f64; 3] {
    [v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees()]
}

fn arr3(v: &Vec3) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

/// A (mm, rad) covariance as nested arrays in (mm, deg).
fn cov_deg(c: &Mat6) -> Vec<Vec<f64>> {
    let f = |k: usize| if k < 3 { 1.0 } else { 1f64.to_degrees() };
    (0..6)
        .map(|i| (0..6).map(|j| c[(i, j)] * f(i) * f(j)).collect())
        .collect()
}

fn stats_json(s: &LinkStatistics) -> Value {
    json!({
        "n_epochs": s.n,
        "base_mm": arr3(&s.base_mm),
        "base_sigma_mm": arr3(&s.base_sigma_mm),
        "base_sem_mm": arr3(&s.base_sem_mm),
        "angles_deg": deg3(&s.angles),
        "angles_sigma_deg": deg3(&s.angles_sigma),
        "angles_sem_deg": deg3(&s.angles_sem),
        "mean_rotation_angles_deg": deg3(&s.mean_rotation_angles),
        "covariance": cov_deg(&s.covariance),
    })
}

fn refined_json(r: &Refinement) -> Value {
    json!({
        "base_mm": arr3(&r.base_mm),
        "base_sigma_mm": arr3(&r.base_sigma_mm),
        "angles_deg": deg3(&r.angles),
        "angles_sigma_deg": deg3(&r.angles_sigma),
        "covariance": cov_deg(&r.covariance),
        "sigma_rotation_deg": deg3(&r.sigma_rotation),
        "sigma_position_mm": arr3(&r.sigma_position_mm),
        "variance_factor": r.variance_factor,
        "n_unknowns": r.n_unknowns,
        "redundancy": r.redundancy,
        "iterations": r.iterations,
    })
}

fn to_json(a: &CalibrateArgs, set: &EpochSet, scale: &Scale, c: &Calibration) -> Value {
    let s = &c.all;
    let epochs: Vec<Value> = c
        .links
        .iter()
        .zip(&c.outliers.outlier)
        .zip(&c.outliers.z_scores)
        .map(|((l, o), z)| {
            json!({
                "name": l.name,
                "base_mm": arr3(&l.base_mm),
                "angles_deg": deg3(&l.angles),
                "outlier": o,
                "z_scores": z,
            })
        })
        .collect();
    let scale_json = match scale {
        Scale::Bar(b) => json!({
            "source": "scale_bar", "point_ids": [b.point_1, b.point_2],
            "length_mm": b.length_mm, "distance_units": b.distance_units,
        }),
        Scale::Given(_) => json!({"source": "mm_per_unit"}),
        Scale::Default => json!({"source": "default"}),
    };
    let drift = c.drift.as_ref().map(|d| {
        json!({
            "order": PARAMS,
            "lags": d.autocorrelation,
            "effective_n": d.effective_n,
            "sem_inflation": d.sem_inflation,
            "white_noise_band": d.white_noise_band,
            "sem_optimistic": d.optimistic,
            "warning": d.any_optimistic(),
        })
    });
    // The contract's statistics over all epochs are exactly `stats_json` of them; the rest
    // are extension fields.
    let mut out = stats_json(s);
    let extra = json!({
        "model": a.model.display().to_string(),
        "camera_a": a.camera_a,
        "camera_b": a.camera_b,
        "mm_per_unit": c.mm_per_unit,
        "scale_factor": c.mm_per_unit,
        "scale": scale_json,
        "outlier_rule": format!(
            "modified z-score 0.6745·(x − median)/MAD, |z| > {OUTLIER_THRESHOLD} on any of x y z ω φ κ (Iglewicz–Hoaglin)"
        ),
        "n_outliers": c.outliers.indices().len(),
        "without_outliers": c.without_outliers.as_ref().map(stats_json),
        "autocorrelation": drift,
        "refined": c.refined.as_ref().map(refined_json),
        "refined_without_outliers": c.refined_without_outliers.as_ref().map(refined_json),
        "pairing": {
            "by_name": set.paired_by_name,
            "by_frame": set.paired_by_frame,
            "unpaired_a": set.unpaired_a,
            "unpaired_b": set.unpaired_b,
            "without_pose": set.without_pose,
        },
        "epochs": epochs,
    });
    if let (Some(o), Value::Object(e)) = (out.as_object_mut(), extra) {
        o.extend(e);
    }
    out
}

fn row(out: &mut String, label: &str, v: [f64; 3], decimals: usize) {
    let _ = writeln!(
        out,
        "  {label:<12}{:>12.d$}{:>12.d$}{:>12.d$}",
        v[0],
        v[1],
        v[2],
        d = decimals
    );
}

fn text_report(a: &CalibrateArgs, set: &EpochSet, scale: &Scale, c: &Calibration) -> String {
    let mut o = String::new();
    let s = &c.all;
    let _ = writeln!(
        o,
        "Rig calibration of {}: B ({}) relative to A ({}), {} epochs ({} by name, {} by frame)",
        a.model.display(),
        a.camera_b,
        a.camera_a,
        s.n,
        set.paired_by_name,
        set.paired_by_frame
    );
    let _ = match scale {
        Scale::Bar(b) => writeln!(
            o,
            "Scale: {:.6} mm per model unit (scale bar: points {} and {}, {:.3} mm = {:.6} units)",
            b.mm_per_unit, b.point_1, b.point_2, b.length_mm, b.distance_units
        ),
        Scale::Given(f) => writeln!(o, "Scale: {f} mm per model unit (given)"),
        Scale::Default => writeln!(o, "Scale: 1 mm per model unit (default; no scale given)"),
    };
    let _ = writeln!(o);
    let _ = writeln!(o, "Table 1 – base: B's projection centre in A's frame (mm)");
    header(&mut o, ["X", "Y", "Z"]);
    stats_rows(&mut o, s, true);
    let _ = writeln!(o);
    let _ = writeln!(o, "Table 2 – orientation: ω φ κ of R_A_from_B (deg)");
    header(&mut o, ["ω", "φ", "κ"]);
    stats_rows(&mut o, s, false);
    row(&mut o, "SO(3) mean", deg3(&s.mean_rotation_angles), 4);
    let _ = writeln!(o);
    let idx = c.outliers.indices();
    let _ = writeln!(
        o,
        "Outliers (|modified z| > {OUTLIER_THRESHOLD} on any parameter): {}",
        idx.len()
    );
    for &i in &idx {
        let z = c.outliers.z_scores[i];
        let _ = writeln!(
            o,
            "  {:<16} z = [{}]",
            c.links[i].name,
            z.iter()
                .map(|v| format!("{v:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if !idx.is_empty() {
        match &c.without_outliers {
            Some(w) => {
                let _ = writeln!(o, "Without outliers ({} epochs):", w.n);
                header(&mut o, ["X (mm)", "Y (mm)", "Z (mm)"]);
                stats_rows(&mut o, w, true);
                header(&mut o, ["ω (deg)", "φ (deg)", "κ (deg)"]);
                stats_rows(&mut o, w, false);
            }
            None => {
                let _ = writeln!(o, "Without outliers: fewer than two epochs remain");
            }
        }
    }
    if let Some(d) = &c.drift {
        let _ = writeln!(o);
        let _ = writeln!(
            o,
            "Drift: lag-1 autocorrelation (white-noise band ±{:.3})",
            d.white_noise_band
        );
        for (j, name) in PARAMS.iter().enumerate() {
            let _ = writeln!(
                o,
                "  {:<6} r1 = {:>6.3}   n_eff ≈ {:>6.1}   SEM × {:.2}{}",
                name,
                d.autocorrelation[j][0],
                d.effective_n[j],
                d.sem_inflation[j],
                if d.optimistic[j] {
                    "   σ/√n likely optimistic"
                } else {
                    ""
                }
            );
        }
    }
    if let Some(r) = &c.refined {
        let _ = writeln!(o);
        let _ = writeln!(
            o,
            "Rig-constrained refinement ({} unknowns, redundancy {}, {} Gauss–Newton steps)",
            r.n_unknowns, r.redundancy, r.iterations,
        );
        let sr = deg3(&r.sigma_rotation);
        let sp = arr3(&r.sigma_position_mm);
        let _ = writeln!(
            o,
            "  per-pose σ in A's axes: rotation ({:.4}, {:.4}, {:.4}) deg, centre ({:.3}, {:.3}, {:.3}) mm",
            sr[0], sr[1], sr[2], sp[0], sp[1], sp[2]
        );
        let _ = writeln!(
            o,
            "  {:<8}{:>27}{:>27}",
            "", "epoch mean ± σ/√n", "refined ± σ"
        );
        for (j, name) in PARAMS.iter().enumerate() {
            let (m, e, rv, rs, d) = if j < 3 {
                (
                    s.base_mm[j],
                    s.base_sem_mm[j],
                    r.base_mm[j],
                    r.base_sigma_mm[j],
                    3,
                )
            } else {
                let k = j - 3;
                (
                    s.angles[k].to_degrees(),
                    s.angles_sem[k].to_degrees(),
                    r.angles[k].to_degrees(),
                    r.angles_sigma[k].to_degrees(),
                    4,
                )
            };
            let _ = writeln!(
                o,
                "  {:<8}{:>16.d$} ± {:>8.d$}{:>16.d$} ± {:>8.d$}",
                name,
                m,
                e,
                rv,
                rs,
                d = d
            );
        }
    }
    if let (Some(r), Some(w)) = (&c.refined_without_outliers, &c.without_outliers) {
        let _ = writeln!(
            o,
            "Rig-constrained refinement without the {} outlier epoch(s) ({} epochs):",
            idx.len(),
            w.n
        );
        for (j, name) in PARAMS.iter().enumerate() {
            let (v, sd, d) = if j < 3 {
                (r.base_mm[j], r.base_sigma_mm[j], 3)
            } else {
                (
                    r.angles[j - 3].to_degrees(),
                    r.angles_sigma[j - 3].to_degrees(),
                    4,
                )
            };
            let _ = writeln!(o, "  {name:<8}{:>43.d$} ± {:>8.d$}", v, sd, d = d);
        }
    }
    o
}

fn header(o: &mut String, names: [&str; 3]) {
    let _ = writeln!(
        o,
        "  {:<12}{:>12}{:>12}{:>12}",
        "", names[0], names[1], names[2]
    );
}

fn stats_rows(o: &mut String, s: &LinkStatistics, base: bool) {
    if base {
        row(o, "mean", arr3(&s.base_mm), 3);
        row(o, "σ (n−1)", arr3(&s.base_sigma_mm), 3);
        row(o, "σ/√n", arr3(&s.base_sem_mm), 3);
    } else {
        row(o, "mean", deg3(&s.angles), 4);
        row(o, "σ (n−1)", deg3(&s.angles_sigma), 4);
        row(o, "σ/√n", deg3(&s.angles_sem), 4);
    }
}

/// Writes the per-epoch series and histograms of the six parameters (PNG and SVG) to `dir`.
pub fn write_plots(dir: &Path, c: &Calibration) -> anyhow::Result<()> {
    use crashrig_plot::{Format, histogram, series};
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the plot directory", dir.display()))?;
    let series_rad = crashrig_rig::stats::parameter_series(&c.links)?;
    let xs: Vec<f64> = (1..=c.links.len()).map(|i| i as f64).collect();
    for j in 0..6 {
        let f = if j < 3 { 1.0 } else { 1f64.to_degrees() };
        let ys: Vec<f64> = series_rad[j].iter().map(|v| v * f).collect();
        let (mean, sigma) = if j < 3 {
            (c.all.base_mm[j], c.all.base_sigma_mm[j])
        } else {
            // Unwrapped series: the mean is continuous with the values.
            let m = ys.iter().sum::<f64>() / ys.len() as f64;
            (m, c.all.angles_sigma[j - 3].to_degrees())
        };
        for (fmt, ext) in [(Format::Png, "png"), (Format::Svg, "svg")] {
            let bytes = series(
                &xs,
                &ys,
                &format!("{} per epoch", LABELS[j]),
                "epoch",
                LABELS[j],
                fmt,
            )
            .with_context(|| format!("plotting the {} series", PARAMS[j]))?;
            let path = dir.join(format!("series_{}.{ext}", PARAMS[j]));
            crate::output::write_atomic(&path, &bytes)?;
            let bytes = histogram(
                &ys,
                &[mean - sigma, mean, mean + sigma],
                &format!(
                    "{} over {} epochs (lines: mean, mean ± σ)",
                    LABELS[j],
                    ys.len()
                ),
                LABELS[j],
                fmt,
            )
            .with_context(|| format!("plotting the {} histogram", PARAMS[j]))?;
            let path = dir.join(format!("hist_{}.{ext}", PARAMS[j]));
            crate::output::write_atomic(&path, &bytes)?;
            if let Some(d) = &c.drift {
                let r = &d.autocorrelation[j];
                let lags: Vec<f64> = (1..=r.len()).map(|k| k as f64).collect();
                let bytes = series(
                    &lags,
                    r,
                    &format!(
                        "autocorrelation of {} (white-noise bound {:.3})",
                        LABELS[j], d.white_noise_band
                    ),
                    "lag [epochs]",
                    "r",
                    fmt,
                )
                .with_context(|| format!("plotting the {} autocorrelation", PARAMS[j]))?;
                let path = dir.join(format!("acf_{}.{ext}", PARAMS[j]));
                crate::output::write_atomic(&path, &bytes)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    fn fixture(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../fixtures/rig")
            .join(name)
    }

    fn args(name: &str) -> CalibrateArgs {
        CalibrateArgs {
            model: fixture(name),
            camera_a: "cam_out/".into(),
            camera_b: "cam_in/".into(),
            scale_points: None,
            scale_length_mm: None,
            mm_per_unit: None,
            plots: None,
            max_lag: 10,
            no_refine: false,
        }
    }

    /// The JSON document of `calibrate` for the paper fixture with its scale bar.
    fn paper_json() -> (Value, Value) {
        let a = args("paper");
        let model = Reconstruction::read(&a.model).unwrap();
        let set = epochs_from_model(
            &model,
            &CameraSelector::parse(&a.camera_a),
            &CameraSelector::parse(&a.camera_b),
        )
        .unwrap();
        let scale = Scale::Bar(scale_from_points(&model, 1, 2, 2000.0).unwrap());
        let cal = calibrate(
            &set.epochs,
            scale.mm_per_unit(),
            &CalibrateOptions::default(),
        )
        .unwrap();
        let text = std::fs::read_to_string(fixture("paper").join("expected.json")).unwrap();
        (
            to_json(&a, &set, &scale, &cal),
            serde_json::from_str(&text).unwrap(),
        )
    }

    #[test]
    fn calibrate_json_nominal_has_contract_fields() {
        let (j, e) = paper_json();
        assert_eq!(j["n_epochs"], 140);
        let s = &e["stats"];
        for key in [
            "base_mm",
            "base_sigma_mm",
            "base_sem_mm",
            "angles_deg",
            "angles_sigma_deg",
            "angles_sem_deg",
        ] {
            for k in 0..3 {
                // The contract's 1e-6 mm / 1e-6° against numpy on the injected links.
                assert_abs_diff_eq!(
                    j[key][k].as_f64().unwrap(),
                    s[key][k].as_f64().unwrap(),
                    epsilon = 1e-6
                );
            }
        }
        for i in 0..6 {
            for k in 0..6 {
                assert_abs_diff_eq!(
                    j["covariance"][i][k].as_f64().unwrap(),
                    s["covariance"][i][k].as_f64().unwrap(),
                    epsilon = 1e-6
                );
            }
        }
        // Scale bar: 2000 mm over 5.4 model units, to rounding of the stored coordinates.
        assert_abs_diff_eq!(
            j["mm_per_unit"].as_f64().unwrap(),
            e["mm_per_unit"].as_f64().unwrap(),
            epsilon = 1e-9
        );
        let epochs = j["epochs"].as_array().unwrap();
        assert_eq!(epochs.len(), 140);
        for ep in epochs {
            assert!(ep["name"].is_string());
            assert!(ep["outlier"].is_boolean());
            assert_eq!(ep["base_mm"].as_array().unwrap().len(), 3);
            assert_eq!(ep["angles_deg"].as_array().unwrap().len(), 3);
        }
        assert_eq!(j["n_outliers"], 1);
        assert_eq!(j["without_outliers"]["n_epochs"], 139);
        assert_eq!(j["refined"]["n_unknowns"], 846);
        assert!(j["autocorrelation"]["lags"][0].is_array());
    }

    #[test]
    fn calibrate_text_nominal_shows_tables() {
        let a = args("paper");
        let model = Reconstruction::read(&a.model).unwrap();
        let set = epochs_from_model(
            &model,
            &CameraSelector::parse("cam_out/"),
            &CameraSelector::parse("cam_in/"),
        )
        .unwrap();
        let scale = Scale::Bar(scale_from_points(&model, 1, 2, 2000.0).unwrap());
        let cal = calibrate(
            &set.epochs,
            scale.mm_per_unit(),
            &CalibrateOptions::default(),
        )
        .unwrap();
        let t = text_report(&a, &set, &scale, &cal);
        assert!(t.contains("Table 1"), "{t}");
        assert!(t.contains("Table 2"), "{t}");
        assert!(t.contains("179.9200"), "{t}");
        assert!(t.contains("61.980"), "{t}");
        assert!(t.contains("refined"), "{t}");
    }

    #[test]
    fn calibrate_plots_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let model = Reconstruction::read(&fixture("wrap")).unwrap();
        let set = epochs_from_model(
            &model,
            &CameraSelector::parse("cam_out/"),
            &CameraSelector::parse("cam_in/"),
        )
        .unwrap();
        let cal = calibrate(&set.epochs, 1.0, &CalibrateOptions::default()).unwrap();
        write_plots(dir.path(), &cal).unwrap();
        for p in PARAMS {
            for ext in ["png", "svg"] {
                let f = dir.path().join(format!("series_{p}.{ext}"));
                assert!(
                    std::fs::metadata(&f).unwrap().len() > 1000,
                    "{}",
                    f.display()
                );
                let f = dir.path().join(format!("hist_{p}.{ext}"));
                assert!(
                    std::fs::metadata(&f).unwrap().len() > 1000,
                    "{}",
                    f.display()
                );
            }
        }
    }
}
