//! The library entry of `crashrig propagate`: a typed [`PropagateConfig`] →
//! [`run_propagate`] → a typed [`PropagateRun`] (the `--json` document and the warnings).
//!
//! # Example
//! ```
//! use crashrig_grid::{PropagateConfig, run_propagate};
//! let scenario = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
//!     .join("../../fixtures/scenarios/paper_chain.toml");
//! let config = PropagateConfig { scenario, samples: Some(2000), seed: Some(1) };
//! let run = run_propagate(&config, None)?;
//! assert_eq!(run.document.cameras.len(), 3);
//! // The same seed gives the same numbers.
//! assert_eq!(run_propagate(&config, None)?.document.cameras, run.document.cameras);
//! # Ok::<(), crashrig_grid::Error>(())
//! ```

use crate::Error;
use crate::run::{load_scenario, resolve_samples};
use crashrig_mc::{Chain, ChainOptions};
use crashrig_stats::progress::{self, Reporter};
use serde::Serialize;
use std::path::PathBuf;

/// What `crashrig propagate` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PropagateConfig {
    /// The scenario file (TOML).
    pub scenario: PathBuf,
    /// Draws (default: the scenario's `samples`).
    pub samples: Option<usize>,
    /// Seed (default: the scenario's).
    pub seed: Option<u64>,
}

/// The result of [`run_propagate`].
#[derive(Debug, Clone)]
pub struct PropagateRun {
    /// The `--json` document.
    pub document: PropagateJson,
    /// Warnings for the user (cameras at gimbal lock), without the `warning:` prefix.
    pub warnings: Vec<String>,
}

/// `cameras[].linear`: the first-order propagation of a camera.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearJson {
    /// σ of the centre (mm).
    pub position_sigma_mm: [f64; 3],
    /// `null` where the nominal ω φ κ are at gimbal lock (see `angles_singular`).
    pub angles_sigma_deg: Option<[f64; 3]>,
    /// σ of the rotation about the camera's own axes (deg).
    pub tangent_sigma_deg: [f64; 3],
    /// The world pose's covariance: centre in world axes (mm), rotation about the camera's own axes (deg).
    pub covariance_tangent: [[f64; 6]; 6],
}

/// `cameras[]`: one propagated camera.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraJson {
    /// Camera name.
    pub name: String,
    /// The camera it is chained to.
    pub parent: Option<String>,
    /// Nominal centre (mm).
    pub position_mm: [f64; 3],
    /// Nominal ω φ κ (deg).
    pub angles_deg: [f64; 3],
    /// σ of the centre (mm).
    pub position_sigma_mm: [f64; 3],
    /// `null` at gimbal lock of the nominal world ω φ κ.
    pub angles_sigma_deg: Option<[f64; 3]>,
    /// σ of the rotation about the camera's own axes (deg).
    pub tangent_sigma_deg: [f64; 3],
    /// Mean centre over the draws (mm).
    pub position_mean_mm: [f64; 3],
    /// `null` at gimbal lock of the nominal world ω φ κ.
    pub angles_mean_deg: Option<[f64; 3]>,
    /// True when the nominal world rotation is at φ = ±90° (to within
    /// `crashrig_geometry::opk::GIMBAL_LOCK_COS_PHI`): ω and κ are then not separable, so the
    /// ω φ κ σ are `null`; the tangent covariance is unaffected.
    pub angles_singular: bool,
    /// The world pose's covariance over the draws: centre in world axes (mm), rotation about
    /// the camera's own axes (deg); n − 1.
    pub covariance_tangent: [[f64; 6]; 6],
    /// First-order propagation.
    pub linear: LinearJson,
}

/// The document of `crashrig propagate --json` (docs/SCENARIO.md).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PropagateJson {
    /// Draws.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
    /// `tangent` or `euler`.
    pub rotation_noise: &'static str,
    /// One entry per camera.
    pub cameras: Vec<CameraJson>,
    /// Wall-clock time of the Monte Carlo (s).
    pub elapsed_s: f64,
}

fn deg(v: nalgebra::Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

/// A tangent covariance (mm, rad) in the contract's units (mm, deg) as 6 rows.
fn rows_deg(c: &nalgebra::Matrix6<f64>) -> [[f64; 6]; 6] {
    let u = crashrig_geometry::UncertainPose {
        b_from_a: crashrig_geometry::Rigid3::identity(),
        covariance: *c,
    }
    .covariance_deg();
    std::array::from_fn(|i| std::array::from_fn(|j| u[(i, j)]))
}

/// Runs the chain's Monte Carlo (`progress` watches its chunks) and first-order
/// propagation.
///
/// # Errors
/// [`Error::Scenario`], [`Error::NoCamera`], [`Error::Setting`] for `--samples`.
pub fn run_propagate(
    config: &PropagateConfig,
    progress: Option<&dyn Reporter>,
) -> Result<PropagateRun, Error> {
    let scenario = load_scenario(&config.scenario)?;
    if scenario.cameras.is_empty() {
        return Err(Error::NoCamera {
            path: config.scenario.clone(),
        });
    }
    let samples = resolve_samples(config.samples, &scenario)?;
    let seed = config.seed.unwrap_or(scenario.seed);
    let chain = Chain::new(&scenario);
    // Any ω φ κ input is a valid rotation; only the ω φ κ *output* of a camera at φ = ±90° is
    // singular: its angle σ are null, with one warning.
    // The scenario's plausibility warnings (units never guessed), then gimbal lock.
    let warnings = scenario
        .warnings
        .iter()
        .cloned()
        .chain(chain
        .names()
        .iter()
        .enumerate()
        .filter(|(i, _)| chain.angles_singular(*i))
        .map(|(_, name)| format!(
            "{}: camera `{name}`: its world orientation is at φ = ±90° (gimbal lock), where ω and κ are not separable; its ω φ κ σ are null (see covariance_tangent / tangent_sigma_deg)",
            config.scenario.display()
        )))
        .collect();
    let start = std::time::Instant::now();
    let stage = progress.map(|r| progress::Stage::new(r, "chunks of draws"));
    let mc = chain
        .monte_carlo(
            &ChainOptions::new(samples, seed),
            stage.as_ref().map(|s| s as &dyn progress::Monitor),
        )
        .map_err(Error::ScenarioFile)?;
    let elapsed_s = start.elapsed().as_secs_f64();
    let lin = chain.linear();
    let cameras: Vec<CameraJson> = mc
        .iter()
        .zip(&lin)
        .zip(&scenario.cameras)
        .map(|((m, l), c)| {
            let ok = !m.angles_singular;
            CameraJson {
                name: m.name.clone(),
                parent: c.parent.map(|p| scenario.cameras[p].name.clone()),
                position_mm: m.nominal.position_mm.into(),
                angles_deg: deg(m.nominal.angles_rad()),
                position_sigma_mm: m.position_sigma_mm.into(),
                angles_sigma_deg: ok.then(|| deg(m.angles_sigma_rad)),
                tangent_sigma_deg: deg(m.tangent_sigma_rad),
                position_mean_mm: m.position_mean_mm.into(),
                angles_mean_deg: ok.then(|| deg(m.angles_mean_rad)),
                angles_singular: m.angles_singular,
                covariance_tangent: rows_deg(&m.covariance_tangent),
                linear: LinearJson {
                    position_sigma_mm: l.position_sigma_mm.into(),
                    angles_sigma_deg: l.angles_sigma_rad.filter(|_| ok).map(deg),
                    tangent_sigma_deg: deg(l.tangent_sigma_rad),
                    covariance_tangent: rows_deg(&l.covariance_tangent),
                },
            }
        })
        .collect();
    let document = PropagateJson {
        samples,
        seed,
        rotation_noise: match scenario.rotation_noise {
            crashrig_mc::RotationNoise::Tangent => "tangent",
            crashrig_mc::RotationNoise::Euler => "euler",
        },
        cameras,
        elapsed_s,
    };
    Ok(PropagateRun { document, warnings })
}
