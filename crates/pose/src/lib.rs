//! Camera pose estimators on nalgebra: resection (P3P in seeded LO-RANSAC, then
//! Levenberg–Marquardt on the reprojection error through the real camera model) and relative
//! orientation (5-point essential matrix in seeded LO-RANSAC, cheirality, Levenberg–Marquardt on
//! the Sampson error), each with its first-order covariance `σ₀²(JᵀJ)⁻¹`.
//!
//! # Conventions
//! - Poses are `b_from_a` ([`crashrig_geometry::Rigid3`]): `x_b = R·x_a + t`. Resection returns
//!   `cam_from_world`; relative orientation returns `b_from_a` with |t| = 1.
//! - Camera axes x right, y down, z forward; pixels in COLMAP's convention; the camera is any
//!   [`Projector`] (implemented for [`crashrig_camera::Camera`], distortion included, and for
//!   [`Pinhole`]).
//! - Covariances: resection in the **left** SE(3) tangent `[ω; v]` (`se3::exp(ξ)·T`), relative
//!   pose in `[ω (left); δt (2, on the unit sphere)]`; σ₀ is estimated from the residuals.
//! - Every RANSAC run is seeded ([`RansacOptions::seed`]).
//! - Bootstrap replicates are meant to **warm-start** from the full-sample pose with
//!   [`refine_absolute_pose`] / [`refine_relative_pose`] on the resampled inliers instead of
//!   re-running RANSAC: when the full-sample solution lies in the basin of every resample's
//!   optimum (small noise, resamples of the same inliers), LM from it reaches the same optimum
//!   RANSAC + LM would, at a fraction of the cost.
//!
//! # Entry points
//! - [`estimate_absolute_pose`], [`refine_absolute_pose`]: resection of one camera.
//! - [`estimate_relative_pose`], [`refine_relative_pose`], [`normalize_pixels`]: two views.
//! - [`p3p()`], [`essential_5point`], [`essential_8point`], [`poses_from_essential`]: the
//!   minimal (and linear) solvers.
//! - [`link_parameters`], [`link_covariance_absolute`], [`link_covariance_relative`],
//!   [`scaled_a_from_b`]: the rig link `A_from_B` as base and ω φ κ with first-order σ.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_geometry::{Rigid3, Vec3};
//! use crashrig_pose::{estimate_absolute_pose, Pinhole, Projector, RansacOptions};
//! use nalgebra::{Translation3, UnitQuaternion};
//!
//! let camera = Pinhole { fx: 800.0, fy: 800.0, cx: 320.0, cy: 240.0 };
//! let truth = Rigid3::from_parts(
//!     Translation3::new(10.0, -5.0, 30.0),
//!     UnitQuaternion::from_euler_angles(0.1, -0.2, 0.05),
//! );
//! // 40 points on a grid in front of the camera, observed without noise.
//! let mut points = Vec::new();
//! let mut pixels = Vec::new();
//! for i in 0..40 {
//!     let p_cam = Vec3::new((i % 8) as f64 * 20.0 - 70.0, (i / 8) as f64 * 20.0 - 40.0,
//!                           900.0 + 37.0 * (i % 5) as f64);
//!     points.push(truth.inverse_transform_point(&p_cam.into()).coords);
//!     pixels.push(camera.project(&p_cam).unwrap());
//! }
//! let est = estimate_absolute_pose(&camera, &pixels, &points, &RansacOptions::new(7)).unwrap();
//! let t = est.refinement.cam_from_world.translation.vector;
//! assert!((t - truth.translation.vector).norm() < 1e-6);
//! assert_eq!(est.inliers.len(), 40);
//! ```
#![deny(missing_docs)]

mod absolute;
mod error;
mod fivept;
mod link;
mod lm;
mod p3p;
mod projector;
mod ransac;
mod relative;

pub use absolute::{
    AbsolutePose, AbsoluteRefinement, dx_img_from_pose_left, estimate_absolute_pose,
    refine_absolute_pose,
};
pub use error::{Degeneracy, Error};
pub use fivept::essential_5point;
pub use link::{
    link_covariance_absolute, link_covariance_relative, link_parameters, scaled_a_from_b,
};
pub use p3p::p3p;
pub use projector::{Pinhole, Projector};
pub use ransac::RansacOptions;
pub use relative::{
    MAX_ROTATION_ONLY_RATIO, Mat5, RelativePose, RelativeRefinement, Vec5, essential_8point,
    essential_from_pose, estimate_relative_pose, normalize_pixels, pose_with_cheirality,
    poses_from_essential, refine_relative_pose, rotation_only_ratio, sampson_error, tangent_basis,
    triangulate_depths,
};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
