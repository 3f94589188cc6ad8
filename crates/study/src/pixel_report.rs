//! The pixel σ checked on the test itself (`[measure]` with camera C): the verdict box beside the
//! length check's at the top of the report, and the subsection "Pixel σ checked on the test"
//! beside the "Length check" — the residuals of B's and C's rays against what the stated pixel σ
//! predicts, the estimate of the true pixel σ, and what that means for every σ of the report.
//!
//! Every number is read from the typed summary the study's `[measure]` step returned
//! ([`crashrig_measure::output::PixelCheckSummary`]; no file or JSON in between).

use crate::html::{Block, Report, Status, Table, Verdict};
use crate::measure_step::MeasureResult;
use crashrig_measure::output::{EstimateSummary, PixelCheckSummary, SigmaRatioSummary};

/// The verdict box "Were the image errors what was stated?" (`None` without the check).
pub fn verdict(m: &MeasureResult) -> Option<Verdict> {
    let c = m.summary.pixel_sigma_check.as_ref()?;
    let (answer, status) = match &m.summary.pixel_sigma_estimate {
        Some(e) => (
            format!(
                "Estimated from the test (pixel_sigma_px = \"estimate\"): {}; every σ of this report uses it.",
                estimate_words(e)
            ),
            Status::Info,
        ),
        None => (headline(&c.common), status(&c.common)),
    };
    Some(Verdict {
        question: "Were the image errors what was stated (the test's own residuals)?".into(),
        answer,
        lines: lines(c),
        status,
    })
}

fn status(r: &SigmaRatioSummary) -> Status {
    if r.verdict == "consistent" {
        Status::Pass
    } else {
        Status::Fail
    }
}

/// The common verdict in words a lab can act on.
fn headline(r: &SigmaRatioSummary) -> String {
    let (lo, hi) = (r.sigma_ratio_band_99[0], r.sigma_ratio_band_99[1]);
    match r.verdict {
        "sigma_too_small" => format!(
            "No: the image errors were {:.2} × what was stated ({:.3} px; estimated {:.3} px). Every σ in this report is too small — by up to {:.2} ×, by that factor where the pixel noise dominates a σ and less where camera A, the link or the tie do. Re-run with pixel_sigma_px = {:.2} (or \"estimate\").",
            r.sigma_ratio, r.stated_px, r.estimate_px, r.sigma_ratio, r.estimate_px
        ),
        "sigma_too_large" => format!(
            "No: the image errors were only {:.2} × what was stated ({:.3} px; estimated {:.3} px). The σ in this report are conservative — by up to {:.2} × where the pixel noise dominates; pixel_sigma_px = {:.2} (or \"estimate\") would give the honest ones.",
            r.sigma_ratio,
            r.stated_px,
            r.estimate_px,
            1.0 / r.sigma_ratio.max(f64::MIN_POSITIVE),
            r.estimate_px
        ),
        _ => format!(
            "Yes: the image errors were {:.2} × what was stated ({:.3} px), inside the 99 % band {lo:.2} … {hi:.2} for a redundancy of {:.0}.",
            r.sigma_ratio, r.stated_px, r.redundancy
        ),
    }
}

/// The common and per-camera numbers, one line each.
fn lines(c: &PixelCheckSummary) -> Vec<String> {
    let line = |who: &str, r: &SigmaRatioSummary| {
        format!(
            "{who}: ratio {:.2} (99 % band {:.2} … {:.2}, redundancy {:.0}): estimated {:.3} px (95 %: {:.3} … {:.3}) against {:.3} px stated — {}",
            r.sigma_ratio,
            r.sigma_ratio_band_99[0],
            r.sigma_ratio_band_99[1],
            r.redundancy,
            r.estimate_px,
            r.estimate_95_px[0],
            r.estimate_95_px[1],
            r.stated_px,
            r.verdict
        )
    };
    let mut all = vec![line("B and C together", &c.common)];
    match (&c.per_camera, &c.per_camera_note) {
        (Some(p), _) => {
            all.push(line("camera B", &p.b));
            all.push(line("camera C", &p.c));
        }
        (None, Some(note)) => all.push(format!("B and C apart: {note}")),
        (None, None) => {}
    }
    all
}

/// What the Monte Carlo used with `"estimate"`.
fn estimate_words(e: &EstimateSummary) -> String {
    let cam = |n: &str, c: &crashrig_measure::output::EstimateCameraSummary| {
        format!(
            "{n} {:.3} px (95 %: {:.3} … {:.3}; the stated σ × {:.2})",
            c.estimate_px, c.estimate_95_px[0], c.estimate_95_px[1], c.scale
        )
    };
    if e.per_camera {
        format!("{}, {}", cam("camera B", &e.b), cam("camera C", &e.c))
    } else {
        cam("B and C", &e.b)
    }
}

/// The subsection "Pixel σ checked on the test" (nothing without the check).
pub fn section(rep: &mut Report, m: &MeasureResult) {
    let Some(c) = &m.summary.pixel_sigma_check else {
        return;
    };
    rep.push(Block::SubHeading("Pixel σ checked on the test".into()));
    rep.push(Block::Paragraph(format!(
        "Every marker-epoch seen by both B and C has four image coordinates for three unknowns, so the rays of the two cameras miss each other by what the image errors really were. {} such marker-epochs are compared with what the stated pixel σ ({}) predicts; the tie B_from_C, one error shared by the whole sequence, is projected out ({} directions) rather than guessed, so an uncertain tie does not raise a false alarm. The ratio is 1 on honest σ and is tested against its two-sided 99 % band for this redundancy. Where the length check sees errors that do not cancel in a distance, this check sees the image noise itself, bars or not; it cannot see camera A's pose or the link A_from_B (they move B and C together).",
        c.marker_epochs,
        match c.stated_from {
            "observations" => "each observation's own",
            "observations_and_pixel_sigma_px" => "each observation's own, else pixel_sigma_px",
            _ => "pixel_sigma_px",
        },
        c.tie_directions
    )));
    rep.push(Block::Table(table(c)));
    let mut words = vec![headline(&c.common)];
    if let Some(e) = &m.summary.pixel_sigma_estimate {
        words.push(format!(
            "pixel_sigma_px = \"estimate\": the Monte Carlo used {} instead of the stated σ, so the σ of this report already carry the test's own image noise.",
            estimate_words(e)
        ));
    }
    rep.push(Block::List(words));
}

/// The common and per-camera numbers (one row each).
fn table(c: &PixelCheckSummary) -> Table {
    let row = |who: &str, r: &SigmaRatioSummary| {
        vec![
            who.to_string(),
            format!("{:.0}", r.redundancy),
            format!(
                "{:.2} ({:.2} … {:.2})",
                r.sigma_ratio, r.sigma_ratio_band_99[0], r.sigma_ratio_band_99[1]
            ),
            format!("{:.3}", r.stated_px),
            format!(
                "{:.3} ({:.3} … {:.3})",
                r.estimate_px, r.estimate_95_px[0], r.estimate_95_px[1]
            ),
            r.verdict.to_string(),
        ]
    };
    let mut rows = vec![row("B and C", &c.common)];
    if let Some(p) = &c.per_camera {
        rows.push(row("B", &p.b));
        rows.push(row("C", &p.c));
    }
    Table {
        caption:
            "The pixel σ checked on the sequence's own residuals (summary.json → pixel_sigma_check)"
                .into(),
        header: [
            "camera",
            "redundancy",
            "ratio (99 % band)",
            "stated σ [px]",
            "estimated σ [px] (95 %)",
            "verdict",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    }
}
