//! A small dense Levenberg–Marquardt on a manifold state, with the normal matrix at the optimum.

use nalgebra::{SMatrix, SVector};

/// Iteration cap of every refinement.
pub const MAX_ITERATIONS: usize = 100;
/// Stop when the relative cost decrease of an accepted step falls below this.
const COST_TOL: f64 = 1e-14;
/// Stop when the step is this small relative to 1 (tangent units: rad and mm or unitless).
const STEP_TOL: f64 = 1e-13;

/// A least-squares problem over a `P`-dimensional tangent space.
pub(crate) trait Problem<const P: usize> {
    /// The state (e.g. a pose), moved by [`Problem::retract`].
    type State: Clone;
    /// Gauss–Newton normal equations at `s`: `(JᵀJ, Jᵀr, Σr²)`; `Err(index)` names a residual
    /// that is undefined.
    #[allow(clippy::type_complexity)]
    fn normal_equations(
        &self,
        s: &Self::State,
    ) -> Result<(SMatrix<f64, P, P>, SVector<f64, P>, f64), usize>;
    /// `Σr²` at `s`; `Err(index)` names a residual that is undefined.
    fn cost(&self, s: &Self::State) -> Result<f64, usize>;
    /// Moves `s` by the tangent step `delta`.
    fn retract(&self, s: &Self::State, delta: &SVector<f64, P>) -> Self::State;
}

/// Result of [`solve`].
#[derive(Debug, Clone)]
pub(crate) struct Outcome<S, const P: usize> {
    pub state: S,
    /// Σr² at `state`.
    pub cost: f64,
    /// JᵀJ at `state`.
    pub jtj: SMatrix<f64, P, P>,
    pub iterations: usize,
}

/// Why [`solve`] failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Failure {
    /// A residual is undefined at the initial state (its index).
    Undefined(usize),
    /// The cost became non-finite.
    Diverged(usize),
}

/// Levenberg–Marquardt with Marquardt's diagonal scaling: solve
/// `(JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr`, accept if the cost drops (λ /= 10), else λ *= 10.
/// Steps that make a residual undefined are rejected like cost increases.
pub(crate) fn solve<const P: usize, Pr: Problem<P>>(
    problem: &Pr,
    init: Pr::State,
    max_iterations: usize,
) -> Result<Outcome<Pr::State, P>, Failure> {
    let mut state = init;
    let (mut jtj, mut jtr, mut cost) = problem
        .normal_equations(&state)
        .map_err(Failure::Undefined)?;
    if !cost.is_finite() {
        return Err(Failure::Diverged(0));
    }
    let mut lambda = 1e-4;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        if cost == 0.0 {
            break;
        }
        let mut a = jtj;
        for i in 0..P {
            a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
        }
        let Some(chol) = a.cholesky() else {
            lambda *= 10.0;
            if lambda > 1e16 {
                break;
            }
            continue;
        };
        let delta = -chol.solve(&jtr);
        let candidate = problem.retract(&state, &delta);
        match problem.cost(&candidate) {
            Ok(c) if c.is_finite() && c < cost => {
                let decrease = (cost - c) / cost;
                state = candidate;
                let ne = problem
                    .normal_equations(&state)
                    .map_err(Failure::Undefined)?;
                (jtj, jtr, cost) = ne;
                lambda = (lambda / 10.0).max(1e-12);
                if decrease < COST_TOL || delta.norm() < STEP_TOL {
                    break;
                }
            }
            _ => {
                lambda *= 10.0;
                if lambda > 1e16 || delta.norm() < STEP_TOL {
                    break;
                }
            }
        }
    }
    if !cost.is_finite() {
        return Err(Failure::Diverged(iterations));
    }
    Ok(Outcome {
        state,
        cost,
        jtj,
        iterations,
    })
}

/// Inverse of a normal matrix, or `None` when it is numerically singular: the
/// Jacobi-scaled matrix `D^{-1/2}·A·D^{-1/2}` (unit diagonal, so mixed units do not matter)
/// has its smallest eigenvalue below [`SINGULAR_RCOND`] or `A` is not positive definite.
pub(crate) fn inverse_if_regular<const P: usize>(
    a: &SMatrix<f64, P, P>,
) -> Option<SMatrix<f64, P, P>> {
    let d = SVector::<f64, P>::from_fn(|i, _| a[(i, i)]);
    if d.iter().any(|v| v.is_nan() || *v <= 0.0 || !v.is_finite()) {
        return None;
    }
    let s = d.map(|v| 1.0 / v.sqrt());
    let scaled = nalgebra::DMatrix::<f64>::from_fn(P, P, |i, j| a[(i, j)] * s[i] * s[j]);
    let min_eig = scaled.symmetric_eigenvalues().min();
    if min_eig.is_nan() || min_eig <= SINGULAR_RCOND {
        return None;
    }
    let inv = a.cholesky()?.inverse();
    inv.iter().all(|v| v.is_finite()).then_some(inv)
}

/// Smallest eigenvalue of the unit-diagonal normal matrix below which a pose is declared
/// unobservable (a correlation this close to ±1 means 1e-10 of the information is left).
pub const SINGULAR_RCOND: f64 = 1e-10;
