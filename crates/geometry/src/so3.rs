//! SO(3): hat, exponential and logarithm maps and their left/right Jacobians.
//!
//! Conventions: a tangent vector `w` (rad) is a rotation vector, `Exp(w)` rotates by `|w|` about
//! `w/|w|`. The right Jacobian satisfies `Exp(w + d) ≈ Exp(w)·Exp(Jr(w)·d)` and the left one
//! `Exp(w + d) ≈ Exp(Jl(w)·d)·Exp(w)`; `Jl(w) = Jr(−w) = Jr(w)ᵀ`.

use crate::tolerance::{SO3_SERIES_ANGLE, SO3_SINC_ANGLE};
use crate::{Mat3, Rot3, Vec3};
use nalgebra::UnitQuaternion;

/// Skew-symmetric matrix `[w]×` such that `[w]× v = w × v`.
pub fn hat(w: &Vec3) -> Mat3 {
    Mat3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// Inverse of [`hat`]: the vector of a skew-symmetric matrix (the antisymmetric part is used).
pub fn vee(m: &Mat3) -> Vec3 {
    Vec3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5
}

/// `sin θ / θ`, exact near 0.
fn sinc(theta: f64) -> f64 {
    if theta < SO3_SINC_ANGLE {
        1.0 - theta * theta / 6.0
    } else {
        theta.sin() / theta
    }
}

/// `(1 − cos θ) / θ²`, written as `½·sinc(θ/2)²` so it has no cancellation.
fn one_minus_cos_over_sq(theta: f64) -> f64 {
    let s = sinc(0.5 * theta);
    0.5 * s * s
}

/// `(θ − sin θ) / θ³`, series below [`SO3_SERIES_ANGLE`].
fn theta_minus_sin_over_cube(theta: f64) -> f64 {
    if theta < SO3_SERIES_ANGLE {
        let t2 = theta * theta;
        // 1/3! − θ²/5! + θ⁴/7! − θ⁶/9! + θ⁸/11!
        1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)))
    } else {
        (theta - theta.sin()) / (theta * theta * theta)
    }
}

/// `1/θ² − cos(θ/2) / (2θ sin(θ/2))`, the coefficient of `[w]×²` in the inverse Jacobians.
fn inv_jacobian_coeff(theta: f64) -> f64 {
    if theta < SO3_SERIES_ANGLE {
        let t2 = theta * theta;
        // 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600 + θ⁸/47900160
        1.0 / 12.0
            + t2 * (1.0 / 720.0
                + t2 * (1.0 / 30_240.0 + t2 * (1.0 / 1_209_600.0 + t2 / 47_900_160.0)))
    } else {
        let half = 0.5 * theta;
        1.0 / (theta * theta) - half.cos() / (2.0 * theta * half.sin())
    }
}

/// Exponential map (Rodrigues), small-angle safe.
pub fn exp(w: &Vec3) -> Rot3 {
    let theta = w.norm();
    let k = hat(w);
    let m = Mat3::identity() + k * sinc(theta) + k * k * one_minus_cos_over_sq(theta);
    Rot3::from_matrix_unchecked(m)
}

/// Logarithm map: the rotation vector with angle in `[0, π]`.
///
/// Goes through the quaternion (Shepperd's robust extraction in nalgebra), so it is accurate
/// near 0 and near π. That quaternion is not normalised, which is harmless here: the result
/// depends only on its direction. At exactly π the axis sign is arbitrary (both are valid).
pub fn log(r: &Rot3) -> Vec3 {
    let q = UnitQuaternion::from_rotation_matrix(r);
    log_quaternion(&q)
}

/// Logarithm of a unit quaternion (`q` and `−q` give the same result).
pub fn log_quaternion(q: &UnitQuaternion<f64>) -> Vec3 {
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let s = v.norm();
    // θ = 2·atan2(s, w); the factor θ/s is 2·atan2(s,w)/s, → 2/w for s → 0.
    let factor = if s < SO3_SINC_ANGLE {
        // atan(x)/x ≈ 1 − x²/3 with x = s/w (w ≈ 1 here).
        let x = s / w;
        2.0 / w * (1.0 - x * x / 3.0)
    } else {
        2.0 * s.atan2(w) / s
    };
    v * factor
}

/// Angle (rad, in `[0, π]`) of the rotation `a⁻¹·b`: the geodesic distance on SO(3).
pub fn angular_distance(a: &Rot3, b: &Rot3) -> f64 {
    log(&(a.inverse() * b)).norm()
}

/// Right Jacobian: `Exp(w + d) ≈ Exp(w)·Exp(Jr(w)·d)`.
pub fn right_jacobian(w: &Vec3) -> Mat3 {
    let theta = w.norm();
    let k = hat(w);
    Mat3::identity() - k * one_minus_cos_over_sq(theta) + k * k * theta_minus_sin_over_cube(theta)
}

/// Inverse of [`right_jacobian`] (singular only at |w| = 2π, outside the log's range).
pub fn right_jacobian_inv(w: &Vec3) -> Mat3 {
    let theta = w.norm();
    let k = hat(w);
    Mat3::identity() + k * 0.5 + k * k * inv_jacobian_coeff(theta)
}

/// Left Jacobian: `Exp(w + d) ≈ Exp(Jl(w)·d)·Exp(w)`; also the `V` matrix of the SE(3) exponential.
pub fn left_jacobian(w: &Vec3) -> Mat3 {
    let theta = w.norm();
    let k = hat(w);
    Mat3::identity() + k * one_minus_cos_over_sq(theta) + k * k * theta_minus_sin_over_cube(theta)
}

/// Inverse of [`left_jacobian`].
pub fn left_jacobian_inv(w: &Vec3) -> Mat3 {
    let theta = w.norm();
    let k = hat(w);
    Mat3::identity() - k * 0.5 + k * k * inv_jacobian_coeff(theta)
}
