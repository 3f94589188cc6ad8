//! The whole study in one call: [`run_study`].
//!
//! calibration (model → epochs → link `A_from_B` with its SEM covariance) → tie (database +
//! model → bootstrap → link `B_from_C` with the replicates' covariance) → chain (outward world
//! pose ∘ link ∘ tie, Monte Carlo and first order) → one grid study per layout, plus a
//! one-at-a-time sensitivity (each input's covariance divided by 4, i.e. its σ halved).
//! Every value that passes between steps is typed ([`UncertainPose`]); nothing is printed,
//! parsed back or rewritten as text.

use crate::Error;
use crate::calibration::{self, CalibrationConfig, CalibrationResult};
use crate::grids::GridSummary;
use crate::study_file::{
    ChainCamera, Layout, ObserverNoise, Study, StudyScale, TieMethod, TieResample,
};
use crate::tie::{self, TieConfig, TieResult};
use crashrig_geometry::{Mat6, UncertainPose};
use crashrig_mc::{GridResult, GridStudy, PoseLinear, PoseMc, Scenario};
use nalgebra::Vector3;
use serde_json::{Value, json};

/// A progress report: `(stage, done, total)`, with `done ≤ total`.
pub type Progress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

/// Options of a run (what the command line can override).
#[derive(Clone, Copy, Default)]
pub struct Options<'a> {
    /// Seed (default: the study file's).
    pub seed: Option<u64>,
    /// Grid draws per point (default: the study file's `samples`).
    pub samples: Option<usize>,
    /// Skip the one-at-a-time sensitivity runs.
    pub no_sensitivity: bool,
    /// Called after each step.
    pub progress: Option<Progress<'a>>,
}

/// One camera of the propagated chain.
#[derive(Debug, Clone)]
pub struct ChainPose {
    /// Which camera.
    pub camera: ChainCamera,
    /// Monte Carlo statistics of its world pose.
    pub mc: PoseMc,
    /// First-order propagation of the same inputs.
    pub linear: PoseLinear,
}

/// The one-at-a-time sensitivity of a layout to one input.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Sensitivity {
    /// The input whose σ is halved (`outward`, `link` (calibration), `tie`, or an observer's
    /// name for a given σ).
    pub input: String,
    /// Median σ_max (mm) with that input's σ halved.
    pub median_sigma_max_mm: f64,
    /// Fraction below the threshold with that input's σ halved.
    pub fraction_below_threshold: f64,
}

/// The result of one layout.
#[derive(Debug, Clone)]
pub struct LayoutResult {
    /// The layout as read.
    pub layout: Layout,
    /// The grid the Monte Carlo library ran (observer σ resolved).
    pub grid: crashrig_mc::Grid,
    /// Per-point statistics.
    pub result: GridResult,
    /// Summary.
    pub summary: GridSummary,
    /// One-at-a-time sensitivity (empty with [`Options::no_sensitivity`]).
    pub sensitivity: Vec<Sensitivity>,
}

/// Everything a study computes.
#[derive(Debug, Clone)]
pub struct StudyResult {
    /// Seed used.
    pub seed: u64,
    /// Grid draws per point used.
    pub samples: usize,
    /// Chain draws used.
    pub chain_samples: usize,
    /// The calibration (link `A_from_B`, `sem` covariance).
    pub calibration: CalibrationResult,
    /// The tie, if the study has one (link `B_from_C`).
    pub tie: Option<TieResult>,
    /// The chain's inputs as typed values: outward `world_from_A`, link `A_from_B` (SEM
    /// covariance), tie `B_from_C` (bootstrap covariance).
    pub inputs: Vec<(ChainCamera, UncertainPose)>,
    /// The propagated world poses.
    pub chain: Vec<ChainPose>,
    /// One entry per layout.
    pub layouts: Vec<LayoutResult>,
}

/// Covariance multipliers of the inputs (1 = as given; 0.25 = σ halved).
#[derive(Debug, Clone)]
struct Scales {
    outward: f64,
    link: f64,
    tie: f64,
    observers: Vec<f64>,
}

impl Scales {
    fn unit(n_observers: usize) -> Scales {
        Scales {
            outward: 1.0,
            link: 1.0,
            tie: 1.0,
            observers: vec![1.0; n_observers],
        }
    }
}

/// σ (mm, rad) from the diagonal of a covariance (mm, rad).
fn sigmas(c: &Mat6) -> crashrig_mc::PoseSigma {
    crashrig_mc::PoseSigma {
        position_mm: Vector3::new(c[(0, 0)], c[(1, 1)], c[(2, 2)]).map(|v| v.max(0.0).sqrt()),
        angles_rad: Vector3::new(c[(3, 3)], c[(4, 4)], c[(5, 5)]).map(|v| v.max(0.0).sqrt()),
    }
}

/// The Monte Carlo library's camera for an uncertain pose (world pose or link).
fn mc_camera(
    name: &str,
    parent: Option<usize>,
    p: &UncertainPose,
    scale: f64,
) -> crashrig_mc::Camera {
    let r: crashrig_geometry::Rot3 = p.b_from_a.rotation.to_rotation_matrix();
    let opk = crashrig_geometry::opk::opk_from_rotation(&r);
    crashrig_mc::Camera {
        name: name.to_string(),
        parent,
        position_mm: p.b_from_a.translation.vector,
        angles_rad: Vector3::new(opk.omega, opk.phi, opk.kappa),
        sigma: sigmas(&(p.covariance * scale)),
    }
}

/// The chain as a scenario of the Monte Carlo library (typed, no TOML), with the inputs'
/// covariances scaled.
fn chain_scenario(
    inputs: &[(ChainCamera, UncertainPose)],
    s: &Scales,
    samples: usize,
    seed: u64,
) -> Scenario {
    let cameras: Vec<crashrig_mc::Camera> = inputs
        .iter()
        .enumerate()
        .map(|(i, (c, p))| {
            let (parent, k) = match c {
                ChainCamera::Outward => (None, s.outward),
                ChainCamera::Inward => (Some(i - 1), s.link),
                ChainCamera::Tie => (Some(i - 1), s.tie),
            };
            mc_camera(c.name(), parent, p, k)
        })
        .collect();
    Scenario {
        seed,
        samples,
        rotation_noise: crashrig_mc::RotationNoise::Tangent,
        order: (0..cameras.len()).collect(),
        cameras,
        grid: None,
    }
}

fn axis(a: (f64, f64, usize)) -> crashrig_mc::Axis {
    crashrig_mc::Axis {
        start: a.0,
        stop: a.1,
        count: a.2,
    }
}

/// The layout's grid on the chain scenario.
fn layout_scenario(chain: &Scenario, layout: &Layout, s: &Scales) -> Scenario {
    let observers = layout
        .observers
        .iter()
        .zip(&s.observers)
        .map(|(o, k)| crashrig_mc::Observer {
            name: o.name.clone(),
            position_mm: o.position_mm,
            sigma: match &o.noise {
                ObserverNoise::Given(c) => crashrig_mc::ObserverSigma::Given(sigmas(&(c * *k))),
                ObserverNoise::From(cam) => {
                    crashrig_mc::ObserverSigma::From(chain.camera_index(cam.name()).unwrap_or(0))
                }
            },
        })
        .collect();
    let mut sc = chain.clone();
    sc.grid = Some(crashrig_mc::Grid {
        x: axis(layout.x_mm),
        y: axis(layout.y_mm),
        z: axis(layout.z_mm),
        threshold_mm: layout.threshold_mm,
        observers,
        pixel: layout
            .pixel
            .map(|(sigma_px, focal_px)| crashrig_mc::PixelNoise { sigma_px, focal_px }),
        correlated: layout.correlated,
        adaptive: None,
    });
    sc
}

/// The calibration configuration of `[calibration]`.
pub fn calibration_config(study: &Study) -> CalibrationConfig {
    let c = &study.calibration;
    CalibrationConfig {
        model: c.model.clone(),
        camera_a: c.camera_a.clone(),
        camera_b: c.camera_b.clone(),
        scale: match c.scale {
            StudyScale::ScaleBar { points, length_mm } => {
                calibration::Scale::ScaleBar { points, length_mm }
            }
            StudyScale::MmPerUnit(f) => calibration::Scale::MmPerUnit(f),
        },
        max_lag: c.max_lag,
        refine: c.refine,
        ..CalibrationConfig::default()
    }
}

/// The bootstrap configuration of `[tie]` with `seed`.
pub fn tie_config(t: &crate::study_file::TieSection, seed: u64) -> TieConfig {
    TieConfig {
        database: t.database.clone(),
        model: t.model.clone(),
        image_a: t.image_a.clone(),
        image_b: t.image_b.clone(),
        method: match t.method {
            TieMethod::Absolute => tie::Method::Absolute,
            TieMethod::Relative => tie::Method::Relative,
        },
        iterations: t.iterations,
        seed,
        mm_per_unit: t.mm_per_unit,
        max_error_px: t.max_error_px,
        base_mm: t.base_mm,
        resample: match t.resample {
            TieResample::Inliers => tie::Resample::Inliers,
            TieResample::AllMatches => tie::Resample::AllMatches,
        },
        ..TieConfig::default()
    }
}

/// Which chain inputs a layout's observers depend on (for the sensitivity).
fn chain_inputs_used(layout: &Layout) -> [bool; 3] {
    let mut used = [false; 3];
    for o in &layout.observers {
        if let ObserverNoise::From(c) = o.noise {
            let depth = match c {
                ChainCamera::Outward => 1,
                ChainCamera::Inward => 2,
                ChainCamera::Tie => 3,
            };
            for u in used.iter_mut().take(depth) {
                *u = true;
            }
        }
    }
    used
}

/// Runs the whole study.
///
/// # Errors
/// [`Error::Step`] naming the study file and the section whose step failed (the step's own
/// message names the data file), [`Error::Mc`] when the Monte Carlo library refuses the chain
/// or a layout.
pub fn run_study(study: &Study, options: &Options<'_>) -> Result<StudyResult, Error> {
    let seed = options.seed.unwrap_or(study.seed);
    let samples = options.samples.unwrap_or(study.samples);
    if samples < 2 {
        return Err(Error::Key {
            path: study.path.clone(),
            line: None,
            key: "samples".into(),
            message: format!("must be at least 2, got {samples}"),
        });
    }
    let n_sens: usize = if options.no_sensitivity {
        0
    } else {
        study
            .layouts
            .iter()
            .map(|l| {
                chain_inputs_used(l).iter().filter(|u| **u).count()
                    + l.observers
                        .iter()
                        .filter(|o| matches!(o.noise, ObserverNoise::Given(_)))
                        .count()
            })
            .sum()
    };
    let total = (2 + usize::from(study.tie.is_some()) + study.layouts.len() + n_sens) as u64;
    let mut done = 0u64;
    let mut tick = |stage: &str| {
        done = (done + 1).min(total);
        if let Some(p) = options.progress {
            p(stage, done, total);
        }
    };

    let calibration = calibration::calibrate(&calibration_config(study))
        .map_err(|e| study.step_error("calibration", 0, e.to_string()))?;
    tick("calibration");
    let tie = match &study.tie {
        Some(t) => {
            let r = tie::bootstrap(&tie_config(t, seed))
                .map_err(|e| study.step_error("tie", 0, e.to_string()))?;
            tick("tie");
            Some(r)
        }
        None => None,
    };

    let mut inputs = vec![
        (ChainCamera::Outward, study.outward),
        (ChainCamera::Inward, calibration.link),
    ];
    if let Some(t) = &tie {
        inputs.push((ChainCamera::Tie, t.link));
    }
    let mc_err = |source| Error::Mc {
        path: study.path.clone(),
        source,
    };
    let unit_chain = chain_scenario(&inputs, &Scales::unit(0), study.chain_samples, seed);
    let chain_mc = crashrig_mc::Chain::new(&unit_chain);
    chain_mc.check_gimbal().map_err(mc_err)?;
    let mc = chain_mc.monte_carlo(study.chain_samples, seed);
    let linear = chain_mc.linear();
    let chain: Vec<ChainPose> = inputs
        .iter()
        .zip(mc.into_iter().zip(linear))
        .map(|((c, _), (mc, linear))| ChainPose {
            camera: *c,
            mc,
            linear,
        })
        .collect();
    tick("propagation");

    let run_layout =
        |layout: &Layout, s: &Scales| -> Result<(crashrig_mc::Grid, GridResult), Error> {
            let chain = chain_scenario(&inputs, s, study.chain_samples, seed);
            let sc = layout_scenario(&chain, layout, s);
            let g = GridStudy::new(&sc, samples, seed).map_err(mc_err)?;
            let r = g.run(samples, seed).map_err(mc_err)?;
            let mut grid = g.grid().clone();
            for (o, sig) in grid.observers.iter_mut().zip(&r.observer_sigma) {
                o.sigma = crashrig_mc::ObserverSigma::Given(*sig);
            }
            Ok((grid, r))
        };
    let mut layouts = Vec::new();
    for layout in &study.layouts {
        let unit = Scales::unit(layout.observers.len());
        let (grid, result) = run_layout(layout, &unit)?;
        let summary = GridSummary::new(&grid, &result);
        tick(&format!("layout {}", layout.name));
        let mut sensitivity = Vec::new();
        if !options.no_sensitivity {
            let used = chain_inputs_used(layout);
            let mut variants: Vec<(String, Scales)> = Vec::new();
            for (k, name) in ["outward", "link", "tie"].iter().enumerate() {
                if used[k] {
                    let mut s = unit.clone();
                    match k {
                        0 => s.outward = 0.25,
                        1 => s.link = 0.25,
                        _ => s.tie = 0.25,
                    }
                    variants.push((name.to_string(), s));
                }
            }
            for (i, o) in layout.observers.iter().enumerate() {
                if matches!(o.noise, ObserverNoise::Given(_)) {
                    let mut s = unit.clone();
                    s.observers[i] = 0.25;
                    variants.push((format!("observer {}", o.name), s));
                }
            }
            for (input, s) in variants {
                let (g, r) = run_layout(layout, &s)?;
                let sm = GridSummary::new(&g, &r);
                sensitivity.push(Sensitivity {
                    input,
                    median_sigma_max_mm: sm.median_sigma_max_mm,
                    fraction_below_threshold: sm.fraction_below_threshold,
                });
                tick(&format!("sensitivity {}", layout.name));
            }
        }
        layouts.push(LayoutResult {
            layout: layout.clone(),
            grid,
            result,
            summary,
            sensitivity,
        });
    }
    Ok(StudyResult {
        seed,
        samples,
        chain_samples: study.chain_samples,
        calibration,
        tie,
        inputs,
        chain,
        layouts,
    })
}

fn deg3(v: Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

/// A 6×6 covariance (mm, rad) in the contract's units (mm, deg) as rows.
pub fn covariance_deg_rows(c: &Mat6) -> Vec<[f64; 6]> {
    let k = [
        1.0,
        1.0,
        1.0,
        180.0 / std::f64::consts::PI,
        180.0 / std::f64::consts::PI,
        180.0 / std::f64::consts::PI,
    ];
    (0..6)
        .map(|i| std::array::from_fn(|j| c[(i, j)] * k[i] * k[j]))
        .collect()
}

impl StudyResult {
    /// `results.json`: `calibration` and `tie` exactly as `calibrate --json` and
    /// `bootstrap --json` print them, then the propagation and each layout's summary. No
    /// timing, so the same study and seed give the same bytes.
    pub fn to_json(&self) -> Value {
        let cameras: Vec<Value> = self
            .chain
            .iter()
            .map(|c| {
                let m = &c.mc;
                json!({
                    "name": c.camera.name(),
                    "position_mm": <[f64; 3]>::from(m.nominal.position_mm),
                    "angles_deg": deg3(m.nominal.angles_rad()),
                    "position_sigma_mm": <[f64; 3]>::from(m.position_sigma_mm),
                    "angles_sigma_deg": deg3(m.angles_sigma_rad),
                    "tangent_sigma_deg": deg3(m.tangent_sigma_rad),
                    "linear": {
                        "position_sigma_mm": <[f64; 3]>::from(c.linear.position_sigma_mm),
                        "angles_sigma_deg": c.linear.angles_sigma_rad.map(deg3),
                        "tangent_sigma_deg": deg3(c.linear.tangent_sigma_rad),
                        "covariance_tangent": covariance_deg_rows(&c.linear.covariance_tangent),
                    },
                })
            })
            .collect();
        let layouts: Vec<Value> = self
            .layouts
            .iter()
            .map(|l| {
                json!({
                    "name": l.layout.name,
                    "dir": format!("grid/{}", l.layout.slug()),
                    "description": l.layout.description,
                    "observers": l.grid.observers.iter().zip(&l.layout.observers).map(|(o, lo)| {
                        let s = match o.sigma { crashrig_mc::ObserverSigma::Given(s) => s, crashrig_mc::ObserverSigma::From(_) => sigmas(&Mat6::zeros()) };
                        json!({
                            "name": o.name,
                            "position_mm": <[f64; 3]>::from(o.position_mm),
                            "from": match lo.noise { ObserverNoise::From(c) => Some(c.name()), ObserverNoise::Given(_) => None },
                            "sigma_position_mm": <[f64; 3]>::from(s.position_mm),
                            "sigma_angles_deg": deg3(s.angles_rad),
                        })
                    }).collect::<Vec<_>>(),
                    "summary": l.summary,
                    "sensitivity": l.sensitivity,
                })
            })
            .collect();
        json!({
            "seed": self.seed,
            "samples": self.samples,
            "calibration": self.calibration.to_json(),
            "tie": self.tie.as_ref().map(TieResult::to_json),
            "propagation": {"samples": self.chain_samples, "seed": self.seed, "rotation_noise": "tangent", "cameras": cameras},
            "layouts": layouts,
        })
    }
}

/// The world φ of a pose or link (deg): where ω and κ become correlated (|φ| → 90°).
pub fn phi_deg(p: &UncertainPose) -> f64 {
    let r: crashrig_geometry::Rot3 = p.b_from_a.rotation.to_rotation_matrix();
    crashrig_geometry::opk::opk_from_rotation(&r)
        .phi
        .to_degrees()
}

/// σ of a link's tangent rotation (deg) from its covariance.
pub fn tangent_sigma_deg(p: &UncertainPose) -> [f64; 3] {
    let s = sigmas(&p.covariance);
    deg3(s.angles_rad)
}
