//! The uncertainty of the mean link when the epochs are autocorrelated.
//!
//! The epochs of a sequence are often not independent: a rig that drifts slowly (temperature,
//! a settling mount) gives positively autocorrelated links, and `Σ/n` (Σ the spread of one
//! epoch's link) then understates the uncertainty of the mean. The rule used here,
//! **`ar1_effective_n`**, works on the six tangent residual series of the links about their
//! mean (centre in A's axes, mm; rotation `log(R̄ᵀ·R)` about B's axes, rad):
//!
//! 1. per axis `j`, the lag-1 autocorrelation `r₁`; the axis is **autocorrelated** when
//!    `r₁ > 2.394/√n` (the one-sided white-noise test of [`crate::drift`], family-wise 5 %
//!    over the six axes);
//! 2. for such an axis, `r₁` is corrected for its small-sample bias under AR(1) with unknown
//!    mean (Marriott–Pope: `E[r₁] ≈ ρ − (1 + 3ρ)/n`), `ρ̃ = min((n·r₁ + 1)/(n − 3), 0.99)`;
//! 3. `τ = 1 + 2 Σ_{k=1}^{n−1} (1 − k/n) ρ̃^k` is the factor by which autocorrelation inflates
//!    `Var(x̄)` over `σ²/n`; the sample variance itself is biased low by `(n − τ)/(n − 1)`, so
//!    the variance of the mean is `s²/n · f` with `f = τ (n − 1)/(n − τ)` (τ capped at `n/2`);
//! 4. `sem_covariance = D (Σ/n) D` with `D = diag(√f_j)` (`f_j = 1` on the other axes): the
//!    correlations of Σ are kept, the matrix stays positive semi-definite.
//!
//! Without any autocorrelated axis the rule reduces to `Σ/n` and is named
//! **`covariance_over_n`**. On AR(1) sequences of 140 epochs with ρ = 0.9, ±2 SE of this rule
//! covers the truth on 90.4 % of axes, where ±2 σ/√n covers 33 % (`docs/CALIBRATE.md`,
//! test `sem_rule_coverage_ar1_slow`).

use crate::drift::autocorrelation;
use crashrig_geometry::{Mat6, Vec6};

/// `Φ⁻¹(1 − 0.05/6)`: the white-noise band of the lag-1 autocorrelation, as in [`crate::drift`].
const WHITE_NOISE_Z: f64 = 2.393_979_8;
/// Cap of the bias-corrected AR(1) coefficient: beyond it the sequence cannot tell its mean.
const RHO_MAX: f64 = 0.99;

/// Name of the rule when some axis is autocorrelated.
pub const RULE_AR1: &str = "ar1_effective_n";
/// Name of the rule when no axis is autocorrelated (or no analysis was possible).
pub const RULE_IID: &str = "covariance_over_n";

/// The uncertainty of the mean link and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct SemEstimate {
    /// Covariance of the mean link (tangent, mm and rad).
    pub covariance: Mat6,
    /// Variance factor `f_j` of each tangent axis over `Σ/n` (1 where not autocorrelated).
    pub inflation: [f64; 6],
    /// Lag-1 autocorrelation of each tangent residual series (0 when not analysed).
    pub lag1: [f64; 6],
    /// Axes found autocorrelated.
    pub autocorrelated: [bool; 6],
    /// [`RULE_AR1`] or [`RULE_IID`].
    pub rule: &'static str,
}

/// Variance factor of the mean of an AR(1) series of length `n` with coefficient `rho`
/// (finite-n integrated autocorrelation time, `1 + 2 Σ (1 − k/n) ρ^k`).
pub fn ar1_tau(n: usize, rho: f64) -> f64 {
    let nf = n as f64;
    let mut sum = 0.0;
    let mut p = 1.0;
    for k in 1..n {
        p *= rho;
        if p.abs() < 1e-17 {
            break;
        }
        sum += (1.0 - k as f64 / nf) * p;
    }
    1.0 + 2.0 * sum
}

/// The variance factor `f` for one residual series (step 2–3 of the module doc), given its
/// lag-1 autocorrelation `r1`.
pub fn ar1_variance_factor(n: usize, r1: f64) -> f64 {
    let nf = n as f64;
    if n < 4 || !r1.is_finite() {
        return 1.0;
    }
    let rho = ((nf * r1 + 1.0) / (nf - 3.0)).min(RHO_MAX);
    if rho <= 0.0 {
        return 1.0;
    }
    let tau = ar1_tau(n, rho).min(0.5 * nf);
    (tau * (nf - 1.0) / (nf - tau)).max(1.0)
}

/// `Σ/n` without autocorrelation analysis (for spreads at numerical zero, or n < 3).
pub fn sem_iid(covariance: &Mat6, n: usize) -> SemEstimate {
    SemEstimate {
        covariance: covariance / n.max(1) as f64,
        inflation: [1.0; 6],
        lag1: [0.0; 6],
        autocorrelated: [false; 6],
        rule: RULE_IID,
    }
}

/// The uncertainty of the mean from the tangent `residuals` of the epochs (in epoch order)
/// and their covariance Σ (n − 1), by the rule of the module doc.
pub fn sem_covariance(residuals: &[Vec6], covariance: &Mat6) -> SemEstimate {
    let n = residuals.len();
    if n < 3 {
        return sem_iid(covariance, n);
    }
    let band = WHITE_NOISE_Z / (n as f64).sqrt();
    let mut lag1 = [0.0; 6];
    let mut autocorrelated = [false; 6];
    let mut inflation = [1.0; 6];
    for j in 0..6 {
        let series: Vec<f64> = residuals.iter().map(|r| r[j]).collect();
        lag1[j] = autocorrelation(&series, 1).first().copied().unwrap_or(0.0);
        if lag1[j] > band {
            autocorrelated[j] = true;
            inflation[j] = ar1_variance_factor(n, lag1[j]);
        }
    }
    let d = Vec6::from_fn(|j, _| inflation[j].sqrt());
    let base = covariance / n as f64;
    let cov = Mat6::from_fn(|i, j| d[i] * base[(i, j)] * d[j]);
    SemEstimate {
        covariance: cov,
        inflation,
        lag1,
        rule: if autocorrelated.iter().any(|&a| a) {
            RULE_AR1
        } else {
            RULE_IID
        },
        autocorrelated,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn ar1_tau_known_answers() {
        // ρ = 0: 1. ρ = 0.5, n = 3: 1 + 2((2/3)·0.5 + (1/3)·0.25) = 1 + 2·(5/12) = 11/6.
        assert_abs_diff_eq!(ar1_tau(10, 0.0), 1.0, epsilon = 0.0);
        assert_abs_diff_eq!(ar1_tau(3, 0.5), 11.0 / 6.0, epsilon = 1e-15);
        // Large n: (1 + ρ)/(1 − ρ) − 2ρ(1 − ρⁿ)/(n(1 − ρ)²); ρ = 0.9, n = 10⁴.
        let (n, r) = (10_000usize, 0.9f64);
        let want = (1.0 + r) / (1.0 - r)
            - 2.0 * r * (1.0 - r.powi(n as i32)) / (n as f64 * (1.0 - r) * (1.0 - r));
        assert_abs_diff_eq!(ar1_tau(n, r), want, epsilon = 1e-9);
    }

    #[test]
    fn ar1_variance_factor_cases() {
        // r1 = 0.9·(137/140) − 1/140 ⇒ ρ̃ = 0.9 exactly.
        let n = 140usize;
        let r1 = (0.9 * (n as f64 - 3.0) - 1.0) / n as f64;
        let tau = ar1_tau(n, 0.9);
        assert_abs_diff_eq!(
            ar1_variance_factor(n, r1),
            tau * 139.0 / (140.0 - tau),
            epsilon = 1e-12
        );
        assert_abs_diff_eq!(ar1_variance_factor(n, -0.3), 1.0, epsilon = 0.0);
        assert_abs_diff_eq!(ar1_variance_factor(3, 0.9), 1.0, epsilon = 0.0);
        // Capped: τ ≤ n/2 ⇒ f ≤ (n/2)(n − 1)/(n/2) = n − 1.
        assert!(ar1_variance_factor(20, 0.999) <= 19.0 + 1e-12);
    }

    #[test]
    fn sem_covariance_scales_only_autocorrelated_axes() {
        // Axis 0 a slow ramp (r1 ≈ 1), axis 1 alternating (r1 ≈ −1), others white-ish.
        let n = 40;
        let residuals: Vec<Vec6> = (0..n)
            .map(|i| {
                let t = i as f64;
                let alt = if i % 2 == 0 { 1.0 } else { -1.0 };
                Vec6::new(
                    0.1 * (t - 19.5),
                    alt,
                    (t * 2.3).sin(),
                    (t * 1.7).cos(),
                    (t * 3.1).sin(),
                    (t * 2.9).cos(),
                )
            })
            .collect();
        let mut cov = Mat6::identity();
        cov[(0, 1)] = 0.3;
        cov[(1, 0)] = 0.3;
        let s = sem_covariance(&residuals, &cov);
        assert!(s.autocorrelated[0] && !s.autocorrelated[1]);
        assert_eq!(s.rule, RULE_AR1);
        assert!(s.inflation[0] > 5.0);
        assert_abs_diff_eq!(s.covariance[(1, 1)], 1.0 / n as f64, epsilon = 1e-15);
        assert_abs_diff_eq!(
            s.covariance[(0, 0)],
            s.inflation[0] / n as f64,
            epsilon = 1e-15
        );
        assert_abs_diff_eq!(
            s.covariance[(0, 1)],
            0.3 * s.inflation[0].sqrt() / n as f64,
            epsilon = 1e-15
        );
    }
}
