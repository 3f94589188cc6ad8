//! The likelihood of the drift model of [`crate::sem`], for its gate and its upper bound.
//!
//! Model of one tangent residual series (as in [`crate::sem`]):
//! `x_t = μ + σ(√s·a_t + √(1 − s)·e_t)`, `a` a stationary unit AR(1) with coefficient ρ, `e`
//! unit white noise. For every point of the grid ρ = 0, 0.01, …, 0.99 × s = 0, 0.05, …, 1 the
//! exact Gaussian **REML** log-likelihood with the mean μ and the scale σ profiled out is
//! computed by a Kalman filter (the state is the drift `√s·a_t`; the filter's gains, innovation
//! variances and whitened ones-series do not depend on the data and are computed once per
//! sequence length):
//!
//! `ℓ(ρ, s) = −½ ((n − 1)·ln(RSS/(n − 1)) + Σ_t ln F_t + ln S₁₁)`,
//!
//! `RSS = Σ v_t²/F_t − (Σ v_t u_t/F_t)² / S₁₁` (v the innovations of the data, u those of the
//! constant 1, F their variances, `S₁₁ = Σ u_t²/F_t`). From it, per series:
//! - the **likelihood-ratio statistic** of drift against white noise, `2(ℓ_max − ℓ(·, 0))`;
//! - the maximum-likelihood ρ̂ (the drift's correlation time `1/(1 − ρ̂)`);
//! - the **upper bound** of the variance factor: the largest model factor
//!   `f(ρ, s) = n·Var(x̄)/E[s²]` (clamped to `[1, n − 1]`) over the grid points whose
//!   log-likelihood is within a given drop of the maximum.
//!
//! The same computation in numpy is `reml_gains` / `reml_loglik` of
//! `fixtures/gen/sem_estimators.py`.

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

/// Steps of the ρ grid (0, 0.01, …, 0.99).
pub const RHO_STEPS: usize = 100;
/// Step of the ρ grid.
pub const RHO_STEP: f64 = 0.01;
/// Steps of the drift-share grid (0, 0.05, …, 1).
pub const SHARE_STEPS: usize = 21;

/// The data-independent part of the REML likelihood at one sequence length, for every grid
/// point (index `i_ρ·SHARE_STEPS + i_s`, white noise at index 0).
#[derive(Debug, Clone, PartialEq)]
pub struct DriftLikelihood {
    n: usize,
    /// ρ per grid point.
    rho: Vec<f64>,
    /// The model factor `f(ρ, s)` per grid point, clamped to `[1, n − 1]`.
    factor: Vec<f64>,
    /// Per epoch t (row) and grid point (column): Kalman gain `P_t/F_t`.
    gain: Vec<f64>,
    /// Per epoch and grid point: `1/F_t`.
    inv_var: Vec<f64>,
    /// Per epoch and grid point: the innovation `u_t` of the constant 1.
    ones: Vec<f64>,
    /// `Σ_t ln F_t + ln S₁₁` per grid point.
    log_det: Vec<f64>,
    /// `S₁₁` per grid point.
    s11: Vec<f64>,
}

/// What the likelihood says about one series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LikelihoodSummary {
    /// `2(ℓ_max − ℓ_white)`: the likelihood-ratio statistic of drift against white noise.
    pub ratio_statistic: f64,
    /// Maximum-likelihood ρ (0 when the maximum is white noise).
    pub rho: f64,
    /// Maximum-likelihood drift share.
    pub share: f64,
    /// The largest model factor over the grid points within the drop of the maximum.
    pub factor_upper: f64,
}

impl DriftLikelihood {
    /// The filter quantities for sequences of `n` ≥ 2 epochs.
    pub fn new(n: usize) -> Self {
        let n = n.max(2);
        let nf = n as f64;
        let points = RHO_STEPS * SHARE_STEPS;
        let mut rho = Vec::with_capacity(points);
        let mut share = Vec::with_capacity(points);
        let mut factor = Vec::with_capacity(points);
        for i in 0..RHO_STEPS {
            let r = i as f64 * RHO_STEP;
            let tau = ar1_tau(n, r);
            for j in 0..SHARE_STEPS {
                let s = j as f64 / (SHARE_STEPS - 1) as f64;
                let expected_s2 =
                    (s * (1.0 - tau / nf) + (1.0 - s) * (nf - 1.0) / nf) * nf / (nf - 1.0);
                rho.push(r);
                share.push(s);
                factor.push(((s * tau + 1.0 - s) / expected_s2).clamp(1.0, nf - 1.0));
            }
        }
        let mut gain = vec![0.0; n * points];
        let mut inv_var = vec![0.0; n * points];
        let mut ones = vec![0.0; n * points];
        let mut log_det = vec![0.0; points];
        let mut s11 = vec![0.0; points];
        for k in 0..points {
            let (r, s) = (rho[k], share[k]);
            // P: variance of the drift state given the past; a1: the state's prediction of the
            // constant-1 regressor.
            let (mut p, mut a1) = (s, 0.0);
            for t in 0..n {
                let var = p + (1.0 - s);
                let g = p / var;
                let u = 1.0 - a1;
                gain[t * points + k] = g;
                inv_var[t * points + k] = 1.0 / var;
                ones[t * points + k] = u;
                log_det[k] += var.ln();
                s11[k] += u * u / var;
                a1 = r * (a1 + g * u);
                p = r * r * p * (1.0 - g) + s * (1.0 - r * r);
            }
        }
        for (d, s) in log_det.iter_mut().zip(&s11) {
            *d += s.ln();
        }
        Self {
            n,
            rho,
            factor,
            gain,
            inv_var,
            ones,
            log_det,
            s11,
        }
    }

    /// Number of grid points.
    pub fn points(&self) -> usize {
        self.rho.len()
    }

    /// The REML log-likelihood of `x` (length n) at every grid point (up to a constant).
    /// Non-finite values where the series has no spread left after the mean.
    pub fn log_likelihood(&self, x: &[f64]) -> Vec<f64> {
        let points = self.points();
        let n = self.n.min(x.len());
        let mut pred = vec![0.0; points];
        let mut sxx = vec![0.0; points];
        let mut sx1 = vec![0.0; points];
        for (t, &xt) in x.iter().enumerate().take(n) {
            let row = t * points..(t + 1) * points;
            let (g, iv, u) = (
                &self.gain[row.clone()],
                &self.inv_var[row.clone()],
                &self.ones[row],
            );
            for k in 0..points {
                let v = xt - pred[k];
                let w = v * iv[k];
                sxx[k] += v * w;
                sx1[k] += w * u[k];
                pred[k] = self.rho[k] * (pred[k] + g[k] * v);
            }
        }
        let dof = (n - 1) as f64;
        (0..points)
            .map(|k| {
                let rss = sxx[k] - sx1[k] * sx1[k] / self.s11[k];
                -0.5 * (dof * (rss / dof).ln() + self.log_det[k])
            })
            .collect()
    }

    /// The profile of `ll` (a [`DriftLikelihood::log_likelihood`]) over the drift share: for
    /// each ρ of the grid, the largest log-likelihood over the shares. Its value at ρ = 0 is
    /// white noise's (a drift with ρ = 0 is white noise).
    pub fn share_profile(ll: &[f64]) -> Vec<f64> {
        ll.chunks(SHARE_STEPS)
            .map(|row| row.iter().copied().fold(f64::NEG_INFINITY, f64::max))
            .collect()
    }

    /// At the grid's ρ number `rho_index`, the largest model factor `f(ρ, s)` over the shares
    /// whose log-likelihood in `ll` is within `drop` of the largest at that ρ (the upper end
    /// of the share's likelihood interval, the drift's time scale held fixed).
    pub fn factor_upper_at(&self, ll: &[f64], rho_index: usize, drop: f64) -> f64 {
        let row = rho_index * SHARE_STEPS..(rho_index + 1) * SHARE_STEPS;
        let (l, f) = (&ll[row.clone()], &self.factor[row]);
        let top = l.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        l.iter()
            .zip(f)
            .filter(|(v, _)| **v >= top - drop)
            .map(|(_, f)| *f)
            .fold(1.0, f64::max)
    }

    /// The statistic, the maximum-likelihood drift and the upper bound of the variance factor
    /// over the grid points within `drop` of the maximum log-likelihood. `None` when the
    /// likelihood is not finite everywhere (a series without spread).
    pub fn summary(&self, x: &[f64], drop: f64) -> Option<LikelihoodSummary> {
        self.summary_of(&self.log_likelihood(x), drop)
    }

    /// [`DriftLikelihood::summary`] from a log-likelihood already computed
    /// ([`DriftLikelihood::log_likelihood`]).
    pub fn summary_of(&self, ll: &[f64], drop: f64) -> Option<LikelihoodSummary> {
        if !ll.iter().all(|v| v.is_finite()) {
            return None;
        }
        // The first maximum in grid order (as numpy's argmax).
        let best = (0..ll.len()).fold(0, |b, k| if ll[k] > ll[b] { k } else { b });
        let factor_upper = ll
            .iter()
            .zip(&self.factor)
            .filter(|(l, _)| **l >= ll[best] - drop)
            .map(|(_, f)| *f)
            .fold(1.0, f64::max);
        Some(LikelihoodSummary {
            ratio_statistic: 2.0 * (ll[best] - ll[0]),
            rho: self.rho[best],
            share: (best % SHARE_STEPS) as f64 / (SHARE_STEPS - 1) as f64,
            factor_upper,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// The REML log-likelihood by dense linear algebra: `V = s·Γ(ρ) + (1 − s)·I`,
    /// `RSS = xᵀV⁻¹x − (1ᵀV⁻¹x)²/(1ᵀV⁻¹1)`, `ℓ = −½((n − 1) ln(RSS/(n − 1)) + ln|V| + ln 1ᵀV⁻¹1)`.
    fn dense(x: &[f64], rho: f64, s: f64) -> f64 {
        let n = x.len();
        let v = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            let d = (i as i32 - j as i32).unsigned_abs();
            s * rho.powi(d as i32) + if i == j { 1.0 - s } else { 0.0 }
        });
        let chol = v.clone().cholesky().unwrap();
        let xv = nalgebra::DVector::from_column_slice(x);
        let one = nalgebra::DVector::from_element(n, 1.0);
        let vx = chol.solve(&xv);
        let v1 = chol.solve(&one);
        let s11 = one.dot(&v1);
        let rss = xv.dot(&vx) - one.dot(&vx).powi(2) / s11;
        let log_det = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let dof = (n - 1) as f64;
        -0.5 * (dof * (rss / dof).ln() + log_det + s11.ln())
    }

    #[test]
    fn kalman_likelihood_equals_the_dense_one() {
        // A deterministic wiggly series of 30 epochs: the filter's value at several grid
        // points equals the dense GLS computation (1e-10 absolute on values of order 10).
        let x: Vec<f64> = (0..30)
            .map(|t| (0.7 * t as f64).sin() + 0.05 * t as f64 + 0.3 * (2.9 * t as f64).cos())
            .collect();
        let m = DriftLikelihood::new(30);
        let ll = m.log_likelihood(&x);
        for (i, j) in [
            (0usize, 0usize),
            (0, 10),
            (50, 5),
            (90, 10),
            (95, 20),
            (99, 20),
        ] {
            let k = i * SHARE_STEPS + j;
            let want = dense(&x, i as f64 * RHO_STEP, j as f64 / 20.0);
            assert_abs_diff_eq!(ll[k], want, epsilon = 1e-10);
        }
        // A constant offset changes nothing (the mean is profiled out).
        let shifted: Vec<f64> = x.iter().map(|v| v + 123.0).collect();
        let ls = m.log_likelihood(&shifted);
        for k in [0, 7, 1000, 2099] {
            assert_abs_diff_eq!(ls[k], ll[k], epsilon = 1e-8);
        }
    }

    #[test]
    fn factors_and_summary() {
        // White noise's factor is 1; pure AR(1)'s is τ(n − 1)/(n − τ).
        let n = 60;
        let m = DriftLikelihood::new(n);
        assert_eq!(m.factor[0], 1.0);
        let k = 90 * SHARE_STEPS + 20;
        let tau = ar1_tau(n, 0.9);
        assert_abs_diff_eq!(
            m.factor[k],
            tau * (n as f64 - 1.0) / (n as f64 - tau),
            epsilon = 1e-12
        );
        // A slow ramp: the maximum is slow drift, the statistic large, and the bound at least
        // the factor of the maximum.
        let ramp: Vec<f64> = (0..n)
            .map(|t| 0.1 * t as f64 + (1.3 * t as f64).sin())
            .collect();
        let s = m.summary(&ramp, 0.5).unwrap();
        assert!(s.ratio_statistic > 20.0 && s.rho >= 0.9, "{s:?}");
        assert!(s.factor_upper >= 10.0, "{s:?}");
        // No spread left after the mean: no summary.
        assert!(m.summary(&[2.0; 60], 0.5).is_none());
    }

    #[test]
    fn share_profile_and_factor_upper_at() {
        let n = 60;
        let m = DriftLikelihood::new(n);
        let x: Vec<f64> = (0..n)
            .map(|t| 0.05 * t as f64 + (1.3 * t as f64).sin())
            .collect();
        let ll = m.log_likelihood(&x);
        let p = DriftLikelihood::share_profile(&ll);
        assert_eq!(p.len(), RHO_STEPS);
        // At ρ = 0 every share is white noise: the profile is white noise's log-likelihood.
        assert_abs_diff_eq!(p[0], ll[0], epsilon = 1e-9 * ll[0].abs());
        for (i, pi) in p.iter().enumerate() {
            let row = &ll[i * SHARE_STEPS..(i + 1) * SHARE_STEPS];
            assert!(row.iter().all(|v| v <= pi) && row.contains(pi));
        }
        let tau = ar1_tau(n, 0.9);
        let pure = tau * (n as f64 - 1.0) / (n as f64 - tau);
        // Any drop: the bound is the factor of the shares within it. Unbounded drop: every
        // share counts, so the bound is pure AR(1)'s (the factor grows with the share);
        // zero drop: the factor of the best share alone.
        assert_abs_diff_eq!(
            m.factor_upper_at(&ll, 90, f64::INFINITY),
            pure,
            epsilon = 1e-12
        );
        let row = &ll[90 * SHARE_STEPS..91 * SHARE_STEPS];
        let best = (0..SHARE_STEPS).fold(0, |b, j| if row[j] > row[b] { j } else { b });
        assert_eq!(
            m.factor_upper_at(&ll, 90, 0.0),
            m.factor[90 * SHARE_STEPS + best]
        );
        // At ρ = 0 every factor is 1.
        assert_abs_diff_eq!(
            m.factor_upper_at(&ll, 0, f64::INFINITY),
            1.0,
            epsilon = 1e-12
        );
    }
}
