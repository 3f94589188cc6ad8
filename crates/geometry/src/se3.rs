//! SE(3) exponential, logarithm and adjoint, tangent order `[ω; v]` (rotation first, as COLMAP).
//!
//! `exp([ω; v]) = (Exp(ω), Jl(ω)·v)`. With the adjoint `Ad(T) = [[R, 0], [[t]× R, R]]`, a left
//! perturbation relates to a right one by `Exp(ξ)·T = T·Exp(Ad(T)⁻¹ ξ)`.

use crate::{Mat3, Mat6, Rigid3, Vec3, Vec6, so3};

/// Exponential map of `xi = [ω; v]` (ω in rad, v in mm).
pub fn exp(xi: &Vec6) -> Rigid3 {
    let w = Vec3::new(xi[0], xi[1], xi[2]);
    let v = Vec3::new(xi[3], xi[4], xi[5]);
    let r = so3::exp(&w);
    let t = so3::left_jacobian(&w) * v;
    crate::quat::rigid_from_rotation(&r, &t)
}

/// Logarithm map, inverse of [`exp`] (rotation angle in `[0, π]`).
pub fn log(t: &Rigid3) -> Vec6 {
    let w = so3::log_quaternion(&t.rotation);
    let v = so3::left_jacobian_inv(&w) * t.translation.vector;
    Vec6::new(w.x, w.y, w.z, v.x, v.y, v.z)
}

/// Adjoint `[[R, 0], [[t]× R, R]]` in the `[ω; v]` order: `T·Exp(ξ)·T⁻¹ = Exp(Ad(T)·ξ)`.
pub fn adjoint(t: &Rigid3) -> Mat6 {
    let r: Mat3 = t.rotation.to_rotation_matrix().into_inner();
    let tr = so3::hat(&t.translation.vector) * r;
    let mut ad = Mat6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(3, 0).copy_from(&tr);
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    ad
}
