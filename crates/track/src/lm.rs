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
    /// Their covariance: `s² (JᵀJ)⁻¹` with `s² = RSS / (n − P)`.
    pub covariance: SMatrix<f64, P, P>,
    /// Root mean square residual, `sqrt(RSS / (n − P))`.
    pub residual_rms: f64,
    /// Iterations taken.
    pub iterations: usize,
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
pub(crate) fn solve<M: Model<P>, const P: usize>(
    model: &M,
    samples: &[Sample],
    p0: [f64; P],
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
                p = q;
                lambda = (lambda * 0.2).max(1e-9);
                (jtj, jtr, rss) = normal_equations(model, samples, &p);
                if centre_step < CENTRE_STEP_PX {
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
    let s2 = rss / dof;
    let inv = jtj.cholesky()?.inverse();
    Some(Solution {
        params: p,
        covariance: inv * s2,
        residual_rms: s2.sqrt(),
        iterations,
    })
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
