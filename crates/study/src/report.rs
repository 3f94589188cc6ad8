//! The study's outputs: `results.json`, each step's files and the self-contained
//! `report.html` (verdict per layout, plan sketch, full-width heat maps, per-axis maps, error
//! ellipses, inputs with provenance and the commands that regenerate every number).

use crate::Error;
use crate::files;
use crate::html::{Block, Report, Status, Table, Verdict, escape};
use crate::measure_step::MeasureResult;
use crate::pipeline::{LayoutResult, StudyResult, phi_deg};
use crate::study_file::{ChainCamera, ObserverNoise, Study, StudyScale, TieMethod, TieResample};
use crashrig_grid::summary::{self as grids, HeatMapPng};
use crashrig_measure::output::{self as measure_output, MarkerPlot};
use crashrig_stats::summary::median;
use std::fmt::Write as _;
use std::path::Path;

/// How the run was started, for the provenance section.
#[derive(Debug, Clone, Default)]
pub struct Provenance {
    /// The command line that produced this output, e.g. `crashrig study lab.toml --out out`.
    pub command: String,
    /// The output directory as the user named it.
    pub out_dir: String,
    /// Wall-clock time of the study's computation (s), stated in `report.html` (never in
    /// `results.json`, which stays reproducible byte for byte).
    pub run_time_s: Option<f64>,
    /// (step, seconds) of every step, in order.
    pub step_times_s: Vec<(String, f64)>,
}

/// The paper's published values (Kaminski et al.), for `reference = "kaminski2023"`.
pub mod published {
    /// Table 1: base (mm).
    pub const BASE_MM: [f64; 3] = [61.98, -1.71, 179.76];
    /// Table 1: σ/√n (mm).
    pub const BASE_SEM_MM: [f64; 3] = [0.19, 0.26, 0.13];
    /// Table 2: ω φ κ (deg).
    pub const ANGLES_DEG: [f64; 3] = [179.92, -0.09, 179.76];
    /// Table 2: σ/√n (deg).
    pub const ANGLES_SEM_DEG: [f64; 3] = [0.004, 0.005, 0.008];
    /// Table 3: σ of the translation in the world (mm), cam1..cam3.
    pub const TABLE3_MM: [[f64; 3]; 3] =
        [[1.00, 1.00, 1.00], [1.52, 1.54, 1.52], [2.53, 2.51, 2.55]];
    /// Table 4: σ of the orientation in the world (deg), cam1..cam3.
    pub const TABLE4_DEG: [[f64; 3]; 3] = [
        [0.01, 0.01, 0.01],
        [0.011, 0.011, 0.013],
        [0.023, 0.023, 0.024],
    ];
}

fn f3(v: [f64; 3], d: usize) -> String {
    format!("{:.d$} / {:.d$} / {:.d$}", v[0], v[1], v[2])
}

fn json_pretty(v: &serde_json::Value) -> Vec<u8> {
    let mut s = serde_json::to_string_pretty(v).unwrap_or_default();
    s.push('\n');
    s.into_bytes()
}

/// Writes everything below `dir`: `results.json`, `calibration/calibrate.json`,
/// `tie/bootstrap.json`, `grid/<layout>/{grid.csv, summary.json, *.png}` and `report.html`.
///
/// # Errors
/// [`Error::Write`] or [`Error::Plot`].
pub fn write_outputs(
    dir: &Path,
    study: &Study,
    r: &StudyResult,
    prov: &Provenance,
) -> Result<(), Error> {
    let results = r.to_json();
    files::write(
        &dir.join("calibration"),
        "calibrate.json",
        &json_pretty(&r.calibration.to_json()),
    )?;
    if let Some(t) = &r.tie {
        files::write(
            &dir.join("tie"),
            "bootstrap.json",
            &json_pretty(&t.to_json()),
        )?;
    }
    let mut maps = Vec::new();
    let scale = grids::MapScale::shared(r.layouts.iter().map(|l| (&l.grid, &l.result)));
    for (l, lj) in r
        .layouts
        .iter()
        .zip(results["layouts"].as_array().into_iter().flatten())
    {
        let d = dir.join("grid").join(l.layout.slug());
        files::write(
            &d,
            "grid.csv",
            grids::layout_csv(&l.grid, &l.result).as_bytes(),
        )?;
        files::write(&d, "grid.ply", &grids::grid_ply(&l.result))?;
        files::write(&d, "summary.json", &json_pretty(lj))?;
        let m = grids::heat_maps(&l.grid, &l.result, &scale)?;
        for h in &m {
            files::write(&d, &h.file, &h.png)?;
            files::write(&d, &h.file.replace(".png", ".svg"), &h.svg)?;
        }
        maps.push(m);
    }
    let (plots, kin_plots, length_plot) = match &r.measure {
        Some(m) => (
            write_measure(&dir.join("measure"), m)?,
            crate::kinematics_report::write(&dir.join("measure"), m)?,
            crate::length_report::write(&dir.join("measure"), m)?,
        ),
        None => (Vec::new(), Vec::new(), None),
    };
    files::write(dir, "results.json", &json_pretty(&results))?;
    let length_plot: Vec<MarkerPlot> = length_plot.into_iter().collect();
    let html = report_html(study, r, &maps, &[&plots, &kin_plots, &length_plot], prov);
    files::write(dir, "report.html", html.as_bytes())
}

/// `DIR/measure/`: the files `crashrig measure` writes (`trajectories.csv`,
/// `displacements.csv`, `plots/<marker>.png|svg`, `summary.json`); returns the plots.
fn write_measure(d: &Path, m: &MeasureResult) -> Result<Vec<MarkerPlot>, Error> {
    let ms = &m.measurement;
    files::write(
        d,
        "trajectories.csv",
        measure_output::trajectories_csv(ms).as_bytes(),
    )?;
    files::write(
        d,
        "displacements.csv",
        measure_output::displacements_csv(ms).as_bytes(),
    )?;
    let plots = measure_output::marker_plots(ms)
        .map_err(|e| crate::error::measure_plot_error(e, "trajectory"))?;
    for p in &plots {
        files::write(&d.join("plots"), &format!("{}.png", p.stem), &p.png)?;
        files::write(&d.join("plots"), &format!("{}.svg", p.stem), &p.svg)?;
    }
    if let Some(a) = &m.a_covariance {
        // What `crashrig covariance --out` writes, and the per-epoch σ plot of the report.
        files::write(d, "a_covariance.json", &json_pretty(&a.to_json()))?;
        for (format, ext) in [
            (crashrig_plot::Format::Png, "png"),
            (crashrig_plot::Format::Svg, "svg"),
        ] {
            let bytes =
                crate::measure_step::a_sigma_plot(a, format).map_err(|source| Error::Plot {
                    what: "camera A's σ per epoch".into(),
                    source,
                })?;
            files::write(d, &format!("a_sigma.{ext}"), &bytes)?;
        }
    }
    let summary = serde_json::to_value(&m.summary).unwrap_or_default();
    files::write(d, "summary.json", &json_pretty(&summary))?;
    Ok(plots)
}

/// The report section of the measured sequence: summary, the length check of the scale bars
/// (with `scale_bars`: its own subsection, and the trajectories then theirs), displacement σ vs
/// position σ per marker, flagged rows, and one trajectory plot per marker.
fn measure_report(
    rep: &mut Report,
    study: &Study,
    m: &MeasureResult,
    plots: &[MarkerPlot],
    length_plot: Option<&MarkerPlot>,
) {
    let Some(sec) = &study.measure else { return };
    let ms = &m.measurement;
    let s = &m.summary;
    rep.push(Block::Heading("The measured test sequence".into()));
    rep.push(Block::Paragraph(format!(
        "{} epochs × {} markers of {} (observations {}), measured with this study's calibrated link A_from_B{} — the same typed values the chain uses — camera A's per-epoch pose uncertainty and {} px pixel noise; {} Monte Carlo replicates per row (seed {}). The link and tie errors are one draw per replicate for the whole sequence (systematic during the test), A's pose error one per epoch, pixel noise one per observation; so the displacements from the reference epoch {:?} cancel most of the systematic part. Files: measure/trajectories.csv, measure/displacements.csv, measure/plots/.",
        s.epochs,
        s.markers,
        sec.model.display(),
        sec.observations.display(),
        if s.cameras.len() > 1 { " and the bootstrapped tie B_from_C" } else { "" },
        s.pixel_sigma_px,
        s.samples_per_point,
        s.seed,
        s.reference_epoch
    )));
    if let Some(a) = &m.a_covariance {
        a_covariance_report(rep, sec, a);
    }
    let opt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
    rep.push(Block::Table(Table {
        caption: "Summary".into(),
        header: [
            "rows",
            "measured",
            "below threshold",
            "median σ_max position [mm]",
            "median σ_max displacement [mm]",
            "flagged (fewer than two views / above threshold / reprojection outlier)",
        ]
        .map(String::from)
        .to_vec(),
        rows: vec![vec![
            s.rows.to_string(),
            s.rows_measured.to_string(),
            format!(
                "{:.1} % (< {} mm)",
                100.0 * s.fraction_below_threshold,
                s.threshold_mm
            ),
            opt(s.median_sigma_max_mm),
            opt(s.median_displacement_sigma_max_mm),
            format!(
                "{} ({} / {} / {})",
                s.rows_flagged,
                s.rows_fewer_than_two_views,
                s.rows_above_threshold,
                s.rows_reprojection_outlier
            ),
        ]],
    }));
    crate::length_report::section(rep, m, length_plot);
    crate::pixel_report::section(rep, m);
    if m.measurement.length_check.is_some() || m.summary.pixel_sigma_check.is_some() {
        rep.push(Block::SubHeading("Trajectories".into()));
    }
    let per_marker: Vec<Vec<String>> = ms
        .markers
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let rows: Vec<_> = ms.rows.iter().filter(|r| r.marker == k).collect();
            let pos: Vec<f64> = rows.iter().filter_map(|r| r.sigma_max_mm()).collect();
            let disp: Vec<f64> = rows
                .iter()
                .filter(|r| r.epoch != ms.reference_epoch)
                .filter_map(|r| r.displacement_sigma_mm.map(|v| v.max()))
                .collect();
            let (mp, md) = (
                median(&pos).unwrap_or(f64::NAN),
                median(&disp).unwrap_or(f64::NAN),
            );
            // A marker measured in no epoch has no median: "—", never NaN.
            let cell = |v: f64| {
                if v.is_finite() {
                    format!("{v:.3}")
                } else {
                    "—".into()
                }
            };
            vec![
                name.clone(),
                rows.len().to_string(),
                cell(mp),
                cell(md),
                if mp > 0.0 && md.is_finite() {
                    format!("{:.2}", md / mp)
                } else {
                    "—".into()
                },
            ]
        })
        .collect();
    rep.push(Block::Table(Table {
        caption: "Displacement σ vs position σ per marker (medians over the epochs; displacement from the reference epoch, which is left out)".into(),
        header: ["marker", "rows", "median σ_max position [mm]", "median σ_max displacement [mm]", "ratio"].map(String::from).to_vec(),
        rows: per_marker,
    }));
    let flagged: Vec<Vec<String>> = ms
        .rows
        .iter()
        .filter(|r| r.flags.any())
        .take(50)
        .map(|r| {
            vec![
                ms.epochs[r.epoch].name.clone(),
                ms.markers[r.marker].clone(),
                r.n_views.to_string(),
                r.sigma_max_mm().map_or("—".into(), |v| format!("{v:.3}")),
                r.reprojection_px.map_or("—".into(), |v| format!("{v:.2}")),
                r.flags.names().join(", "),
            ]
        })
        .collect();
    if flagged.is_empty() {
        rep.push(Block::Paragraph("No row is flagged.".into()));
    } else {
        rep.push(Block::Table(Table {
            caption: format!(
                "Flagged rows ({} of {}; at most 50 listed, all in measure/displacements.csv column flags)",
                s.rows_flagged, s.rows
            ),
            header: ["epoch", "marker", "views", "σ_max [mm]", "reprojection [px]", "flags"].map(String::from).to_vec(),
            rows: flagged,
        }));
    }
    if !m.warnings.is_empty() {
        rep.push(Block::List(
            m.warnings.iter().map(|w| format!("warning: {w}")).collect(),
        ));
    }
    for p in plots {
        rep.push(Block::Wide {
            caption: format!(
                "marker {}: x, y, z (world frame) against time with ±3σ bands",
                p.marker
            ),
            png: p.png.clone(),
        });
    }
}

/// Camera A's pose uncertainty from the bundle (`[measure] a_control_points`): σ̂₀ and the
/// pixel σ used, the adjustment's size, the σ per epoch (range table and plot against epoch).
fn a_covariance_report(
    rep: &mut Report,
    sec: &crate::study_file::MeasureSection,
    a: &crashrig_covariance::CovarianceResult,
) {
    let crate::study_file::MeasureANoise::Bundle(b) = &sec.a_noise else {
        return;
    };
    let given = b.pixel_sigma_px.is_some();
    rep.push(Block::Paragraph(format!(
        "Camera A's pose uncertainty comes from the bundle (crashrig covariance, docs/COVARIANCE.md): {} observations of {} with {} control points observed ({}), {} unknowns (intrinsics marginalised: {}), redundancy {}. σ̂₀ of the residuals = {}; pixel σ used = {:.3} px ({}). A's epochs of one replicate are drawn jointly from their joint covariance{}. File: measure/a_covariance.json.",
        a.observations,
        b.model.display(),
        a.control_points,
        b.control_points.display(),
        a.parameters,
        a.intrinsics.name(),
        a.redundancy,
        if a.sigma0_px.is_finite() { format!("{:.3} px", a.sigma0_px) } else { "— (no redundancy)".into() },
        a.pixel_sigma_px,
        if given { "a_pixel_sigma_px" } else { "σ̂₀" },
        if a.epochs.len() > crashrig_measure::input::MAX_JOINT_EPOCHS {
            " — except here: more epochs than measure draws jointly, so they are drawn independently"
        } else {
            ""
        }
    )));
    let per_axis: Vec<[f64; 6]> = a
        .epochs
        .iter()
        .map(|e| {
            let p = e.world_from_a.sigma_position();
            let r = e.world_from_a.sigma_rotation().map(f64::to_degrees);
            [p.x, p.y, p.z, r.x, r.y, r.z]
        })
        .collect();
    let names = [
        "x [mm]",
        "y [mm]",
        "z [mm]",
        "θx [deg]",
        "θy [deg]",
        "θz [deg]",
    ];
    let rows = (0..6)
        .map(|k| {
            let v: Vec<f64> = per_axis.iter().map(|s| s[k]).collect();
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let d = if k < 3 { 3 } else { 4 };
            vec![
                names[k].to_string(),
                format!("{min:.d$}"),
                format!("{:.d$}", median(&v).unwrap_or(f64::NAN)),
                format!("{max:.d$}"),
            ]
        })
        .collect();
    rep.push(Block::Table(Table {
        caption: format!(
            "Camera A's σ over its {} epochs (centre in world axes, rotation about A's own axes)",
            a.epochs.len()
        ),
        header: ["σ of", "min", "median", "max"].map(String::from).to_vec(),
        rows,
    }));
    if let Ok(png) = crate::measure_step::a_sigma_plot(a, crashrig_plot::Format::Png) {
        rep.push(Block::Wide {
            caption: "camera A: σ of its world pose against the epoch, from the bundle (measure/a_sigma.png)".into(),
            png,
        });
    }
}

/// The plan view of a layout (x right, y up, vehicle frame): grid points, observers with their
/// viewing directions (towards the grid centre: they re-aim at every point), and the outward
/// camera behind the rear observer looking out of the trunk (−x).
fn plan_sketch(l: &LayoutResult) -> String {
    let g = &l.grid;
    let pts = g.points();
    let mut xs: Vec<f64> = pts
        .iter()
        .map(|p| p.x)
        .chain(g.observers.iter().map(|o| o.position_mm.x))
        .collect();
    let mut ys: Vec<f64> = pts
        .iter()
        .map(|p| p.y)
        .chain(g.observers.iter().map(|o| o.position_mm.y))
        .collect();
    xs.push(0.0);
    ys.push(0.0);
    let (x0, x1) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min) - 150.0,
        xs.iter().copied().fold(f64::NEG_INFINITY, f64::max) + 150.0,
    );
    let (y0, y1) = (
        ys.iter().copied().fold(f64::INFINITY, f64::min) - 150.0,
        ys.iter().copied().fold(f64::NEG_INFINITY, f64::max) + 150.0,
    );
    let w = 900.0;
    let k = w / (x1 - x0);
    let h = (y1 - y0) * k;
    let px = |x: f64| (x - x0) * k;
    let py = |y: f64| (y1 - y) * k;
    // Legend lines under the sketch (the text is 12 px: about 130 characters fit in 900 px).
    let legend2 = if crashrig_grid::fixed_maps::has_fixed(g) {
        36.0
    } else {
        18.0
    };
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{:.0}\" viewBox=\"0 0 {w:.0} {:.0}\" style=\"background:#fafafa;border:1px solid #ccc;max-width:100%\">",
        h + 20.0 + legend2,
        h + 20.0 + legend2
    );
    let _ = write!(
        s,
        "<text x=\"6\" y=\"{:.0}\" font-size=\"12\">plan view (vehicle frame): x forwards from the trunk opening, y left; grey dots = grid points, red dots = σ_max at or above the threshold;</text><text x=\"6\" y=\"{:.0}\" font-size=\"12\">blue = interior cameras (arrow of an aimed camera: towards the grid, it re-aims at every point)</text>",
        h + 15.0,
        h + 33.0
    );
    let _ = write!(
        s,
        "<line x1=\"{:.1}\" y1=\"0\" x2=\"{:.1}\" y2=\"{h:.1}\" stroke=\"#888\" stroke-dasharray=\"4 3\"/><text x=\"{:.1}\" y=\"12\" font-size=\"11\" fill=\"#666\">x = 0 (trunk opening)</text>",
        px(0.0),
        px(0.0),
        px(0.0) + 3.0
    );
    for p in &l.result.points {
        if !p.is_measurable() {
            let _ = write!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"2.5\" fill=\"none\" stroke=\"#333\" stroke-width=\"0.8\"/>",
                px(p.point.x),
                py(p.point.y),
            );
            continue;
        }
        let bad = grids::not_below(p.sigma_max_mm, g.threshold_mm);
        let _ = write!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"2\" fill=\"{}\"/>",
            px(p.point.x),
            py(p.point.y),
            if bad { "#d22" } else { "#999" }
        );
    }
    if crashrig_grid::fixed_maps::has_fixed(g) {
        let _ = write!(
            s,
            "<text x=\"6\" y=\"{:.0}\" font-size=\"12\">open circles = not measurable (seen by fewer than two cameras); a fixed camera's arrow is its optical axis</text>",
            h + 51.0
        );
    }
    let cx = pts.iter().map(|p| p.x).sum::<f64>() / pts.len().max(1) as f64;
    let cy = pts.iter().map(|p| p.y).sum::<f64>() / pts.len().max(1) as f64;
    for o in &g.observers {
        let (ox, oy) = (o.position_mm.x, o.position_mm.y);
        // A fixed camera points along its optical axis (third column of R_world_from_cam);
        // an aimed one re-aims at every point: drawn towards the grid centre.
        let (dx, dy) = match &o.aim {
            crashrig_mc::Aim::Fixed(f) => (f.rotation[(0, 2)], f.rotation[(1, 2)]),
            crashrig_mc::Aim::Point => (cx - ox, cy - oy),
        };
        let n = (dx * dx + dy * dy).sqrt().max(1e-9);
        let (ux, uy) = (dx / n * 250.0, dy / n * 250.0);
        let _ = write!(
            s,
            "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"#06c\" stroke-width=\"2\" marker-end=\"url(#arr)\"/>",
            px(ox),
            py(oy),
            px(ox + ux),
            py(oy + uy)
        );
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"10\" height=\"10\" fill=\"#06c\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" fill=\"#036\">{}</text>",
            px(ox) - 5.0,
            py(oy) - 5.0,
            px(ox) + 8.0,
            py(oy) - 8.0,
            escape(&o.name)
        );
    }
    // The outward camera: at the rear, looking out of the trunk opening (−x).
    let rear = g
        .observers
        .iter()
        .map(|o| o.position_mm)
        .min_by(|a, b| a.x.total_cmp(&b.x));
    if let Some(r) = rear {
        let ox = r.x - 60.0;
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"10\" height=\"10\" fill=\"#c60\"/><line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"#c60\" stroke-width=\"2\" marker-end=\"url(#arr)\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" fill=\"#630\">outward camera A (looks out of the car)</text>",
            px(ox) - 5.0,
            py(r.y) - 5.0,
            px(ox),
            py(r.y),
            px(ox - 200.0),
            py(r.y),
            px(ox) - 5.0,
            py(r.y) + 22.0
        );
    }
    s.push_str("<defs><marker id=\"arr\" markerWidth=\"8\" markerHeight=\"8\" refX=\"6\" refY=\"3\" orient=\"auto\"><path d=\"M0,0 L6,3 L0,6 z\" fill=\"#333\"/></marker></defs></svg>");
    s
}

/// The "aim" cell of an observer: re-aimed, or fixed with its lens, pixel σ and coverage.
fn aim_cell(o: &crashrig_mc::Observer, l: &LayoutResult) -> String {
    match &o.aim {
        crashrig_mc::Aim::Point => "aimed at every point".into(),
        crashrig_mc::Aim::Fixed(f) => {
            let seen = l
                .summary
                .fixed
                .as_ref()
                .and_then(|fx| fx.observer_coverage.iter().find(|c| c.name == o.name))
                .map_or(f64::NAN, |c| c.fraction_seen);
            let p = &f.lens.params;
            format!(
                "fixed: {} {}×{} px, params [{}], pixel σ {} px; sees {:.0} % of the grid",
                f.lens.model.name(),
                f.lens.width,
                f.lens.height,
                p.iter()
                    .map(|v| format!("{v}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                f.pixel_sigma_px,
                100.0 * seen
            )
        }
    }
}

fn verdict_rows(r: &StudyResult) -> Vec<Vec<String>> {
    r.layouts
        .iter()
        .map(|l| {
            let s = &l.summary;
            if !s.max_sigma_mm.is_finite() {
                // Nothing measurable (a fixed layout whose cameras share no point): no σ at all.
                return vec![
                    l.layout.name.clone(),
                    "0.0 % (no point is seen by two cameras)".to_string(),
                    "0.0 %".to_string(),
                    "—".to_string(),
                    "—".to_string(),
                    "the whole grid is not measurable".to_string(),
                    "—".to_string(),
                ];
            }
            let worst = match s.worst.above_threshold_box_mm {
                Some(b) => format!(
                    "{} points ≥ {} mm within x {:.0}…{:.0}, y {:.0}…{:.0} mm; max {:.2} mm at ({:.0}, {:.0}, {:.0})",
                    s.worst.points_above_threshold, s.threshold_mm, b[0][0], b[0][1], b[1][0], b[1][1], s.max_sigma_mm, s.worst.max_point_mm[0], s.worst.max_point_mm[1], s.worst.max_point_mm[2]
                ),
                None => format!("all below; max {:.2} mm at ({:.0}, {:.0}, {:.0})", s.max_sigma_mm, s.worst.max_point_mm[0], s.worst.max_point_mm[1], s.worst.max_point_mm[2]),
            };
            let dominant = l
                .sensitivity
                .iter()
                .min_by(|a, b| a.median_sigma_max_mm.total_cmp(&b.median_sigma_max_mm))
                .map_or("—".to_string(), |d| format!("{} (median σ_max {:.2} → {:.2} mm with its σ halved)", d.input, s.median_sigma_max_mm, d.median_sigma_max_mm));
            let below = match &s.fixed {
                Some(f) => format!("{:.1} % (measurable at all: {:.1} %)", 100.0 * s.fraction_below_threshold, 100.0 * f.fraction_measurable),
                None => format!("{:.1} %", 100.0 * s.fraction_below_threshold),
            };
            vec![
                l.layout.name.clone(),
                below,
                format!("{:.1} %", 100.0 * s.fraction_worst_below_threshold),
                format!("{:.2}", s.median_sigma_max_mm),
                format!("{:.2}", s.median_sigma_worst_mm),
                worst,
                dominant,
            ]
        })
        .collect()
}

/// " SEM NOT RELIABLE on …" for the tangent axes whose effective n is below 10, else "".
fn unreliable_sem_note(c: &crashrig_calibrate::CalibrationResult) -> String {
    const AXES: [&str; 6] = ["x", "y", "z", "θx", "θy", "θz"];
    let bad: Vec<String> = (0..6)
        .filter(|&j| !c.sem_reliable[j])
        .map(|j| format!("{} (effective n {:.1})", AXES[j], c.effective_n[j]))
        .collect();
    if bad.is_empty() {
        return String::new();
    }
    format!(
        " SEM NOT RELIABLE on {}: the calibration sequence is too short for the drift seen (effective n < 10).",
        bad.join(", ")
    )
}

/// The assumption behind a layout whose observers take their σ from the same chain
/// (`from = …`) but are drawn independently — `correlated = false`, or observers that do not
/// stand at their chain cameras (so the physical default, [`crate::pipeline::resolve_correlated`],
/// cannot apply): stated in the verdict (issue 25 §5); `None` when no layout does that.
pub(crate) fn independent_chain_observers_note(r: &StudyResult) -> Option<String> {
    let names: Vec<String> = r
        .layouts
        .iter()
        .filter(|l| {
            !l.result.correlated
                && l.layout
                    .observers
                    .iter()
                    .filter(|o| o.fixed.is_none() && matches!(o.noise, ObserverNoise::From(_)))
                    .count()
                    >= 2
        })
        .map(|l| {
            let why = if l.layout.correlated == Some(false) {
                "`correlated = false`"
            } else {
                "observers not at their chain cameras"
            };
            format!("{} ({why})", l.layout.name)
        })
        .collect();
    (!names.is_empty()).then(|| format!(
        "Assumption of {}: the observers take their σ from the same chain (outward camera → link → tie) but are drawn independently of each other, although they share the outward camera's and the link's errors. The shared error then shifts the two rays by different random amounts instead of moving the whole rig as one rigid body, so σ_max there is not the physical (rigid-body) figure and can differ from it in either direction point by point; read these layouts as observers with independent errors of this run's size. A layout whose chain-fed observers stand at their chain cameras (the chain and the grid in one frame) is drawn jointly, as one rigid body, unless it sets `correlated = false` (docs/REFERENCE.md).",
        names.join(", ")
    ))
}

/// The paper's "what differs" item on fixed cameras: per layout and z level, the fraction
/// below the threshold with cameras re-aimed at every point (`*_z0_paper`, `*_z300_paper`) and
/// with the fixed cameras of `*_fixed_paper`, and the fraction measurable at all.
fn fixed_vs_aimed(r: &StudyResult) -> String {
    let find = |slug: &str| r.layouts.iter().find(|l| l.layout.slug() == slug);
    let mut parts = Vec::new();
    for (system, fixed) in [
        ("four", "four_cameras_fixed_paper"),
        ("three", "three_cameras_fixed_paper"),
    ] {
        let Some(f) = find(fixed) else { continue };
        for (z, aimed) in [(0.0, "z0"), (300.0, "z300")] {
            let Some(a) = find(&format!("{system}_cameras_{aimed}_paper")) else {
                continue;
            };
            let pts: Vec<_> = f.result.points.iter().filter(|p| p.point.z == z).collect();
            let n = pts.len().max(1) as f64;
            let below = pts
                .iter()
                .filter(|p| p.sigma_max_mm < f.layout.threshold_mm)
                .count() as f64
                / n;
            let measurable = pts.iter().filter(|p| p.is_measurable()).count() as f64 / n;
            parts.push(format!(
                "{system}-camera system at z = {z} mm: {:.0} % below {} mm re-aimed, {:.0} % fixed ({:.0} % measurable at all)",
                100.0 * a.summary.fraction_below_threshold,
                f.layout.threshold_mm,
                100.0 * below,
                100.0 * measurable
            ));
        }
    }
    if parts.is_empty() {
        return "Fixed cameras: the layouts *_fixed_paper are not in this study.".into();
    }
    format!(
        "Real fields of view (beyond the paper, layouts *_fixed_paper): the paper turns every camera towards every grid point. Bolted in place with the paper's 8 mm inward lens on a 2560 × 1440 sensor — assumed pixel pitch 5.0 µm (f = 1600 px; the 12.5 mm outward lens would be 2500 px but sees no interior point), principal point at the image centre (1280, 720) px, no distortion, no pixel noise — {}. Points seen by fewer than two cameras are not measurable with this layout and count as not below the threshold.",
        parts.join("; ")
    )
}

/// The report page: the verdicts and the table of contents first (a few screens), then one
/// collapsible section per step with the details. `measure_plots`: the measured sequence's
/// trajectory plots, its kinematics plots (with `cfc`) and its length check's plot (with
/// `scale_bars`; at most one).
pub fn report_html(
    study: &Study,
    r: &StudyResult,
    maps: &[Vec<HeatMapPng>],
    measure_plots: &[&[MarkerPlot]; 3],
    prov: &Provenance,
) -> String {
    let paper = study.reference.as_deref() == Some("kaminski2023");
    let mut rep = Report {
        title: if paper {
            "crashrig: uncertainty of an on-board crash-test camera system (paper reproduction)"
                .into()
        } else {
            format!("crashrig study: {}", study.path.display())
        },
        ..Default::default()
    };
    verdicts(&mut rep, r, paper, &r.unit_warnings(study));
    rep.push(Block::Raw(meta_html(study, r, prov)));
    rep.push(Block::Toc);
    view3d::section(&mut rep, r);
    rep.push(Block::Heading("Verdict per layout".into()));
    rep.push(Block::Table(Table {
        caption: "Fraction of the grid with σ_max below the threshold (per axis) and with the worst-direction σ below it (every direction), where the worst region is, and which input dominates (one at a time: the input whose halved σ lowers the median σ_max most)".into(),
        header: ["layout", "below threshold (σ_max)", "below threshold in every direction", "median σ_max [mm]", "median worst-direction σ [mm]", "worst region", "dominant input"].map(String::from).to_vec(),
        rows: verdict_rows(r),
    }));
    if let Some(note) = independent_chain_observers_note(r) {
        rep.push(Block::Paragraph(note));
    }
    calibration_section(&mut rep, study, r, paper);
    crate::quality_report::report_section(&mut rep, study, &r.calibration);
    tie_section(&mut rep, study, r);
    chain_section(&mut rep, r, paper);
    layouts_section(&mut rep, r, maps);
    if let Some(m) = &r.measure {
        measure_report(
            &mut rep,
            study,
            m,
            measure_plots[0],
            measure_plots[2].first(),
        );
        crate::kinematics_report::section(&mut rep, m, measure_plots[1]);
    }
    not_included(&mut rep, study, r);
    provenance_section(&mut rep, study, r, prov);
    if paper {
        paper_differences(&mut rep, study, r);
    }
    rep.to_html()
}

/// The line under the title: study file, seed, draws, the command, crashrig's version and the
/// run time with the time of each step (the report states them; `results.json` does not).
fn meta_html(study: &Study, r: &StudyResult, prov: &Provenance) -> String {
    let time = match prov.run_time_s {
        Some(t) => {
            // Summed per kind of step (calibration, tie, propagation, layouts, sensitivity,
            // measure), in order of first appearance.
            let mut kinds: Vec<(&str, f64, usize)> = Vec::new();
            for (s, t) in &prov.step_times_s {
                let k = s.split_whitespace().next().unwrap_or("");
                match kinds.iter_mut().find(|e| e.0 == k) {
                    Some(e) => {
                        e.1 += t;
                        e.2 += 1;
                    }
                    None => kinds.push((k, *t, 1)),
                }
            }
            let steps: Vec<String> = kinds
                .iter()
                .map(|(k, t, n)| {
                    if *n > 1 {
                        format!("{k} {t:.2} s over {n} runs")
                    } else {
                        format!("{k} {t:.2} s")
                    }
                })
                .collect();
            format!(
                " The study ran in {t:.2} s{}.",
                if steps.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", steps.join(", "))
                }
            )
        }
        None => " Run time: not measured (the library was called directly).".into(),
    };
    format!(
        "<p class=\"meta\">Study file {}; seed {}; {} Monte Carlo draws per grid point, {} draws of the chain. Produced by <code>{}</code> with crashrig {}.{}</p>",
        escape(&study.path.display().to_string()),
        r.seed,
        r.samples,
        r.chain_samples,
        escape(&prov.command),
        env!("CARGO_PKG_VERSION"),
        escape(&time)
    )
}

/// The first screen: the inputs' plausibility when a length looks typed in another unit (it
/// qualifies every answer after it), the answer table and the layout names, the calibration's
/// verdict (and the length check's), then the boxes with the long lists.
fn verdicts(rep: &mut Report, r: &StudyResult, paper: bool, unit_warnings: &[String]) {
    if let Some(v) = units_verdict(unit_warnings) {
        rep.push(Block::Raw("<div class=\"verdicts\">".into()));
        rep.push(Block::Verdict(v));
        rep.push(Block::Raw("</div>".into()));
    }
    crate::first_screen::push(rep, r, paper);
    rep.push(Block::Raw("<div class=\"verdicts\">".into()));
    rep.push(Block::Verdict(crate::quality_report::verdict(
        &r.calibration,
    )));
    if let Some(v) = r.measure.as_ref().and_then(crate::length_report::verdict) {
        rep.push(Block::Verdict(v));
    }
    if let Some(v) = r.measure.as_ref().and_then(crate::pixel_report::verdict) {
        rep.push(Block::Verdict(v));
    }
    rep.push(Block::Raw("</div>".into()));
    rep.push(Block::Raw("<div class=\"verdicts\">".into()));
    crate::first_screen::list_boxes(rep, r);
    rep.push(Block::Raw("</div>".into()));
}

/// The unit warnings as a verdict (`None` without any): the inputs hold a length or σ that
/// looks typed in another unit, so the verdicts computed from them are qualified.
fn units_verdict(unit_warnings: &[String]) -> Option<Verdict> {
    (!unit_warnings.is_empty()).then(|| Verdict {
        question: "Are the inputs' lengths plausible (millimetres)?".into(),
        answer: format!(
            "No: {} length{} or σ look{} typed in another unit (metres?); the answers below hold only if {} right — every one stands unless a length is in the wrong unit.",
            unit_warnings.len(),
            if unit_warnings.len() == 1 { "" } else { "s" },
            if unit_warnings.len() == 1 { "s" } else { "" },
            if unit_warnings.len() == 1 { "it is" } else { "they are" }
        ),
        lines: unit_warnings.iter().map(|w| format!("warning: {w}")).collect(),
        status: Status::Fail,
    })
}

fn calibration_section(rep: &mut Report, study: &Study, r: &StudyResult, paper: bool) {
    // Calibration.
    let c = &r.calibration;
    let link = &c.link;
    let t = link.b_from_a.translation.vector;
    let opk =
        crashrig_geometry::opk::opk_from_rotation(&link.b_from_a.rotation.to_rotation_matrix());
    let sem = crate::pipeline::tangent_sigma_deg(link);
    let sem_p = [
        link.covariance[(0, 0)].sqrt(),
        link.covariance[(1, 1)].sqrt(),
        link.covariance[(2, 2)].sqrt(),
    ];
    rep.push(Block::Heading("Rig calibration: the link A_from_B".into()));
    rep.push(Block::Paragraph(format!(
        "{} epochs of {} (A = {:?}, B = {:?}); base = B's centre in A's frame, angles = ω φ κ of R_A_from_B. The chain uses the mean link with its SEM covariance (rule: {}).{}",
        c.n_epochs, study.calibration.model.display(), study.calibration.camera_a, study.calibration.camera_b, c.sem_rule,
        unreliable_sem_note(c)
    )));
    let mut tc = Table {
        caption: "Calibrated link (this run)".into(),
        header: ["", "x / ω", "y / φ", "z / κ"].map(String::from).to_vec(),
        rows: vec![
            vec![
                "base [mm]".into(),
                format!("{:.2}", t.x),
                format!("{:.2}", t.y),
                format!("{:.2}", t.z),
            ],
            vec![
                "SEM base [mm]".into(),
                format!("{:.3}", sem_p[0]),
                format!("{:.3}", sem_p[1]),
                format!("{:.3}", sem_p[2]),
            ],
            vec![
                "angles [°]".into(),
                format!("{:.3}", opk.omega.to_degrees()),
                format!("{:.3}", opk.phi.to_degrees()),
                format!("{:.3}", opk.kappa.to_degrees()),
            ],
            vec![
                "SEM tangent θx θy θz [°]".into(),
                format!("{:.4}", sem[0]),
                format!("{:.4}", sem[1]),
                format!("{:.4}", sem[2]),
            ],
        ],
    };
    if paper {
        tc.rows.push(vec![
            "paper base [mm]".into(),
            format!("{:.2}", published::BASE_MM[0]),
            format!("{:.2}", published::BASE_MM[1]),
            format!("{:.2}", published::BASE_MM[2]),
        ]);
        tc.rows.push(vec![
            "paper σ/√n base [mm]".into(),
            format!("{:.2}", published::BASE_SEM_MM[0]),
            format!("{:.2}", published::BASE_SEM_MM[1]),
            format!("{:.2}", published::BASE_SEM_MM[2]),
        ]);
        tc.rows.push(vec![
            "paper angles [°]".into(),
            format!("{:.2}", published::ANGLES_DEG[0]),
            format!("{:.2}", published::ANGLES_DEG[1]),
            format!("{:.2}", published::ANGLES_DEG[2]),
        ]);
        tc.rows.push(vec![
            "paper σ/√n angles [°]".into(),
            format!("{:.3}", published::ANGLES_SEM_DEG[0]),
            format!("{:.3}", published::ANGLES_SEM_DEG[1]),
            format!("{:.3}", published::ANGLES_SEM_DEG[2]),
        ]);
    }
    rep.push(Block::Table(tc));
    if !c.warnings.is_empty() {
        rep.push(Block::List(
            c.warnings.iter().map(|w| format!("warning: {w}")).collect(),
        ));
    }
}

fn tie_section(rep: &mut Report, study: &Study, r: &StudyResult) {
    // Tie.
    if let (Some(tie), Some(ts)) = (&r.tie, &study.tie) {
        let l = &tie.link;
        let tt = l.b_from_a.translation.vector;
        let s = crate::pipeline::tangent_sigma_deg(l);
        let sp = [
            l.covariance[(0, 0)].sqrt(),
            l.covariance[(1, 1)].sqrt(),
            l.covariance[(2, 2)].sqrt(),
        ];
        let o =
            crashrig_geometry::opk::opk_from_rotation(&l.b_from_a.rotation.to_rotation_matrix());
        rep.push(Block::Heading(
            "The tie: bootstrap of the third camera".into(),
        ));
        rep.push(Block::Paragraph(format!(
            "{} replicates ({} orientation) of {:?} relative to {:?} from {} and {}; resampled: {}. The chain uses the link with the covariance of the replicates.",
            ts.iterations,
            match ts.method { TieMethod::Absolute => "absolute", TieMethod::Relative => "relative" },
            ts.image_b, ts.image_a, ts.database.display(), ts.model.display(),
            match ts.resample { TieResample::Inliers => "the verified inliers only (the default; paper §2.3.1 resamples all matches)", TieResample::AllMatches => "all matches (paper §2.3.1)" }
        )));
        rep.push(Block::Table(Table {
            caption: "Tie link B_from_C".into(),
            header: ["", "x / ω", "y / φ", "z / κ"].map(String::from).to_vec(),
            rows: vec![
                vec![
                    "base [mm]".into(),
                    format!("{:.2}", tt.x),
                    format!("{:.2}", tt.y),
                    format!("{:.2}", tt.z),
                ],
                vec![
                    "bootstrap σ base [mm]".into(),
                    format!("{:.3}", sp[0]),
                    format!("{:.3}", sp[1]),
                    format!("{:.3}", sp[2]),
                ],
                vec![
                    "angles [°]".into(),
                    format!("{:.3}", o.omega.to_degrees()),
                    format!("{:.3}", o.phi.to_degrees()),
                    format!("{:.3}", o.kappa.to_degrees()),
                ],
                vec![
                    "bootstrap σ tangent θx θy θz [°]".into(),
                    format!("{:.4}", s[0]),
                    format!("{:.4}", s[1]),
                    format!("{:.4}", s[2]),
                ],
            ],
        }));
    }
}

fn chain_section(rep: &mut Report, r: &StudyResult, paper: bool) {
    // Chain.
    rep.push(Block::Heading(
        "Propagation through the chain (world poses)".into(),
    ));
    rep.push(Block::Paragraph(format!(
        "{} Monte Carlo draws of the outward camera's world pose and {}, composed; first-order propagation beside it. Position σ in world axes; rotation σ both as the tangent σ (small rotations about the camera's own axes — what the grid uses) and as σ of ω φ κ (display only).",
        r.chain_samples,
        if r.tie.is_some() {
            "the calibrated link and the tie"
        } else {
            "the calibrated link (this study has no tie)"
        }
    )));
    let mut t3 = Table {
        caption: "World pose σ of every camera of the chain".into(),
        header: [
            "camera",
            "world φ [°]",
            "σ position MC [mm]",
            "σ tangent MC [°]",
            "σ ω φ κ MC [°]",
            "σ position first order [mm]",
            "σ tangent first order [°]",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    for cp in &r.chain {
        let m = &cp.mc;
        let d = |v: nalgebra::Vector3<f64>| -> [f64; 3] { v.map(f64::to_degrees).into() };
        t3.rows.push(vec![
            cp.camera.name().into(),
            format!("{:.1}", m.nominal.angles_rad().y.to_degrees()),
            f3(m.position_sigma_mm.into(), 3),
            f3(d(m.tangent_sigma_rad), 4),
            f3(d(m.angles_sigma_rad), 4),
            f3(cp.linear.position_sigma_mm.into(), 3),
            f3(d(cp.linear.tangent_sigma_rad), 4),
        ]);
    }
    if paper {
        for (i, name) in ["paper cam1", "paper cam2", "paper cam3"]
            .iter()
            .enumerate()
        {
            t3.rows.push(vec![
                name.to_string(),
                String::new(),
                f3(published::TABLE3_MM[i], 2),
                String::new(),
                f3(published::TABLE4_DEG[i], 3),
                String::new(),
                String::new(),
            ]);
        }
    }
    rep.push(Block::Table(t3));
    if let Some(cp) = r.chain.iter().find(|c| c.camera == ChainCamera::Tie) {
        let phi = cp.mc.nominal.angles_rad().y.to_degrees();
        let link_phi = r.tie.as_ref().map_or(f64::NAN, |t| phi_deg(&t.link));
        rep.push(Block::Raw(format!(
            "<p class=\"note\">Why the tie camera's two rotation σ differ: its world pose has φ = {phi:.1}° (the tie link itself φ = {link_phi:.1}°). Near |φ| = 90° the ω φ κ parametrization is singular: ω and κ describe almost the same rotation, so tiny body-axis rotations show up as large, strongly correlated ω and κ changes. The ω φ κ σ ({}°) therefore overstate the pose's rotation uncertainty; the tangent σ ({}°) is what a rotation of the camera actually does and is what the grid uses. Passing ω φ κ σ on as tangent σ would overstate the observers' noise.</p>",
            f3(cp.mc.angles_sigma_rad.map(f64::to_degrees).into(), 4),
            f3(cp.mc.tangent_sigma_rad.map(f64::to_degrees).into(), 4)
        )));
    }
}

fn provenance_section(rep: &mut Report, study: &Study, r: &StudyResult, prov: &Provenance) {
    rep.push(Block::Heading("Inputs and provenance".into()));
    let cal = &study.calibration;
    let scale = match cal.scale {
        StudyScale::ScaleBar { points, length_mm } => format!(
            "--scale-points {} {} --scale-length-mm {length_mm}",
            points[0], points[1]
        ),
        StudyScale::MmPerUnit(f) => format!("--mm-per-unit {f}"),
    };
    let mut inputs = vec![
        format!("study file: {}", study.path.display()),
        format!(
            "calibration model: {} (cameras {:?} and {:?}, {scale})",
            cal.model.display(),
            cal.camera_a,
            cal.camera_b
        ),
        format!(
            "outward camera world σ (from the study file [outward]): position {} mm, tangent {}°",
            f3(
                [
                    study.outward.covariance[(0, 0)].sqrt(),
                    study.outward.covariance[(1, 1)].sqrt(),
                    study.outward.covariance[(2, 2)].sqrt()
                ],
                3
            ),
            f3(crate::pipeline::tangent_sigma_deg(&study.outward), 4)
        ),
        format!(
            "seed {} (every random step), {} grid draws per point, {} chain draws",
            r.seed, r.samples, r.chain_samples
        ),
    ];
    if let Some(t) = &study.tie {
        inputs.push(format!(
            "tie: database {}, model {}, images {:?} → {:?}",
            t.database.display(),
            t.model.display(),
            t.image_a,
            t.image_b
        ));
    }
    rep.push(Block::List(inputs));
    rep.push(Block::Heading(
        "Commands that regenerate every number".into(),
    ));
    let mut cmds = vec![format!(
        "crashrig calibrate {} --camera-a {} --camera-b {} {scale} --max-lag {}{} --json   # = results.json \"calibration\"",
        cal.model.display(),
        cal.camera_a,
        cal.camera_b,
        cal.max_lag,
        if cal.refine { "" } else { " --no-refine" }
    )];
    if let Some(t) = &study.tie {
        cmds.push(format!(
            "crashrig bootstrap {} --model {} --image-a {} --image-b {} --method {} --iterations {} --mm-per-unit {} --max-error-px {} --seed {} --json   # = results.json \"tie\"",
            t.database.display(), t.model.display(), t.image_a, t.image_b,
            match t.method { TieMethod::Absolute => "absolute", TieMethod::Relative => "relative" },
            t.iterations, t.mm_per_unit, t.max_error_px, r.seed
        ));
    }
    if let (Some(m), Some(mr)) = (&study.measure, &r.measure) {
        let dir = if prov.out_dir.is_empty() {
            "DIR"
        } else {
            &prov.out_dir
        };
        let a_noise = match &m.a_noise {
            crate::study_file::MeasureANoise::File(p) => format!("--a-covariance {}", p.display()),
            crate::study_file::MeasureANoise::Bundle(b) => {
                cmds.push(format!(
                    "crashrig covariance {} --camera {} --control-points {} --mm-per-unit {}{} --intrinsics {} --out {dir}/measure/a_covariance.json   # = {dir}/measure/a_covariance.json",
                    b.model.display(),
                    m.camera_a,
                    b.control_points.display(),
                    m.mm_per_unit.unwrap_or(1.0),
                    b.pixel_sigma_px.map_or(String::new(), |s| format!(" --pixel-sigma-px {s}")),
                    b.intrinsics.name()
                ));
                format!("--a-covariance {dir}/measure/a_covariance.json")
            }
            crate::study_file::MeasureANoise::Sigmas(p, a) => format!(
                "--sigma-a-position-mm {} {} {} --sigma-a-angles-deg {} {} {}",
                p.x, p.y, p.z, a.x, a.y, a.z
            ),
        };
        cmds.push(format!(
            "crashrig measure {} --camera-a {} --camera-b {}{} --link {dir}/calibration/calibrate.json{} --observations {}{} {a_noise} --pixel-sigma-px {} --samples {} --threshold-mm {}{}{}{}{} --seed {} --out MEASURE_DIR   # = {dir}/measure/ (the study passes the link with the SO(3) mean rotation; the command reads angles_deg, the per-angle mean: set angles_deg to mean_rotation_angles_deg for identical numbers)",
            m.model.display(),
            m.camera_a,
            m.camera_b,
            m.camera_c.as_ref().map_or(String::new(), |c| format!(" --camera-c {c}")),
            if m.camera_c.is_some() { format!(" --tie {dir}/tie/bootstrap.json") } else { String::new() },
            m.observations.display(),
            m.mm_per_unit.map_or(String::new(), |f| format!(" --mm-per-unit {f}")),
            m.pixel_sigma_px,
            mr.summary.samples_per_point,
            m.threshold_mm,
            m.reference_epoch.as_ref().map_or(String::new(), |e| format!(" --reference-epoch {e}")),
            m.frame_rate_hz.map_or(String::new(), |f| format!(" --frame-rate-hz {f}")),
            m.max_reprojection_px.map_or(String::new(), |f| format!(" --max-reprojection-px {f}")),
            crate::kinematics_report::flags(m),
            r.seed
        ));
    }
    cmds.push(format!(
        "crashrig study {} --out {} --seed {} --samples {}   # everything, this page included",
        study.path.display(),
        if prov.out_dir.is_empty() {
            "DIR"
        } else {
            &prov.out_dir
        },
        r.seed,
        r.samples
    ));
    rep.push(Block::List(cmds));
}

/// The paper reproduction's "What differs from the paper, and why".
fn paper_differences(rep: &mut Report, study: &Study, r: &StudyResult) {
    rep.push(Block::Heading(
        "What differs from the paper, and why".into(),
    ));
    let rear = |stem: &str| {
        r.layouts.iter().find(|l| l.layout.slug() == stem).map(|l| {
            let rb: Vec<f64> = l
                .result
                .points
                .iter()
                .filter(|p| p.point.x <= 800.0)
                .map(|p| p.sigma_max_mm)
                .collect();
            median(&rb).unwrap_or(f64::NAN)
        })
    };
    let fig13 = match (rear("three_cameras_z0_paper"), rear("three_cameras_z300_paper")) {
        (Some(a), Some(b)) => format!(
            "Figure 13: the paper reports that raising the points by 30 cm increases σ_max in the rear area. With the assumed layout this is not reproduced: the rear band (x ≤ 800 mm) median σ_max goes {a:.2} → {b:.2} mm ({}). The paper gives no layout dimensions; ours are assumptions (fixtures/scenarios/README.md), so this shape is not confirmed.",
            if b > a { "it rises here" } else { "it falls instead of rising" }
        ),
        _ => "Figure 13: layouts three_cameras_z0_paper / three_cameras_z300_paper not in this study.".into(),
    };
    let resample = match study.tie.as_ref().map(|t| t.resample) {
        Some(TieResample::AllMatches) => {
            "The bootstrap resampled all matches, as paper §2.3.1 describes."
        }
        _ => {
            "The bootstrap resampled the verified inliers only (crashrig's default, `resample = \"inliers\"`); paper §2.3.1 says all matches are resampled (`resample = \"matches\"`)."
        }
    };
    let fixed = fixed_vs_aimed(r);
    rep.push(Block::List(vec![
        fixed,
        "Tables 1–2: the bundled sequence was generated with the paper's statistics, so agreement checks the estimator (pairing, SO(3) mean, wrap-safe angles, scale bar), not the lab.".into(),
        "Table 3: the paper's cam2/cam3 translation σ (1.52/2.53 mm) cannot be reproduced from its stated inputs (docs/table3.md); the layouts named *_paper use the paper's Table 3–4 σ directly so Figures 10–13 are comparable, the layouts named *_this_run use this run's propagated σ.".into(),
        "Figures 8–9: the bundled two-view scene gives a smaller bootstrap spread than the paper's real image pair.".into(),
        fig13,
        resample.into(),
        "The world frame is the outward camera's frame (its pose is the identity); the layouts' vehicle frame is taken with parallel axes, so the observers take the chain cameras' world covariance unchanged.".into(),
    ]));
}

/// "Forward intersection over the interior": the method, then one collapsible subsection per
/// layout.
fn layouts_section(rep: &mut Report, r: &StudyResult, maps: &[Vec<HeatMapPng>]) {
    rep.push(Block::Heading(
        "Forward intersection over the interior, per layout".into(),
    ));
    let scale = grids::MapScale::shared(r.layouts.iter().map(|l| (&l.grid, &l.result)));
    rep.push(Block::Paragraph(format!(
        "Each grid point (vehicle frame: x forwards from the trunk opening, y left, z up) is observed by the layout's cameras aimed at it without roll, intersected by linear least squares (DLT) for every draw; σx σy σz are the sample standard deviations, σ_max the largest of them, and the worst-direction σ the square root of the largest eigenvalue of the point's 3×3 covariance (the σ along the direction in which the point is least certain; a 5 mm promise holds in every direction only when it is below 5 mm). Every σ map of this study shares one colour scale, 0 to {} mm, chosen from the data (90th percentile of the worst-direction σ over all layouts, at least 1.2× the threshold; larger values saturate); the threshold is the white contour on the map and the black mark on the colour bar. The maps show the interior cameras (red triangles), the outward camera A (behind the rear-most interior camera, looking out of the trunk) and a sketch of the car (grey, trunk opening at x = 0; not a vehicle model).",
        scale.top_mm
    )));
    if r.layouts
        .iter()
        .any(|l| crashrig_grid::fixed_maps::has_fixed(&l.grid))
    {
        rep.push(Block::Paragraph("Layouts with fixed cameras (aim = \"fixed\"): a fixed camera is bolted in place with a real lens; it sees a point only when the point lies in front of it and projects inside its image (COLMAP's pixel convention). Each draw observes the true projection plus the camera's pixel noise, undistorts it through the lens model and intersects the perturbed rays of the cameras that see the point. A point seen by fewer than two cameras is not measurable: hatched grey on the maps, blank in grid.csv, and counted as not below the threshold. The outlines are each fixed camera's field-of-view footprint on the plane; a map of the number of cameras seeing each point follows the σ maps.".into()));
    }
    for (l, m) in r.layouts.iter().zip(maps) {
        layout_section(rep, l, m);
    }
}

/// One layout: observers, sensitivity, plan sketch, the σ_max and worst-direction maps (and
/// the camera count), the per-axis maps (collapsed) and the error ellipses.
fn layout_section(rep: &mut Report, l: &LayoutResult, m: &[HeatMapPng]) {
    rep.push(Block::SubHeading(format!("Layout: {}", l.layout.name)));
    if !l.layout.description.is_empty() {
        rep.push(Block::Paragraph(l.layout.description.clone()));
    }
    rep.push(Block::Table(observer_table(l)));
    let s = &l.summary;
    // A layout with nothing measurable has no σ to summarise (its verdict row says so).
    if s.max_sigma_mm.is_finite() {
        let mut rows = vec![vec![
            "as given".into(),
            format!("{:.2}", s.median_sigma_max_mm),
            format!("{:.1} %", 100.0 * s.fraction_below_threshold),
        ]];
        for x in &l.sensitivity {
            rows.push(vec![
                format!("σ of {} halved", x.input),
                format!("{:.2}", x.median_sigma_max_mm),
                format!("{:.1} %", 100.0 * x.fraction_below_threshold),
            ]);
        }
        rep.push(Block::Table(Table {
            caption: format!("One-at-a-time sensitivity (median σ_x σ_y σ_z = {} mm; first-order median σ_max {:.2} mm)", f3(s.median_sigma_mm, 2), s.linear_median_sigma_max_mm),
            header: ["inputs", "median σ_max [mm]", "below threshold"].map(String::from).to_vec(),
            rows,
        }));
    }
    rep.push(Block::Raw(plan_sketch(l)));
    let fixed = if l.summary.fixed.is_some() {
        "; outlines: field-of-view footprints; hatched: not measurable"
    } else {
        ""
    };
    for h in m
        .iter()
        .filter(|h| ["sigma_max", "sigma_worst", "observers_seen"].contains(&h.stem))
    {
        let what = match h.stem {
            "observers_seen" => "number of cameras seeing each point",
            "sigma_worst" => "worst-direction σ (largest eigen-axis of the covariance)",
            _ => "σ_max (largest of σx σy σz)",
        };
        rep.push(Block::Wide {
            caption: format!(
                "{}: {what} at z = {} mm (threshold {} mm{fixed})",
                l.layout.name, h.z_mm, l.summary.threshold_mm
            ),
            png: h.png.clone(),
        });
    }
    // The per-axis maps are files next to grid.csv (linked, not embedded: the page stays
    // small).
    let links: Vec<String> = m
        .iter()
        .filter(|h| ["sigma_x", "sigma_y", "sigma_z"].contains(&h.stem))
        .map(|h| {
            let path = format!("grid/{}/{}", l.layout.slug(), h.file);
            format!(
                "<a href=\"{}\">{} at z = {} mm</a>",
                escape(&path),
                escape(&h.stem.replace("sigma_", "σ")),
                h.z_mm
            )
        })
        .collect();
    rep.push(Block::Raw(format!(
        "<p>Per-axis maps (same colour scale, files next to grid.csv): {}.</p>",
        links.join(", ")
    )));
    ellipse_figures(rep, l);
}

fn observer_table(l: &LayoutResult) -> Table {
    Table {
        caption: "Observers".into(),
        header: [
            "observer",
            "position [mm]",
            "noise from",
            "σ position [mm]",
            "σ tangent [°]",
            "aim",
        ]
        .map(String::from)
        .to_vec(),
        rows: l
            .grid
            .observers
            .iter()
            .zip(&l.layout.observers)
            .zip(&l.result.observer_sigma)
            .map(|((o, lo), s)| {
                vec![
                    o.name.clone(),
                    f3(o.position_mm.into(), 0),
                    match lo.noise {
                        ObserverNoise::From(c) => format!("chain camera {}", c.name()),
                        ObserverNoise::Given(_) => "given in the study file".into(),
                    },
                    f3(s.position_mm.into(), 3),
                    f3(s.angles_rad.map(f64::to_degrees).into(), 4),
                    aim_cell(o, l),
                ]
            })
            .collect(),
    }
}

/// "What this uncertainty does not include": the error sources outside the model, named for
/// this study (which parts are modelled depends on its inputs).
fn not_included(rep: &mut Report, study: &Study, r: &StudyResult) {
    rep.push(Block::Heading(
        "What this uncertainty does not include".into(),
    ));
    rep.push(Block::Paragraph("Every σ on this page is the spread caused by the inputs' stated uncertainties, propagated through a model that is assumed exact. A lab should add, or bound separately:".into()));
    let mut items = vec![
        "Model errors: the vehicle frame is taken parallel to the world frame of the outward camera, the link is assumed rigid during the crash (no deformation of the mount under load), and the cameras' positions in the layouts are the study file's nominal values.".to_string(),
        "The lens model: the intrinsics and distortion of every camera are taken as exact (COLMAP's refined values); their own uncertainty and any lens model error (e.g. a distortion model too simple for the lens, focus breathing, temperature) are not propagated.".into(),
        "Rolling shutter and motion blur: every image is treated as one instant (global shutter); a rolling-shutter readout during fast motion shifts rows in time.".into(),
        "Marker identification and sub-pixel centring bias: pixel noise is Gaussian and unbiased; a systematic offset of a marker's detected centre (perspective, lighting, partial occlusion) is not.".into(),
        format!(
            "Scale: the model's scale ({}) is taken as exact; an error of the scale bar's length scales every distance.",
            match study.calibration.scale {
                StudyScale::ScaleBar { length_mm, .. } => format!("scale bar of {length_mm} mm"),
                StudyScale::MmPerUnit(f) => format!("{f} mm per model unit"),
            }
        ),
    ];
    items.push(match &study.measure {
        Some(_) => "Timing: the measured sequence assumes camera A and the inward cameras are triggered together unless a synchronisation σ is given; frame-time jitter is not modelled.".into(),
        None => "Timing: this study has no measured sequence; the synchronisation of camera A and the inward cameras during a crash (trigger offset, frame-time jitter) is not modelled.".into(),
    });
    if r.tie.is_none() {
        items.push("A third, tied-in camera: this study has none, so nothing of a tie's uncertainty is included.".into());
    }
    items.push("Statistical noise of the Monte Carlo itself: with n draws a σ is known to about σ/√(2n) (see the draws in the first line).".into());
    rep.push(Block::List(items));
}

/// 1σ error ellipses in plan (x–y) and side (x–z) view at a subsample of points of the first
/// z level, magnified, with axes, ticks and a key (`crashrig_plot::ellipses`).
fn ellipse_figures(rep: &mut Report, l: &LayoutResult) {
    let g = &l.grid;
    let (xs, ys) = (g.x.values(), g.y.values());
    let step_x = (xs.len() / 6).max(1);
    let step_y = (ys.len() / 5).max(1);
    let spacing = if xs.len() > 1 {
        (xs[1] - xs[0]).abs()
    } else {
        100.0
    };
    // Magnify so that an ellipse of the threshold's size spans half a cell of the subsample.
    let mag = (0.5 * spacing * step_x as f64 / g.threshold_mm)
        .round()
        .max(1.0);
    let per_z = xs.len() * ys.len();
    let pts = &l.result.points[..per_z.min(l.result.points.len())];
    let sub: Vec<_> = pts
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            (i % xs.len()) % step_x == 0
                && (i / xs.len()) % step_y == 0
                && p.sigma_max_mm.is_finite()
        })
        .map(|(_, p)| p)
        .collect();
    if sub.is_empty() {
        rep.push(Block::Paragraph(
            "No measurable point: no error ellipses.".into(),
        ));
        return;
    }
    let car = grids::car_outline(g);
    for (view, b, label) in [
        ("plan view (x–y)", 1usize, "y [mm] (left)"),
        (
            "side view (x–z)",
            2,
            "z [mm] (up), points offset by their y",
        ),
    ] {
        let e: Vec<crashrig_plot::Ellipse> = sub
            .iter()
            .map(|p| {
                let c = &p.covariance;
                // Side view: the rows of the subsample (different y) are spread vertically
                // by their y so they do not overlap; the ellipse is the x–z covariance.
                let v = if b == 2 {
                    p.point[1] + p.point[2]
                } else {
                    p.point[1]
                };
                crashrig_plot::Ellipse {
                    centre: (p.point[0], v),
                    covariance: [[c[(0, 0)], c[(0, b)]], [c[(b, 0)], c[(b, b)]]],
                    flagged: grids::not_below(p.sigma_worst_mm(), g.threshold_mm),
                }
            })
            .collect();
        let title = format!("{}: 1-sigma error ellipses, {view}", l.layout.name);
        let plot = crashrig_plot::EllipsePlot {
            ellipses: &e,
            magnification: mag,
            key_sigma: g.threshold_mm,
            title: &title,
            x_label: "x [mm] (vehicle frame)",
            y_label: label,
            context: if b == 1 { &car } else { &[] },
        };
        if let Ok(png) = crashrig_plot::ellipses(&plot, crashrig_plot::Format::Png) {
            rep.push(Block::Wide {
                caption: format!(
                    "{}: 1σ ellipses ×{mag:.0} in {view} at z = {} mm (red: worst-direction σ at or above the {} mm threshold; the black key circle is a σ of {} mm at the same magnification)",
                    l.layout.name,
                    g.z.values().first().copied().unwrap_or(0.0),
                    g.threshold_mm,
                    g.threshold_mm
                ),
                png,
            });
        }
    }
}

/// A study with a CFC filter: its kinematics files and report subsection.
#[cfg(test)]
mod kinematics_tests;
/// The section "3-D view" (three.js, the data blob `crashrig-3d`).
mod view3d;
