//! RANSAC settings and the adaptive stopping rule shared by the estimators.

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
pub(crate) fn sample_distinct<const K: usize>(rng: &mut impl rand::Rng, n: usize) -> [usize; K] {
    use rand::RngExt;
    let mut out = [0usize; K];
    let mut k = 0;
    while k < K {
        let c = rng.random_range(0..n);
        if !out[..k].contains(&c) {
            out[k] = c;
            k += 1;
        }
    }
    out
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
