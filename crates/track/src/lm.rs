//! A small Levenberg–Marquardt solver over the pixels of one window, and the covariance of its
//! solution from the normal matrix scaled by the fit's own residual variance.

use nalgebra::{SMatrix, SVector};

/// A grey-value model with `P` parameters, evaluated at a pixel centre.
pub(crate) trait Model<const P: usize> {
    /// Indices of the two centre parameters (`u`, `v`) in the parameter vector.
    const CENTRE: [usize; 2];

    /// The model's value at `(x, y)` and its gradient with respect to the parameters.
    fn eval(&self, p: &[f64; P], x: f64, y: f64, grad: &mut [f64; P]) -> f64;

    /// Brings `p` back into the model's domain after a step (e.g. a blur width that turned
    /// negative); `false` when it cannot (the step is then rejected).
    fn constrain(&self, p: &mut [f64; P]) -> bool;
}

/// One pixel of a window: its centre and its grey value.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// The solution of [`solve`].
#[derive(Debug, Clone)]
pub(crate) struct Solution<const P: usize> {
    /// The parameters at the minimum.
    pub params: [f64; P],
    /// Their covariance `s² (JᵀJ)⁻¹` (see [`solve`]).
    pub covariance: SMatrix<f64, P, P>,
    /// Root mean square residual, `sqrt(RSS / (n − P))`.
    pub residual_rms: f64,
}

/// Step of the centre (pixels) below which the fit has converged.
const CENTRE_STEP_PX: f64 = 1e-5;
/// Iterations at most.
const MAX_ITERATIONS: usize = 40;

fn normal_equations<M: Model<P>, const P: usize>(
    model: &M,
    samples: &[Sample],
    p: &[f64; P],
) -> (SMatrix<f64, P, P>, SVector<f64, P>, f64) {
    let mut jtj = SMatrix::<f64, P, P>::zeros();
    let mut jtr = SVector::<f64, P>::zeros();
    let mut rss = 0.0;
    let mut g = [0.0; P];
    for s in samples {
        let r = s.z - model.eval(p, s.x, s.y, &mut g);
        rss += r * r;
        for a in 0..P {
            jtr[a] += g[a] * r;
            for b in 0..=a {
                jtj[(a, b)] += g[a] * g[b];
            }
        }
    }
    for a in 0..P {
        for b in 0..a {
            jtj[(b, a)] = jtj[(a, b)];
        }
    }
    (jtj, jtr, rss)
}

fn rss_of<M: Model<P>, const P: usize>(model: &M, samples: &[Sample], p: &[f64; P]) -> f64 {
    let mut g = [0.0; P];
    samples
        .iter()
        .map(|s| {
            let r = s.z - model.eval(p, s.x, s.y, &mut g);
            r * r
        })
        .sum()
}

/// Minimises the sum of squared residuals of `model` over `samples` from `p0`. `None` when the
/// problem is degenerate (fewer samples than twice the parameters, a singular normal matrix)
/// or the iterations run out before the centre settles.
///
/// The covariance is `s² (JᵀJ)⁻¹`; `s²` is the white-noise variance of the residuals
/// ([`white_noise_variance`]) when `neighbours` lists runs of adjacent pixels, else
/// `RSS / (n − P)`.
pub(crate) fn solve<M: Model<P>, const P: usize>(
    model: &M,
    samples: &[Sample],
    p0: [f64; P],
    neighbours: Option<&[[u32; 3]]>,
) -> Option<Solution<P>> {
    if samples.len() < 2 * P {
        return None;
    }
    let mut p = p0;
    let (mut jtj, mut jtr, mut rss) = normal_equations(model, samples, &p);
    let mut lambda = 1e-3;
    let mut converged = false;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut a = jtj;
        for k in 0..P {
            a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
        }
        let Some(chol) = a.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let delta = chol.solve(&jtr);
        let mut q = p;
        for k in 0..P {
            q[k] += delta[k];
        }
        let centre_step = delta[M::CENTRE[0]].hypot(delta[M::CENTRE[1]]);
        if model.constrain(&mut q) && q.iter().all(|v| v.is_finite()) {
            let rss_q = rss_of(model, samples, &q);
            if rss_q <= rss {
                let settled = rss - rss_q <= 1e-10 * rss;
                p = q;
                lambda = (lambda * 0.2).max(1e-9);
                (jtj, jtr, rss) = normal_equations(model, samples, &p);
                if centre_step < CENTRE_STEP_PX || (settled && centre_step < 1e-3) {
                    converged = true;
                    break;
                }
                continue;
            }
        }
        if centre_step < CENTRE_STEP_PX * 1e-2 && lambda > 1e3 {
            // No step lowers the cost and the proposed one no longer moves the centre.
            converged = true;
            break;
        }
        lambda *= 10.0;
        if lambda > 1e12 {
            break;
        }
    }
    if !converged {
        return None;
    }
    let dof = (samples.len() - P) as f64;
    let s2_fit = rss / dof;
    let s2 = match neighbours {
        Some(pairs) => white_noise_variance(model, samples, &p, pairs).unwrap_or(s2_fit),
        None => s2_fit,
    };
    let inv = jtj.cholesky()?.inverse();
    Some(Solution {
        params: p,
        covariance: inv * s2,
        residual_rms: s2_fit.sqrt(),
    })
}

/// The variance of the white (pixel-to-pixel) part of the residuals from their second
/// differences along rows and columns, `r(i−1) − 2 r(i) + r(i+1)` (variance 6σ² for white
/// noise): what the model misses varies smoothly across an edge's blur width and largely
/// cancels in them; the noise does not. `triples` holds the indices of three consecutive
/// pixels in `samples`. `None` with fewer than 16 triples.
fn white_noise_variance<M: Model<P>, const P: usize>(
    model: &M,
    samples: &[Sample],
    p: &[f64; P],
    triples: &[[u32; 3]],
) -> Option<f64> {
    if triples.len() < 16 {
        return None;
    }
    let mut g = [0.0; P];
    let r: Vec<f64> = samples
        .iter()
        .map(|s| s.z - model.eval(p, s.x, s.y, &mut g))
        .collect();
    let sum: f64 = triples
        .iter()
        .map(|&[a, b, c]| (r[a as usize] - 2.0 * r[b as usize] + r[c as usize]).powi(2))
        .sum();
    // The fit removed P of the n degrees of freedom.
    let n = samples.len() as f64;
    Some(sum / (6.0 * triples.len() as f64) * n / (n - P as f64))
}

/// The runs of three consecutive pixels along rows and columns among `samples` (pixel centres
/// on the integer-plus-half grid).
pub(crate) fn adjacent_pairs(samples: &[Sample]) -> Vec<[u32; 3]> {
    let key = |s: &Sample| ((s.x - 0.5).round() as i64, (s.y - 0.5).round() as i64);
    let index: std::collections::HashMap<(i64, i64), u32> = samples
        .iter()
        .enumerate()
        .map(|(k, s)| (key(s), k as u32))
        .collect();
    let mut out = Vec::with_capacity(2 * samples.len());
    for (k, s) in samples.iter().enumerate() {
        let (i, j) = key(s);
        for (a, b) in [((i - 1, j), (i + 1, j)), ((i, j - 1), (i, j + 1))] {
            if let (Some(&ia), Some(&ib)) = (index.get(&a), index.get(&b)) {
                out.push([ia, k as u32, ib]);
            }
        }
    }
    out
}

/// `erf(x)` (Abramowitz & Stegun 7.1.26, |error| ≤ 1.5·10⁻⁷) and its exact derivative
/// `2/√π · exp(−x²)`.
#[inline]
pub(crate) fn erf_and_derivative(x: f64) -> (f64, f64) {
    const P: f64 = 0.327_591_1;
    const A: [f64; 5] = [
        0.254_829_592,
        -0.284_496_736,
        1.421_413_741,
        -1.453_152_027,
        1.061_405_429,
    ];
    let ax = x.abs();
    let t = 1.0 / (1.0 + P * ax);
    let poly = t * (A[0] + t * (A[1] + t * (A[2] + t * (A[3] + t * A[4]))));
    let e = (-ax * ax).exp();
    let y = 1.0 - poly * e;
    (
        if x < 0.0 { -y } else { y },
        std::f64::consts::FRAC_2_SQRT_PI * e,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn erf_nominal() {
        // Known values (A&S table 7.1): erf(0.5) = 0.5204998778, erf(1) = 0.8427007929,
        // erf(2) = 0.9953222650; the approximation is within 1.5e-7.
        for (x, want) in [
            (0.5, 0.520_499_877_8),
            (1.0, 0.842_700_792_9),
            (2.0, 0.995_322_265_0),
        ] {
            assert_abs_diff_eq!(erf_and_derivative(x).0, want, epsilon = 1.5e-7);
            assert_abs_diff_eq!(erf_and_derivative(-x).0, -want, epsilon = 1.5e-7);
        }
    }
}
