//! The uncertainty of the mean link when the epochs drift.
//!
//! The epochs of a sequence are often not independent: a rig on a moving car drifts slowly
//! (temperature, a settling mount) **and** scatters from epoch to epoch, and `Σ/n` (Σ the
//! spread of one epoch's link) then understates the uncertainty of the mean. The rule used
//! here, **`ar1_noise_fit_bound`** ([`RULE`]), models each of the six tangent residual series
//! (centre in A's axes, mm; rotation `log(R̄ᵀ·R)` about B's axes, rad) as slow AR(1) drift
//! mixed with epoch noise, `x_t = μ + √s·a_t + √(1 − s)·e_t` (a unit AR(1) with coefficient
//! ρ, white noise e, drift share s of the variance), and per axis:
//!
//! 1. fits (ρ, s) to the series' own sample autocorrelations `r_k`, `k = 1..=L`,
//!    `L = min(20, ⌊n/3⌋)`: for every (ρ, s) of a grid (ρ = 0, 0.01, …, 0.99; s = 0, 0.025,
//!    …, 1) the **expected** sample autocorrelations of that model at this n, demeaning
//!    included ([`DriftModel`]: `E[γ̂_k] = s·A_k(ρ) + (1 − s)·B_k`), and the (ρ, s) nearest to
//!    `r_k` in least squares, taken only when its squared error is below white noise's by
//!    more than [`DRIFT_PENALTY`]`/n` (otherwise s = 0). Its variance factor
//!    `f̂ = n·Var(x̄) / E[s²]`, both exact at this n (`n·Var(x̄) = s·τ(ρ) + 1 − s`, τ the
//!    finite-n integrated autocorrelation time [`ar1_tau`]; `E[s²]` carries the sample
//!    variance's own downward bias under drift), clamped to `[1, n − 1]`;
//! 2. where the drift is **significant** — the REML likelihood-ratio statistic of drift
//!    against white noise ([`crate::likelihood`]) exceeds [`DRIFT_GATE`] = χ²₂(0.95) — widens
//!    f̂ to the **upper likelihood bound** `f_U`: the largest model factor over the (ρ, s) grid
//!    points whose REML log-likelihood is within [`BOUND_DROP`] = ½ of the maximum (the upper
//!    end of the one-σ likelihood interval). So the factor is `F = max(f̂, f_U)` there, `f̂`
//!    elsewhere: a short sequence cannot tell a ρ = 0.9 drift from a ρ = 0.97 one, and the
//!    bound covers both;
//! 3. folds in the small-sample factor `q = min(t_{ν,0.975}/z_{0.975}, 1.3)²` of the
//!    estimator's degrees of freedom `ν = max(n/F − 1, 1)` ([`small_sample_factor`]);
//! 4. `sem_covariance = D (Σ/n) D` with `D = diag(√(F_j·q_j))`: the correlations of Σ are kept,
//!    the matrix stays positive semi-definite. The **effective n** of an axis is `n / F_j`.
//!
//! **Refusal** (`reliable = false`, the contract's `sem_reliable`): an axis whose effective n
//! is below [`RELIABLE_EFFECTIVE_N`] = 10 **and** whose sequence does not resolve the drift it
//! shows — the maximum-likelihood drift's correlation time `1/(1 − ρ̂)` is at least the
//! sequence length n (the sequence sees less than one correlation time, so the drift cannot be
//! told from a constant offset), or n itself is below 10. There ±2 SE cannot be relied on; the
//! SE stays finite (the widened number above). An axis with a small effective n whose drift
//! *is* resolved (for example 140 epochs of a ρ = 0.95 drift, effective n ≈ 3) keeps a
//! reliable, widened SE: on such sequences the rule's ±2 SE covers the truth in ≥ 95 %.
//!
//! Why this rule: the contract's coverage table, counted with refusals as covered and as
//! misses, on 48 cells (ρ × drift share × n), is `docs/CALIBRATE.md`, recomputed by the slow
//! test `sem_coverage_contract_grid_slow` (`crates/rig/tests/sem_coverage.rs`); the candidate
//! estimators compared in numpy are `fixtures/gen/sem_estimators.py`. A fit of the drift model
//! and not a lag-1 rule or a kernel estimator: the lag-1 autocorrelation of drift mixed with
//! noise is `s·ρ`, so an AR(1) rule from it (`ar1_effective_n`, two rules back) takes a
//! ρ = 0.95 half-and-half mixture for ρ ≈ 0.47 and covers the truth in half of the sequences;
//! kernel (Newey–West, Andrews), batch-means and Geyer estimators cannot see a correlation time
//! longer than their bandwidth. The bound (not the point fit alone, `ar1_noise_fit`, the rule
//! before this one) because the point fit's ρ is biased low near 1 on short sequences.
//!
//! Fewer than [`MIN_EPOCHS`] epochs (or a spread at numerical zero): `Σ/n`, rule
//! **`covariance_over_n`** ([`RULE_IID`]).

use crate::drift::autocorrelation;
pub use crate::likelihood::ar1_tau;
use crate::likelihood::{DriftLikelihood, LikelihoodSummary};
use crashrig_geometry::{Mat6, Vec6};

/// Name of the rule (drift model fitted to the autocorrelations, widened to its upper
/// likelihood bound where the drift is significant).
pub const RULE: &str = "ar1_noise_fit_bound";
/// Name of the rule when no analysis is possible (fewer than [`MIN_EPOCHS`] epochs, or a
/// spread at numerical zero).
pub const RULE_IID: &str = "covariance_over_n";
/// Fewest epochs the drift model is fitted to (three lags for two parameters).
pub const MIN_EPOCHS: usize = 9;
/// Below this effective number of epochs, where the sequence does not resolve its drift, an
/// axis's SE is marked not reliable.
pub const RELIABLE_EFFECTIVE_N: f64 = 10.0;
/// The likelihood-ratio statistic of drift against white noise above which the factor is
/// widened to its upper bound: χ²₂(0.95) (two drift parameters, ρ and s).
pub const DRIFT_GATE: f64 = 5.991_464_547_107_979;
/// Drop of the log-likelihood below its maximum that delimits the upper bound of the factor
/// (½: the one-σ likelihood interval).
pub const BOUND_DROP: f64 = 0.5;
/// Largest lag of the fit (and the fit uses at most a third of the sequence).
pub const MAX_LAG: usize = 20;
/// The drift model is taken only when it fits the autocorrelations better than white noise
/// by more than `DRIFT_PENALTY / n` in squared error (the sampling variance of one `r_k` under
/// white noise is about `1/n`).
pub const DRIFT_PENALTY: f64 = 1.0;
/// Cap of the small-sample factor's ratio `t_{ν,0.975} / z_{0.975}` (at ν = 4: 1.41).
pub const T_RATIO_CAP: f64 = 1.3;
/// `Φ⁻¹(0.975)`.
const Z_975: f64 = 1.959_963_984_540_054;
/// Steps of the ρ grid (0, 0.01, …, 0.99).
const RHO_STEPS: usize = 100;
/// Step of the ρ grid.
const RHO_STEP: f64 = 0.01;
/// Steps of the drift-share grid (0, 0.025, …, 1).
const SHARE_STEPS: usize = 41;

/// The uncertainty of the mean link and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct SemEstimate {
    /// Covariance of the mean link (tangent, mm and rad).
    pub covariance: Mat6,
    /// Variance factor of each tangent axis over `Σ/n`: the rule's factor `F_j` (the drift
    /// fit's, or its upper likelihood bound) times the small-sample factor `q_j` (1 for
    /// `covariance_over_n`).
    pub inflation: [f64; 6],
    /// The small-sample factor `q_j` included in [`SemEstimate::inflation`].
    pub small_sample_factor: [f64; 6],
    /// Effective number of epochs of each axis, `n / F_j`.
    pub effective_n: [f64; 6],
    /// False where the effective n is below [`RELIABLE_EFFECTIVE_N`] and the sequence does not
    /// resolve the drift it shows (see the module doc).
    pub reliable: [bool; 6],
    /// Lag-1 autocorrelation of each tangent residual series (0 when not analysed).
    pub lag1: [f64; 6],
    /// AR(1) coefficient of the drift fitted to the autocorrelations (0 when not analysed).
    pub drift_rho: [f64; 6],
    /// Share of the drift in each axis's variance, fitted to the autocorrelations (0 when not
    /// analysed).
    pub drift_share: [f64; 6],
    /// Axes whose factor `F_j` exceeds 1 (drift fitted or bounded).
    pub autocorrelated: [bool; 6],
    /// The REML likelihood-ratio statistic of drift against white noise (0 when not analysed).
    pub drift_statistic: [f64; 6],
    /// Maximum-likelihood AR(1) coefficient of the drift (0 when not analysed).
    pub drift_rho_ml: [f64; 6],
    /// Axes whose factor was widened to the upper likelihood bound.
    pub bounded: [bool; 6],
    /// [`RULE`] or [`RULE_IID`].
    pub rule: &'static str,
}

/// The rule on one tangent axis (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisSem {
    /// The drift model fitted to the autocorrelations (step 1).
    pub fit: DriftFit,
    /// What the REML likelihood says (`None` for a series without spread).
    pub likelihood: Option<LikelihoodSummary>,
    /// The factor `F = max(f̂, f_U)` where the drift is significant, else `f̂`.
    pub factor: f64,
    /// True where `F` is the upper likelihood bound (above the fit's `f̂`).
    pub bounded: bool,
    /// The small-sample factor `q` of `ν = max(n/F − 1, 1)`.
    pub small_sample_factor: f64,
    /// `F·q`: the variance factor over `σ²/n`.
    pub inflation: f64,
    /// `n / F`.
    pub effective_n: f64,
    /// False for a refusal (effective n below 10 and the drift not resolved).
    pub reliable: bool,
}

/// The two models of the rule at one sequence length (the drift fit's expected
/// autocorrelations and the REML filter); build once, apply to many series of that length.
#[derive(Debug, Clone, PartialEq)]
pub struct SemModel {
    n: usize,
    drift: DriftModel,
    likelihood: DriftLikelihood,
}

impl SemModel {
    /// The models for sequences of `n` ≥ [`MIN_EPOCHS`] epochs.
    pub fn new(n: usize) -> Self {
        let n = n.max(MIN_EPOCHS);
        Self {
            n,
            drift: DriftModel::new(n),
            likelihood: DriftLikelihood::new(n),
        }
    }

    /// The drift model fitted to the autocorrelations.
    pub fn drift_model(&self) -> &DriftModel {
        &self.drift
    }

    /// The rule on one residual series of length n (steps 1–3 and the refusal).
    pub fn axis(&self, series: &[f64]) -> AxisSem {
        let nf = self.n as f64;
        let fit = self.drift.fit(series);
        let likelihood = self.likelihood.summary(series, BOUND_DROP);
        let upper = likelihood
            .filter(|l| l.ratio_statistic > DRIFT_GATE)
            .map_or(1.0, |l| l.factor_upper);
        let bounded = upper > fit.model_factor;
        let factor = fit.model_factor.max(upper);
        let q = small_sample_factor((nf / factor - 1.0).max(1.0));
        let effective_n = nf / factor;
        let unresolved =
            nf < RELIABLE_EFFECTIVE_N || likelihood.is_some_and(|l| nf * (1.0 - l.rho) < 1.0);
        AxisSem {
            fit,
            likelihood,
            factor,
            bounded,
            small_sample_factor: q,
            inflation: factor * q,
            effective_n,
            reliable: !(effective_n < RELIABLE_EFFECTIVE_N && unresolved),
        }
    }

    /// The uncertainty of the mean from the tangent `residuals` (n epochs, in epoch order) and
    /// their covariance Σ (n − 1), by the rule of the module doc.
    pub fn estimate(&self, residuals: &[Vec6], covariance: &Mat6) -> SemEstimate {
        let n = residuals.len();
        let mut est = sem_iid(covariance, n);
        est.rule = RULE;
        for j in 0..6 {
            let series: Vec<f64> = residuals.iter().map(|r| r[j]).collect();
            let a = self.axis(&series);
            est.lag1[j] = autocorrelation(&series, 1).first().copied().unwrap_or(0.0);
            est.drift_rho[j] = a.fit.rho;
            est.drift_share[j] = a.fit.share;
            est.inflation[j] = a.inflation;
            est.small_sample_factor[j] = a.small_sample_factor;
            est.autocorrelated[j] = a.factor > 1.0;
            est.effective_n[j] = a.effective_n;
            est.reliable[j] = a.reliable;
            est.bounded[j] = a.bounded;
            if let Some(l) = a.likelihood {
                est.drift_statistic[j] = l.ratio_statistic;
                est.drift_rho_ml[j] = l.rho;
            }
        }
        let d = Vec6::from_fn(|j, _| est.inflation[j].sqrt());
        let base = covariance / n as f64;
        est.covariance = Mat6::from_fn(|i, j| d[i] * base[(i, j)] * d[j]);
        est
    }
}

/// The expected sample autocovariances of the drift model at one sequence length: for a unit
/// AR(1) with coefficient ρ on the grid, `A_k(ρ) = E[γ̂_k]` (`γ̂_k = Σ_t (x_t − x̄)(x_{t+k} − x̄)/n`)
/// and `τ(ρ) = n·Var(x̄)`; for unit white noise `B_0 = (n − 1)/n`, `B_k = −(n − k)/n²`.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftModel {
    n: usize,
    lags: usize,
    /// Row per grid ρ: `A_0..=A_L`.
    a: Vec<Vec<f64>>,
    /// `B_0..=B_L`.
    b: Vec<f64>,
    /// `τ(ρ)` per grid ρ.
    tau: Vec<f64>,
}

/// The fitted drift model of one series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriftFit {
    /// AR(1) coefficient of the drift.
    pub rho: f64,
    /// Share of the drift in the variance.
    pub share: f64,
    /// `f = n·Var(x̄)/E[s²]` of the fitted model, clamped to `[1, n − 1]`.
    pub model_factor: f64,
    /// The small-sample factor `q = min(t_{ν,0.975}/z_{0.975}, 1.3)²`, `ν = max(n/f − 1, 1)`.
    pub small_sample_factor: f64,
    /// The variance factor applied, `f·q`.
    pub inflation: f64,
    /// `E[s²]/σ²` of the fitted model (≤ 1): how much the sample variance — and any spread
    /// taken about the sample's own centre — understates the epochs' σ under this drift.
    pub variance_ratio: f64,
}

impl DriftModel {
    /// The model for sequences of `n` epochs (`n` ≥ [`MIN_EPOCHS`]), lags
    /// `1..=min(MAX_LAG, n/3)`.
    pub fn new(n: usize) -> Self {
        let n = n.max(MIN_EPOCHS);
        let lags = MAX_LAG.min(n / 3);
        let nf = n as f64;
        let a_tau = (0..RHO_STEPS)
            .map(|i| unit_ar1_expected(n, lags, i as f64 * RHO_STEP))
            .collect::<Vec<_>>();
        let b = (0..=lags)
            .map(|k| {
                if k == 0 {
                    (nf - 1.0) / nf
                } else {
                    -(nf - k as f64) / (nf * nf)
                }
            })
            .collect();
        Self {
            n,
            lags,
            tau: a_tau.iter().map(|(_, t)| *t).collect(),
            a: a_tau.into_iter().map(|(a, _)| a).collect(),
            b,
        }
    }

    /// Number of lags fitted.
    pub fn lags(&self) -> usize {
        self.lags
    }

    /// Expected sample autocorrelations `r_1..=r_L` of the model (ρ grid index, share).
    fn expected_r(&self, rho_index: usize, share: f64, out: &mut [f64]) {
        let a = &self.a[rho_index];
        let den = share * a[0] + (1.0 - share) * self.b[0];
        for (k, o) in out.iter_mut().enumerate() {
            *o = (share * a[k + 1] + (1.0 - share) * self.b[k + 1]) / den;
        }
    }

    /// Fits the model to the sample autocorrelations `r_1..=r_L` (step 2 of the module doc)
    /// and returns its variance factor (step 3). Non-finite input gives the white-noise model.
    pub fn fit_autocorrelations(&self, r: &[f64]) -> DriftFit {
        let l = self.lags.min(r.len());
        let nf = self.n as f64;
        let mut best = (f64::INFINITY, 0usize, 0.0f64);
        let mut white = f64::INFINITY;
        let mut m = vec![0.0; self.lags];
        if r[..l].iter().all(|v| v.is_finite()) {
            for i in 0..RHO_STEPS {
                for j in 0..SHARE_STEPS {
                    let share = j as f64 / (SHARE_STEPS - 1) as f64;
                    self.expected_r(i, share, &mut m);
                    let sse: f64 = r[..l].iter().zip(&m).map(|(x, y)| (x - y) * (x - y)).sum();
                    if i == 0 && j == 0 {
                        white = sse;
                    }
                    if sse < best.0 {
                        best = (sse, i, share);
                    }
                }
            }
        }
        // Drift only when it fits clearly better than white noise (step 2).
        let (i, share) = if white - best.0 > DRIFT_PENALTY / nf {
            (best.1, best.2)
        } else {
            (0, 0.0)
        };
        let n_var_mean = share * self.tau[i] + 1.0 - share;
        let expected_s2 = (share * self.a[i][0] + (1.0 - share) * self.b[0]) * nf / (nf - 1.0);
        let f = (n_var_mean / expected_s2).clamp(1.0, nf - 1.0);
        let q = small_sample_factor((nf / f - 1.0).max(1.0));
        DriftFit {
            rho: i as f64 * RHO_STEP,
            share,
            model_factor: f,
            small_sample_factor: q,
            inflation: f * q,
            variance_ratio: expected_s2.min(1.0),
        }
    }

    /// Fits the model to a series (its own sample autocorrelations, lags `1..=L`).
    pub fn fit(&self, series: &[f64]) -> DriftFit {
        self.fit_autocorrelations(&autocorrelation(series, self.lags))
    }
}

/// `min(t_{ν,0.975}/z_{0.975}, T_RATIO_CAP)²`: the Student-t quantile of the estimator's
/// degrees of freedom folded into the variance (ν = 59: 1.042; ν = 4: capped, 1.69).
pub fn small_sample_factor(nu: f64) -> f64 {
    // Upper tail of Student's t: P(T > t) = ½·I_{ν/(ν+t²)}(ν/2, ½) = 0.025.
    let y = statrs::function::beta::inv_beta_reg(0.5 * nu, 0.5, 0.05);
    let t = (nu * (1.0 - y) / y).sqrt();
    (t / Z_975).min(T_RATIO_CAP).powi(2)
}

/// `(A_0..=A_L, τ)` of a unit AR(1) with coefficient `rho` over `n` epochs: with
/// `c_t = Cov(x_t, x̄) = (1/n) Σ_s ρ^|t−s|` and `V = Var(x̄) = mean c_t`,
/// `A_k = (1/n) Σ_{t<n−k} (ρ^k − c_t − c_{t+k} + V)`; `τ = n·V`.
fn unit_ar1_expected(n: usize, lags: usize, rho: f64) -> (Vec<f64>, f64) {
    let nf = n as f64;
    // Forward sums F_t = Σ_{s≤t} ρ^(t−s) and backward sums G_t = Σ_{s≥t} ρ^(s−t).
    let mut f = vec![0.0; n];
    let mut g = vec![0.0; n];
    let mut acc = 0.0;
    for ft in f.iter_mut() {
        acc = 1.0 + rho * acc;
        *ft = acc;
    }
    acc = 0.0;
    for gt in g.iter_mut().rev() {
        acc = 1.0 + rho * acc;
        *gt = acc;
    }
    let c: Vec<f64> = f.iter().zip(&g).map(|(a, b)| (a + b - 1.0) / nf).collect();
    let v = c.iter().sum::<f64>() / nf;
    let a = (0..=lags)
        .map(|k| {
            let rk = rho.powi(k as i32);
            (0..n - k).map(|t| rk - c[t] - c[t + k] + v).sum::<f64>() / nf
        })
        .collect();
    (a, nf * v)
}

/// `Σ/n` without autocorrelation analysis (for spreads at numerical zero, or short sequences).
pub fn sem_iid(covariance: &Mat6, n: usize) -> SemEstimate {
    let nf = n.max(1) as f64;
    SemEstimate {
        covariance: covariance / nf,
        inflation: [1.0; 6],
        small_sample_factor: [1.0; 6],
        effective_n: [nf; 6],
        reliable: [nf >= RELIABLE_EFFECTIVE_N; 6],
        lag1: [0.0; 6],
        drift_rho: [0.0; 6],
        drift_share: [0.0; 6],
        autocorrelated: [false; 6],
        drift_statistic: [0.0; 6],
        drift_rho_ml: [0.0; 6],
        bounded: [false; 6],
        rule: RULE_IID,
    }
}

/// The uncertainty of the mean from the tangent `residuals` of the epochs (in epoch order)
/// and their covariance Σ (n − 1), by the rule of the module doc ([`SemModel::estimate`]).
pub fn sem_covariance(residuals: &[Vec6], covariance: &Mat6) -> SemEstimate {
    let n = residuals.len();
    if n < MIN_EPOCHS {
        return sem_iid(covariance, n);
    }
    SemModel::new(n).estimate(residuals, covariance)
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
    fn drift_model_known_answers() {
        // White noise is the AR(1) with ρ = 0: A_k(0) = B_k = −(n − k)/n², A_0 = (n − 1)/n.
        // For any ρ: E[Σ(x − x̄)²/n] = γ_0 − Var(x̄), so A_0(ρ) = 1 − τ(ρ)/n.
        for n in [9usize, 60, 140] {
            let m = DriftModel::new(n);
            let nf = n as f64;
            assert_eq!(m.lags(), 20.min(n / 3));
            assert_abs_diff_eq!(m.a[0][0], (nf - 1.0) / nf, epsilon = 1e-15);
            for k in 1..=m.lags() {
                assert_abs_diff_eq!(m.a[0][k], -(nf - k as f64) / (nf * nf), epsilon = 1e-15);
                assert_abs_diff_eq!(m.b[k], m.a[0][k], epsilon = 1e-15);
            }
            for i in [0usize, 50, 90, 95, 99] {
                let tau = ar1_tau(n, i as f64 * 0.01);
                assert_abs_diff_eq!(m.tau[i] / tau, 1.0, epsilon = 1e-12);
                assert_abs_diff_eq!(m.a[i][0], 1.0 - tau / nf, epsilon = 1e-12);
            }
        }
    }

    /// A stationary unit AR(1) series of `n` epochs (stream `rep` of `seed`).
    fn unit_ar1(seed: u64, rep: u64, n: usize, rho: f64) -> Vec<f64> {
        use rand::RngExt;
        use rand_distr::StandardNormal;
        let mut rng = crashrig_stats::stream(seed, rep);
        let mut x = Vec::with_capacity(n);
        let mut v: f64 = rng.sample(StandardNormal);
        for _ in 0..n {
            x.push(v);
            let e: f64 = rng.sample(StandardNormal);
            v = rho * v + (1.0f64 - rho * rho).sqrt() * e;
        }
        x
    }

    #[test]
    fn drift_model_matches_simulated_autocovariances() {
        // 4000 stationary unit AR(1) series, ρ = 0.9, n = 60: the mean of γ̂_k (k = 0..3) lies
        // within 4 Monte Carlo standard errors of A_k(0.9).
        let (n, reps, rho) = (60usize, 4000u64, 0.9);
        let m = DriftModel::new(n);
        let mut sums = [[0.0f64; 2]; 4];
        for rep in 0..reps {
            let x = unit_ar1(31, rep, n, rho);
            let mean = x.iter().sum::<f64>() / n as f64;
            for (k, s) in sums.iter_mut().enumerate() {
                let g = (0..n - k)
                    .map(|t| (x[t] - mean) * (x[t + k] - mean))
                    .sum::<f64>()
                    / n as f64;
                s[0] += g;
                s[1] += g * g;
            }
        }
        for (k, s) in sums.iter().enumerate() {
            let mean = s[0] / reps as f64;
            let se = ((s[1] / reps as f64 - mean * mean) / reps as f64).sqrt();
            let want = m.a[90][k];
            assert!(
                (mean - want).abs() <= 4.0 * se,
                "k = {k}: {mean} vs {want} ± {se}"
            );
        }
    }

    #[test]
    fn fit_recovers_the_model_it_is_given() {
        // Fed the model's own expected autocorrelations, the fit returns its (ρ, s) and the
        // exact factor n·Var(x̄)/E[s²]; for pure AR(1) (s = 1) that is τ(n − 1)/(n − τ).
        let n = 140usize;
        let nf = n as f64;
        let m = DriftModel::new(n);
        let mut r = vec![0.0; m.lags()];
        for (i, share) in [(90usize, 1.0), (95, 0.5), (50, 0.25)] {
            m.expected_r(i, share, &mut r);
            let fit = m.fit_autocorrelations(&r);
            assert_abs_diff_eq!(fit.rho, i as f64 * 0.01, epsilon = 1e-12);
            assert_abs_diff_eq!(fit.share, share, epsilon = 1e-12);
            let tau = ar1_tau(n, fit.rho);
            let want = (share * tau + 1.0 - share)
                / ((share * (1.0 - tau / nf) + (1.0 - share) * (nf - 1.0) / nf) * nf / (nf - 1.0));
            assert_abs_diff_eq!(fit.model_factor / want, 1.0, epsilon = 1e-12);
            let q = small_sample_factor(nf / want - 1.0);
            assert_abs_diff_eq!(fit.inflation / (want * q), 1.0, epsilon = 1e-12);
            if share == 1.0 {
                assert_abs_diff_eq!(
                    fit.model_factor / (tau * (nf - 1.0) / (nf - tau)),
                    1.0,
                    epsilon = 1e-12
                );
            }
        }
        // White noise's expected autocorrelations: s = 0, f = 1.
        let white: Vec<f64> = (1..=m.lags()).map(|k| m.b[k] / m.b[0]).collect();
        let fit = m.fit_autocorrelations(&white);
        assert_eq!((fit.share, fit.model_factor), (0.0, 1.0));
        assert_abs_diff_eq!(fit.inflation, small_sample_factor(139.0), epsilon = 0.0);
        // Non-finite input: the white-noise model.
        assert_eq!(m.fit_autocorrelations(&[f64::NAN; 20]).model_factor, 1.0);
        // A fit barely better than white noise (by less than DRIFT_PENALTY/n) is not taken:
        // white noise's autocorrelations plus 0.5/√(nL) on every lag improve the white
        // model's squared error by at most 0.25/n.
        let nudged: Vec<f64> = white
            .iter()
            .map(|w| w + 0.5 / (nf * m.lags() as f64).sqrt())
            .collect();
        assert_eq!(m.fit_autocorrelations(&nudged).model_factor, 1.0);
    }

    #[test]
    fn small_sample_factor_matches_scipy() {
        // scipy 1.17: (min(t.ppf(0.975, ν)/norm.ppf(0.975), 1.3))².
        for (nu, want) in [
            (59.0, 1.04230780284848),
            (139.0, 1.0176424990322817),
            (4.0, 1.69),
            (1.0, 1.69),
        ] {
            assert_abs_diff_eq!(small_sample_factor(nu) / want, 1.0, epsilon = 1e-9);
        }
    }

    #[test]
    fn ar1_variance_inflation_against_closed_form() {
        // The true factor n·Var(x̄)/E[s²] of a unit AR(1), ρ = 0.5, n = 60, by Monte Carlo
        // (20000 series), against τ(n − 1)/(n − τ) = 3.03: Var(x̄) within 4 of its standard
        // errors (relative SE of a variance √(2/N) = 1 %), E[s²] within 4 of its own.
        let (n, reps, rho) = (60usize, 20_000u64, 0.5);
        let nf = n as f64;
        let (mut sm, mut smm, mut ss, mut sss) = (0.0, 0.0, 0.0, 0.0);
        for rep in 0..reps {
            let x = unit_ar1(32, rep, n, rho);
            let mean = x.iter().sum::<f64>() / nf;
            let s2 = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (nf - 1.0);
            sm += mean;
            smm += mean * mean;
            ss += s2;
            sss += s2 * s2;
        }
        let r = reps as f64;
        let var_mean = smm / r - (sm / r).powi(2);
        let e_s2 = ss / r;
        let se_s2 = ((sss / r - e_s2 * e_s2) / r).sqrt();
        let tau = ar1_tau(n, rho);
        assert!((var_mean * nf - tau).abs() <= 4.0 * tau * (2.0 / r).sqrt());
        assert!((e_s2 - (nf - tau) / (nf - 1.0)).abs() <= 4.0 * se_s2);
        // By hand: τ = (1 + ρ)/(1 − ρ) − 2ρ(1 − ρⁿ)/(n(1 − ρ)²) = 3 − 1/15, f = τ·59/(60 − τ).
        assert_abs_diff_eq!(tau, 3.0 - 1.0 / 15.0, epsilon = 1e-12);
        let f = tau * (nf - 1.0) / (nf - tau);
        assert_abs_diff_eq!(f, 3.032_710, epsilon = 1e-6);
    }

    #[test]
    fn refusal_needs_an_unresolved_drift() {
        // 140 epochs of a unit ρ = 0.95 AR(1) (correlation time 20 epochs; true effective n
        // 3.2): significant drift, widened to the upper likelihood bound, effective n below
        // 10 — but n(1 − ρ̂) ≥ 1, the drift is resolved: reliable.
        let m = SemModel::new(140);
        let a = m.axis(&unit_ar1(40, 0, 140, 0.95));
        let l = a.likelihood.unwrap();
        assert!(l.ratio_statistic > DRIFT_GATE && a.bounded, "{a:?}");
        assert_eq!(a.factor, l.factor_upper.max(a.fit.model_factor));
        assert!(a.effective_n < RELIABLE_EFFECTIVE_N, "{a:?}");
        assert!(140.0 * (1.0 - l.rho) >= 1.0 && a.reliable, "{a:?}");
        // 60 epochs of white noise on a slow ramp (a drift much slower than the sequence): the
        // likelihood's best drift is the slowest of the grid, 60·(1 − 0.99) < 1 — unresolved,
        // effective n below 10: refused.
        let m = SemModel::new(60);
        let ramp: Vec<f64> = unit_ar1(41, 0, 60, 0.0)
            .iter()
            .enumerate()
            .map(|(t, e)| 0.5 * e + 0.05 * t as f64)
            .collect();
        let a = m.axis(&ramp);
        let l = a.likelihood.unwrap();
        assert_eq!(l.rho, 0.99, "{a:?}");
        assert!(a.effective_n < RELIABLE_EFFECTIVE_N && !a.reliable, "{a:?}");
        // White noise of 60 epochs: no significant drift, not bounded, reliable.
        let a = m.axis(&unit_ar1(42, 0, 60, 0.0));
        assert!(a.likelihood.unwrap().ratio_statistic <= DRIFT_GATE, "{a:?}");
        assert!(a.reliable && !a.bounded && a.effective_n > 10.0, "{a:?}");
    }

    #[test]
    fn sem_covariance_widens_a_drift_not_an_alternation() {
        // Axis 0 a slow ramp (drift), axis 1 alternating (r1 ≈ −1), others deterministic
        // quasi-noise.
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
        assert_eq!(s.rule, RULE);
        assert!(s.autocorrelated[0] && !s.autocorrelated[1]);
        assert!(s.inflation[0] > 5.0, "{:?}", s.inflation);
        assert!(!s.reliable[0] && s.reliable[1]);
        assert_abs_diff_eq!(
            s.effective_n[0],
            40.0 * s.small_sample_factor[0] / s.inflation[0],
            epsilon = 1e-12
        );
        // Axis 1: no drift, only the small-sample factor of ν = 39.
        assert_abs_diff_eq!(s.inflation[1], small_sample_factor(39.0), epsilon = 0.0);
        assert_abs_diff_eq!(
            s.covariance[(1, 1)],
            s.inflation[1] / n as f64,
            epsilon = 1e-15
        );
        assert_abs_diff_eq!(
            s.covariance[(0, 0)],
            s.inflation[0] / n as f64,
            epsilon = 1e-15
        );
        assert_abs_diff_eq!(
            s.covariance[(0, 1)],
            0.3 * (s.inflation[0] * s.inflation[1]).sqrt() / n as f64,
            epsilon = 1e-15
        );
        // Too short to fit: Σ/n, not reliable.
        let short = sem_covariance(&residuals[..8], &cov);
        assert_eq!(short.rule, RULE_IID);
        assert!(short.reliable.iter().all(|r| !r));
    }
}
