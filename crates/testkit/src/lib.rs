//! Dev-only helpers for crashrig tests: pose comparison, proptest strategies, central finite
//! differences and synthetic seeded scenes.
//!
//! Use it from `tests/` and `benches/` only (as a `[dev-dependency]`): in-`src` unit tests of a
//! crate that testkit depends on would see a second copy of that crate.
//!
//! # Conventions
//! - Same as `crashrig-geometry`: `b_from_a` poses, mm, radians, f64.
//! - Pose comparison follows COLMAP's `Rigid3dNear`: rotation by angular distance (rad),
//!   translation relative to the reference (absolute when the reference translation is zero);
//!   NaN never matches.
//! - Every random scene takes an explicit seed (ChaCha8).
//!
//! # Entry points
//! - [`pose::assert_rigid_near`], [`pose::rigid_near`] (and `_abs` variants),
//!   [`pose::assert_rot3_near`].
//! - [`strategies`]: `rot3()`, `rigid3()`, `vec3_in(r)`, `opk_away_from_gimbal()`, ...
//! - [`fd::central_jacobian`], [`fd::central_derivative`]: finite-difference Jacobians.
//! - [`scene::rig_sequence`], [`scene::two_view_scene`], [`scene::paper_a_from_b`].
//!
//! # Example
//! ```
//! use crashrig_testkit::{pose::assert_rigid_near, scene};
//!
//! // Noise-free rig epochs reproduce the link A_from_B = A_from_world · (B_from_world)⁻¹.
//! let a_from_b = scene::paper_a_from_b();
//! for epoch in scene::rig_sequence(7, 5, &a_from_b, 0.0, 0.0) {
//!     let estimate = epoch.a_from_world * epoch.b_from_world.inverse();
//!     // Rounding through two compositions of poses ~2000 mm from the origin: ~1e-13 relative.
//!     assert_rigid_near(&estimate, &a_from_b, 1e-12, 1e-10);
//! }
//! ```
#![deny(missing_docs)]

pub mod fd;
pub mod pose;
pub mod scene;
pub mod strategies;
