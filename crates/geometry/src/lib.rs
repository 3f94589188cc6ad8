//! Rigid-body geometry for photogrammetric rigs: poses, rotations, ω-φ-κ, means, forward
//! intersection and alignment, in `f64`, millimetres and radians.
//!
//! # Conventions
//! - Transforms are named `b_from_a`: `x_b = R·x_a + t` ([`Rigid3`] is nalgebra's
//!   `Isometry3<f64>`; compose with `*`, invert with `inverse()`). COLMAP's image pose is
//!   `cam_from_world`; the projection centre is `C = −Rᵀt` ([`projection_center`]).
//! - Camera axes are OpenCV/COLMAP: x right, y down, z forward.
//! - Lengths are millimetres, angles radians (degrees only at the CLI/IO edge).
//! - ω-φ-κ: `R = Rx(ω)·Ry(φ)·Rz(κ)` ([`opk`]).
//! - Quaternions are `w, x, y, z` on disk; [`quat`] is the only place that converts.
//!   Build a [`Rigid3`] from a rotation matrix with [`quat::rigid_from_rotation`] (or
//!   [`quat::unit_quaternion_from_rotation`]): nalgebra's `UnitQuaternion::from_rotation_matrix`
//!   does not normalise, and the resulting norm error compounds over repeated conversions.
//! - Lie tangent vectors: SO(3) rotation vectors; SE(3) `[ω; v]`, rotation first (COLMAP).
//! - Tolerances are named constants in [`tolerance`].
//!
//! # Entry points
//! - [`quat::rigid_from_colmap`], [`quat::colmap_from_rigid`]: the COLMAP pose edge;
//!   [`quat::rigid_from_rotation`]: a pose from a rotation matrix and a translation.
//! - [`projection_center`]: `C = −Rᵀt` of a `cam_from_world` pose.
//! - [`so3`], [`se3`]: exp/log, Jacobians, adjoint.
//! - [`opk::rotation_from_opk`], [`opk::opk_from_rotation`] and their derivatives.
//! - [`angles::wrapped_stats`]: wrap-safe mean/σ/SEM of angles.
//! - [`mean::chordal_mean`], [`mean::karcher_mean`]: rotation averages;
//!   [`mean::nearest_rotation`]: projection of a 3×3 matrix onto SO(3).
//! - [`look_at::world_from_cam_look_at`]: aim a camera without roll.
//! - [`triangulate::dlt`], [`triangulate::dlt_covariance`]: forward intersection (n ≥ 2 views)
//!   and its first-order covariance.
//! - [`umeyama::align`]: similarity alignment of point sets.
//! - [`UncertainPose`]: a nominal `b_from_a` with its 6×6 tangent covariance (sampling,
//!   estimation from samples, first-order composition and inversion, ω φ κ for display).
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! The rig link "B relative to A" from two COLMAP image poses, as base (mm) and ω-φ-κ.
//! ```
//! use crashrig_geometry::{opk, projection_center, quat, Rigid3, Vec3};
//!
//! // cam_from_world of camera A: identity rotation, centre at the origin.
//! let a_from_world = quat::rigid_from_colmap([1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0])?;
//! // Camera B: turned 180° about y (quaternion w=0, y=1), centre at (60, 0, 180) mm.
//! let r_b = quat::rotation_from_wxyz([0.0, 0.0, 1.0, 0.0])?;
//! let c_b = Vec3::new(60.0, 0.0, 180.0);
//! let b_from_world = Rigid3::from_parts((-(r_b * c_b)).into(), r_b);
//!
//! // A_from_B = A_from_world · (B_from_world)⁻¹
//! let a_from_b = a_from_world * b_from_world.inverse();
//! let base_mm = projection_center(&a_from_b.inverse()); // B's centre in A's frame
//! assert!((base_mm - c_b).norm() < 1e-12);
//!
//! let angles = opk::opk_from_rotation(&a_from_b.rotation.to_rotation_matrix());
//! // Rx(180°)·Ry(0)·Rz(180°) is the same 180° turn about y.
//! assert!((angles.omega.abs() - std::f64::consts::PI).abs() < 1e-12);
//! assert!(angles.phi.abs() < 1e-12);
//! assert!((angles.kappa.abs() - std::f64::consts::PI).abs() < 1e-12);
//! # Ok::<(), crashrig_geometry::Error>(())
//! ```
#![deny(missing_docs)]

pub mod angles;
mod error;
pub mod look_at;
pub mod mean;
pub mod opk;
pub mod quat;
pub mod se3;
pub mod so3;
pub mod tolerance;
pub mod triangulate;
pub mod umeyama;
pub mod uncertain;

pub use error::Error;
pub use uncertain::UncertainPose;

/// 3-vector (mm or rad).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3×3 matrix.
pub type Mat3 = nalgebra::Matrix3<f64>;
/// 6-vector, e.g. an SE(3) tangent `[ω; v]`.
pub type Vec6 = nalgebra::Vector6<f64>;
/// 6×6 matrix, e.g. a pose covariance in `[ω; v]` order.
pub type Mat6 = nalgebra::Matrix6<f64>;
/// Rotation matrix.
pub type Rot3 = nalgebra::Rotation3<f64>;
/// Rigid transform `b_from_a`: `x_b = R·x_a + t`.
pub type Rigid3 = nalgebra::Isometry3<f64>;

/// Projection centre `C = −Rᵀ t` of a `cam_from_world` pose (world coordinates, mm).
pub fn projection_center(cam_from_world: &Rigid3) -> Vec3 {
    -(cam_from_world.rotation.inverse() * cam_from_world.translation.vector)
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
