//! Monte Carlo propagation of pose uncertainty through camera chains, and the
//! forward-intersection precision study over a grid of the car interior (the paper's §2.3.2
//! and §3.3), each next to its first-order (linear) propagation.
//!
//! # Conventions
//! - Lengths in mm, angles in radians (the scenario file is in degrees; [`Scenario`] converts).
//! - Transforms are `b_from_a`. A camera's pose is `world_from_cam` (projection centre and
//!   `R_world_from_cam`); a link is `parent_from_cam` (base = the camera's centre in the
//!   parent frame). ω φ κ describe `R = Rx(ω)·Ry(φ)·Rz(κ)`.
//! - Noise (fixed semantics, `docs/SCENARIO.md`): independent Gaussian position noise on
//!   the projection centre (world axes for a camera, parent axes for a link); rotation noise
//!   `tangent` = `R·Exp(σ∘ε)` about the camera's own axes, or `euler` = `N(0, σ)` added to
//!   ω, φ, κ.
//! - Observers aim their optical axis at each grid point without roll (world z up, image y
//!   down) and observe it at the principal point (plus optional pixel noise); each draw is
//!   forward-intersected by the inhomogeneous linear least-squares DLT in normalized image
//!   coordinates; at the principal point this equals the point closest to all rays.
//! - σ is the sample standard deviation (n − 1). Statistics are streamed: memory does not
//!   grow with the number of draws ([`crashrig_stats::Moments`] for the chain; for the grid,
//!   sums of deviations from the grid point, which vectorise and need no per-draw division).
//! - Normals come from [`FastNormal`], a 256-layer ziggurat over the ChaCha8 streams.
//! - Determinism: work is cut into fixed chunks of [`CHUNK`] draws, chunk k drawing from
//!   `crashrig_stats::stream(seed, k)`, merged in index order: the same seed gives
//!   bit-identical results on any number of threads.
//!
//! # Entry points
//! - [`Scenario::from_path`] / [`Scenario::from_toml_str`]: read and validate a scenario.
//! - [`Chain`]: [`Chain::monte_carlo`] and [`Chain::linear`] (Table 3/4 of the paper).
//! - [`GridStudy`]: [`GridStudy::run`], [`GridStudy::run_adaptive`] → [`GridResult`] of
//!   [`PointStats`] (σ per axis, covariance, ellipsoid, linear covariance).
//! - [`limits`]: the documented bounds every scenario value is checked against (counts that
//!   size memory or work, magnitudes, array lengths), with errors naming key and line.
//! - [`degenerate`]: the intersection angle of a grid point and the threshold below which it
//!   is degenerate; [`GridStudy::new`] refuses a layout where every point is.
//!
//! # Example
//! ```
//! use crashrig_mc::{Chain, GridStudy, Scenario};
//! use std::path::Path;
//!
//! let text = r#"
//! seed = 1
//! samples = 2000
//! [[camera]]
//! name = "cam1"
//! position_mm = [0.0, 0.0, 0.0]
//! angles_deg = [0.0, 0.0, 0.0]
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! [[camera]]
//! name = "cam2"
//! parent = "cam1"
//! position_mm = [61.98, -1.71, 179.76]
//! angles_deg = [179.92, -0.09, 179.76]
//! sigma_position_mm = [0.19, 0.26, 0.13]
//! sigma_angles_deg = [0.004, 0.005, 0.008]
//! [grid]
//! x_mm = [0.0, 1000.0, 3]
//! y_mm = [500.0, 700.0, 2]
//! z_mm = [0.0, 0.0, 1]
//! [[grid.observer]]
//! position_mm = [0.0, 0.0, 0.0]
//! sigma_from = "cam2"
//! [[grid.observer]]
//! position_mm = [1000.0, 0.0, 0.0]
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! "#;
//! let scenario = Scenario::from_toml_str(text, Path::new("example.toml"))?;
//! let chain = Chain::new(&scenario);
//! let mc = chain.monte_carlo(scenario.samples, scenario.seed);
//! let lin = chain.linear();
//! // cam2's position σ: Monte Carlo and first order agree for small σ.
//! assert!((mc[1].position_sigma_mm.x / lin[1].position_sigma_mm.x - 1.0).abs() < 0.1);
//!
//! let study = GridStudy::new(&scenario, scenario.samples, scenario.seed)?;
//! let result = study.run(scenario.samples, scenario.seed)?;
//! assert_eq!(result.points.len(), 6);
//! assert!(result.points.iter().all(|p| p.sigma_max_mm > 0.0));
//! # Ok::<(), crashrig_mc::Error>(())
//! ```
#![deny(missing_docs)]

mod accumulate;
mod chain;
pub mod degenerate;
mod error;
mod grid;
mod kernel;
pub mod limits;
mod normal;
pub mod reference;
mod scenario;

pub use chain::{CameraId, Chain, ChainBuilder, PoseLinear, PoseMc, WorldPose};
pub use error::Error;
pub use grid::{
    CHAIN_SAMPLES_MIN, GridBuilder, GridResult, GridStudy, INPUTS_PER_OBSERVER, PointStats,
};
pub use normal::FastNormal;
pub use reference::{ResultKind, link_from_result_json};
pub use scenario::{
    Adaptive, Axis, CORRELATED_POSITION_TOLERANCE_MM, Camera, Grid, Observer, ObserverSigma,
    PixelNoise, PoseSigma, RotationNoise, Scenario,
};

/// Draws per work chunk (and per RNG stream). Fixed, so results do not depend on the thread
/// count.
pub const CHUNK: usize = 4096;

/// Smallest distance (mm) between an observer and a grid point.
pub const MIN_OBSERVER_DISTANCE_MM: f64 = 1e-6;
