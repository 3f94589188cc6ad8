//! Summaries of a scalar replicate distribution: σ, bias, percentile and BCa intervals.

use crate::error::BcaReason;
use crate::{Error, normal};
use crashrig_stats::summary::quantile_sorted;

/// A two-sided confidence interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

fn check_finite(values: &[f64], needed: usize) -> Result<(), Error> {
    if values.len() < needed {
        return Err(Error::TooFewValues {
            needed,
            found: values.len(),
        });
    }
    if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NotFinite { index, value });
    }
    Ok(())
}

fn check_level(level: f64) -> Result<(), Error> {
    if level > 0.0 && level < 1.0 {
        Ok(())
    } else {
        Err(Error::BadLevel { level })
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Bootstrap standard error: the sample standard deviation (n − 1) of the replicate values.
pub fn sigma(values: &[f64]) -> Result<f64, Error> {
    check_finite(values, 2)?;
    let m = mean(values);
    let ss: f64 = values.iter().map(|v| (v - m) * (v - m)).sum();
    Ok((ss / (values.len() as f64 - 1.0)).sqrt())
}

/// Bootstrap bias estimate: mean of the replicates minus the full-sample `estimate`.
pub fn bias(values: &[f64], estimate: f64) -> Result<f64, Error> {
    check_finite(values, 1)?;
    Ok(mean(values) - estimate)
}

/// Percentile interval at confidence `level` (e.g. 0.95): the type-7 quantiles
/// `(1 − level)/2` and `(1 + level)/2` of the replicate values.
pub fn percentile_interval(values: &[f64], level: f64) -> Result<Interval, Error> {
    check_finite(values, 2)?;
    check_level(level)?;
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    Ok(Interval {
        lo: quantile_sorted(&v, 0.5 * (1.0 - level)),
        hi: quantile_sorted(&v, 0.5 * (1.0 + level)),
    })
}

/// BCa acceleration from jackknife values θ₍ᵢ₎ (Efron & Tibshirani 1993, eq. 14.15):
/// `a = Σ(θ̄ − θ₍ᵢ₎)³ / (6 (Σ(θ̄ − θ₍ᵢ₎)²)^{3/2})`.
pub fn acceleration(jackknife: &[f64]) -> Result<f64, Error> {
    check_finite(jackknife, 2)?;
    let m = mean(jackknife);
    let (mut s2, mut s3) = (0.0, 0.0);
    for &t in jackknife {
        let d = m - t;
        s2 += d * d;
        s3 += d * d * d;
    }
    if s2 == 0.0 {
        return Err(Error::BcaUndefined {
            reason: BcaReason::ConstantJackknife,
        });
    }
    Ok(s3 / (6.0 * s2.powf(1.5)))
}

/// BCa bias correction z₀ = Φ⁻¹(proportion of replicates below `estimate`), ties counted half.
pub fn bias_correction(values: &[f64], estimate: f64) -> Result<f64, Error> {
    check_finite(values, 2)?;
    let below = values.iter().filter(|&&v| v < estimate).count() as f64;
    let equal = values.iter().filter(|&&v| v == estimate).count() as f64;
    let p = (below + 0.5 * equal) / values.len() as f64;
    let z0 = normal::inverse_cdf(p);
    if z0.is_finite() {
        Ok(z0)
    } else {
        Err(Error::BcaUndefined {
            reason: BcaReason::EstimateOutsideReplicates,
        })
    }
}

/// Bias-corrected and accelerated (BCa) interval at confidence `level`
/// (Efron 1987; Efron & Tibshirani 1993, §14.3).
///
/// `values` are the bootstrap replicates, `estimate` the statistic on the full sample and
/// `jackknife` the leave-one-out values (see [`crate::jackknife`]). The interval ends are the
/// type-7 quantiles at `Φ(z₀ + (z₀ + z)/(1 − a(z₀ + z)))` for `z = Φ⁻¹((1 ∓ level)/2)`.
pub fn bca_interval(
    values: &[f64],
    estimate: f64,
    jackknife: &[f64],
    level: f64,
) -> Result<Interval, Error> {
    check_level(level)?;
    let z0 = bias_correction(values, estimate)?;
    let a = acceleration(jackknife)?;
    let adjusted = |p: f64| {
        let z = normal::inverse_cdf(p);
        let w = z0 + z;
        normal::cdf(z0 + w / (1.0 - a * w))
    };
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let p_lo = adjusted(0.5 * (1.0 - level)).clamp(0.0, 1.0);
    let p_hi = adjusted(0.5 * (1.0 + level)).clamp(0.0, 1.0);
    Ok(Interval {
        lo: quantile_sorted(&v, p_lo),
        hi: quantile_sorted(&v, p_hi),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{jackknife, run};
    use approx::{assert_abs_diff_eq, assert_relative_eq};
    use rand::RngExt;
    use rand_distr::StandardNormal;

    fn normal_data(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = crashrig_stats::stream(seed, 0);
        (0..n).map(|_| rng.sample(StandardNormal)).collect()
    }

    fn mean_at(data: &[f64], idx: &[usize]) -> Result<f64, ()> {
        Ok(idx.iter().map(|&i| data[i]).sum::<f64>() / idx.len() as f64)
    }

    #[test]
    fn sigma_nominal_mean_of_normal_data() {
        // The ideal bootstrap σ of the mean is exactly the plug-in σ̂/√n = s/√n·√((n−1)/n).
        let n = 40;
        let data = normal_data(n, 1);
        let m = mean(&data);
        let s = (data.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
        let ideal = s / (n as f64).sqrt() * ((n as f64 - 1.0) / n as f64).sqrt();
        let b = 4000;
        let reps = run(n, b, 7, |idx| mean_at(&data, idx), None).unwrap();
        let v: Vec<f64> = reps.values_only().copied().collect();
        // The replicate mean is ~normal, so σ from B replicates has relative standard error
        // 1/√(2(B−1)) = 1.1 %; 4 of those is 4.5 %.
        assert_relative_eq!(sigma(&v).unwrap(), ideal, max_relative = 0.045);
        // Bias of the mean is 0 in expectation; its Monte Carlo error is ideal/√B.
        assert_abs_diff_eq!(
            bias(&v, m).unwrap(),
            0.0,
            epsilon = 4.0 * ideal / (b as f64).sqrt()
        );
    }

    #[test]
    fn sigma_proportion_is_binomial() {
        // Resampling n Bernoulli items with replacement makes the count Binomial(n, p̂) exactly,
        // so the ideal bootstrap σ of the proportion is √(p̂(1 − p̂)/n).
        let n = 60;
        let data: Vec<f64> = (0..n).map(|i| f64::from(u8::from(i % 5 < 2))).collect();
        let p_hat = 0.4;
        let ideal = (p_hat * (1.0 - p_hat) / n as f64).sqrt();
        let b = 4000;
        let v: Vec<f64> = run(n, b, 21, |idx| mean_at(&data, idx), None)
            .unwrap()
            .values_only()
            .copied()
            .collect();
        // Binomial(60, 0.4) is close to normal (excess kurtosis −0.03), so σ from B replicates
        // has relative standard error ≈ 1/√(2(B − 1)) = 1.1 %; 4 of those is 4.5 %.
        assert_relative_eq!(sigma(&v).unwrap(), ideal, max_relative = 0.045);
        assert_abs_diff_eq!(
            bias(&v, p_hat).unwrap(),
            0.0,
            epsilon = 4.0 * ideal / (b as f64).sqrt()
        );
    }

    #[test]
    fn percentile_interval_nominal_mean_of_normal_data() {
        // For the mean the replicate distribution is ~N(x̄, ideal²): the 95 % percentile interval
        // is x̄ ± 1.96·ideal up to Monte Carlo error of the 2.5 % quantile (≈ 2.3·ideal/√B·…).
        let n = 50;
        let data = normal_data(n, 2);
        let m = mean(&data);
        let v: Vec<f64> = run(n, 4000, 9, |idx| mean_at(&data, idx), None)
            .unwrap()
            .values_only()
            .copied()
            .collect();
        let ideal =
            sigma(&data).unwrap() / (n as f64).sqrt() * ((n as f64 - 1.0) / n as f64).sqrt();
        let ci = percentile_interval(&v, 0.95).unwrap();
        // Standard error of the 2.5 % sample quantile of N(0, σ²) with B = 4000:
        // √(p(1−p)/B)/φ(1.96) σ = 0.0427 σ; the data skewness adds more, so allow 0.15 σ.
        assert_abs_diff_eq!(ci.lo, m - 1.959_964 * ideal, epsilon = 0.15 * ideal);
        assert_abs_diff_eq!(ci.hi, m + 1.959_964 * ideal, epsilon = 0.15 * ideal);
    }

    #[test]
    fn acceleration_nominal_mean_closed_form() {
        // For the mean, θ̄ − θ₍ᵢ₎ = (xᵢ − x̄)/(n − 1), so a = Σd³/(6(Σd²)^{3/2}) with d = xᵢ − x̄.
        let data = [0.3, 1.7, -2.0, 4.5, 0.0, 0.9];
        let jk: Vec<f64> = jackknife(data.len(), |idx| mean_at(&data, idx), None)
            .unwrap()
            .into_iter()
            .map(Result::unwrap)
            .collect();
        let m = mean(&data);
        let s2: f64 = data.iter().map(|x| (x - m).powi(2)).sum();
        let s3: f64 = data.iter().map(|x| (x - m).powi(3)).sum();
        assert_relative_eq!(
            acceleration(&jk).unwrap(),
            s3 / (6.0 * s2.powf(1.5)),
            epsilon = 1e-12
        );
        assert_eq!(
            acceleration(&[1.0, 1.0, 1.0]).unwrap_err(),
            Error::BcaUndefined {
                reason: BcaReason::ConstantJackknife
            }
        );
    }

    #[test]
    fn bca_interval_nominal_transformation_respecting() {
        // BCa is transformation-respecting: for a monotone g, the BCa interval of g(θ) is g of
        // the BCa interval of θ when it picks the same order statistics (z₀ and a are
        // invariant up to the jackknife's second-order terms, so compare with a tolerance).
        let data: Vec<f64> = normal_data(30, 4).iter().map(|x| 1.0 + 0.2 * x).collect();
        let stat = |idx: &[usize]| mean_at(&data, idx);
        let reps: Vec<f64> = run(30, 2000, 5, stat, None)
            .unwrap()
            .values_only()
            .copied()
            .collect();
        let all: Vec<usize> = (0..30).collect();
        let est = stat(&all).unwrap();
        let jk: Vec<f64> = jackknife(30, stat, None)
            .unwrap()
            .into_iter()
            .map(Result::unwrap)
            .collect();
        let ci = bca_interval(&reps, est, &jk, 0.9).unwrap();
        assert!(ci.lo < est && est < ci.hi);
        // Identity transform of a symmetric statistic: BCa is close to the percentile interval
        // (|z₀|, |a| are O(1/√n)); within one bootstrap σ.
        let pct = percentile_interval(&reps, 0.9).unwrap();
        let sd = sigma(&reps).unwrap();
        assert_abs_diff_eq!(ci.lo, pct.lo, epsilon = sd);
        assert_abs_diff_eq!(ci.hi, pct.hi, epsilon = sd);
        // Exponential transform: same ranks, so the BCa ends map through exp.
        let ereps: Vec<f64> = reps.iter().map(|v| v.exp()).collect();
        let ejk: Vec<f64> = jk.iter().map(|v| v.exp()).collect();
        let eci = bca_interval(&ereps, est.exp(), &ejk, 0.9).unwrap();
        // The jackknife acceleration changes slightly under exp (second order); 2 % of the
        // interval width covers it.
        let w = ci.hi.exp() - ci.lo.exp();
        assert_abs_diff_eq!(eci.lo, ci.lo.exp(), epsilon = 0.02 * w);
        assert_abs_diff_eq!(eci.hi, ci.hi.exp(), epsilon = 0.02 * w);
    }

    #[test]
    fn bca_interval_rejects_estimate_outside() {
        let v = [1.0, 2.0, 3.0];
        assert_eq!(
            bca_interval(&v, 0.5, &[0.1, 0.2], 0.95).unwrap_err(),
            Error::BcaUndefined {
                reason: BcaReason::EstimateOutsideReplicates
            }
        );
        assert_eq!(
            percentile_interval(&v, 1.0).unwrap_err(),
            Error::BadLevel { level: 1.0 }
        );
        assert!(matches!(
            sigma(&[1.0, f64::INFINITY]),
            Err(Error::NotFinite { index: 1, .. })
        ));
    }

    /// Hits of the 90 % percentile and BCa intervals for the mean (0) of normal data, out of
    /// `datasets` independent data sets of size `n`.
    fn coverage(datasets: usize, n: usize, b: usize) -> (usize, usize) {
        let mut hit_pct = 0;
        let mut hit_bca = 0;
        for d in 0..datasets {
            let data = normal_data(n, 1000 + d as u64);
            let stat = |idx: &[usize]| mean_at(&data, idx);
            let reps: Vec<f64> = run(n, b, d as u64, stat, None)
                .unwrap()
                .values_only()
                .copied()
                .collect();
            let all: Vec<usize> = (0..n).collect();
            let est = stat(&all).unwrap();
            let jk: Vec<f64> = jackknife(n, stat, None)
                .unwrap()
                .into_iter()
                .map(Result::unwrap)
                .collect();
            let p = percentile_interval(&reps, 0.9).unwrap();
            let c = bca_interval(&reps, est, &jk, 0.9).unwrap();
            // True mean is 0.
            hit_pct += usize::from(p.lo <= 0.0 && 0.0 <= p.hi);
            hit_bca += usize::from(c.lo <= 0.0 && 0.0 <= c.hi);
        }
        (hit_pct, hit_bca)
    }

    /// `P(X ≤ k)` for `X ~ Binomial(n, p)`, by summing the pmf in log space.
    fn binomial_cdf(k: usize, n: usize, p: f64) -> f64 {
        let ln_choose = |i: usize| -> f64 {
            (1..=i)
                .map(|j| ((n - i + j) as f64 / j as f64).ln())
                .sum::<f64>()
        };
        (0..=k.min(n))
            .map(|i| (ln_choose(i) + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln()).exp())
            .sum::<f64>()
            .min(1.0)
    }

    /// Binomial acceptance test of a coverage count: `hits` of `trials` is accepted when it is
    /// not significantly low against the smallest plausible true coverage `p_lo` nor
    /// significantly high against the largest `p_hi`, each one-sided at `alpha / 2`. A
    /// correct implementation (true coverage in `[p_lo, p_hi]`) fails with probability ≤ alpha.
    fn binomial_accepts(hits: usize, trials: usize, p_lo: f64, p_hi: f64, alpha: f64) -> bool {
        let low_tail = binomial_cdf(hits, trials, p_lo); // P(X ≤ hits | p_lo)
        let high_tail = if hits == 0 {
            1.0
        } else {
            1.0 - binomial_cdf(hits - 1, trials, p_hi) // P(X ≥ hits | p_hi)
        };
        low_tail >= alpha / 2.0 && high_tail >= alpha / 2.0
    }

    #[test]
    fn binomial_helpers_known_values() {
        // Binomial(10, 0.5): P(X ≤ 5) = 638/1024; P(X ≤ 0) = 1/1024.
        assert_abs_diff_eq!(binomial_cdf(5, 10, 0.5), 638.0 / 1024.0, epsilon = 1e-12);
        assert_abs_diff_eq!(binomial_cdf(0, 10, 0.5), 1.0 / 1024.0, epsilon = 1e-15);
        assert_abs_diff_eq!(binomial_cdf(10, 10, 0.3), 1.0, epsilon = 1e-12);
        // Acceptance regions at α = 0.001 for [0.86, 0.90] (scipy.stats.binom): 58..=79 of 80,
        // 823..=930 of 1000. P(X ≤ 55 | 80, 0.86) = 6.1e-5 < 5e-4: rejected.
        assert!(binomial_accepts(72, 80, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(55, 80, 0.86, 0.90, 1e-3));
        assert!(binomial_accepts(58, 80, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(57, 80, 0.86, 0.90, 1e-3));
        assert!(binomial_accepts(79, 80, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(80, 80, 0.86, 0.90, 1e-3));
        assert!(binomial_accepts(823, 1000, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(822, 1000, 0.86, 0.90, 1e-3));
        assert!(binomial_accepts(930, 1000, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(931, 1000, 0.86, 0.90, 1e-3));
        assert!(!binomial_accepts(1000, 1000, 0.86, 0.90, 1e-3));
    }

    /// Plausible true coverage of the nominal 90 % intervals for the mean of n = 25 normal
    /// values: the z-based bootstrap intervals with the plug-in σ behave like ±1.645·σ̂/√n
    /// against a t₂₄ pivot, P(|t₂₄| ≤ 1.645·√(24/25)) = 0.879; BCa is within a point of it.
    const COVERAGE_LO: f64 = 0.86;
    const COVERAGE_HI: f64 = 0.90;

    #[test]
    fn coverage_fast_reduced() {
        // 80 data sets, binomial test at α = 0.001 against a true coverage in [0.86, 0.90]
        // (acceptance region 58..=79 hits, i.e. 0.73–0.99: wide, because 80 is few; it still
        // catches an interval that is badly wrong, e.g. a 68 % interval).
        let (p, c) = coverage(80, 25, 400);
        assert!(
            binomial_accepts(p, 80, COVERAGE_LO, COVERAGE_HI, 1e-3),
            "percentile coverage {p}/80"
        );
        assert!(
            binomial_accepts(c, 80, COVERAGE_LO, COVERAGE_HI, 1e-3),
            "BCa coverage {c}/80"
        );
    }

    #[test]
    #[ignore = "slow: 1000 data sets x 1000 replicates; run by cargo xtask test --slow"]
    fn slow_coverage_percentile_and_bca() {
        // 1000 data sets, binomial test at α = 0.001 against a true coverage in [0.86, 0.90]
        // (acceptance region 823..=930 hits); 1000 bootstrap replicates each keep the
        // interval end points' own Monte Carlo error well below the binomial spread.
        let (p, c) = coverage(1000, 25, 1000);
        assert!(
            binomial_accepts(p, 1000, COVERAGE_LO, COVERAGE_HI, 1e-3),
            "percentile coverage {p}/1000"
        );
        assert!(
            binomial_accepts(c, 1000, COVERAGE_LO, COVERAGE_HI, 1e-3),
            "BCa coverage {c}/1000"
        );
    }
}
