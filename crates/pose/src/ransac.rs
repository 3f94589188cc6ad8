//! RANSAC settings, the adaptive stopping rule and the one LO-RANSAC driver shared by the
//! estimators ([`lo_ransac`] over an [`Estimator`]: absolute pose with P3P, relative pose with
//! the 5-point solver).

use crate::Error;

/// Settings of a seeded LO-RANSAC run. No `Default`: a seed must be chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacOptions {
    /// Inlier threshold on the residual, pixels (reprojection error for absolute pose,
    /// Sampson distance scaled by the focal length for relative pose).
    pub max_error_px: f64,
    /// Probability of having drawn at least one all-inlier sample when stopping.
    pub confidence: f64,
    /// Minimum number of hypotheses drawn.
    pub min_iterations: usize,
    /// Maximum number of hypotheses drawn.
    pub max_iterations: usize,
    /// Minimum number of inliers for a pose to be accepted.
    pub min_inliers: usize,
    /// Seed of the sampling stream (`crashrig_stats::stream(seed, 0)`).
    pub seed: u64,
}

impl RansacOptions {
    /// COLMAP-like settings with the given seed: 4 px threshold, confidence 0.9999,
    /// 100..=10 000 hypotheses, at least 15 inliers.
    pub fn new(seed: u64) -> Self {
        Self {
            max_error_px: 4.0,
            confidence: 0.9999,
            min_iterations: 100,
            max_iterations: 10_000,
            min_inliers: 15,
            seed,
        }
    }
}

/// Hypotheses needed so that an all-inlier sample of size `sample` has been drawn with
/// probability `confidence` at inlier ratio `ratio`.
pub(crate) fn needed_iterations(ratio: f64, sample: i32, confidence: f64, cap: usize) -> usize {
    let good = ratio.powi(sample);
    if good >= 1.0 {
        return 0;
    }
    if good <= 0.0 {
        return cap;
    }
    let n = (1.0 - confidence).ln() / (1.0 - good).ln();
    if n.is_finite() && n < cap as f64 {
        n.ceil() as usize
    } else {
        cap
    }
}

/// Draws `K` distinct indices in `0..n` (n ≥ K) by rejection.
#[cfg(test)]
pub(crate) fn sample_distinct<const K: usize>(rng: &mut impl rand::Rng, n: usize) -> [usize; K] {
    let mut out = [0usize; K];
    sample_distinct_into(rng, n, &mut out);
    out
}

/// Fills `out` with distinct indices in `0..n` (n ≥ `out.len()`) by rejection.
fn sample_distinct_into(rng: &mut impl rand::Rng, n: usize, out: &mut [usize]) {
    use rand::RngExt;
    let mut k = 0;
    while k < out.len() {
        let c = rng.random_range(0..n);
        if !out[..k].contains(&c) {
            out[k] = c;
            k += 1;
        }
    }
}

/// What the LO-RANSAC driver needs from a model family: minimal solutions, an MSAC score and a
/// local optimisation on the inliers.
pub(crate) trait Estimator {
    /// A hypothesis (a pose, an essential matrix).
    type Model;
    /// Size of a minimal sample.
    const SAMPLE: usize;
    /// Number of correspondences.
    fn len(&self) -> usize;
    /// Every solution of the minimal problem on the correspondences `sample`.
    fn minimal(&self, sample: &[usize]) -> Vec<Self::Model>;
    /// MSAC score `Σ min(e², th²)` (lower is better) and the inliers (`e² < th²`, increasing).
    fn score(&self, model: &Self::Model) -> (f64, Vec<usize>);
    /// A re-estimate of `model` from its `inliers` (the "LO" step), or `None` when not possible.
    fn local_optimize(&self, model: &Self::Model, inliers: &[usize]) -> Option<Self::Model>;
}

/// The best hypothesis of [`lo_ransac`].
pub(crate) struct Consensus<M> {
    /// The model with the lowest score.
    pub model: M,
    /// Its inliers (increasing).
    pub inliers: Vec<usize>,
    /// Hypotheses (minimal samples) drawn.
    pub iterations: usize,
}

/// Seeded LO-RANSAC (Chum, Matas & Kittler 2003) with MSAC scoring: minimal samples from the
/// stream `crashrig_stats::stream(options.seed, 0)`; every hypothesis that beats the best so far
/// is locally optimised on its inliers (kept if that scores better) and updates the adaptive
/// number of hypotheses ([`needed_iterations`] at `options.confidence`, within
/// `options.min_iterations..=options.max_iterations`).
///
/// Errors: [`Error::NoConsensus`] when the best hypothesis has fewer than `needed` inliers.
pub(crate) fn lo_ransac<E: Estimator>(
    estimator: &E,
    options: &RansacOptions,
    needed: usize,
) -> Result<Consensus<E::Model>, Error> {
    let n = estimator.len();
    let mut rng = crashrig_stats::stream(options.seed, 0);
    let mut sample = vec![0usize; E::SAMPLE];
    let mut best: Option<(f64, E::Model, Vec<usize>)> = None;
    let mut target = options.min_iterations.max(1);
    let mut iterations = 0;
    while iterations < target.min(options.max_iterations) {
        iterations += 1;
        sample_distinct_into(&mut rng, n, &mut sample);
        for model in estimator.minimal(&sample) {
            let (sc, inl) = estimator.score(&model);
            if best.as_ref().is_some_and(|(bs, _, _)| sc >= *bs) {
                continue;
            }
            let mut cand = (sc, model, inl);
            if let Some(m2) = estimator.local_optimize(&cand.1, &cand.2) {
                let (sc2, inl2) = estimator.score(&m2);
                if sc2 < cand.0 {
                    cand = (sc2, m2, inl2);
                }
            }
            let ratio = cand.2.len() as f64 / n as f64;
            target = options.min_iterations.max(needed_iterations(
                ratio,
                E::SAMPLE as i32,
                options.confidence,
                options.max_iterations,
            ));
            best = Some(cand);
        }
    }
    let best_count = best.as_ref().map_or(0, |b| b.2.len());
    match best {
        Some((_, model, inliers)) if inliers.len() >= needed => Ok(Consensus {
            model,
            inliers,
            iterations,
        }),
        _ => Err(Error::NoConsensus {
            needed,
            best: best_count,
            iterations,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needed_iterations_nominal() {
        // ln(1 − 0.99)/ln(1 − 0.5³) = 34.5 → 35.
        assert_eq!(needed_iterations(0.5, 3, 0.99, 10_000), 35);
        assert_eq!(needed_iterations(1.0, 3, 0.99, 10_000), 0);
        assert_eq!(needed_iterations(0.0, 3, 0.99, 10_000), 10_000);
    }

    /// A 1-parameter model (a constant) fitted to 1-D data: a minimal sample is one value, the
    /// local optimisation is the mean of the inliers.
    struct Constant {
        data: Vec<f64>,
        th: f64,
    }

    impl Estimator for Constant {
        type Model = f64;
        const SAMPLE: usize = 1;
        fn len(&self) -> usize {
            self.data.len()
        }
        fn minimal(&self, s: &[usize]) -> Vec<f64> {
            vec![self.data[s[0]]]
        }
        fn score(&self, m: &f64) -> (f64, Vec<usize>) {
            let th2 = self.th * self.th;
            let mut sc = 0.0;
            let mut inl = Vec::new();
            for (i, v) in self.data.iter().enumerate() {
                let e2 = (v - m) * (v - m);
                if e2 < th2 {
                    sc += e2;
                    inl.push(i);
                } else {
                    sc += th2;
                }
            }
            (sc, inl)
        }
        fn local_optimize(&self, _m: &f64, inliers: &[usize]) -> Option<f64> {
            (!inliers.is_empty())
                .then(|| inliers.iter().map(|&i| self.data[i]).sum::<f64>() / inliers.len() as f64)
        }
    }

    #[test]
    fn lo_ransac_known_answer_and_no_consensus() {
        // 60 values 10 ± 0.3 (deterministic) and 40 gross outliers spread over 100..500: the
        // consensus is the 60 inliers and, after the local optimisation, their exact mean.
        let mut data: Vec<f64> = (0..60)
            .map(|i| 10.0 + 0.3 * ((i % 7) as f64 - 3.0) / 3.0)
            .collect();
        data.extend((0..40).map(|i| 100.0 + 10.0 * i as f64));
        let est = Constant { data, th: 1.0 };
        let mut opts = RansacOptions::new(3);
        opts.min_iterations = 5;
        let c = lo_ransac(&est, &opts, 15).unwrap();
        assert_eq!(c.inliers, (0..60).collect::<Vec<_>>());
        let mean = est.data[..60].iter().sum::<f64>() / 60.0;
        assert!((c.model - mean).abs() < 1e-12, "{} vs {mean}", c.model);
        // Inlier ratio 0.6, one-point samples: ln(1e-4)/ln(0.4) = 10.05 → 11 hypotheses.
        assert_eq!(c.iterations, 11);
        assert!(matches!(
            lo_ransac(&est, &opts, 61),
            Err(Error::NoConsensus {
                needed: 61,
                best: 60,
                ..
            })
        ));
    }

    #[test]
    fn sample_distinct_nominal() {
        let mut rng = crashrig_stats::stream(1, 0);
        for _ in 0..100 {
            let s = sample_distinct::<5>(&mut rng, 6);
            for i in 0..5 {
                for j in 0..i {
                    assert_ne!(s[i], s[j]);
                }
            }
        }
    }
}
