//! Named, bounded proptest strategies for geometry values.

use crashrig_geometry::{Rigid3, Rot3, Vec3, Vec6};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Margin (rad) kept from φ = ±π/2 by [`opk_away_from_gimbal`].
pub const GIMBAL_MARGIN: f64 = 1e-2;

/// Largest translation component (mm) produced by [`rigid3`].
pub const RIGID3_MAX_TRANSLATION_MM: f64 = 1e4;

/// A uniformly distributed unit quaternion (Shoemake's subgroup algorithm, no rejection).
pub fn unit_quaternion() -> impl Strategy<Value = UnitQuaternion<f64>> {
    (0.0..=1.0f64, 0.0..TAU, 0.0..TAU).prop_map(|(u1, a, b)| {
        let (r1, r2) = ((1.0 - u1).sqrt(), u1.sqrt());
        UnitQuaternion::new_normalize(Quaternion::new(
            r2 * b.cos(),
            r1 * a.sin(),
            r1 * a.cos(),
            r2 * b.sin(),
        ))
    })
}

/// A uniformly distributed rotation.
pub fn rot3() -> impl Strategy<Value = Rot3> {
    unit_quaternion().prop_map(|q| q.to_rotation_matrix())
}

/// A unit vector (uniform on the sphere: z uniform in [−1, 1], azimuth uniform).
pub fn unit_vec3() -> impl Strategy<Value = Vec3> {
    (-1.0..=1.0f64, 0.0..TAU).prop_map(|(z, a)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * a.cos(), r * a.sin(), z)
    })
}

/// A vector with each component in `[-r, r]`.
pub fn vec3_in(r: f64) -> impl Strategy<Value = Vec3> {
    (-r..=r, -r..=r, -r..=r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A rigid transform: uniform rotation, translation components in ±[`RIGID3_MAX_TRANSLATION_MM`].
pub fn rigid3() -> impl Strategy<Value = Rigid3> {
    (unit_quaternion(), vec3_in(RIGID3_MAX_TRANSLATION_MM))
        .prop_map(|(q, t)| Rigid3::from_parts(Translation3::from(t), q))
}

/// A rotation vector with angle in `[min_angle, max_angle]` (rad, `0 ≤ min ≤ max ≤ π`).
pub fn rotation_vector(min_angle: f64, max_angle: f64) -> impl Strategy<Value = Vec3> {
    (unit_vec3(), min_angle..=max_angle).prop_map(|(axis, angle)| axis * angle)
}

/// Largest angle (rad) produced by [`rotation_vector_any`]: π minus a margin, so that the
/// logarithm is unique (at exactly π, `w` and `−w` are both valid logarithms).
pub const MAX_UNIQUE_LOG_ANGLE: f64 = PI - 1e-12;

/// A rotation vector of any angle in `[0, π)`, with extra weight near 0 and near π
/// (up to [`MAX_UNIQUE_LOG_ANGLE`]).
pub fn rotation_vector_any() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        rotation_vector(0.0, MAX_UNIQUE_LOG_ANGLE),
        rotation_vector(0.0, 1e-6),
        rotation_vector(1e-6, 0.2),
        rotation_vector(PI - 1e-3, MAX_UNIQUE_LOG_ANGLE),
        rotation_vector(PI - 1e-8, MAX_UNIQUE_LOG_ANGLE),
    ]
}

/// An SE(3) tangent `[ω; v]` with |ω| < π (weighted at 0 and π) and |v_i| ≤ `r` mm.
pub fn se3_tangent(r: f64) -> impl Strategy<Value = Vec6> {
    (rotation_vector_any(), vec3_in(r)).prop_map(|(w, v)| Vec6::new(w.x, w.y, w.z, v.x, v.y, v.z))
}

/// ω, φ, κ (rad) with ω, κ in (−π, π) and |φ| ≤ π/2 − [`GIMBAL_MARGIN`].
pub fn opk_away_from_gimbal() -> impl Strategy<Value = (f64, f64, f64)> {
    let lim = PI - 1e-9;
    (
        -lim..lim,
        -(FRAC_PI_2 - GIMBAL_MARGIN)..=(FRAC_PI_2 - GIMBAL_MARGIN),
        -lim..lim,
    )
}
