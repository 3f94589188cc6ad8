//! Units are never guessed: the plausibility warnings of a study file (issue 36 §2). Every
//! length and σ key gets the check of [`crashrig_mc::plausible`] (the scenario reader's, with
//! the same thresholds, `docs/LIMITS.md` "Plausibility warnings"), and each warning names the
//! file, the key's line, the key and the unit:
//!
//! - a `[[layout]]` grid axis spanning less than 20 mm (`x_mm = [0.4, 1.8, 8]`);
//! - an observer near, but not at, another observer of its layout or the origin of the vehicle
//!   frame (when the file is read), or its chain camera once the chain's nominal positions are
//!   known ([`chain_warnings`]);
//! - a pose σ below a micrometre or with a lever arm below 10 mm (`[outward]`, given observer
//!   σ, `[measure] sigma_a_position_mm`);
//! - a σ threshold below 0.01 mm; a `[measure] mpe_mm` below 0.01 mm; a `[tie] base_mm`
//!   outside the 20 mm – 5 m of two cameras in one car.
//!
//! The study's run repeats them as `warning:` lines and its report's verdicts, so that a
//! verdict computed from a length in the wrong unit never stands unqualified.

use super::{Ctx, ObserverNoise, Raw, Spanned, line_of};
use crate::study_file::{ChainCamera, Layout, MeasureANoise, MeasureSection, TieSection};
use crashrig_geometry::{Mat6, UncertainPose, Vec3};
use crashrig_mc::plausible;

/// The validated sections the checks read (the raw file gives the lines).
pub(super) struct Read<'a> {
    pub(super) outward: &'a UncertainPose,
    pub(super) layouts: &'a [Layout],
    pub(super) tie: Option<&'a TieSection>,
    pub(super) measure: Option<&'a MeasureSection>,
}

/// `path:line: `key` sentence`.
fn located(cx: &Ctx<'_>, at: usize, key: &str, sentence: &str) -> String {
    format!(
        "{}:{}: `{key}` {sentence}",
        cx.path.display(),
        line_of(cx.text, at)
    )
}

/// Position σ (mm) and angle σ (deg) of a covariance in mm and rad.
fn sigmas(c: &Mat6) -> ([f64; 3], [f64; 3]) {
    let s = |i: usize| c[(i, i)].max(0.0).sqrt();
    (
        [s(0), s(1), s(2)],
        [s(3).to_degrees(), s(4).to_degrees(), s(5).to_degrees()],
    )
}

/// The σ key of a pose as written: `covariance_tangent` when given, else `sigma_position_mm`,
/// with its offset (or the section's).
fn sigma_key(
    cov: &Option<Spanned<Vec<Vec<f64>>>>,
    position: &Option<Spanned<[f64; 3]>>,
    section: usize,
) -> (&'static str, usize) {
    match (cov, position) {
        (Some(c), _) => ("covariance_tangent", c.span().start),
        (None, Some(p)) => ("sigma_position_mm", p.span().start),
        (None, None) => ("sigma_position_mm", section),
    }
}

/// The plausibility warnings that the file alone shows (everything but the chain cameras).
pub(super) fn read_warnings(cx: &Ctx<'_>, raw: &Raw, read: &Read<'_>) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(o) = &raw.outward {
        let r = o.get_ref();
        let (p, a) = sigmas(&read.outward.covariance);
        if let Some(w) = plausible::position_sigma(p, a) {
            let (leaf, at) = sigma_key(&r.covariance_tangent, &r.sigma_position_mm, o.span().start);
            out.push(located(cx, at, &format!("outward.{leaf}"), &w));
        }
    }
    for ((li, l), layout) in raw.layout.iter().enumerate().zip(read.layouts) {
        let rl = l.get_ref();
        let k = |f: &str| format!("layout[{li}].{f}");
        for (name, spec, axis) in [
            ("x_mm", &rl.x_mm, layout.x_mm),
            ("y_mm", &rl.y_mm, layout.y_mm),
            ("z_mm", &rl.z_mm, layout.z_mm),
        ] {
            if let (Some(v), Some(w)) = (spec, plausible::grid_axis(axis.0, axis.1, axis.2)) {
                out.push(located(cx, v.span().start, &k(name), &w));
            }
        }
        if let (Some(v), Some(w)) = (&rl.threshold_mm, plausible::threshold(layout.threshold_mm)) {
            out.push(located(cx, v.span().start, &k("threshold_mm"), &w));
        }
        for ((oi, ob), o) in rl.observer.iter().enumerate().zip(&layout.observers) {
            let ro = ob.get_ref();
            let ko = |f: &str| format!("layout[{li}].observer[{oi}].{f}");
            if let ObserverNoise::Given(c) = &o.noise {
                let (p, a) = sigmas(c);
                if let Some(w) = plausible::position_sigma(p, a) {
                    let (leaf, at) = sigma_key(
                        &ro.covariance_tangent,
                        &ro.sigma_position_mm,
                        ob.span().start,
                    );
                    out.push(located(cx, at, &ko(leaf), &w));
                }
            }
            let others: Vec<(String, Vec3)> = layout.observers[..oi]
                .iter()
                .enumerate()
                .map(|(j, e)| {
                    (
                        format!("layout[{li}].observer[{j}] {:?}", e.name),
                        e.position_mm,
                    )
                })
                .collect();
            if let (Some(v), Some(w)) = (
                &ro.position_mm,
                plausible::observer_position(&o.position_mm, &[], &others),
            ) {
                out.push(located(cx, v.span().start, &ko("position_mm"), &w));
            }
        }
    }
    if let (Some(t), Some(tie)) = (&raw.tie, read.tie)
        && let (Some(v), Some(base)) = (&t.get_ref().base_mm, tie.base_mm)
    {
        let (lo, hi) = crashrig_calibrate::BASELINE_RANGE_MM;
        if !(lo..=hi).contains(&base) {
            out.push(located(
                cx,
                v.span().start,
                "tie.base_mm",
                &format!(
                    "= {base} mm is outside the {lo} mm – {} m of two cameras in one car; lengths are in millimetres",
                    hi / 1000.0
                ),
            ));
        }
    }
    if let (Some(m), Some(ms)) = (&raw.measure, read.measure) {
        let rm = m.get_ref();
        if let MeasureANoise::Sigmas(p, a) = &ms.a_noise
            && let Some(w) = plausible::position_sigma((*p).into(), (*a).into())
        {
            let at = rm
                .sigma_a_position_mm
                .as_ref()
                .map_or(m.span().start, |v| v.span().start);
            out.push(located(cx, at, "measure.sigma_a_position_mm", &w));
        }
        if let (Some(v), Some(w)) = (&rm.threshold_mm, plausible::threshold(ms.threshold_mm)) {
            out.push(located(cx, v.span().start, "measure.threshold_mm", &w));
        }
        if let (Some(v), Some(w)) = (&rm.mpe_mm, ms.mpe_mm.and_then(plausible::mpe)) {
            out.push(located(cx, v.span().start, "measure.mpe_mm", &w));
        }
    }
    out
}

/// Observers near, but not at, their chain camera (`from = "…"`), once the chain's nominal
/// world positions are known (`chain_positions_mm`, after the calibration and the tie): one
/// warning each, located at the observer's `position_mm`.
pub fn chain_warnings(
    study: &crate::Study,
    chain_positions_mm: &[(ChainCamera, Vec3)],
) -> Vec<String> {
    let mut out = Vec::new();
    for (li, layout) in study.layouts.iter().enumerate() {
        for (oi, o) in layout.observers.iter().enumerate() {
            let ObserverNoise::From(cam) = o.noise else {
                continue;
            };
            let cameras: Vec<(String, Vec3)> = chain_positions_mm
                .iter()
                .filter(|(c, _)| *c == cam)
                .map(|(c, p)| {
                    let at = format!("[{:.1}, {:.1}, {:.1}]", p.x, p.y, p.z);
                    (format!("its chain camera `{}` (at {at} mm)", c.name()), *p)
                })
                .collect();
            if let Some(w) = plausible::observer_position(&o.position_mm, &cameras, &[])
                // The origin is checked on reading.
                && !w.contains("the origin of the frame")
            {
                let key = format!("layout[{li}].observer[{oi}].position_mm");
                let line = super::key_line(
                    &study.text,
                    "layout.observer",
                    nth_observer(study, li, oi),
                    "position_mm",
                );
                out.push(match line {
                    Some(line) => format!("{}:{line}: `{key}` {w}", study.path.display()),
                    None => format!("{}: `{key}` {w}", study.path.display()),
                });
            }
        }
    }
    out
}

/// The index of observer `oi` of layout `li` among all `[[layout.observer]]` headers.
fn nth_observer(study: &crate::Study, li: usize, oi: usize) -> usize {
    study.layouts[..li]
        .iter()
        .map(|l| l.observers.len())
        .sum::<usize>()
        + oi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Study;
    use std::path::{Path, PathBuf};

    fn own() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml")
    }

    fn edited(from: &str, to: &str) -> (Study, String) {
        let t = std::fs::read_to_string(own()).unwrap();
        assert!(t.contains(from), "{from}");
        let t = t.replacen(from, to, 1);
        (Study::from_toml_str(&t, &own()).unwrap(), t)
    }

    fn line(t: &str, what: &str) -> usize {
        t.lines().position(|l| l.contains(what)).unwrap() + 1
    }

    #[test]
    fn own_study_has_no_unit_warning() {
        assert_eq!(
            Study::from_path(&own()).unwrap().warnings,
            Vec::<String>::new()
        );
    }

    #[test]
    fn every_length_and_sigma_key_is_checked() {
        // (edit from, to, the text of the key's line, key, what the warning says)
        for (from, to, at, key, says) in [
            (
                "z_mm = [300.0, 300.0, 1]",
                "z_mm = [0.3, 0.31, 2]",
                "z_mm = [0.3, 0.31, 2]",
                "layout[1].z_mm",
                "spans 0.01 mm (less than 20 mm)",
            ),
            (
                "name = \"rear right\"\nposition_mm = [150.0, -400.0, 0.0]",
                "name = \"rear right\"\nposition_mm = [150.0, 395.0, 0.0]",
                "position_mm = [150.0, 395.0, 0.0]",
                "layout[1].observer[1].position_mm",
                "is 5 mm from layout[1].observer[0] \"rear left\" without being at it",
            ),
            (
                "sigma_position_mm = [1.0, 1.0, 1.0]",
                "sigma_position_mm = [0.001, 0.001, 0.001]",
                "sigma_position_mm = [0.001, 0.001, 0.001]",
                "layout[1].observer[0].sigma_position_mm",
                "is a lever arm of 5.73 mm",
            ),
            (
                "  [1.0, 0.2, 0.0, 0.0, 0.0, 0.0],\n  [0.2, 1.0, 0.0, 0.0, 0.0, 0.0],\n  [0.0, 0.0, 1.0,",
                "  [1e-6, 0.0, 0.0, 0.0, 0.0, 0.0],\n  [0.0, 1e-6, 0.0, 0.0, 0.0, 0.0],\n  [0.0, 0.0, 1e-6,",
                "covariance_tangent = [",
                "layout[1].observer[1].covariance_tangent",
                "is a lever arm of 5.73 mm",
            ),
            (
                "threshold_mm = 3.0\n\n[[layout.observer]]\nname = \"rear left\"",
                "threshold_mm = 0.003\n\n[[layout.observer]]\nname = \"rear left\"",
                "threshold_mm = 0.003",
                "layout[1].threshold_mm",
                "0.003 mm is below 0.01 mm",
            ),
            (
                "sigma_a_position_mm = [0.3, 0.3, 0.3]",
                "sigma_a_position_mm = [0.0003, 0.0003, 0.0003]",
                "sigma_a_position_mm = [0.0003",
                "measure.sigma_a_position_mm",
                "σ of 0.0003 mm is below a micrometre",
            ),
            (
                "frame_rate_hz = 1000.0\nthreshold_mm = 3.0",
                "frame_rate_hz = 1000.0\nthreshold_mm = 3.0\nscale_bars = \"measure/scale_bars.csv\"\nmpe_mm = 0.0005",
                "mpe_mm = 0.0005",
                "measure.mpe_mm",
                "0.0005 mm is below 0.01 mm",
            ),
            (
                "iterations = 60",
                "iterations = 60\nbase_mm = 1.2",
                "base_mm = 1.2",
                "tie.base_mm",
                "= 1.2 mm is outside the 20 mm – 5 m of two cameras in one car",
            ),
        ] {
            let (s, t) = edited(from, to);
            let want = format!("study.toml:{}: `{key}` ", line(&t, at));
            let hit: Vec<&String> = s
                .warnings
                .iter()
                .filter(|w| w.contains(&want) && w.contains(says))
                .collect();
            assert_eq!(hit.len(), 1, "{to}: want {want}{says}\n{:?}", s.warnings);
            assert!(hit[0].contains("millimetres"), "{}", hit[0]);
        }
    }

    /// An observer fed by a chain camera, a few millimetres from that camera's nominal
    /// position once the chain is known: one warning at its `position_mm` line; at the camera
    /// (within 1 mm) or far from it, none.
    #[test]
    fn chain_warnings_name_the_chain_camera() {
        let s = Study::from_path(&own()).unwrap();
        let t = &s.text;
        let at = |x: f64| {
            vec![
                (ChainCamera::Outward, Vec3::zeros()),
                (ChainCamera::Inward, Vec3::new(150.0 + x, 0.0, 0.0)),
                (ChainCamera::Tie, Vec3::new(729.0, -126.0, -873.0)),
            ]
        };
        assert!(chain_warnings(&s, &at(0.9)).is_empty());
        assert!(chain_warnings(&s, &at(400.0)).is_empty());
        let w = chain_warnings(&s, &at(7.0));
        // Both `from = "inward"` observers at (150, 0, 0): layout 0 and the fixed layout 2.
        assert_eq!(w.len(), 2, "{w:?}");
        let first = t
            .lines()
            .position(|l| l == "position_mm = [150.0, 0.0, 0.0]")
            .unwrap()
            + 1;
        assert!(
            w[0].contains(&format!("study.toml:{first}: `layout[0].observer[0].position_mm` is 7 mm from its chain camera `inward` (at [157.0, 0.0, 0.0] mm) without being at it")),
            "{w:?}"
        );
        assert!(
            w[1].contains("`layout[2].observer[0].position_mm`"),
            "{w:?}"
        );
    }
}
