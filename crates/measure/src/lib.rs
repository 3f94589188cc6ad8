//! Marker trajectories with their uncertainty from a crash-test sequence: camera A's per-epoch
//! pose, the calibrated link to the inward camera B, an optional tied-in camera C, and marker
//! pixels → forward-intersected positions, displacements and velocities, each with its Monte
//! Carlo σ under the physical correlation structure.
//!
//! # Conventions
//! - Frames: positions are in the world frame of the COLMAP model, in mm. Poses are `b_from_a`
//!   (`world_from_A`, `A_from_B`, `B_from_C`); uncertain poses are
//!   [`crashrig_geometry::UncertainPose`] (mm and **radians** inside; the files use degrees).
//! - Pixels follow COLMAP (centre of the upper-left pixel at (0.5, 0.5)); intrinsics are the
//!   model's cameras in any COLMAP camera model.
//! - σ is the sample standard deviation (n − 1) over the Monte Carlo replicates.
//! - Correlation structure ([`engine`]): link and tie drawn once per replicate, A's pose per
//!   epoch, pixel noise per observation. Displacements from a reference epoch cancel the
//!   systematic link and tie errors; velocities are finite differences between neighbouring
//!   epochs.
//! - Reproducible: one RNG stream per (seed, task), bit-identical for any thread count; memory
//!   independent of the number of draws.
//!
//! # Entry points
//! - [`run`]: the library entry of `crashrig measure` and of the study's `[measure]` step:
//!   [`MeasureConfig`] (typed) → [`MeasureRun`], writing the output directory when asked.
//! - [`sequence::a_sequence`], [`sequence::inward_camera`]: A's poses and B/C intrinsics from a
//!   [`crashrig_colmap::Reconstruction`].
//! - [`input::read_observations`], [`input::load_link`], [`input::read_a_covariance`]: the
//!   input files.
//! - [`engine::measure`]: the measurement → [`engine::Measurement`] (typed rows).
//! - [`length`]: the length check of scale bars (`--scale-bars`): each bar's distance in every
//!   replicate, its error against the certificate with σ, and the verdict on the predicted σ.
//! - [`plausible`]: the bound on the replicates, the finiteness check of the result and the
//!   plausibility warnings (frame rate, velocity) that name the suspect flag and its unit.
//! - [`output`]: the rows as `crashrig measure`'s files (`trajectories.csv`,
//!   `displacements.csv`, per-marker plots, the numbers of `summary.json`), shared by the
//!   command and the study.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! Two inward cameras 500 mm apart looking along +z; a marker 2 m in front of them.
//! ```
//! use crashrig_camera::{Camera, ModelId};
//! use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
//! use crashrig_measure::engine::{Epoch, Rig, Settings, measure};
//! use crashrig_measure::input::{Inward, Observation};
//! use nalgebra::Vector2;
//!
//! let pinhole = Camera::new(ModelId::Pinhole, 1000, 1000, vec![1000.0, 1000.0, 500.0, 500.0])?;
//! let rig = Rig {
//!     // B coincides with A; its link is known to 0.1 mm and 0.001°.
//!     a_from_b: UncertainPose::from_sigmas(
//!         Rigid3::identity(),
//!         Vec3::repeat(0.1),
//!         Vec3::repeat(0.001_f64.to_radians()),
//!     ),
//!     camera_b: pinhole.clone(),
//!     // C is 500 mm to the right of B, known to 0.5 mm.
//!     c: Some((
//!         UncertainPose::from_sigmas(Rigid3::translation(500.0, 0.0, 0.0), Vec3::repeat(0.5), Vec3::zeros()),
//!         pinhole,
//!     )),
//! };
//! let epochs: Vec<Epoch> = (0..3)
//!     .map(|i| Epoch {
//!         key: format!("{i:04}.png"),
//!         name: format!("{i:04}"),
//!         world_from_a: UncertainPose::from_sigmas(Rigid3::identity(), Vec3::repeat(0.2), Vec3::zeros()),
//!     })
//!     .collect();
//! // The marker at (250, 0, 2000) mm: u = 500 + 1000·250/2000 in B, 500 − 125 in C.
//! let mut obs = Vec::new();
//! for (i, e) in epochs.iter().enumerate() {
//!     for (camera, u) in [(Inward::B, 625.0), (Inward::C, 375.0)] {
//!         obs.push(Observation {
//!             epoch: e.name.clone(),
//!             camera,
//!             marker: "head".into(),
//!             pixel: Vector2::new(u, 500.0),
//!             sigma: None,
//!             line: 2 + obs.len() as u64,
//!         });
//!     }
//! }
//! let settings = Settings {
//!     samples: 500,
//!     seed: 7,
//!     pixel_sigma_px: 0.1,
//!     reference_epoch: None,
//!     frame_rate_hz: Some(1000.0),
//!     frame_times: None,
//!     threshold_mm: 5.0,
//!     max_reprojection_px: None,
//!     cfc: None,
//!     sync_sigma_ms: 0.0,
//! };
//! let m = measure(&epochs, None, &rig, &obs, None, &settings)?;
//! assert_eq!(m.rows.len(), 3);
//! let row = &m.rows[1];
//! assert!((row.position_mm.unwrap() - Vec3::new(250.0, 0.0, 2000.0)).norm() < 1e-9);
//! // The tie's 0.5 mm is one draw for the whole sequence: it moves the position…
//! let sigma = row.sigma_mm.unwrap();
//! // …but cancels in the displacement from the first epoch.
//! let sigma_d = row.displacement_sigma_mm.unwrap();
//! assert!(sigma_d.x < sigma.x);
//! assert!(row.velocity_sigma_mm_s.is_some());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod csv_table;
pub mod engine;
mod error;
pub mod filter;
pub mod input;
pub mod isomme;
pub mod kinematics;
pub mod length;
mod options;
pub mod output;
pub mod pixel_check;
pub mod plausible;
pub mod rules;
mod run;
pub mod sequence;
pub mod shard;
mod simd;

pub use engine::{Epoch, Measurement, Rig, Row, Settings, measure};
pub use error::Error;
pub use options::{DEFAULT_SEED, MeasureOptions};
pub use run::{ANoise, MeasureConfig, MeasureRun, OutputDir, ScaleBarsFile, check_out, run};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
