//! Outlier epochs: the Iglewicz–Hoaglin modified z-score on each of the six parameters.
//!
//! For a series `x` with median `m` and median absolute deviation `MAD = median |x − m|`, the
//! modified z-score is `M = 0.6745 (x − m) / MAD` (0.6745 makes `MAD/0.6745` a consistent σ for
//! Gaussian data). An epoch is an **outlier when `|M| > 3.5` on any of the six parameters**
//! (x, y, z, ω, φ, κ; angles unwrapped about their circular mean). Iglewicz & Hoaglin (1993),
//! *How to Detect and Handle Outliers*, recommend 3.5. When `MAD = 0` (more than half the values
//! equal) the mean absolute deviation is used instead, `M = (x − m) / (1.253314 · MeanAD)`;
//! when that is 0 too, every value is equal and every score is 0. Both spreads are floored at
//! the numerical resolution of a link computed from f64 poses ([`BASE_RESOLUTION_MM`],
//! [`ANGLE_RESOLUTION_RAD`]), so a series that is constant up to rounding has no outliers.

use crate::stats::parameter_series;
use crate::{Error, Link};

/// The outlier threshold on `|M|` (Iglewicz–Hoaglin).
pub const OUTLIER_THRESHOLD: f64 = 3.5;
/// Resolution of a base coordinate: ~10⁴ ulps of a 10 m coordinate, far below any measurement.
pub const BASE_RESOLUTION_MM: f64 = 1e-9;
/// Resolution of an angle (rad): ~10⁴ ulps of π, far below any measurement.
pub const ANGLE_RESOLUTION_RAD: f64 = 1e-12;
/// `Φ⁻¹(0.75)`: `MAD / 0.6745` estimates σ for Gaussian data.
const MAD_TO_Z: f64 = 0.6745;
/// `√(π/2)`: `MeanAD · 1.253314` estimates σ for Gaussian data.
const MEAN_AD_TO_SIGMA: f64 = 1.253314;

/// Median of a non-empty finite slice (mean of the two middle values for even length).
pub(crate) fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Modified z-scores of `values` (see the module doc); spreads below `resolution` are raised
/// to it. Empty in, empty out.
pub fn modified_z_scores(values: &[f64], resolution: f64) -> Vec<f64> {
    if values.is_empty() {
        return Vec::new();
    }
    let m = median(values);
    let dev: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
    let mad = median(&dev);
    let mean_ad = dev.iter().sum::<f64>() / dev.len() as f64;
    if mad > 0.0 || mean_ad <= resolution {
        let mad = mad.max(resolution);
        return values.iter().map(|v| MAD_TO_Z * (v - m) / mad).collect();
    }
    values
        .iter()
        .map(|v| (v - m) / (MEAN_AD_TO_SIGMA * mean_ad))
        .collect()
}

/// Per-epoch robust scores and flags.
#[derive(Debug, Clone, PartialEq)]
pub struct OutlierReport {
    /// Modified z-score of each epoch on (x, y, z, ω, φ, κ).
    pub z_scores: Vec<[f64; 6]>,
    /// True when any `|z| > `[`OUTLIER_THRESHOLD`].
    pub outlier: Vec<bool>,
}

impl OutlierReport {
    /// Indices of the flagged epochs, ascending.
    pub fn indices(&self) -> Vec<usize> {
        self.outlier
            .iter()
            .enumerate()
            .filter_map(|(i, &o)| o.then_some(i))
            .collect()
    }
}

/// Flags outlier epochs with the rule of the module doc.
///
/// # Errors
/// [`Error::Geometry`] when an angle series has no circular mean.
pub fn flag_outliers(links: &[Link]) -> Result<OutlierReport, Error> {
    if links.is_empty() {
        return Ok(OutlierReport {
            z_scores: Vec::new(),
            outlier: Vec::new(),
        });
    }
    let series = parameter_series(links)?;
    let z: Vec<Vec<f64>> = series
        .iter()
        .enumerate()
        .map(|(j, s)| {
            modified_z_scores(
                s,
                if j < 3 {
                    BASE_RESOLUTION_MM
                } else {
                    ANGLE_RESOLUTION_RAD
                },
            )
        })
        .collect();
    let z_scores: Vec<[f64; 6]> = (0..links.len())
        .map(|i| std::array::from_fn(|j| z[j][i]))
        .collect();
    let outlier = z_scores
        .iter()
        .map(|zs| zs.iter().any(|v| v.abs() > OUTLIER_THRESHOLD))
        .collect();
    Ok(OutlierReport { z_scores, outlier })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::tests_support::link;
    use approx::assert_abs_diff_eq;

    #[test]
    fn modified_z_scores_nominal() {
        // median 3, |x − 3| = 2 1 0 1 97 → MAD 1; M = 0.6745 (x − 3).
        let z = modified_z_scores(&[1.0, 2.0, 3.0, 4.0, 100.0], 1e-9);
        let expect = [-1.349, -0.6745, 0.0, 0.6745, 65.4265];
        for (a, b) in z.iter().zip(expect) {
            assert_abs_diff_eq!(*a, b, epsilon = 1e-12);
        }
    }

    #[test]
    fn modified_z_scores_zero_mad_uses_mean_ad() {
        // median 5, MAD 0, MeanAD = 5/4 → M(10) = 5 / (1.253314 · 1.25).
        let z = modified_z_scores(&[5.0, 5.0, 5.0, 10.0], 1e-9);
        assert_abs_diff_eq!(z[3], 5.0 / (1.253314 * 1.25), epsilon = 1e-12);
        assert_abs_diff_eq!(z[0], 0.0, epsilon = 0.0);
        let z = modified_z_scores(&[2.0, 2.0, 2.0], 1e-9);
        assert!(z.iter().all(|v| *v == 0.0));
        // Constant up to rounding: the resolution floor keeps the scores small.
        let z = modified_z_scores(&[2.0, 2.0 + 4e-16, 2.0, 2.0 - 4e-16, 2.0 + 8e-16], 1e-9);
        assert!(z.iter().all(|v| v.abs() < 1e-5));
    }

    #[test]
    fn flag_outliers_gross_base_and_angle() {
        let mut links: Vec<Link> = (0..20)
            .map(|i| {
                let d = (i as f64 * 0.7).sin();
                link(
                    [62.0 + d, -1.7 - d, 179.8 + 0.5 * d],
                    [179.95 + 0.05 * d, -0.09, 179.76 - 0.05 * d],
                )
            })
            .collect();
        links[4] = link([90.0, -1.7, 179.8], [179.95, -0.09, 179.76]);
        // ω pushed across the ±180° wrap by 1°: still one small-spread series plus one outlier.
        links[11] = link([62.0, -1.7, 179.8], [-179.0, -0.09, 179.76]);
        let r = flag_outliers(&links).unwrap();
        assert_eq!(r.indices(), vec![4, 11]);
        assert!(r.z_scores[4][0] > OUTLIER_THRESHOLD);
        assert!(r.z_scores[11][3] > OUTLIER_THRESHOLD);
    }
}
