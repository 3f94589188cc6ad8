//! Degenerate forward-intersection geometry: where the observers' lines of sight to a grid
//! point are (nearly) parallel, the intersection is undetermined along them and a Monte Carlo σ
//! there is meaningless (metres, or `inf`). Such points are flagged, get no σ, and are left out
//! of medians and colour scales; a layout where every point is degenerate is an error.
//!
//! The measure is the **intersection angle** of a point: the largest angle between the lines of
//! sight of any two observers, `α = atan2(|dᵢ × dⱼ|, |dᵢ · dⱼ|) ∈ [0°, 90°]` (lines, not rays:
//! two observers on opposite sides of the point on one line see it under 0° as well). With two
//! views the smallest eigenvalue of the DLT normal matrix `Σ(I − ddᵀ)` is `1 − cos α`, so the
//! error along the lines of sight grows like `1/α` for small α.
//!
//! # Example
//! ```
//! use crashrig_mc::degenerate::{MIN_INTERSECTION_ANGLE_DEG, intersection_angle_deg};
//! use nalgebra::Vector3;
//!
//! let point = Vector3::new(1000.0, 0.0, 0.0);
//! // Observers at right angles: 90°.
//! let a = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(1000.0, 1000.0, 0.0)];
//! assert!((intersection_angle_deg(&a, &point) - 90.0).abs() < 1e-9);
//! // Observers on one line through the point (one behind the other): degenerate.
//! let b = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(500.0, 0.0, 0.0)];
//! assert!(intersection_angle_deg(&b, &point) < MIN_INTERSECTION_ANGLE_DEG);
//! ```

use crate::error::Error;
use crate::model::{Aim, Grid};
use crate::result::{GridResult, PointStats};
use nalgebra::Vector3;

/// Smallest intersection angle (degrees) at which a grid point is measurable: COLMAP's own
/// triangulation and mapper filters reject points seen under less than 1.5°
/// (`min_tri_angle`, `filter_min_tri_angle`). At 1.5° the along-ray error is already about
/// 1/sin(1.5°) ≈ 38× the across-ray error; exactly parallel views give no intersection at all.
/// (The smallest angle of the bundled paper layouts is 1.685°, so none of their points is
/// flagged.)
pub const MIN_INTERSECTION_ANGLE_DEG: f64 = 1.5;

/// The largest angle (degrees, in [0, 90]) between the lines of sight from any two of
/// `centres` to `point`; 0 with fewer than two centres or when a centre coincides with the
/// point.
pub fn intersection_angle_deg(centres: &[Vector3<f64>], point: &Vector3<f64>) -> f64 {
    let dirs: Vec<Vector3<f64>> = centres
        .iter()
        .filter_map(|c| (point - c).try_normalize(0.0))
        .collect();
    let mut best = 0.0f64;
    for (i, a) in dirs.iter().enumerate() {
        for b in &dirs[i + 1..] {
            let angle = a.cross(b).norm().atan2(a.dot(b).abs());
            best = best.max(angle);
        }
    }
    best.to_degrees()
}

/// Whether a point seen under `angle_deg` is degenerate (below [`MIN_INTERSECTION_ANGLE_DEG`]).
pub fn is_degenerate(angle_deg: f64) -> bool {
    // NaN (no angle at all) is degenerate too.
    angle_deg.is_nan() || angle_deg < MIN_INTERSECTION_ANGLE_DEG
}

/// Centres of the observers that see `point`: every aimed observer, and a fixed observer
/// when the point lies inside its image.
fn seeing_centres(grid: &Grid, point: &Vector3<f64>) -> Vec<Vector3<f64>> {
    grid.observers
        .iter()
        .filter(|o| match &o.aim {
            Aim::Point => true,
            Aim::Fixed(f) => crate::view::sight(f, &o.position_mm, point).is_some(),
        })
        .map(|o| o.position_mm)
        .collect()
}

/// The intersection angle of every grid point (in [`Grid::points`] order) from the nominal
/// centres of the observers that see it; NaN where fewer than two see it (not measurable,
/// which is not the same as degenerate).
pub fn grid_angles_deg(grid: &Grid) -> Vec<f64> {
    grid.points()
        .iter()
        .map(|p| {
            let centres = seeing_centres(grid, p);
            if centres.len() < 2 {
                f64::NAN
            } else {
                intersection_angle_deg(&centres, p)
            }
        })
        .collect()
}

/// [`Error::AllDegenerate`] when every point seen by two or more observers is degenerate (a
/// layout where no point is seen twice is reported as not measurable instead).
pub fn check_layout(grid: &Grid) -> Result<(), Error> {
    let seen: Vec<f64> = grid_angles_deg(grid)
        .into_iter()
        .filter(|a| !a.is_nan())
        .collect();
    if seen.is_empty() {
        return Ok(());
    }
    let largest = seen.into_iter().fold(0.0, f64::max);
    if is_degenerate(largest) {
        return Err(Error::AllDegenerate {
            min_deg: MIN_INTERSECTION_ANGLE_DEG,
            largest_deg: largest,
        });
    }
    Ok(())
}

/// Whether a point is degenerate: measurable (seen by two or more observers) with an
/// intersection angle below [`MIN_INTERSECTION_ANGLE_DEG`].
pub fn is_degenerate_point(p: &PointStats, angle_deg: f64) -> bool {
    p.is_measurable() && is_degenerate(angle_deg)
}

/// Blanks (NaN) the statistics of the degenerate points of `result` (so they stay out of
/// colour scales, medians and maxima) and returns every point's intersection angle.
pub fn mask_degenerate(result: &mut GridResult, grid: &Grid) -> Vec<f64> {
    let angles = grid_angles_deg(grid);
    for (p, &a) in result.points.iter_mut().zip(&angles) {
        if is_degenerate_point(p, a) {
            p.sigma_mm.fill(f64::NAN);
            p.sigma_max_mm = f64::NAN;
            p.mean_mm.fill(f64::NAN);
            p.covariance.fill(f64::NAN);
            p.linear_covariance.fill(f64::NAN);
        }
    }
    angles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_known_angles() {
        let p = Vector3::new(0.0, 0.0, 0.0);
        // Two observers 1000 mm away, 60° apart around the point.
        let c = [
            Vector3::new(1000.0, 0.0, 0.0),
            Vector3::new(500.0, 500.0 * 3f64.sqrt(), 0.0),
        ];
        assert!((intersection_angle_deg(&c, &p) - 60.0).abs() < 1e-12);
        // 120° between the rays is a 60° angle between the lines.
        let c = [
            Vector3::new(1000.0, 0.0, 0.0),
            Vector3::new(-500.0, 500.0 * 3f64.sqrt(), 0.0),
        ];
        assert!((intersection_angle_deg(&c, &p) - 60.0).abs() < 1e-12);
        // Three observers: the best pair counts (two coincident ones and one at 90°).
        let c = [
            Vector3::new(1000.0, 0.0, 0.0),
            Vector3::new(1000.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 1000.0),
        ];
        assert!((intersection_angle_deg(&c, &p) - 90.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_tiny_baselines_are_resolved() {
        let p = Vector3::new(0.0, 1000.0, 0.0);
        // 1e-6 mm apart at 1 m: 1e-9 rad = 5.73e-8°, resolved by atan2 (acos would give 0).
        let c = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(1e-6, 0.0, 0.0)];
        let a = intersection_angle_deg(&c, &p);
        assert!((a / 1e-9f64.to_degrees() - 1.0).abs() < 1e-6, "{a}");
        assert!(is_degenerate(a));
        assert!(is_degenerate(f64::NAN));
        assert!(!is_degenerate(MIN_INTERSECTION_ANGLE_DEG));
        // Coincident observers and one observer alone: 0°.
        assert_eq!(intersection_angle_deg(&[c[0], c[0]], &p), 0.0);
        assert_eq!(intersection_angle_deg(&c[..1], &p), 0.0);
    }

    /// A scenario with two observers at `a` and `b` over a 3 × 3 grid at x = 1000…2000.
    fn layout(a: &str, b: &str, y: &str) -> String {
        format!(
            "samples = 10\n[grid]\nx_mm = [1000.0, 2000.0, 3]\ny_mm = {y}\nz_mm = [0.0, 0.0, 1]\n\
             [[grid.observer]]\nposition_mm = [{a}]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n\
             [[grid.observer]]\nposition_mm = [{b}]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n"
        )
    }

    #[test]
    fn degenerate_layouts_are_errors_and_good_ones_are_not() {
        let study = |text: String| {
            let s = crate::Scenario::from_toml_str(&text, std::path::Path::new("d.toml")).unwrap();
            crate::GridStudy::new(&s, 10, 1).map(|_| ())
        };
        let wide = "[-500.0, 500.0, 3]";
        for (a, b, y) in [
            // Coincident observers.
            ("0.0, 0.0, 0.0", "0.0, 0.0, 0.0", wide),
            // 1e-6 mm apart.
            ("0.0, 0.0, 0.0", "0.0, 0.000001, 0.0", wide),
            // Every line of sight along the x axis (grid on it, observers on it).
            ("0.0, 0.0, 0.0", "500.0, 0.0, 0.0", "[0.0, 0.0, 1]"),
        ] {
            let e = study(layout(a, b, y)).unwrap_err();
            assert!(matches!(e, Error::AllDegenerate { .. }), "{a} / {b}: {e}");
        }
        // Observers 1 m apart across the grid: fine.
        study(layout("0.0, -500.0, 0.0", "0.0, 500.0, 0.0", wide)).unwrap();
    }
}
