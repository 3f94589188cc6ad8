//! Central finite differences for checking analytic Jacobians.

use nalgebra::{DMatrix, DVector};

/// Central-difference Jacobian `∂f/∂x` (rows: outputs, columns: inputs) with step `h`.
///
/// The truncation error is O(h²·f‴) and the rounding error O(ε·|f|/h); `h ≈ 1e-5·scale(x)`
/// balances them to about 1e-10 relative for smooth functions.
pub fn central_jacobian(
    f: impl Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
    h: f64,
) -> DMatrix<f64> {
    let f0 = f(x);
    let mut jac = DMatrix::zeros(f0.len(), x.len());
    for j in 0..x.len() {
        let mut xp = x.clone();
        let mut xm = x.clone();
        xp[j] += h;
        xm[j] -= h;
        let col = (f(&xp) - f(&xm)) / (2.0 * h);
        jac.set_column(j, &col);
    }
    jac
}

/// Central difference of a scalar-to-matrix function (e.g. `∂R/∂ω`), entry by entry.
pub fn central_derivative<const R: usize, const C: usize>(
    f: impl Fn(f64) -> nalgebra::SMatrix<f64, R, C>,
    x: f64,
    h: f64,
) -> nalgebra::SMatrix<f64, R, C> {
    (f(x + h) - f(x - h)) / (2.0 * h)
}
