//! ω-φ-κ angles (rad): `R = Rx(ω)·Ry(φ)·Rz(κ)`, with derivatives.
//!
//! `Rx(a) = [[1,0,0],[0,cos a,−sin a],[0,sin a,cos a]]`, likewise `Ry`, `Rz` (right-handed, active).
//! The decomposition is singular at φ = ±π/2 (gimbal lock), where only ω ± κ is defined.

use crate::tolerance::GIMBAL_LOCK_COS_PHI;
use crate::{Error, Mat3, Rot3, Vec3, so3};

/// `Rx(ω)·Ry(φ)·Rz(κ)`.
pub fn rotation_from_opk(omega: f64, phi: f64, kappa: f64) -> Rot3 {
    Rot3::from_axis_angle(&Vec3::x_axis(), omega)
        * Rot3::from_axis_angle(&Vec3::y_axis(), phi)
        * Rot3::from_axis_angle(&Vec3::z_axis(), kappa)
}

/// ω-φ-κ of a rotation (rad), with the gimbal-lock flag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opk {
    /// ω, rotation about x, in (−π, π].
    pub omega: f64,
    /// φ, rotation about y, in [−π/2, π/2].
    pub phi: f64,
    /// κ, rotation about z, in (−π, π]; 0 at gimbal lock.
    pub kappa: f64,
    /// True when |cos φ| < [`GIMBAL_LOCK_COS_PHI`]: κ was set to 0 and the rest put into ω.
    pub gimbal_lock: bool,
}

/// Decompose `R = Rx(ω)·Ry(φ)·Rz(κ)` with φ in [−π/2, π/2].
///
/// At gimbal lock (|cos φ| < [`GIMBAL_LOCK_COS_PHI`]) κ is set to 0, ω absorbs the combined
/// rotation, and `gimbal_lock` is set; `rotation_from_opk` of the result reproduces `R`.
pub fn opk_from_rotation(r: &Rot3) -> Opk {
    let m = r.matrix();
    // R = [[cφcκ, −cφsκ, sφ], [·, ·, −sωcφ], [·, ·, cωcφ]]
    let cos_phi = m[(0, 0)].hypot(m[(0, 1)]);
    let phi = m[(0, 2)].atan2(cos_phi);
    if cos_phi < GIMBAL_LOCK_COS_PHI {
        // With κ = 0: R = Rx(ω)Ry(φ), whose column 1 is [0, cω, sω]; for any κ at sφ = ±1 that
        // column is [·, cos(ω ± κ), sin(ω ± κ)], so ω takes the whole in-plane rotation.
        let omega = m[(2, 1)].atan2(m[(1, 1)]);
        Opk {
            omega,
            phi,
            kappa: 0.0,
            gimbal_lock: true,
        }
    } else {
        Opk {
            omega: (-m[(1, 2)]).atan2(m[(2, 2)]),
            phi,
            kappa: (-m[(0, 1)]).atan2(m[(0, 0)]),
            gimbal_lock: false,
        }
    }
}

/// Partial derivatives `[∂R/∂ω, ∂R/∂φ, ∂R/∂κ]` of [`rotation_from_opk`].
pub fn d_rotation_d_opk(omega: f64, phi: f64, kappa: f64) -> [Mat3; 3] {
    let rx = Rot3::from_axis_angle(&Vec3::x_axis(), omega).into_inner();
    let ry = Rot3::from_axis_angle(&Vec3::y_axis(), phi).into_inner();
    let rz = Rot3::from_axis_angle(&Vec3::z_axis(), kappa).into_inner();
    let r = rx * ry * rz;
    [
        so3::hat(&Vec3::x()) * r,
        rx * so3::hat(&Vec3::y()) * ry * rz,
        r * so3::hat(&Vec3::z()),
    ]
}

/// `d(ω,φ,κ)/dδ` at δ = 0 for the right perturbation `R·Exp(δ)` (δ about the body axes).
///
/// # Errors
/// [`Error::GimbalLock`] when |cos φ| < [`GIMBAL_LOCK_COS_PHI`].
pub fn d_opk_d_tangent_right(r: &Rot3) -> Result<Mat3, Error> {
    let a = opk_from_rotation(r);
    if a.gimbal_lock {
        return Err(Error::GimbalLock { phi: a.phi });
    }
    // Body angular velocity: Rᵀ Ṙ = [Rzᵀ Ryᵀ e_x ω̇ + Rzᵀ e_y φ̇ + e_z κ̇]×.
    let ry = Rot3::from_axis_angle(&Vec3::y_axis(), a.phi);
    let rz = Rot3::from_axis_angle(&Vec3::z_axis(), a.kappa);
    let m = Mat3::from_columns(&[
        rz.inverse() * (ry.inverse() * Vec3::x()),
        rz.inverse() * Vec3::y(),
        Vec3::z(),
    ]);
    invert_rate_matrix(&m, a.phi)
}

/// `d(ω,φ,κ)/dδ` at δ = 0 for the left perturbation `Exp(δ)·R` (δ about the fixed axes).
///
/// # Errors
/// [`Error::GimbalLock`] when |cos φ| < [`GIMBAL_LOCK_COS_PHI`].
pub fn d_opk_d_tangent_left(r: &Rot3) -> Result<Mat3, Error> {
    let a = opk_from_rotation(r);
    if a.gimbal_lock {
        return Err(Error::GimbalLock { phi: a.phi });
    }
    // Spatial angular velocity: Ṙ Rᵀ = [e_x ω̇ + Rx e_y φ̇ + Rx Ry e_z κ̇]×.
    let rx = Rot3::from_axis_angle(&Vec3::x_axis(), a.omega);
    let ry = Rot3::from_axis_angle(&Vec3::y_axis(), a.phi);
    let m = Mat3::from_columns(&[Vec3::x(), rx * Vec3::y(), rx * (ry * Vec3::z())]);
    invert_rate_matrix(&m, a.phi)
}

/// Inverse of an angle-rate matrix (det = cos φ), `GimbalLock` if it is singular.
fn invert_rate_matrix(m: &Mat3, phi: f64) -> Result<Mat3, Error> {
    m.try_inverse().ok_or(Error::GimbalLock { phi })
}
