//! The rig link "B relative to A" (`A_from_B`) as base and ω φ κ, with first-order covariance
//! propagated from an estimator's tangent covariance.

use crate::relative::{Mat5, Vec5, tangent_basis};
use crashrig_geometry::angles::wrap_pi;
use crashrig_geometry::{Mat6, Rigid3, Vec3, Vec6, opk, se3, so3};
use nalgebra::{SMatrix, SVector, Translation3};

/// Base (B's projection centre in A's frame, length unit of the poses) and ω, φ, κ (rad) of
/// `R_A_from_B`, as `[x, y, z, ω, φ, κ]`.
pub fn link_parameters(a_from_b: &Rigid3) -> [f64; 6] {
    let t = a_from_b.translation.vector;
    let a = opk::opk_from_rotation(&a_from_b.rotation.to_rotation_matrix());
    [t.x, t.y, t.z, a.omega, a.phi, a.kappa]
}

/// Relative tangent step (rad or length unit) of the central differences below.
const FD_STEP: f64 = 1e-6;

/// First-order covariance `J·Σ·Jᵀ` of `f` at the origin of a `P`-dimensional tangent, `J` by
/// central differences; components 3..6 are angles and differenced wrap-safely.
fn propagate<const P: usize>(
    cov: &SMatrix<f64, P, P>,
    f: impl Fn(&SVector<f64, P>) -> [f64; 6],
) -> Mat6 {
    let mut j = SMatrix::<f64, 6, P>::zeros();
    for k in 0..P {
        // Step scaled to the parameter's own σ keeps the difference well inside the linear
        // range while far above rounding.
        let h = (cov[(k, k)].sqrt() * 1e-3).max(FD_STEP * 1e-3);
        let mut d = SVector::<f64, P>::zeros();
        d[k] = h;
        let p = f(&d);
        let m = f(&(-d));
        for i in 0..6 {
            let diff = if i >= 3 {
                wrap_pi(p[i] - m[i])
            } else {
                p[i] - m[i]
            };
            j[(i, k)] = diff / (2.0 * h);
        }
    }
    j * cov * j.transpose()
}

/// Covariance (order x y z, ω φ κ; length unit², rad²) of the link `A_from_B =
/// A_from_world·B_from_world⁻¹` when `B_from_world` has covariance `cov_b` in the left SE(3)
/// tangent (as returned by [`crate::refine_absolute_pose`]) and `A_from_world` is fixed.
pub fn link_covariance_absolute(
    a_from_world: &Rigid3,
    b_from_world: &Rigid3,
    cov_b: &Mat6,
) -> Mat6 {
    propagate(cov_b, |xi: &Vec6| {
        link_parameters(&(a_from_world * (se3::exp(xi) * b_from_world).inverse()))
    })
}

/// `A_from_B` of a relative pose `b_from_a` whose unit translation is scaled to `base_length`.
pub fn scaled_a_from_b(b_from_a: &Rigid3, base_length: f64) -> Rigid3 {
    let t = b_from_a.translation.vector.normalize() * base_length;
    Rigid3::from_parts(Translation3::from(t), b_from_a.rotation).inverse()
}

/// Covariance (order x y z, ω φ κ) of the link `A_from_B` from a relative pose `b_from_a`
/// (unit translation) with covariance `cov` in its 5-dimensional tangent (as returned by
/// [`crate::refine_relative_pose`]), the base length being fixed at `base_length`.
pub fn link_covariance_relative(b_from_a: &Rigid3, base_length: f64, cov: &Mat5) -> Mat6 {
    let r0 = b_from_a.rotation.to_rotation_matrix();
    let t0 = b_from_a.translation.vector.normalize();
    let basis = tangent_basis(&t0);
    propagate(cov, |d: &Vec5| {
        let r = so3::exp(&Vec3::new(d[0], d[1], d[2])) * r0;
        let t = (t0 + basis * nalgebra::Vector2::new(d[3], d[4])).normalize();
        let p = Rigid3::from_parts(
            Translation3::from(t),
            crashrig_geometry::quat::unit_quaternion_from_rotation(&r),
        );
        link_parameters(&scaled_a_from_b(&p, base_length))
    })
}
