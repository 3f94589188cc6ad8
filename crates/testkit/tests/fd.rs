//! Tests of the finite-difference helpers.

use approx::assert_relative_eq;
use crashrig_testkit::fd::{central_derivative, central_jacobian};
use nalgebra::{DMatrix, DVector, Matrix2};

#[test]
fn central_jacobian_nominal() {
    // f(x, y) = (x², x·y, sin y): J = [[2x, 0], [y, x], [0, cos y]].
    let f = |v: &DVector<f64>| DVector::from_vec(vec![v[0] * v[0], v[0] * v[1], v[1].sin()]);
    let x = DVector::from_vec(vec![1.5, -0.7]);
    let j = central_jacobian(f, &x, 1e-5);
    let expected = DMatrix::from_row_slice(3, 2, &[3.0, 0.0, -0.7, 1.5, 0.0, (-0.7f64).cos()]);
    // Truncation h²·f‴/6 ≈ 2e-11 (sin), quadratics are exact up to rounding ε/h ≈ 2e-11.
    assert_relative_eq!(j, expected, epsilon = 1e-9);
}

#[test]
fn central_derivative_nominal() {
    let f = |t: f64| Matrix2::new(t.cos(), -t.sin(), t.sin(), t.cos());
    let d = central_derivative(f, 0.3, 1e-5);
    let expected = Matrix2::new(
        -(0.3f64).sin(),
        -(0.3f64).cos(),
        (0.3f64).cos(),
        -(0.3f64).sin(),
    );
    // Same error budget as above.
    assert_relative_eq!(d, expected, epsilon = 1e-9);
}
