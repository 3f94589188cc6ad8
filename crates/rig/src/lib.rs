//! Rig calibration from an epoch sequence: the base and orientation of camera B relative to
//! camera A (`A_from_B`) from independently estimated poses, with its spread, outliers, drift
//! and a rig-constrained refinement (the paper's §2.2, §3.1, Tables 1–2).
//!
//! # Conventions
//! - Transforms are `b_from_a` (`x_b = R·x_a + t`). An epoch holds the COLMAP poses
//!   `A_from_world`, `B_from_world` in model units; its link is
//!   `A_from_B = A_from_world · (B_from_world)⁻¹`.
//! - The **base** is B's projection centre in A's frame, the translation of `A_from_B`, in mm
//!   (model units times `mm_per_unit`). The **angles** are ω, φ, κ of `R_A_from_B` with
//!   `R = Rx(ω)·Ry(φ)·Rz(κ)`, in **radians** (degrees only at the CLI).
//! - σ is the sample standard deviation (n − 1), SEM = σ/√n. Angle statistics are wrap-safe:
//!   each series is unwrapped to within ±π of its circular mean first. The rotation mean is also
//!   given on SO(3) (Karcher mean).
//! - Covariances are ordered (x, y, z mm, ω, φ, κ rad).
//! - Outliers: modified z-score `0.6745 (x − median)/MAD` on each parameter, flagged above a
//!   threshold `t(n)` that holds the per-sequence false-flag rate at 0.5 %, raised per
//!   parameter where it drifts ([`robust`]).
//! - The spread of one epoch's link and the uncertainty of the mean link are 6×6 tangent
//!   covariances ([`crashrig_geometry::UncertainPose`]: centre in A's axes, rotation
//!   `log(R̄ᵀ·R)` about B's axes); the latter accounts for slow drift mixed with epoch noise,
//!   with an effective n per axis ([`sem`]).
//! - A sequence whose links are all identical (a bundle adjusted with a rig constraint) is
//!   refused ([`Error::RigConstrained`]) unless accepted explicitly.
//!
//! # Entry points
//! - [`Epoch`], [`link_of`], [`links_of`]: per-epoch links.
//! - [`link_statistics`] → [`LinkStatistics`]: mean, σ, SEM, covariance, SO(3) mean.
//! - [`flag_outliers`] → [`OutlierReport`]; [`drift_report`] → [`DriftReport`].
//! - [`sem::sem_covariance`] → [`sem::SemEstimate`]: the uncertainty of the mean link and, per
//!   axis, whether it can be relied on ([`likelihood`]: the drift model's REML likelihood).
//! - [`refine()`] → [`Refinement`]: one link fitted jointly with all poses of A, with covariance
//!   (a weighted mean of the same poses, floored at the uncertainty of the mean).
//! - [`calibrate`] → [`Calibration`]: all of the above in one call.
//!
//! Epochs from a COLMAP model (camera selectors, pairing, scale bar) are read by
//! `crashrig_calibrate::epochs_from_model`; this crate works on poses only.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_geometry::{Rigid3, Vec3, opk::rotation_from_opk};
//! use crashrig_rig::{CalibrateOptions, Epoch, calibrate};
//! use nalgebra::{Translation3, UnitQuaternion};
//!
//! let pose = |w: f64, p: f64, k: f64, t: Vec3| {
//!     let r = rotation_from_opk(w.to_radians(), p.to_radians(), k.to_radians());
//!     Rigid3::from_parts(Translation3::from(t), UnitQuaternion::from_rotation_matrix(&r))
//! };
//! // Five epochs of a rig whose B sits 62 mm right of and 180 mm behind A, facing backwards.
//! let epochs: Vec<Epoch> = (0..5)
//!     .map(|i| {
//!         let d = 0.01 * (i as f64 - 2.0);
//!         let a_from_b = pose(179.9 + d, -0.1, 179.8 - d, Vec3::new(62.0 + d, -1.7, 179.8));
//!         let a_from_world = pose(10.0 * i as f64, 5.0, 0.0, Vec3::new(100.0 * i as f64, 0.0, 3000.0));
//!         Epoch {
//!             name: format!("{i:06}.png"),
//!             a_from_world,
//!             b_from_world: a_from_b.inverse() * a_from_world,
//!         }
//!     })
//!     .collect();
//! let c = calibrate(&epochs, 1.0, &CalibrateOptions::default(), None)?;
//! assert_eq!(c.all.n, 5);
//! assert!((c.all.base_mm.x - 62.0).abs() < 1e-9);
//! assert!((c.all.angles.x.to_degrees() - 179.9).abs() < 1e-9);
//! assert!(c.outliers.indices().is_empty());
//! // The mean link with the uncertainty of the mean (6×6 tangent covariance, mm and rad).
//! assert!((c.link.center().x - 62.0).abs() < 1e-9);
//! assert!(c.link.sigma_position().x > 0.0);
//! # Ok::<(), crashrig_rig::Error>(())
//! ```
#![deny(missing_docs)]

mod calibrate;
pub mod drift;
mod error;
pub mod likelihood;
mod link;
pub mod refine;
pub mod robust;
pub mod sem;
pub mod stats;

pub use calibrate::{
    CalibrateOptions, Calibration, ZERO_SPREAD_RAD, ZERO_SPREAD_RELATIVE, calibrate, epoch_spread,
};
pub use crashrig_stats::progress::{Cancelled, Monitor};
pub use drift::{DriftReport, drift_report};
pub use error::Error;
pub use link::{Epoch, Link, check_scale, link_of, links_of};
pub use refine::{RefineOptions, Refinement, refine};
pub use robust::{OutlierReport, flag_outliers, outlier_threshold};
pub use sem::SemEstimate;
pub use stats::{LinkStatistics, link_statistics};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
