//! Units are never guessed: plausibility of the lengths and σ of a scenario or study file
//! (issue 36 §2). A value that is legal but points at a length typed in metres gives one
//! `warning:` sentence; the scenario reader ([`crate::Scenario`]) and the study reader
//! (`crashrig_study::Study`) put the file, the line and the key in front of it. The thresholds
//! (`docs/LIMITS.md`, "Plausibility warnings") are far from anything a car or a lab has, and
//! far from the same values typed in metres:
//!
//! | check | warning when | in metres it would be |
//! |---|---|---|
//! | a grid axis (`x_mm`, `y_mm`, `z_mm`, count ≥ 2) | spans less than [`MIN_GRID_SPAN_MM`] | a car interior of 0.5–5 m spans 0.5–5 |
//! | an observer | is more than [`AT_CAMERA_MM`] and less than [`MIN_CAMERA_SEPARATION_MM`] from a chain camera, another observer or the frame's origin | cameras 0.1–3 m apart are 0.1–3 apart |
//! | a rig link (`position_mm` of a camera with a parent) | is shorter than [`MIN_CAMERA_SEPARATION_MM`] (and not 0) | a 60 mm base is 0.06 |
//! | a pose's position σ | has a component in (0, [`MIN_POSITION_SIGMA_MM`]) | 0.8 mm is 0.0008 |
//! | a pose's position σ over its angle σ (rad) | is below [`MIN_LEVER_ARM_MM`] | 0.8 mm / 0.008° is 5.7 m, in metres 5.7 |
//! | a σ threshold (`threshold_mm`) | is in (0, [`MIN_THRESHOLD_MM`]) | 5 mm is 0.005 |
//! | a length check's maximum permissible error (`mpe_mm`) | is in (0, [`MIN_MPE_MM`]) | 1 mm is 0.001 |
//!
//! ```
//! use crashrig_mc::plausible::{grid_axis, position_sigma};
//! assert!(grid_axis(400.0, 1800.0, 8).is_none());
//! let w = grid_axis(0.4, 1.8, 8).unwrap();
//! assert!(w.starts_with("spans 1.4 mm"), "{w}");
//! assert!(position_sigma([0.8, 0.8, 1.2], [0.008, 0.008, 0.012]).is_none());
//! assert!(position_sigma([0.0008, 0.0008, 0.0012], [0.008, 0.008, 0.012]).is_some());
//! ```

use nalgebra::Vector3;

/// A grid axis with two or more values spans at least this (mm): a car interior is metres
/// across.
pub const MIN_GRID_SPAN_MM: f64 = 20.0;
/// Two cameras (projection centres) are at least this far apart (mm): camera bodies are tens of
/// millimetres across.
pub const MIN_CAMERA_SEPARATION_MM: f64 = 20.0;
/// An observer this close to a camera (mm) stands at it (the tolerance of correlated
/// observers, [`crate::CORRELATED_POSITION_TOLERANCE_MM`]).
pub const AT_CAMERA_MM: f64 = crate::model::CORRELATED_POSITION_TOLERANCE_MM;
/// A camera pose's position σ is at least this (mm): no camera pose is known to a micrometre.
pub const MIN_POSITION_SIGMA_MM: f64 = 1e-3;
/// A pose's position σ divided by its angle σ (rad) — the distance of the points that
/// determine it — is at least this (mm): a camera's pose in a car or a lab is determined by
/// points metres away.
pub const MIN_LEVER_ARM_MM: f64 = 10.0;
/// A σ threshold is at least this (mm).
pub const MIN_THRESHOLD_MM: f64 = 0.01;
/// A length check's maximum permissible error of a bar's length is at least this (mm): a
/// lab's photogrammetry holds lengths to tenths of a millimetre, not to micrometres.
pub const MIN_MPE_MM: f64 = 0.01;

/// The closing words of every warning: the unit.
const UNIT: &str = "lengths are in millimetres";

/// A grid axis `[start, stop, count]` (mm) that spans less than [`MIN_GRID_SPAN_MM`] with two
/// or more values.
pub fn grid_axis(start: f64, stop: f64, count: usize) -> Option<String> {
    let span = (stop - start).abs();
    (count >= 2 && span < MIN_GRID_SPAN_MM).then(|| {
        format!(
            "spans {} mm (less than {MIN_GRID_SPAN_MM} mm) — a car interior is metres across; {UNIT}",
            round(span)
        )
    })
}

/// A pose's σ (position mm, angles deg): a position σ component in (0,
/// [`MIN_POSITION_SIGMA_MM`]), or position σ over angle σ (rad) below [`MIN_LEVER_ARM_MM`]
/// (both maxima, when both are positive).
pub fn position_sigma(position_mm: [f64; 3], angles_deg: [f64; 3]) -> Option<String> {
    if let Some(tiny) = position_mm
        .iter()
        .copied()
        .filter(|s| *s > 0.0 && *s < MIN_POSITION_SIGMA_MM)
        .reduce(f64::min)
    {
        return Some(format!(
            "σ of {} mm is below a micrometre ({MIN_POSITION_SIGMA_MM} mm) — no camera pose is known that well; {UNIT} (0.8 mm, not 0.0008)",
            round(tiny)
        ));
    }
    let p = position_mm.iter().copied().fold(0.0, f64::max);
    let a = angles_deg.iter().copied().fold(0.0, f64::max).to_radians();
    let lever = p / a;
    (p > 0.0 && a > 0.0 && lever < MIN_LEVER_ARM_MM).then(|| {
        format!(
            "position σ {} mm over angle σ {}° is a lever arm of {} mm (less than {MIN_LEVER_ARM_MM} mm): a camera's pose is fixed by points metres away, so its position σ in mm is metres × its angle σ in rad; {UNIT}",
            round(p),
            round(a.to_degrees()),
            round(lever)
        )
    })
}

/// The position σ (mm) and angle σ (deg) of a `covariance_tangent` given in the contract's
/// units (mm², deg²): the square roots of its diagonal.
pub fn sigmas_of_covariance_deg(c: &[[f64; 6]; 6]) -> ([f64; 3], [f64; 3]) {
    let s = |i: usize| c[i][i].max(0.0).sqrt();
    ([s(0), s(1), s(2)], [s(3), s(4), s(5)])
}

/// A σ threshold (mm) in (0, [`MIN_THRESHOLD_MM`]).
pub fn threshold(t_mm: f64) -> Option<String> {
    (t_mm > 0.0 && t_mm < MIN_THRESHOLD_MM).then(|| {
        format!(
            "{} mm is below {MIN_THRESHOLD_MM} mm — no crash-test measurement aims at a σ that small; {UNIT}",
            round(t_mm)
        )
    })
}

/// A length check's maximum permissible error (mm) in (0, [`MIN_MPE_MM`]).
pub fn mpe(mpe_mm: f64) -> Option<String> {
    (mpe_mm > 0.0 && mpe_mm < MIN_MPE_MM).then(|| {
        format!(
            "{} mm is below {MIN_MPE_MM} mm — no crash-test length check holds a bar's length that tightly; {UNIT} (0.5 mm, not 0.0005)",
            round(mpe_mm)
        )
    })
}

/// A rig link's base `|base_mm|` in (0, [`MIN_CAMERA_SEPARATION_MM`]).
pub fn link_base(base_mm: &Vector3<f64>) -> Option<String> {
    let d = base_mm.norm();
    (d > 0.0 && d < MIN_CAMERA_SEPARATION_MM).then(|| {
        format!(
            "puts the camera {} mm from its parent (less than {MIN_CAMERA_SEPARATION_MM} mm) — camera bodies are tens of millimetres across; {UNIT}",
            round(d)
        )
    })
}

/// An observer at `p` (mm) near, but not at, a camera: `cameras` are the chain cameras'
/// nominal positions (an observer within [`AT_CAMERA_MM`] of one stands at it: no warning),
/// `others` the layout's other observers; the frame's origin counts as a camera that an
/// observer is only at when it is exactly there. The nearest such camera closer than
/// [`MIN_CAMERA_SEPARATION_MM`] is named.
pub fn observer_position(
    p: &Vector3<f64>,
    cameras: &[(String, Vector3<f64>)],
    others: &[(String, Vector3<f64>)],
) -> Option<String> {
    if cameras.iter().any(|(_, c)| (p - c).norm() <= AT_CAMERA_MM) {
        return None;
    }
    let near = cameras
        .iter()
        .chain(others)
        .map(|(name, c)| (name.as_str(), (p - c).norm()))
        .filter(|(_, d)| *d > AT_CAMERA_MM && *d < MIN_CAMERA_SEPARATION_MM)
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let (what, d) = match near {
        Some(n) => n,
        None if p.norm() > 0.0 && p.norm() < MIN_CAMERA_SEPARATION_MM => {
            ("the origin of the frame", p.norm())
        }
        None => return None,
    };
    Some(format!(
        "is {} mm from {what} without being at it (less than {MIN_CAMERA_SEPARATION_MM} mm) — camera bodies are tens of millimetres across and a car interior is metres across; {UNIT}",
        round(d)
    ))
}

/// `x` with four significant digits, as text (1.4, 0.0008, 5.73).
fn round(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{x:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_axis_nominal_and_in_metres() {
        assert!(grid_axis(400.0, 2000.0, 17).is_none());
        // One value: no span to judge.
        assert!(grid_axis(0.0, 0.0, 1).is_none());
        assert!(grid_axis(300.0, 300.0, 1).is_none());
        // Exactly at the threshold is plausible; just below is not.
        assert!(grid_axis(0.0, MIN_GRID_SPAN_MM, 2).is_none());
        let w = grid_axis(-0.5, 0.5, 6).unwrap();
        assert!(w.starts_with("spans 1 mm (less than 20 mm)"), "{w}");
        assert!(w.ends_with("lengths are in millimetres"), "{w}");
    }

    #[test]
    fn position_sigma_below_a_micrometre_and_lever_arm() {
        // The paper's σ (link 0.19 mm / 0.004°, observers 1.52 mm / 0.011°): lever arms of
        // metres.
        assert!(position_sigma([0.19, 0.26, 0.13], [0.004, 0.005, 0.008]).is_none());
        assert!(position_sigma([1.52, 1.54, 1.52], [0.011, 0.011, 0.013]).is_none());
        // Zero σ (a pose held fixed) is no unit error.
        assert!(position_sigma([0.0; 3], [0.0; 3]).is_none());
        assert!(position_sigma([0.3; 3], [0.0; 3]).is_none());
        let w = position_sigma([0.0008, 0.0008, 0.0012], [0.008, 0.008, 0.012]).unwrap();
        assert!(w.starts_with("σ of 0.0008 mm is below a micrometre"), "{w}");
        // 2 mm typed in metres is above a micrometre, but its lever arm gives it away:
        // 0.002 mm / 0.01° = 0.002 / 1.745e-4 rad = 11.46 mm... just above 10 mm; 0.0015 mm
        // gives 8.59 mm.
        assert!(position_sigma([0.002; 3], [0.01; 3]).is_none());
        let w = position_sigma([0.0015; 3], [0.01; 3]).unwrap();
        assert!(w.contains("lever arm of 8.594 mm"), "{w}");
    }

    #[test]
    fn observer_near_a_camera_or_the_origin() {
        let cams = vec![("camera `cam2`".to_string(), Vector3::new(62.0, -1.7, 179.8))];
        let none: Vec<(String, Vector3<f64>)> = Vec::new();
        // At its chain camera (within 1 mm), far from everything, at the origin: plausible.
        assert!(observer_position(&Vector3::new(62.5, -1.7, 179.8), &cams, &none).is_none());
        assert!(observer_position(&Vector3::new(1300.0, -700.0, 0.0), &cams, &none).is_none());
        assert!(observer_position(&Vector3::zeros(), &none, &none).is_none());
        let w = observer_position(&Vector3::new(62.0, 3.3, 179.8), &cams, &none).unwrap();
        assert!(
            w.starts_with("is 5 mm from camera `cam2` without being at it"),
            "{w}"
        );
        // Typed in metres: 1.37 mm from the origin (the own study's side camera).
        let w = observer_position(&Vector3::new(1.2, 0.65, 0.1), &none, &none).unwrap();
        assert!(
            w.starts_with("is 1.368 mm from the origin of the frame"),
            "{w}"
        );
        let others = vec![("observer[0]".to_string(), Vector3::new(150.0, 400.0, 0.0))];
        let w = observer_position(&Vector3::new(150.0, 390.0, 0.0), &none, &others).unwrap();
        assert!(w.starts_with("is 10 mm from observer[0]"), "{w}");
    }

    #[test]
    fn threshold_and_link_base() {
        assert!(threshold(5.0).is_none());
        assert!(threshold(0.01).is_none());
        assert!(
            threshold(0.005)
                .unwrap()
                .starts_with("0.005 mm is below 0.01 mm")
        );
        assert!(mpe(0.5).is_none());
        assert!(mpe(MIN_MPE_MM).is_none());
        let w = mpe(0.0005).unwrap();
        assert!(w.starts_with("0.0005 mm is below 0.01 mm"), "{w}");
        assert!(w.contains("lengths are in millimetres"), "{w}");
        assert!(link_base(&Vector3::new(61.98, -1.71, 179.76)).is_none());
        assert!(link_base(&Vector3::zeros()).is_none());
        let w = link_base(&Vector3::new(0.06198, -0.00171, 0.17976)).unwrap();
        assert!(
            w.starts_with("puts the camera 0.1902 mm from its parent"),
            "{w}"
        );
    }

    #[test]
    fn round_keeps_four_significant_digits() {
        assert_eq!(round(1.4), "1.4");
        assert_eq!(round(0.0008), "0.0008");
        assert_eq!(round(5729.578), "5730");
        assert_eq!(round(7.6), "7.6");
        assert_eq!(round(0.0), "0");
    }
}
