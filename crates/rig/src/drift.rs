//! Drift in the epoch series: autocorrelation and the effective number of epochs.
//!
//! σ/√n assumes independent epochs. A slowly drifting rig (temperature, a loose mount) gives a
//! positively autocorrelated series, and σ/√n is then optimistic. With the lag-1
//! autocorrelation ρ₁ of a parameter, the AR(1) effective sample size is
//! `n_eff = n (1 − ρ₁)/(1 + ρ₁)` (for ρ₁ > 0; `n` otherwise), and the SEM should be inflated by
//! `√(n / n_eff)`. Under white noise ρ₁ is approximately `N(0, 1/n)` (Bartlett); a parameter is
//! flagged when ρ₁ exceeds `2.394/√n`, a one-sided test of positive autocorrelation at a
//! **family-wise** level of 5 % over the six parameters (Bonferroni: `Φ⁻¹(1 − 0.05/6) = 2.394`),
//! so a white-noise sequence raises the warning in about 5 % of cases, not in 1 − 0.975⁶ ≈ 14 %.

use crate::stats::parameter_series;
use crate::{Error, Link};

/// `Φ⁻¹(1 − 0.05/6)`: one-sided, Bonferroni over the six parameters, family-wise 5 %.
const WHITE_NOISE_Z: f64 = 2.393_979_8;

/// Sample autocorrelation `r_k = Σ_t (x_t − x̄)(x_{t+k} − x̄) / Σ_t (x_t − x̄)²` for
/// `k = 1..=max_lag` (lags ≥ n are left out). A constant series has all `r_k = 0`.
pub fn autocorrelation(series: &[f64], max_lag: usize) -> Vec<f64> {
    let n = series.len();
    if n == 0 {
        return Vec::new();
    }
    let m = series.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = series.iter().map(|v| v - m).collect();
    let c0: f64 = d.iter().map(|v| v * v).sum();
    (1..=max_lag.min(n.saturating_sub(1)))
        .map(|k| {
            if c0 > 0.0 {
                d.iter().zip(&d[k..]).map(|(a, b)| a * b).sum::<f64>() / c0
            } else {
                0.0
            }
        })
        .collect()
}

/// AR(1) effective number of independent epochs for lag-1 autocorrelation `rho1`
/// (`n` when `rho1 ≤ 0`, at least 1).
pub fn effective_n(n: usize, rho1: f64) -> f64 {
    let n = n as f64;
    if rho1 <= 0.0 || !rho1.is_finite() {
        return n;
    }
    (n * (1.0 - rho1) / (1.0 + rho1)).clamp(1.0_f64.min(n), n)
}

/// Autocorrelation of each of the six parameter series and what it means for the SEM.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftReport {
    /// Lags 1..=k of (x, y, z, ω, φ, κ), in that order.
    pub autocorrelation: [Vec<f64>; 6],
    /// AR(1) effective number of epochs per parameter.
    pub effective_n: [f64; 6],
    /// Factor `√(n / n_eff)` by which σ/√n understates the SEM under AR(1).
    pub sem_inflation: [f64; 6],
    /// The white-noise bound `2.394/√n` of the lag-1 autocorrelation (see the module doc).
    pub white_noise_band: f64,
    /// Parameters whose lag-1 autocorrelation exceeds the band (σ/√n likely optimistic).
    pub optimistic: [bool; 6],
}

impl DriftReport {
    /// True when any parameter's σ/√n is likely optimistic.
    pub fn any_optimistic(&self) -> bool {
        self.optimistic.iter().any(|&b| b)
    }
}

/// Drift report over the epoch order of `links` (lags 1..=`max_lag`, at least lag 1 is used).
///
/// # Errors
/// [`Error::TooFewEpochs`] for fewer than three links; [`Error::Geometry`] when an angle
/// series has no circular mean.
pub fn drift_report(links: &[Link], max_lag: usize) -> Result<DriftReport, Error> {
    let n = links.len();
    if n < 3 {
        return Err(Error::TooFewEpochs {
            what: "autocorrelation",
            needed: 3,
            found: n,
        });
    }
    let series = parameter_series(links)?;
    let autocorrelation: [Vec<f64>; 6] =
        std::array::from_fn(|j| autocorrelation(&series[j], max_lag.max(1)));
    let effective: [f64; 6] = std::array::from_fn(|j| effective_n(n, autocorrelation[j][0]));
    let band = WHITE_NOISE_Z / (n as f64).sqrt();
    Ok(DriftReport {
        sem_inflation: std::array::from_fn(|j| (n as f64 / effective[j]).sqrt()),
        optimistic: std::array::from_fn(|j| autocorrelation[j][0] > band),
        effective_n: effective,
        white_noise_band: band,
        autocorrelation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::tests_support::link;
    use approx::assert_abs_diff_eq;

    #[test]
    fn autocorrelation_nominal() {
        // x = 1 2 3 4: d = −1.5 −0.5 0.5 1.5, c0 = 5; r1 = (0.75 − 0.25 + 0.75)/5 = 0.25,
        // r2 = (−0.75 − 0.75)/5 = −0.3, r3 = −2.25/5 = −0.45.
        let r = autocorrelation(&[1.0, 2.0, 3.0, 4.0], 5);
        assert_eq!(r.len(), 3);
        assert_abs_diff_eq!(r[0], 0.25, epsilon = 1e-15);
        assert_abs_diff_eq!(r[1], -0.3, epsilon = 1e-15);
        assert_abs_diff_eq!(r[2], -0.45, epsilon = 1e-15);
        assert!(autocorrelation(&[2.0; 5], 2).iter().all(|v| *v == 0.0));
    }

    #[test]
    fn effective_n_cases() {
        assert_abs_diff_eq!(effective_n(100, 0.5), 100.0 / 3.0, epsilon = 1e-12);
        assert_abs_diff_eq!(effective_n(100, -0.2), 100.0, epsilon = 0.0);
        assert_abs_diff_eq!(effective_n(10, 0.999), 1.0, epsilon = 0.0);
    }

    #[test]
    fn drift_report_white_noise_warns_about_five_percent() {
        use rand::RngExt;
        use rand_distr::StandardNormal;
        // 400 white-noise sequences of 140 epochs: the family-wise rate is ~5 % (slightly less:
        // ρ₁ is biased by −1/n). Binomial standard error √(400·0.05·0.95) ≈ 4.4 sequences, so
        // [4, 36] is 5 % ± ~3.6 SE with room for the bias.
        let mut warned = 0;
        for rep in 0..400 {
            let mut rng = crashrig_stats::stream(11, rep);
            let mut g = || -> f64 { rng.sample(StandardNormal) };
            let links: Vec<Link> = (0..140)
                .map(|_| {
                    link(
                        [62.0 + 2.0 * g(), -1.7 + 3.0 * g(), 179.8 + 1.5 * g()],
                        [179.92 + 0.05 * g(), -0.09 + 0.06 * g(), 179.76 + 0.09 * g()],
                    )
                })
                .collect();
            if drift_report(&links, 1).unwrap().any_optimistic() {
                warned += 1;
            }
        }
        assert!((4..=36).contains(&warned), "{warned} of 400 warned");
    }

    #[test]
    fn drift_report_flags_a_ramp_not_alternation() {
        // x drifts linearly (ρ₁ near 1); y alternates (ρ₁ near −1).
        let links: Vec<Link> = (0..40)
            .map(|i| {
                let alt = if i % 2 == 0 { 1.0 } else { -1.0 };
                link([60.0 + 0.1 * i as f64, alt, 180.0], [179.9, 0.0, 179.7])
            })
            .collect();
        let d = drift_report(&links, 5).unwrap();
        assert!(d.optimistic[0]);
        assert!(!d.optimistic[1]);
        assert!(d.sem_inflation[0] > 3.0);
        assert_abs_diff_eq!(d.sem_inflation[1], 1.0, epsilon = 0.0);
        assert!(d.any_optimistic());
        assert_eq!(d.autocorrelation[0].len(), 5);
    }
}
