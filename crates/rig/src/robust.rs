//! Outlier epochs: robust z-scores on each of the six parameters, with a threshold that holds
//! the **per-sequence** false-flag rate (multiple testing over `6n` scores).
//!
//! For a series `x` with median `m` and median absolute deviation `MAD = median |x − m|`, the
//! modified z-score is `M = 0.6745 (x − m) / MAD` (Iglewicz–Hoaglin; `MAD/0.6745` is a
//! consistent σ for Gaussian data). A fixed cut-off such as their `|M| > 3.5` is a per-score
//! rule: over the `6n` scores of a 140-epoch sequence it flags clean epochs in most sequences.
//! Here an epoch is an **outlier when `|M| > t(n)` on any of the six parameters** (x, y, z, ω,
//! φ, κ; angles unwrapped about their circular mean), with
//!
//! `t(n) = t_ν⁻¹(1 − α / (2·6n))`, `α` = [`FAMILY_WISE_FALSE_FLAG_RATE`] = 0.5 %,
//! `ν = 0.3675 n`:
//!
//! - `α/(2·6n)` is Bonferroni over the `6n` two-sided scores, so a clean Gaussian sequence gets
//!   **any** flag with probability at most about `α` (less when the parameters are correlated);
//! - the Student-t quantile accounts for the MAD's own sampling error: the MAD estimate of σ has
//!   the variance of a sample σ with `ν = n/(2·1.3605) = 0.3675 n` degrees of freedom
//!   (its asymptotic variance is `1.3605 σ²/n`).
//!
//! `t(140) = 5.04`, `t(60) = 5.54`, `t(30) = 6.9`: a gross error of 10 σ is flagged in a
//! 140-epoch sequence whatever the other epochs do. Measured on clean simulated sequences
//! (`docs/CALIBRATE.md`, test `outlier_rule_false_flag_rate_slow`), the per-sequence
//! false-flag rate is 0.57 % (23 of 4000 sequences of 140 epochs).
//!
//! **Under drift** a series' own spread understates σ (it wanders less than the process
//! does), so each parameter's threshold is raised to `t(n)/√q_j`, `q_j = E[s²]/σ²` of the drift
//! model fitted to that series ([`crate::sem::DriftModel`], `q = 1` where no drift is fitted):
//! on AR(1) ρ = 0.9 sequences of 140 epochs 0.57 % of them get a flag (23 of 4000; issue 25
//! measured 1.27 % with the single threshold), test `outlier_rule_under_drift_and_heavy_tails_slow`. The rule makes
//! no promise for epochs with heavier tails than Gaussian: on Student t₅ epochs 92.7 % of
//! sequences get a flag — the tail epochs, which is what the scores measure.
//!
//! When `MAD = 0` (more than half the values equal) the mean absolute deviation is used instead,
//! `M = (x − m) / (1.253314 · MeanAD)`; when that is 0 too, every value is equal and every score
//! is 0. Both spreads are floored at the numerical resolution of a link computed from f64 poses
//! ([`BASE_RESOLUTION_MM`], [`ANGLE_RESOLUTION_RAD`]), so a series that is constant up to
//! rounding has no outliers.

use crate::stats::parameter_series;
use crate::{Error, Link};

/// Nominal probability that a clean sequence (Gaussian, independent epochs) gets any flag.
pub const FAMILY_WISE_FALSE_FLAG_RATE: f64 = 0.005;
/// Degrees of freedom of the MAD scale estimate per epoch (`1/(2·1.3605)`).
pub const MAD_DEGREES_OF_FREEDOM_PER_EPOCH: f64 = 0.3675;
/// Resolution of a base coordinate: ~10⁴ ulps of a 10 m coordinate, far below any measurement.
pub const BASE_RESOLUTION_MM: f64 = 1e-9;
/// Resolution of an angle (rad): ~10⁴ ulps of π, far below any measurement.
pub const ANGLE_RESOLUTION_RAD: f64 = 1e-12;
/// `Φ⁻¹(0.75)`: `MAD / 0.6745` estimates σ for Gaussian data.
const MAD_TO_Z: f64 = 0.6745;
/// `√(π/2)`: `MeanAD · 1.253314` estimates σ for Gaussian data.
const MEAN_AD_TO_SIGMA: f64 = 1.253314;

/// The threshold `t(n)` on `|M|` for a sequence of `n` epochs (see the module doc);
/// infinite for fewer than two epochs.
pub fn outlier_threshold(n: usize) -> f64 {
    if n < 2 {
        return f64::INFINITY;
    }
    let nu = MAD_DEGREES_OF_FREEDOM_PER_EPOCH * n as f64;
    let tail = FAMILY_WISE_FALSE_FLAG_RATE / (2.0 * 6.0 * n as f64);
    // Upper tail of Student's t: P(T > t) = ½·I_{ν/(ν+t²)}(ν/2, ½), inverted directly (no
    // `1 − p` cancellation).
    let y = statrs::function::beta::inv_beta_reg(0.5 * nu, 0.5, 2.0 * tail);
    (nu * (1.0 - y) / y).sqrt()
}

/// A one-line description of the rule, for reports.
pub fn outlier_rule_description(n: usize) -> String {
    format!(
        "modified z-score 0.6745·(x − median)/MAD on each of x y z ω φ κ; flagged when any \
         |z| > t(n) = {:.3} (Student-t quantile 1 − α/(12n), α = {} per sequence, ν = {}·n)",
        outlier_threshold(n),
        FAMILY_WISE_FALSE_FLAG_RATE,
        MAD_DEGREES_OF_FREEDOM_PER_EPOCH
    )
}

/// Modified z-scores of `values` (see the module doc); spreads below `resolution` are raised
/// to it. Empty in, empty out.
pub fn modified_z_scores(values: &[f64], resolution: f64) -> Vec<f64> {
    if values.is_empty() {
        return Vec::new();
    }
    let median = |v: &[f64]| crashrig_stats::summary::median(v).unwrap_or(f64::NAN);
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
    /// True when any `|z|` exceeds its parameter's threshold
    /// ([`OutlierReport::thresholds`]).
    pub outlier: Vec<bool>,
    /// The threshold `t(n)` for independent epochs ([`outlier_threshold`]).
    pub threshold: f64,
    /// The threshold applied to each parameter (x, y, z, ω, φ, κ): `t(n)/√q_j`, `q_j ≤ 1` the
    /// factor by which drift makes the series' own spread understate σ (see the module doc);
    /// `t(n)` where no drift is fitted.
    pub thresholds: [f64; 6],
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

/// `t(n)/√q_j` per series: `q_j = E[s²]/σ²` of the drift model fitted to the series
/// ([`crate::sem::DriftModel`]); `t(n)` for series shorter than [`crate::sem::MIN_EPOCHS`].
fn drift_thresholds(series: &[Vec<f64>; 6], threshold: f64) -> [f64; 6] {
    let n = series[0].len();
    if n < crate::sem::MIN_EPOCHS {
        return [threshold; 6];
    }
    let model = crate::sem::DriftModel::new(n);
    std::array::from_fn(|j| threshold / model.fit(&series[j]).variance_ratio.sqrt())
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
            threshold: f64::INFINITY,
            thresholds: [f64::INFINITY; 6],
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
    let threshold = outlier_threshold(links.len());
    let thresholds = drift_thresholds(&series, threshold);
    let outlier = z_scores
        .iter()
        .map(|zs| zs.iter().zip(&thresholds).any(|(v, t)| v.abs() > *t))
        .collect();
    Ok(OutlierReport {
        z_scores,
        outlier,
        threshold,
        thresholds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::tests_support::link;
    use approx::assert_abs_diff_eq;

    #[test]
    fn outlier_threshold_matches_scipy() {
        // scipy 1.17.1: stats.t.isf(0.005 / (12 n), 0.3675 n) (as fixtures/gen/rig_sequence.py).
        for (n, want) in [
            (10, 19.022426890816206),
            (20, 8.641585477127837),
            (60, 5.551954923027369),
            (140, 5.047665877229857),
            (500, 4.950727455530289),
        ] {
            // statrs' incomplete-beta inversion: ~1e-9 relative at these tails.
            assert_abs_diff_eq!(outlier_threshold(n) / want, 1.0, epsilon = 1e-8);
        }
        assert!(outlier_threshold(1).is_infinite());
    }

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
        assert!(r.z_scores[4][0] > r.threshold);
        assert!(r.z_scores[11][3] > r.threshold);
    }
}
