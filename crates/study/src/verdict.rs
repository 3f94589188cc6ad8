//! The answer of a layout on the report's first screen, computed as one typed value
//! ([`LayoutVerdict`], declared with the documents in [`crate::contract`]; `results.json` →
//! `layouts[].verdict`): whether the threshold is reached,
//! the share of the grid that is measurable at all and, of that, the share below the
//! threshold, the worst point with the reason it is worst, and the dominant input — every σ the
//! worst-direction σ (√ of the largest eigenvalue of the point's covariance, what "σ < 5 mm in
//! every direction" promises).
//!
//! A point seen by fewer than two cameras, or seen under an intersection angle below
//! `crashrig_mc::degenerate::MIN_INTERSECTION_ANGLE_DEG`, has no σ: it is *not measurable* and is
//! counted apart, never as "above the threshold".
//!
//! The module is private; its known-answer test is below.

use crate::contract::{DominantInput, HotSpot, LayoutVerdict, Sensitivity};
use crashrig_grid::summary::not_below;
use crashrig_mc::{Grid, GridResult};
use crashrig_stats::summary::median;

/// The σ measure of every number of [`LayoutVerdict`].
pub const SIGMA_MEASURE: &str = "worst_direction";

/// The index of the measurable point with the largest worst-direction σ (`None` when none is
/// measurable): the hot spot, at which the sensitivity runs also record their σ.
pub fn hot_spot_index(result: &GridResult) -> Option<usize> {
    result
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| (i, p.sigma_worst_mm()))
        .filter(|(_, s)| s.is_finite())
        .fold(None, |best: Option<(usize, f64)>, (i, s)| match best {
            Some((_, b)) if b >= s => best,
            _ => Some((i, s)),
        })
        .map(|(i, _)| i)
}

/// The input of `sensitivity` with the smallest `value` (σ with it halved), against `unit`.
fn dominant(
    sensitivity: &[Sensitivity],
    value: fn(&Sensitivity) -> Option<f64>,
    unit: f64,
) -> Option<DominantInput> {
    sensitivity
        .iter()
        .filter_map(|s| value(s).filter(|v| v.is_finite()).map(|v| (s, v)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(s, v)| DominantInput {
            input: s.input.clone(),
            sigma_worst_halved_mm: v,
            sigma_worst_mm: unit,
        })
}

/// The verdict of `result` over `grid`, with the layout's one-at-a-time `sensitivity`
/// (whose `hot_spot_sigma_worst_mm` was taken at [`hot_spot_index`] of `result`).
pub fn layout_verdict(
    grid: &Grid,
    result: &GridResult,
    sensitivity: &[Sensitivity],
) -> LayoutVerdict {
    let t = grid.threshold_mm;
    let worst: Vec<f64> = result.points.iter().map(|p| p.sigma_worst_mm()).collect();
    let measurable: Vec<f64> = worst.iter().copied().filter(|s| s.is_finite()).collect();
    let seen_once = result.points.iter().filter(|p| !p.is_measurable()).count();
    let below = measurable.iter().filter(|s| !not_below(**s, t)).count();
    let above: Vec<[f64; 3]> = result
        .points
        .iter()
        .zip(&worst)
        .filter(|(_, s)| s.is_finite() && not_below(**s, t))
        .map(|(p, _)| p.point.into())
        .collect();
    let above_box = (!above.is_empty()).then(|| {
        let mut b = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
        for p in &above {
            for (bk, v) in b.iter_mut().zip(p) {
                bk[0] = bk[0].min(*v);
                bk[1] = bk[1].max(*v);
            }
        }
        b
    });
    let median_worst = median(&measurable);
    let hot_spot = hot_spot_index(result).map(|i| {
        let angles = crashrig_mc::degenerate::grid_angles_deg(grid);
        let measurable_angles: Vec<f64> = angles
            .iter()
            .zip(&worst)
            .filter(|(_, s)| s.is_finite())
            .map(|(a, _)| *a)
            .collect();
        let p = &result.points[i];
        HotSpot {
            dominant_input: dominant(sensitivity, |s| s.hot_spot_sigma_worst_mm, worst[i]),
            intersection_angle_deg: angles[i],
            median_intersection_angle_deg: median(&measurable_angles).unwrap_or(f64::NAN),
            observers_seen: p.observers_seen,
            point_mm: p.point.into(),
            sigma_worst_mm: worst[i],
        }
    });
    let n = result.points.len();
    LayoutVerdict {
        above_threshold_box_mm: above_box,
        dominant_input: median_worst
            .and_then(|m| dominant(sensitivity, |s| s.median_sigma_worst_mm, m)),
        fraction_measurable: measurable.len() as f64 / n.max(1) as f64,
        fraction_below_threshold_of_measurable: below as f64 / measurable.len().max(1) as f64,
        hot_spot,
        median_sigma_worst_mm: median_worst,
        points: n,
        points_above_threshold: measurable.len() - below,
        points_below_threshold: below,
        points_degenerate: n - seen_once - measurable.len(),
        points_measurable: measurable.len(),
        points_seen_by_fewer_than_two: seen_once,
        reached: n > 0 && below == n,
        sigma: SIGMA_MEASURE,
        threshold_mm: t,
    }
}

/// The reason for `v`'s hot spot in words: the intersection angle there against the grid's
/// median, and the input that lowers its σ most.
pub fn hot_spot_reason(v: &LayoutVerdict) -> String {
    let Some(h) = &v.hot_spot else {
        return "—".into();
    };
    let mut why = if h.intersection_angle_deg < 0.5 * h.median_intersection_angle_deg {
        format!(
            "rays meet at {:.1}° there (grid median {:.1}°): the error along the rays grows as 1/sin of that angle",
            h.intersection_angle_deg, h.median_intersection_angle_deg
        )
    } else {
        format!(
            "rays meet at {:.1}° there (grid median {:.1}°)",
            h.intersection_angle_deg, h.median_intersection_angle_deg
        )
    };
    if let Some(d) = &h.dominant_input {
        why.push_str(&format!(
            "; {} dominates there ({:.2} → {:.2} mm with its σ halved)",
            d.input, d.sigma_worst_mm, d.sigma_worst_halved_mm
        ));
    }
    why
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_mc::PointStats;
    use nalgebra::{Matrix3, Vector3};

    fn point(x: f64, var: [f64; 3], seen: usize) -> PointStats {
        let c = Matrix3::from_diagonal(&Vector3::from(var));
        let s = Vector3::from(var.map(f64::sqrt));
        PointStats {
            point: Vector3::new(x, 0.0, 0.0),
            count: if seen >= 2 { 100 } else { 0 },
            mean_mm: Vector3::new(x, 0.0, 0.0),
            covariance: if seen >= 2 {
                c
            } else {
                Matrix3::from_element(f64::NAN)
            },
            sigma_mm: if seen >= 2 {
                s
            } else {
                Vector3::from_element(f64::NAN)
            },
            sigma_max_mm: if seen >= 2 { s.max() } else { f64::NAN },
            linear_covariance: c,
            observers_seen: seen,
            converged: None,
        }
    }

    /// Not-measurable points are counted apart, never as above the threshold: of 4 points, 1
    /// is seen once, 2 of the 3 measurable ones are below 5 mm, the hot spot is the 6 mm point.
    #[test]
    fn not_measurable_is_not_above_and_the_shares_are_of_the_measurable() {
        let result = GridResult {
            points: vec![
                point(0.0, [1.0, 4.0, 1.0], 2),  // σ_worst 2
                point(1.0, [36.0, 1.0, 1.0], 2), // 6
                point(2.0, [9.0, 16.0, 1.0], 2), // 4
                point(3.0, [f64::NAN; 3], 1),    // not measurable
            ],
            observer_sigma: vec![],
            observer_covariance: vec![],
            correlated: false,
        };
        assert_eq!(hot_spot_index(&result), Some(1));
        let sens = vec![
            Sensitivity {
                input: "link".into(),
                fraction_below_threshold: 0.5,
                median_sigma_max_mm: 3.0,
                median_sigma_worst_mm: Some(3.5),
                hot_spot_sigma_worst_mm: Some(5.5),
            },
            Sensitivity {
                input: "tie".into(),
                fraction_below_threshold: 0.5,
                median_sigma_max_mm: 3.0,
                median_sigma_worst_mm: Some(3.9),
                hot_spot_sigma_worst_mm: Some(4.0),
            },
        ];
        let v = layout_verdict(&test_grid(), &result, &sens);
        assert_eq!(
            (
                v.points,
                v.points_measurable,
                v.points_seen_by_fewer_than_two
            ),
            (4, 3, 1)
        );
        assert_eq!((v.points_below_threshold, v.points_above_threshold), (2, 1));
        assert_eq!(v.points_degenerate, 0);
        assert!((v.fraction_measurable - 0.75).abs() < 1e-15);
        assert!((v.fraction_below_threshold_of_measurable - 2.0 / 3.0).abs() < 1e-15);
        assert!(!v.reached);
        assert_eq!(v.median_sigma_worst_mm, Some(4.0));
        assert_eq!(
            v.above_threshold_box_mm,
            Some([[1.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
        );
        let h = v.hot_spot.as_ref().expect("a hot spot");
        assert_eq!(h.point_mm, [1.0, 0.0, 0.0]);
        assert!((h.sigma_worst_mm - 6.0).abs() < 1e-12);
        // The two cameras look at the hot spot (1, 0, 0) from (1 ∓ 1000, −1000, 0): at right
        // angles.
        assert!((h.intersection_angle_deg - 90.0).abs() < 1e-9, "{h:?}");
        assert_eq!(h.observers_seen, 2);
        // Over the grid the link dominates (3.5 < 3.9); at the hot spot the tie (4.0 < 5.5).
        assert_eq!(
            v.dominant_input.as_ref().map(|d| d.input.as_str()),
            Some("link")
        );
        let hd = h.dominant_input.as_ref().expect("dominant at the hot spot");
        assert_eq!((hd.input.as_str(), hd.sigma_worst_halved_mm), ("tie", 4.0));
    }

    /// Four points on x = 0…3 mm, two aimed cameras at (1 ∓ 1000, −1000, 0), threshold 5 mm.
    fn test_grid() -> crashrig_mc::Grid {
        let axis = |start, stop, count| crashrig_mc::Axis { start, stop, count };
        let observer = |x: f64| crashrig_mc::Observer {
            name: format!("o{x}"),
            position_mm: Vector3::new(x, -1000.0, 0.0),
            sigma: crashrig_mc::ObserverSigma::From(0),
            aim: crashrig_mc::Aim::Point,
        };
        crashrig_mc::Grid {
            x: axis(0.0, 3.0, 4),
            y: axis(0.0, 0.0, 1),
            z: axis(0.0, 0.0, 1),
            threshold_mm: 5.0,
            observers: vec![observer(-999.0), observer(1001.0)],
            pixel: None,
            correlated: false,
            adaptive: None,
        }
    }
}
