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
//! - Normals: Philox4x32-10 counter-based bits (key = seed, counter = (task, draw, slot)) into
//!   a vectorised Box–Muller transform, 64 draws per block, compiled for the CPU's best
//!   instruction set at run time ([`Isa::Auto`]; the `isa` field of [`RunOptions`] /
//!   [`ChainOptions`] takes an explicit [`Isa`], a typed argument — no environment variable
//!   is read).
//! - Determinism: work is cut into fixed chunks of [`CHUNK`] draws (tasks), each with its own
//!   counter range, merged in index order: the same seed gives bit-identical results on any
//!   number of threads and on every instruction-set level.
//! - Common random numbers (correlated mode): replicate `j` of every grid point of a map takes
//!   the same chain draw — one rig error per crash test, shared by all the points it measures
//!   — drawn once per block of replicates for the points drawn together; a point's own noise
//!   (pixels, independent observers) comes from its own stream. Each point's σ keeps its
//!   distribution, and [`GridStudy::joint`] gives the joint errors of points measured in the
//!   same test (cross-covariances, the σ of a distance).
//!
//! # Layers and features
//! The crate reads bottom-up (`docs/ARCHITECTURE.md`): a `kernel` layer (instruction-set
//! dispatch, Philox, normals, the lane forms of the pose noise, rotations and DLT rows, streaming
//! sums) that imports nothing above it; the engine's vocabulary (`model`: [`Camera`], [`Grid`],
//! [`Observer`], …); the chain and grid engines; and, behind the default feature `scenario`,
//! the TOML scenario reader ([`Scenario::from_path`]), [`mod@reference`] and the COLMAP model reader
//! of `camera_from`. With `default-features = false` the engine builds without toml,
//! serde_json, the COLMAP reader and SQLite: build chains and grids with [`ChainBuilder`] and
//! [`GridBuilder`].
//!
//! # Entry points
//! - [`ChainBuilder`] → [`Chain`]: world poses and links as
//!   [`crashrig_geometry::UncertainPose`]s; [`Chain::monte_carlo`] and [`Chain::linear`]
//!   (Tables 3/4 of the paper), each camera's world pose with its tangent covariance
//!   ([`PoseMc::uncertain`], [`PoseLinear::uncertain`]).
//! - [`GridBuilder`] → [`GridStudy`]: observers with a covariance or a chain camera's
//!   (`observer_from`, optionally `correlated`); [`GridStudy::run`] → [`GridResult`] of
//!   [`PointStats`] (σ per axis, covariance, ellipsoid, linear covariance);
//!   [`GridStudy::joint`] → [`JointResult`] (points measured in the same test: their
//!   cross-covariances and the σ of their distances, [`DistanceStats`]).
//! - One entry per engine, each taking a typed options value and an optional
//!   [`crashrig_stats::progress::Monitor`] (progress and cancellation, [`Error::Cancelled`]):
//!   [`GridStudy::run`]`(&`[`RunOptions`]`, monitor)` — draws per point ([`Draws::Samples`] or
//!   the adaptive rule, [`Draws::Adaptive`]), seed, [`Isa`]; [`GridStudy::options`] gives the
//!   settings the study was built with — and [`Chain::monte_carlo`]`(&`[`ChainOptions`]`,
//!   monitor)`.
//! - [`limits`]: the documented bounds every scenario value is checked against (counts that
//!   size memory or work, magnitudes, array lengths), with errors naming key and line.
//! - [`degenerate`]: the intersection angle of a grid point and the threshold below which it
//!   is degenerate; [`GridStudy::new`] refuses a layout where every point is.
//! - The scenario file, one front end of the builders: [`Scenario::from_path`] /
//!   [`Scenario::from_toml_str`], then [`Chain::new`] and [`GridStudy::new`] (keys in
//!   `docs/SCENARIO.md`).
//! - [`reference::link_from_result_json`]: a `calibrate` / `bootstrap` JSON result as an
//!   uncertain link (what `from = "…"` in a scenario reads).
//! - [`Scenario::from_path`] / [`Scenario::from_toml_str`]: read and validate a scenario.
//! - [`Chain`]: [`Chain::monte_carlo`] and [`Chain::linear`] (Table 3/4 of the paper).
//! - [`GridStudy`]: [`GridStudy::run`] (fixed draws or adaptive) → [`GridResult`] of
//!   [`PointStats`] (σ per axis, covariance, ellipsoid, linear covariance, observers seen).
//! - Fixed observers ([`Aim::Fixed`], `aim = "fixed"` with a COLMAP lens, `docs/FIXED_CAMERAS.md`):
//!   a point is seen only inside a camera's image; each draw undistorts the true pixel plus
//!   pixel noise through the lens; points seen by fewer than two observers are not measurable
//!   ([`PointStats::is_measurable`], [`GridResult::fraction_measurable`],
//!   [`footprint_margin_px`] for field-of-view footprints; [`coverage`]: which observer sees
//!   which point, the fraction each sees, footprint rasters).
//!
//! # Example: the builders
//! ```
//! use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3, opk, quat};
//! use crashrig_mc::{Axis, ChainBuilder, ChainOptions, GridBuilder, Isa, RunOptions};
//! use nalgebra::Vector3;
//! use std::sync::atomic::{AtomicUsize, Ordering};
//!
//! // The outward camera in the world: 1 mm and 0.01° (about its own axes), independent.
//! let world = UncertainPose::from_sigmas(
//!     Rigid3::identity(),
//!     Vec3::repeat(1.0),
//!     Vec3::repeat(0.01_f64.to_radians()),
//! );
//! // The calibrated rig link cam1_from_cam2 (the paper's Tables 1/2) with a full tangent
//! // covariance in the contract's units (mm, deg): here the SEM row with a correlation.
//! let r = opk::rotation_from_opk(
//!     179.92_f64.to_radians(),
//!     (-0.09_f64).to_radians(),
//!     179.76_f64.to_radians(),
//! );
//! let s = [0.19, 0.26, 0.13, 0.004, 0.005, 0.008];
//! let cov = Mat6::from_fn(|i, j| if i == j { s[i] * s[i] } else if i + j == 1 { 0.3 * s[0] * s[1] } else { 0.0 });
//! let link = UncertainPose::from_covariance_deg(
//!     quat::rigid_from_rotation(&r, &Vec3::new(61.98, -1.71, 179.76)),
//!     cov,
//! )
//! .expect("a valid covariance");
//!
//! let mut b = ChainBuilder::new();
//! let cam1 = b.world("cam1", world)?;
//! let cam2 = b.link("cam2", cam1, link)?;
//! let chain = b.build();
//! // 20 000 joint draws under seed 1, no monitor.
//! let mc = chain.monte_carlo(&ChainOptions::new(20_000, 1), None)?;
//! let lin = chain.linear();
//! // cam2's world position σ: Monte Carlo and first order agree for small σ.
//! let k = cam2.index();
//! assert!((mc[k].position_sigma_mm.x / lin[k].position_sigma_mm.x - 1.0).abs() < 0.05);
//! // Its world pose with the full tangent covariance, ready for the next step.
//! let cam2_world: UncertainPose = lin[k].uncertain();
//! assert!(cam2_world.covariance[(0, 1)] != 0.0);
//!
//! // A grid with cam2 as one observer (its propagated covariance) and a fixed-σ one.
//! let axis = |start: f64, stop: f64, count: usize| Axis { start, stop, count };
//! let study = GridBuilder::new(axis(0.0, 1000.0, 3), axis(500.0, 700.0, 2), axis(0.0, 0.0, 1))
//!     .chain(chain)
//!     .observer_from("rear", Vector3::new(0.0, 0.0, 0.0), cam2)
//!     .observer("door", Vector3::new(1000.0, 0.0, 0.0), Mat6::from_diagonal_element(1e-4))
//!     .build(2000, 7)?;
//! // The settings it was built with (2000 draws per point, seed 7), watching the progress in
//! // grid points (any `Fn(done, total)` closure is a monitor that never cancels).
//! let done = AtomicUsize::new(0);
//! let watch = |d: usize, _total: usize| {
//!     done.fetch_max(d, Ordering::Relaxed);
//! };
//! let result = study.run(&study.options(), Some(&watch))?;
//! assert_eq!(result.points.len(), 6);
//! assert_eq!(done.load(Ordering::Relaxed), 6);
//! assert!(result.points.iter().all(|p| p.sigma_max_mm > 0.0));
//! // Another instruction-set level draws the same bits (only the speed differs).
//! let baseline = RunOptions { isa: Isa::Baseline, ..study.options() };
//! assert_eq!(study.run(&baseline, None)?, result);
//! # Ok::<(), crashrig_mc::Error>(())
//! ```
//!
//! # Example: a scenario file
//! ```
//! use crashrig_mc::{Chain, ChainOptions, GridStudy, RunOptions, Scenario};
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
//! let mc = chain.monte_carlo(&ChainOptions::new(scenario.samples, scenario.seed), None)?;
//! let lin = chain.linear();
//! // cam2's position σ: Monte Carlo and first order agree for small σ.
//! assert!((mc[1].position_sigma_mm.x / lin[1].position_sigma_mm.x - 1.0).abs() < 0.1);
//!
//! let study = GridStudy::new(&scenario, scenario.samples, scenario.seed)?;
//! let result = study.run(&RunOptions::samples(scenario.samples, scenario.seed), None)?;
//! assert_eq!(result.points.len(), 6);
//! assert!(result.points.iter().all(|p| p.sigma_max_mm > 0.0));
//! # Ok::<(), crashrig_mc::Error>(())
//! ```
//!
//! Fixed cameras with lenses: a point is measurable only where two of them see it.
//! ```
//! use crashrig_mc::{GridStudy, RunOptions, Scenario};
//! use std::path::Path;
//!
//! let text = r#"
//! [grid]
//! x_mm = [1000.0, 1400.0, 5]
//! y_mm = [0.0, 0.0, 1]
//! z_mm = [0.0, 0.0, 1]
//! [[grid.observer]]
//! aim = "fixed"
//! position_mm = [1200.0, -1500.0, 0.0]
//! look_at_mm = [1200.0, 0.0, 0.0]
//! camera = { model = "OPENCV", width = 1000, height = 800, params = [600.0, 600.0, 500.0, 400.0, -0.05, 0.01, 0.0, 0.0] }
//! pixel_sigma_px = 0.5
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! [[grid.observer]]
//! aim = "fixed"
//! position_mm = [1400.0, 1500.0, 0.0]
//! look_at_mm = [1600.0, 0.0, 0.0]
//! camera = { model = "PINHOLE", width = 800, height = 600, params = [1500.0, 1500.0, 400.0, 300.0] }
//! sigma_position_mm = [1.0, 1.0, 1.0]
//! sigma_angles_deg = [0.01, 0.01, 0.01]
//! "#;
//! let scenario = Scenario::from_toml_str(text, Path::new("fixed.toml"))?;
//! let result = GridStudy::new(&scenario, 500, 1)?.run(&RunOptions::samples(500, 1), None)?;
//! // The narrow right camera sees only part of the line: the rest is not measurable.
//! let seen: Vec<usize> = result.points.iter().map(|p| p.observers_seen).collect();
//! assert!(seen.contains(&1) && seen.contains(&2));
//! for p in &result.points {
//!     assert_eq!(p.is_measurable(), p.sigma_max_mm.is_finite());
//! }
//! assert!(result.fraction_measurable() > 0.0 && result.fraction_measurable() < 1.0);
//! # Ok::<(), crashrig_mc::Error>(())
//! ```
#![deny(missing_docs)]

mod block;
mod chain;
pub mod coverage;
pub mod degenerate;
mod error;
mod fixed;
mod grid;
mod grid_builder;
mod joint;
mod kernel;
pub mod limits;
mod map;
mod model;
mod options;
#[cfg(feature = "scenario")]
pub mod reference;
mod result;
#[cfg(feature = "scenario")]
mod scenario;
mod schedule;
#[cfg(test)]
mod testdata;
mod view;

pub use chain::{CameraId, Chain, ChainBuilder, PoseLinear, PoseMc, WorldPose};
pub use error::Error;
pub use fixed::LinearTerm;
pub use grid::{CHAIN_SAMPLES_MIN, GridStudy, INPUTS_PER_OBSERVER};
pub use grid_builder::GridBuilder;
pub use joint::{DistanceStats, JOINT_POINTS_MAX, JointResult};
pub use kernel::Isa;
pub use model::{
    Adaptive, Aim, Axis, CORRELATED_POSITION_TOLERANCE_MM, Camera, FixedCamera, Grid, MAX_NDIG,
    MIN_OBSERVER_DISTANCE_MM, Observer, ObserverSigma, PixelNoise, PoseSigma, RotationNoise,
    Scenario, Tolerance, ndig_tolerance,
};
pub use options::{ChainOptions, Draws, RunOptions};
#[cfg(feature = "scenario")]
pub use reference::{ResultKind, link_from_result_json};
pub use result::{GridResult, PointStats};
#[cfg(feature = "scenario")]
pub use scenario::plausible;
#[cfg(feature = "scenario")]
pub use scenario::{AimKeys, LensKeys, aim_from_keys, candidates_from_toml_str, read_candidates};
pub use schedule::ADAPTIVE_MIN_BATCHES;
pub use view::{UNDISTORT_RESIDUAL_PX, footprint_margin_px};

/// Draws per work chunk (and per RNG stream). Fixed, so results do not depend on the thread
/// count.
pub const CHUNK: usize = schedule::CHUNK;

/// Hooks for the benchmarks (`benches/`) and external tests: the engine's building blocks
/// with an explicit instruction-set level. Not a stable interface.
#[doc(hidden)]
pub mod bench {
    use crate::kernel::normal::{LANES, fill_block};
    use crate::kernel::philox::key_of_seed;
    use crate::kernel::simd::{Isa, dispatch};

    /// Draws per block of the vectorised kernels.
    pub const BLOCK: usize = LANES;

    /// Standard normals of draws `draw0 .. draw0 + BLOCK` of `task` under `seed`:
    /// `rows[i][d]` is normal `i` of draw `draw0 + d` (`rows.len()` even).
    pub fn philox_normals(isa: Isa, seed: u64, task: u64, draw0: u64, rows: &mut [[f64; BLOCK]]) {
        let key = key_of_seed(seed);
        dispatch(
            isa,
            #[inline(always)]
            |width| fill_block(key, task, draw0, rows, width),
        );
    }

    /// As [`philox_normals`], by a 256-layer ziggurat's fast path in lanes instead of the
    /// Box–Muller transform: **timing only** (its rare slow-path lanes take a stand-in, so
    /// its output is not a sample of N(0, 1); no engine uses it). `docs/performance.md`,
    /// issue 39, weighs it.
    pub fn philox_ziggurat_normals(
        isa: Isa,
        seed: u64,
        task: u64,
        draw0: u64,
        rows: &mut [[f64; BLOCK]],
    ) {
        let key = key_of_seed(seed);
        dispatch(
            isa,
            #[inline(always)]
            |width| crate::kernel::zig_lanes::fill_block_ziggurat(key, task, draw0, rows, width),
        );
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
