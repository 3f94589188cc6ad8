//! The report's first screen: the compact answer table (one row per layout, every number from
//! the typed [`LayoutVerdict`] that `results.json` carries as
//! `layouts[].verdict`), the layout names explained once, and below them the verdict boxes with
//! the long lists (is the threshold reached, where not and why, what dominates).
//!
//! One σ measure throughout: the worst-direction σ (√ of the largest eigenvalue of the point's
//! covariance), named wherever a number appears; points that are not measurable (seen by fewer
//! than two cameras, or under a degenerate intersection angle) are counted apart, never as
//! above the threshold.

use crate::contract::LayoutVerdict;
use crate::html::{Block, Report, Status, Verdict};
use crate::pipeline::StudyResult;
use crate::verdict::hot_spot_reason;

/// The answer table's columns: (header, `data-key` of the cell). The keys name the
/// `results.json` field a cell shows (`layouts[].verdict.<key>`; `name` is `layouts[].name`).
pub const ANSWER_COLUMNS: [(&str, &str); 8] = [
    ("layout", "name"),
    ("reached everywhere?", "reached"),
    ("measurable (seen by ≥ 2 cameras)", "fraction_measurable"),
    (
        "of those, below the threshold",
        "fraction_below_threshold_of_measurable",
    ),
    (
        "worst-direction σ: median / largest [mm]",
        "median_sigma_worst_mm",
    ),
    ("largest at (x, y, z) [mm]", "hot_spot.point_mm"),
    (
        "why there: ray angle; input dominating there (σ → σ with its σ halved)",
        "hot_spot",
    ),
    (
        "dominant input (median σ → with its σ halved)",
        "dominant_input",
    ),
];

/// A share as the table shows it (`93.2 %`).
pub fn percent(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

/// A σ as the table shows it (`1.55`), "—" when there is none.
pub fn mm(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or("—".into(), |v| format!("{v:.2}"))
}

/// A point as the table shows it (`(1000, -500, 0)`).
pub fn point(p: [f64; 3]) -> String {
    format!("({:.0}, {:.0}, {:.0})", p[0], p[1], p[2])
}

/// One row of the answer table, cells in [`ANSWER_COLUMNS`] order.
pub fn answer_row(name: &str, v: &LayoutVerdict) -> Vec<String> {
    vec![
        name.to_string(),
        if v.reached { "yes" } else { "no" }.to_string(),
        percent(v.fraction_measurable),
        if v.points_measurable == 0 {
            "—".into()
        } else {
            percent(v.fraction_below_threshold_of_measurable)
        },
        format!(
            "{} / {}",
            mm(v.median_sigma_worst_mm),
            mm(v.hot_spot.as_ref().map(|h| h.sigma_worst_mm))
        ),
        v.hot_spot
            .as_ref()
            .map_or("—".into(), |h| point(h.point_mm)),
        hot_spot_cell(v),
        v.dominant_input.as_ref().map_or("—".into(), |d| {
            format!(
                "{}: {:.2} → {:.2} mm",
                d.input, d.sigma_worst_mm, d.sigma_worst_halved_mm
            )
        }),
    ]
}

/// The "why there" cell: the intersection angle at the hot spot against the grid's median, and
/// the input whose halved σ lowers the σ there most.
fn hot_spot_cell(v: &LayoutVerdict) -> String {
    let Some(h) = &v.hot_spot else {
        return "—".into();
    };
    let mut cell = format!(
        "rays meet at {:.1}° (grid median {:.1}°)",
        h.intersection_angle_deg, h.median_intersection_angle_deg
    );
    if let Some(d) = &h.dominant_input {
        cell.push_str(&format!(
            "; {}: {:.2} → {:.2} mm",
            d.input, d.sigma_worst_mm, d.sigma_worst_halved_mm
        ));
    }
    cell
}

/// The thresholds of the layouts, as text ("5 mm", or "3 / 5 mm" when they differ).
pub fn thresholds(r: &StudyResult) -> String {
    let mut t: Vec<f64> = r.layouts.iter().map(|l| l.verdict.threshold_mm).collect();
    t.sort_by(f64::total_cmp);
    t.dedup();
    let t: Vec<String> = t.iter().map(|v| format!("{v}")).collect();
    format!("{} mm", t.join(" / "))
}

/// The answer table as trusted HTML: `<table class="answer" id="answer">`, one
/// `<tr data-layout="…">` per layout and a `data-key` on every cell (the test that compares the
/// first screen with `results.json` reads them).
fn answer_html(r: &StudyResult) -> String {
    use crate::html::escape;
    let mut s = format!(
        "<table class=\"answer\" id=\"answer\">\n<caption>Is σ &lt; {} reached, in every direction? One row per layout. Every σ is the worst-direction σ (the σ in the direction a point is least certain). Points no two cameras see are not measurable: counted apart, never as above the threshold. Same numbers: results.json → layouts[].verdict.</caption>\n<thead><tr>",
        escape(&thresholds(r)),
    );
    for (h, _) in ANSWER_COLUMNS {
        s.push_str(&format!("<th>{}</th>", escape(h)));
    }
    s.push_str("</tr></thead>\n<tbody>\n");
    for l in &r.layouts {
        let class = if l.verdict.reached { "pass" } else { "fail" };
        s.push_str(&format!(
            "<tr class=\"{class}\" data-layout=\"{}\">",
            escape(&l.layout.name)
        ));
        for ((_, key), cell) in ANSWER_COLUMNS
            .iter()
            .zip(answer_row(&l.layout.name, &l.verdict))
        {
            s.push_str(&format!("<td data-key=\"{key}\">{}</td>", escape(&cell)));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody>\n</table>");
    s
}

/// The layout names of the bundled paper study, explained once.
pub const PAPER_LAYOUT_NAMES: &str = "Layout names: four_cameras = the paper's four-camera system (two on-board rigs; observers rear cam2 and door cam2', both inward cameras), three_cameras = its three-camera system (rear cam2 and door cam3, tied in by image matching); z0 = grid points at camera height, z300 = 30 cm higher, fixed = both levels; _paper = observers with the paper's Table 3-4 σ, _this_run = with the σ this run propagated through the chain (outward camera → link → tie); _pixel_noise = plus 0.5 px image noise; fixed_paper = cameras bolted in place with the paper's lenses (real fields of view) instead of turned towards every point.";

/// The first screen: the answer table, the layout names, the verdict boxes of the calibration
/// (and the length check), then the boxes with the long lists.
pub fn push(rep: &mut Report, r: &StudyResult, paper: bool) {
    rep.push(Block::Raw(answer_html(r)));
    rep.push(Block::Paragraph(format!(
        "How to read it: the worst-direction σ is √ of the largest eigenvalue of the point's 3×3 covariance, never below the largest of σx, σy, σz, so \"σ < 5 mm in every direction\" holds where it is below 5 mm. Measurable: seen by two or more cameras under at least {}°. The share below the threshold counts the measurable points only. Why there: the largest angle between two cameras' lines of sight at the worst point (the error along the rays grows as 1/sin of it), against its median over the grid, and the input whose halved σ lowers the σ at that point most (one-at-a-time sensitivity); the dominant input does the same for the median σ over the grid.",
        crashrig_mc::degenerate::MIN_INTERSECTION_ANGLE_DEG
    )));
    // The 3-D view (the first section, below the verdicts and the contents): linked from here,
    // so that a reader of the first screen finds the picture of the whole study.
    if !r.layouts.is_empty() {
        rep.push(Block::Raw(
            "<p><b>See it in 3-D:</b> <a href=\"#v3d\">the 3-D view</a> (the first section under the contents) shows the cameras and each layout's grid coloured by this σ, the threshold marked; drag to turn it.</p>".into(),
        ));
    }
    if paper {
        rep.push(Block::Paragraph(PAPER_LAYOUT_NAMES.into()));
    } else if r.layouts.iter().any(|l| !l.layout.description.is_empty()) {
        rep.push(Block::Paragraph(format!(
            "Layouts: {}.",
            r.layouts
                .iter()
                .map(|l| format!("{}: {}", l.layout.name, l.layout.description))
                .collect::<Vec<_>>()
                .join("; ")
        )));
    }
}

/// The verdict boxes with the long lists, below the answer table and the calibration's box.
pub fn list_boxes(rep: &mut Report, r: &StudyResult) {
    rep.push(Block::Verdict(reached_verdict(r)));
    rep.push(Block::Verdict(where_verdict(r)));
    rep.push(Block::Verdict(dominant_verdict(r)));
}

fn reached_verdict(r: &StudyResult) -> Verdict {
    let n = r.layouts.len();
    let full: Vec<&str> = r
        .layouts
        .iter()
        .filter(|l| l.verdict.reached)
        .map(|l| l.layout.name.as_str())
        .collect();
    let lines = r
        .layouts
        .iter()
        .map(|l| {
            let v = &l.verdict;
            if v.points_measurable == 0 {
                return format!(
                    "{}: no point is measurable (seen by two cameras)",
                    l.layout.name
                );
            }
            format!(
                "{}: {} of the grid measurable; of those {} below {} mm in every direction; worst-direction σ median {} mm, largest {} mm",
                l.layout.name,
                percent(v.fraction_measurable),
                percent(v.fraction_below_threshold_of_measurable),
                v.threshold_mm,
                mm(v.median_sigma_worst_mm),
                mm(v.hot_spot.as_ref().map(|h| h.sigma_worst_mm)),
            )
        })
        .collect();
    let (answer, status) = if n == 0 {
        ("No layout in this study.".to_string(), Status::Info)
    } else if full.len() == n {
        (
            "Yes: at every grid point of every layout, in every direction.".to_string(),
            Status::Pass,
        )
    } else if full.is_empty() {
        (
            format!("No: no layout reaches it at every point in every direction (0 of {n})."),
            Status::Fail,
        )
    } else {
        (
            format!(
                "In {} of {n} layouts everywhere, in every direction: {}.",
                full.len(),
                full.join(", ")
            ),
            Status::Fail,
        )
    };
    Verdict {
        question: format!(
            "Is σ < {} reached, in every direction? (worst-direction σ)",
            thresholds(r)
        ),
        answer,
        lines,
        status,
    }
}

fn where_verdict(r: &StudyResult) -> Verdict {
    let mut lines = Vec::new();
    for l in &r.layouts {
        let v = &l.verdict;
        let unseen = v.points_seen_by_fewer_than_two + v.points_degenerate;
        let not_measurable = (unseen > 0).then(|| {
            format!(
                "{unseen} of {} points not measurable ({} seen by fewer than two cameras, {} with nearly parallel rays), not counted as above",
                v.points, v.points_seen_by_fewer_than_two, v.points_degenerate
            )
        });
        let above = v.above_threshold_box_mm.map(|b| {
            format!(
                "{} measurable points at or above {} mm (worst-direction σ) within x {:.0}…{:.0}, y {:.0}…{:.0}, z {:.0}…{:.0} mm",
                v.points_above_threshold, v.threshold_mm, b[0][0], b[0][1], b[1][0], b[1][1], b[2][0], b[2][1]
            )
        });
        if above.is_none() && not_measurable.is_none() {
            continue;
        }
        let mut parts: Vec<String> = above.into_iter().chain(not_measurable).collect();
        if let Some(h) = &v.hot_spot
            && v.points_above_threshold > 0
        {
            parts.push(format!(
                "largest worst-direction σ {:.2} mm at {}: {}",
                h.sigma_worst_mm,
                point(h.point_mm),
                hot_spot_reason(v)
            ));
        }
        lines.push(format!("{}: {}", l.layout.name, parts.join("; ")));
    }
    let (answer, status) = if lines.is_empty() {
        (
            "Nowhere: every point of every layout is measurable and below it.".to_string(),
            Status::Pass,
        )
    } else {
        (format!("In {} layout(s):", lines.len()), Status::Fail)
    };
    Verdict {
        question: "Where is it not reached, and why?".into(),
        answer,
        lines,
        status,
    }
}

fn dominant_verdict(r: &StudyResult) -> Verdict {
    let mut count: Vec<(String, usize)> = Vec::new();
    let mut lines = Vec::new();
    for l in &r.layouts {
        let Some(d) = &l.verdict.dominant_input else {
            continue;
        };
        match count.iter_mut().find(|(n, _)| *n == d.input) {
            Some(c) => c.1 += 1,
            None => count.push((d.input.clone(), 1)),
        }
        lines.push(format!(
            "{}: {} (median worst-direction σ {:.2} → {:.2} mm with its σ halved)",
            l.layout.name, d.input, d.sigma_worst_mm, d.sigma_worst_halved_mm
        ));
    }
    count.sort_by_key(|c| std::cmp::Reverse(c.1));
    let answer = match count.first() {
        None => {
            "Not computed (no sensitivity runs: --no-sensitivity, or nothing measurable).".into()
        }
        Some((input, k)) => format!(
            "Mostly {input} ({k} of {} layouts): halving its σ helps most.",
            lines.len()
        ),
    };
    Verdict {
        question: "What dominates the uncertainty?".into(),
        answer,
        lines,
        status: Status::Info,
    }
}
