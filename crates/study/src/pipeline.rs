//! The whole study in one call: [`run_study`].
//!
//! calibration (model → epochs → link `A_from_B` with its SEM covariance) → tie (database +
//! model → bootstrap → link `B_from_C` with the replicates' covariance) → chain (outward world
//! pose ∘ link ∘ tie, Monte Carlo and first order) → one grid study per layout, plus a
//! one-at-a-time sensitivity (each input's covariance divided by 4, i.e. its σ halved).
//! Every value that passes between steps is typed ([`UncertainPose`]); nothing is printed,
//! parsed back or rewritten as text.

use crate::Error;
use crate::contract::{
    ACovarianceSummary, ChainCameraDocument, LayoutDocument, LinearDocument, MeasureDocument,
    ObserverDocument, PropagationDocument, StudyDocument,
};
use crate::study_file::{
    ChainCamera, Layout, ObserverNoise, Study, StudyScale, TieMethod, TieResample,
};
use crashrig_calibrate::{self as calibration, CalibrationConfig, CalibrationResult};
use crashrig_geometry::{Mat6, UncertainPose};
use crashrig_grid::summary::GridSummary;
use crashrig_mc::{
    CameraId, Chain, ChainBuilder, GridBuilder, GridResult, GridStudy, PoseLinear, PoseMc,
};
use crashrig_stats::progress::Monitor;
use crashrig_tie::{self as tie, TieConfig, TieResult};
use nalgebra::Vector3;
use serde_json::Value;

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

pub use crate::contract::Sensitivity;

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
    /// The layout's answer on the report's first screen (`results.json` → `layouts[].verdict`).
    pub verdict: crate::contract::LayoutVerdict,
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
    /// The measured test sequence (`[measure]`), if the study names one.
    pub measure: Option<crate::measure_step::MeasureResult>,
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

/// The chain outward → inward → tie from the typed inputs (covariances scaled), with the id
/// of each camera.
fn build_chain(
    inputs: &[(ChainCamera, UncertainPose)],
    s: &Scales,
) -> Result<(Chain, Vec<(ChainCamera, CameraId)>), crashrig_mc::Error> {
    let mut b = ChainBuilder::new();
    let mut ids: Vec<(ChainCamera, CameraId)> = Vec::new();
    for (c, p) in inputs {
        let k = match c {
            ChainCamera::Outward => s.outward,
            ChainCamera::Inward => s.link,
            ChainCamera::Tie => s.tie,
        };
        let scaled = UncertainPose {
            b_from_a: p.b_from_a,
            covariance: p.covariance * k,
        };
        let id = match ids.last() {
            None => b.world(c.name(), scaled)?,
            Some((_, parent)) => b.link(c.name(), *parent, scaled)?,
        };
        ids.push((*c, id));
    }
    Ok((b.build(), ids))
}

fn axis(a: (f64, f64, usize)) -> crashrig_mc::Axis {
    crashrig_mc::Axis {
        start: a.0,
        stop: a.1,
        count: a.2,
    }
}

/// The world covariance (mm, rad) a fixed observer with `from = "<chain camera>"` takes: the
/// chain camera's Monte Carlo propagated world covariance (centre in world axes, rotation
/// about its own axes), with the draws and seed rule the grid library uses for an aimed
/// `observer_from` (at least [`crashrig_mc::CHAIN_SAMPLES_MIN`] draws). A fixed observer is
/// drawn independently of the other observers (a study refuses `correlated = true` with it).
/// The chain is propagated only when some fixed observer needs it.
fn fixed_from_covariances<'c>(
    chain: &'c Chain,
    ids: &'c [(ChainCamera, CameraId)],
    layout: &Layout,
    seed: u64,
) -> impl Fn(ChainCamera) -> Result<Mat6, crashrig_mc::Error> + 'c {
    let needed = layout
        .observers
        .iter()
        .any(|o| o.fixed.is_some() && matches!(o.noise, ObserverNoise::From(_)));
    let options = crashrig_mc::ChainOptions::new(crashrig_mc::CHAIN_SAMPLES_MIN, seed);
    let mc = needed.then(|| chain.monte_carlo(&options, None));
    move |cam: ChainCamera| {
        let i = ids.iter().position(|(c, _)| *c == cam).ok_or_else(|| {
            crashrig_mc::Error::UnknownCamera {
                key: "layout.observer.from".into(),
                name: cam.name().into(),
            }
        })?;
        Ok(match &mc {
            Some(Ok(m)) => m[i].covariance_tangent,
            // Its only error, and without a monitor it never happens.
            Some(Err(_)) => return Err(crashrig_stats::progress::Cancelled.into()),
            None => Mat6::zeros(),
        })
    }
}

/// Whether a layout draws its `from` observers jointly from the chain — the physical,
/// rigid-body model, where an error shared upstream (the outward camera's, the link's) moves
/// every such observer as one body — or independently of each other.
///
/// `correlated` in the study file decides when given. Without it (issue 25 §5) the physical
/// model is the default for observers fed from the same chain: jointly when the layout has at
/// least two aimed observers with `from` and every one of them stands within
/// [`crashrig_mc::CORRELATED_POSITION_TOLERANCE_MM`] of its chain camera's nominal world
/// position (`chain_positions_mm`; the chain and the grid then share one frame); otherwise
/// independently, and the report's verdict states that assumption. Fixed observers always take
/// the chain camera's propagated covariance independently and are not counted.
pub fn resolve_correlated(
    layout: &Layout,
    chain_positions_mm: &[(ChainCamera, Vector3<f64>)],
) -> bool {
    if let Some(given) = layout.correlated {
        return given;
    }
    let mut fed = 0usize;
    for o in layout.observers.iter().filter(|o| o.fixed.is_none()) {
        let ObserverNoise::From(cam) = o.noise else {
            continue;
        };
        let at_camera = chain_positions_mm.iter().any(|(c, p)| {
            *c == cam && (o.position_mm - p).norm() <= crashrig_mc::CORRELATED_POSITION_TOLERANCE_MM
        });
        if !at_camera {
            return false;
        }
        fed += 1;
    }
    fed >= 2
}

/// The layout's grid study on the chain built from the (scaled) inputs.
fn layout_study(
    inputs: &[(ChainCamera, UncertainPose)],
    layout: &Layout,
    s: &Scales,
    samples: usize,
    seed: u64,
) -> Result<GridStudy, crashrig_mc::Error> {
    let (chain, ids) = build_chain(inputs, s)?;
    let from_cov = fixed_from_covariances(&chain, &ids, layout, seed);
    let positions: Vec<(ChainCamera, Vector3<f64>)> = ids
        .iter()
        .map(|(c, id)| (*c, chain.nominal()[id.index()].position_mm))
        .collect();
    let mut g = GridBuilder::new(axis(layout.x_mm), axis(layout.y_mm), axis(layout.z_mm))
        .chain(chain.clone())
        .threshold_mm(layout.threshold_mm)
        .correlated(resolve_correlated(layout, &positions));
    if let Some((sigma_px, focal_px)) = layout.pixel {
        g = g.pixel_noise(crashrig_mc::PixelNoise { sigma_px, focal_px });
    }
    for (o, k) in layout.observers.iter().zip(&s.observers) {
        if let Some(f) = &o.fixed {
            let c = match &o.noise {
                ObserverNoise::Given(c) => c * *k,
                ObserverNoise::From(cam) => from_cov(*cam)?,
            };
            g = g.fixed_observer(o.name.clone(), o.position_mm, c, (**f).clone());
            continue;
        }
        g = match &o.noise {
            ObserverNoise::Given(c) => g.observer(o.name.clone(), o.position_mm, c * *k),
            ObserverNoise::From(cam) => {
                let id = ids
                    .iter()
                    .find(|(c, _)| c == cam)
                    .map(|(_, id)| *id)
                    .ok_or_else(|| crashrig_mc::Error::UnknownCamera {
                        key: "layout.observer.from".into(),
                        name: cam.name().into(),
                    })?;
                g.observer_from(o.name.clone(), o.position_mm, id)
            }
        };
    }
    g.build(samples, seed)
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
        accept_rig_constrained: c.accept_rig_constrained,
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
/// message names the data file), also when the Monte Carlo library refuses the chain (named
/// at `[outward]`) or a layout (at its `[[layout]]`).
pub fn run_study(study: &Study, options: &Options<'_>) -> Result<StudyResult, Error> {
    let seed = options.seed.unwrap_or(study.seed);
    let samples = options.samples.unwrap_or(study.samples);
    check_sizes(study, samples)?;
    check_measure_cameras(study)?;
    let steps = Steps::new(study, options);

    let sub = steps.within("calibration".into());
    let calibration = calibration::calibrate(
        &calibration_config(study),
        steps.on().then_some(&sub as &dyn Monitor),
    )
    .map_err(|e| study.step_error("calibration", 0, e))?;
    steps.tick("calibration");
    let tie = match &study.tie {
        Some(t) => {
            let sub = steps.within("tie replicates + jackknife".into());
            let r = tie::bootstrap(
                &tie_config(t, seed),
                steps.on().then_some(&sub as &dyn Monitor),
            )
            .map_err(|e| study.step_error("tie", 0, e))?;
            steps.tick("tie");
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
    let chain = propagate(study, &inputs, seed, &steps)?;
    let run = LayoutRun {
        study,
        inputs: &inputs,
        samples,
        seed,
        steps: &steps,
    };
    let layouts = study
        .layouts
        .iter()
        .map(|layout| run.layout_result(layout, options.no_sensitivity))
        .collect::<Result<Vec<_>, Error>>()?;
    let measure = measure_sequence(study, &calibration, tie.as_ref(), samples, seed)?;
    if measure.is_some() {
        steps.tick("measure");
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
        measure,
    })
}

/// `[measure]`'s cameras against its model, before any step runs: a wrong camera is reported
/// at its key's line before the calibration, the tie and the layouts are computed.
fn check_measure_cameras(study: &Study) -> Result<(), Error> {
    let Some(m) = &study.measure else {
        return Ok(());
    };
    let step = |e: crashrig_measure::Error| study.step_error("measure", 0, e);
    let model = crashrig_colmap::Reconstruction::read(&m.model)
        .map_err(|e| step(crashrig_measure::Error::from(e)))?;
    crashrig_measure::sequence::check_cameras(
        &model,
        &m.camera_a,
        &m.camera_b,
        m.camera_c.as_deref(),
    )
    .map_err(step)
}

/// The run's sizes within their limits: `samples` and every layout's grid (`docs/LIMITS.md`).
fn check_sizes(study: &Study, samples: usize) -> Result<(), Error> {
    let max = crashrig_mc::limits::MAX_SAMPLES;
    if !(2..=max).contains(&samples) {
        return Err(Error::Key {
            path: study.path.clone(),
            line: Some(crate::study_file::key_line_top(&study.text, "samples").unwrap_or(1)),
            key: "samples".into(),
            message: format!("must be from 2 to {max}, got {samples}"),
        });
    }
    for (i, layout) in study.layouts.iter().enumerate() {
        crate::study_file::check_layout_size(layout, samples)
            .map_err(|problem| study.step_error("layout", i, Error::LayoutSize { problem }))?;
    }
    Ok(())
}

/// The progress of a run: one step per calibration, tie, propagation, measure, layout and
/// sensitivity run, reported through [`Options::progress`].
struct Steps<'a> {
    done: std::sync::atomic::AtomicU64,
    total: u64,
    progress: Option<Progress<'a>>,
}

impl<'a> Steps<'a> {
    fn new(study: &Study, options: &Options<'a>) -> Self {
        let n_sens: usize = if options.no_sensitivity {
            0
        } else {
            study
                .layouts
                .iter()
                .map(|l| sensitivity_variants(l, &Scales::unit(l.observers.len())).len())
                .sum()
        };
        let total = (2
            + usize::from(study.tie.is_some())
            + usize::from(study.measure.is_some())
            + study.layouts.len()
            + n_sens) as u64;
        Steps {
            done: std::sync::atomic::AtomicU64::new(0),
            total,
            progress: options.progress,
        }
    }

    /// Whether anyone listens (finer progress is only computed then).
    fn on(&self) -> bool {
        self.progress.is_some()
    }

    /// One step done.
    fn tick(&self, stage: &str) {
        let d = (self.done.load(std::sync::atomic::Ordering::Relaxed) + 1).min(self.total);
        self.done.store(d, std::sync::atomic::Ordering::Relaxed);
        if let Some(p) = self.progress {
            p(stage, d, self.total);
        }
    }

    /// Finer progress inside a step: `stage d/t` as the message, the step count unchanged.
    fn within(&self, stage: String) -> impl Fn(usize, usize) + Sync + '_ {
        move |d: usize, t: usize| {
            if let Some(p) = self.progress {
                let steps = self.done.load(std::sync::atomic::Ordering::Relaxed);
                p(&format!("{stage} {d}/{t}"), steps, self.total);
            }
        }
    }
}

/// The chain of outward → inward → tie, Monte Carlo and first order: its errors name
/// `[outward]`'s line.
fn propagate(
    study: &Study,
    inputs: &[(ChainCamera, UncertainPose)],
    seed: u64,
    steps: &Steps<'_>,
) -> Result<Vec<ChainPose>, Error> {
    let mc_err = |e: crashrig_mc::Error| study.step_error("outward", 0, e);
    let (chain_mc, _) = build_chain(inputs, &Scales::unit(0)).map_err(mc_err)?;
    let sub = steps.within("propagation chunks".into());
    let mc = chain_mc
        .monte_carlo(
            &crashrig_mc::ChainOptions::new(study.chain_samples, seed),
            steps.on().then_some(&sub as &dyn Monitor),
        )
        .map_err(mc_err)?;
    let linear = chain_mc.linear();
    let chain = inputs
        .iter()
        .zip(mc.into_iter().zip(linear))
        .map(|((c, _), (mc, linear))| ChainPose {
            camera: *c,
            mc,
            linear,
        })
        .collect();
    steps.tick("propagation");
    Ok(chain)
}

/// The one-at-a-time sensitivity runs of a layout: each chain input it depends on, then each
/// observer with a given σ, with that input's covariance divided by 4 (σ halved).
fn sensitivity_variants(layout: &Layout, unit: &Scales) -> Vec<(String, Scales)> {
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
    variants
}

/// What every layout's grid runs share: the chain's inputs, draws, seed and progress.
struct LayoutRun<'r> {
    study: &'r Study,
    inputs: &'r [(ChainCamera, UncertainPose)],
    samples: usize,
    seed: u64,
    steps: &'r Steps<'r>,
}

impl LayoutRun<'_> {
    /// One layout: its grid with the inputs as given, then (unless `no_sensitivity`) its
    /// one-at-a-time sensitivity.
    fn layout_result(&self, layout: &Layout, no_sensitivity: bool) -> Result<LayoutResult, Error> {
        let unit = Scales::unit(layout.observers.len());
        let (grid, result) = self.grid(layout, &unit, format!("layout {}", layout.name))?;
        let summary = GridSummary::new(&grid, &result);
        self.steps.tick(&format!("layout {}", layout.name));
        let hot = crate::verdict::hot_spot_index(&result);
        let mut sensitivity = Vec::new();
        if !no_sensitivity {
            for (input, s) in sensitivity_variants(layout, &unit) {
                let (g, r) = self.grid(layout, &s, format!("sensitivity {}", layout.name))?;
                let sm = GridSummary::new(&g, &r);
                let worst: Vec<f64> = r
                    .points
                    .iter()
                    .map(|p| p.sigma_worst_mm())
                    .filter(|s| s.is_finite())
                    .collect();
                sensitivity.push(Sensitivity {
                    input,
                    median_sigma_max_mm: sm.median_sigma_max_mm,
                    fraction_below_threshold: sm.fraction_below_threshold,
                    median_sigma_worst_mm: crashrig_stats::summary::median(&worst),
                    hot_spot_sigma_worst_mm: hot
                        .and_then(|i| r.points.get(i))
                        .map(|p| p.sigma_worst_mm())
                        .filter(|s| s.is_finite()),
                });
                self.steps.tick(&format!("sensitivity {}", layout.name));
            }
        }
        let verdict = crate::verdict::layout_verdict(&grid, &result, &sensitivity);
        Ok(LayoutResult {
            layout: layout.clone(),
            grid,
            result,
            summary,
            sensitivity,
            verdict,
        })
    }

    /// The grid of a layout with the inputs' covariances scaled by `s`: degenerate points
    /// blanked, the observers' σ resolved.
    fn grid(
        &self,
        layout: &Layout,
        s: &Scales,
        stage: String,
    ) -> Result<(crashrig_mc::Grid, GridResult), Error> {
        let study = self.study;
        // Errors about a layout name its `[[layout]]` line.
        let at_layout = |e: crashrig_mc::Error| {
            let i = study
                .layouts
                .iter()
                .position(|l| std::ptr::eq(l, layout))
                .unwrap_or(0);
            study.step_error("layout", i, e)
        };
        let g = layout_study(self.inputs, layout, s, self.samples, self.seed).map_err(at_layout)?;
        crashrig_mc::degenerate::check_layout(g.grid()).map_err(at_layout)?;
        let sub = self.steps.within(format!("{stage}: points"));
        let mut r = g
            .run(
                &g.options(),
                self.steps.on().then_some(&sub as &dyn Monitor),
            )
            .map_err(at_layout)?;
        let mut grid = g.grid().clone();
        // Degenerate points (rays nearly parallel) are blanked (NaN): kept out of colour
        // scaling, medians and the worst region, counted as not below the threshold.
        crashrig_mc::degenerate::mask_degenerate(&mut r, &grid);
        for (o, c) in grid.observers.iter_mut().zip(&r.observer_covariance) {
            o.sigma = crashrig_mc::ObserverSigma::Covariance(*c);
        }
        Ok((grid, r))
    }
}

/// `[measure]`: the test sequence measured with the calibration's typed link (mean with its
/// SEM covariance) and the tie's (with the replicates' covariance); `samples` replicates per
/// row unless the section gives its own.
fn measure_sequence(
    study: &Study,
    calibration: &CalibrationResult,
    tie: Option<&TieResult>,
    samples: usize,
    seed: u64,
) -> Result<Option<crate::measure_step::MeasureResult>, Error> {
    study
        .measure
        .as_ref()
        .map(|m| {
            let samples = m.samples.unwrap_or(samples);
            let tie = tie.map(|t| t.link);
            crate::measure_step::run_measure(study, m, calibration.link, tie, samples, seed)
        })
        .transpose()
}

fn deg3(v: Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

impl StudyResult {
    /// The warnings on units and plausibility (docs/LIMITS.md, "Plausibility warnings"), each
    /// naming the file, the key's line, the key and its unit: the study file's own
    /// ([`Study::warnings`]), observers near but not at their chain camera
    /// ([`crate::study_file::units::chain_warnings`]) and the calibration's rig baseline
    /// (located at `scale_length_mm` or `mm_per_unit`). The run's warnings and the report's
    /// verdicts repeat them.
    pub fn unit_warnings(&self, study: &Study) -> Vec<String> {
        let mut out = study.warnings.clone();
        let chain: Vec<(ChainCamera, Vector3<f64>)> = self
            .chain
            .iter()
            .map(|c| (c.camera, c.mc.nominal.position_mm))
            .collect();
        out.extend(crate::study_file::units::chain_warnings(study, &chain));
        if let Some(w) = self
            .calibration
            .baseline_warning("calibration.scale_length_mm", "calibration.mm_per_unit")
        {
            let key = match study.calibration.scale {
                crate::study_file::StudyScale::ScaleBar { .. } => "scale_length_mm",
                crate::study_file::StudyScale::MmPerUnit(_) => "mm_per_unit",
            };
            let line = crate::study_file::key_line(&study.text, "calibration", 0, key)
                .or_else(|| study.section_line("calibration", 0))
                .unwrap_or(1);
            out.push(format!(
                "{}:{line}: [calibration]: {w}",
                study.path.display()
            ));
        }
        out
    }

    /// `results.json`: `calibration` and `tie` exactly as `calibrate --json` and
    /// `bootstrap --json` print them, then the propagation and each layout's summary. No
    /// timing, so the same study and seed give the same bytes.
    pub fn document(&self) -> StudyDocument {
        StudyDocument {
            calibration: self.calibration.document(),
            calibration_quality: quality_document(&self.calibration),
            layouts: self.layouts.iter().map(layout_document).collect(),
            measure: self.measure.as_ref().map(measure_document),
            propagation: PropagationDocument {
                cameras: self.chain.iter().map(chain_camera_document).collect(),
                rotation_noise: "tangent",
                samples: self.chain_samples,
                seed: self.seed,
            },
            samples: self.samples,
            seed: self.seed,
            tie: self.tie.as_ref().map(TieResult::to_json),
        }
    }

    /// [`Self::document`] as a JSON value (object keys sorted): `results.json`.
    pub fn to_json(&self) -> Value {
        // Serialising plain numbers, strings and arrays cannot fail; non-finite numbers
        // become null.
        serde_json::to_value(self.document()).unwrap_or(Value::Null)
    }
}

/// `calibration_quality` of `results.json`: the split-half check and the reprojection residuals
/// the report's calibration verdict and section show.
fn quality_document(c: &CalibrationResult) -> crate::contract::CalibrationQualityDocument {
    use crate::contract::{ReprojectionDocument, SplitHalfDocument};
    let deg = |i: usize| if i < 3 { 1.0 } else { 1f64.to_degrees() };
    crate::contract::CalibrationQualityDocument {
        reprojection: c
            .reprojection
            .iter()
            .map(|r| ReprojectionDocument {
                images: r.images,
                max_px: r.max_px,
                median_px: r.median_px,
                observations: r.residuals_px.len(),
                role: r.role.to_string(),
                selector: r.selector.clone(),
                sigma_px: r.sigma_px,
            })
            .collect(),
        split_half: c.split_half.as_ref().map(|s| SplitHalfDocument {
            agree: s.agree,
            bound_z: calibration::SPLIT_HALF_Z,
            difference: std::array::from_fn(|i| s.difference[i] * deg(i)),
            max_z: s.z.iter().copied().fold(0.0, f64::max),
            n_first: s.n_first,
            n_second: s.n_second,
            order: ["x", "y", "z", "θx", "θy", "θz"],
            sigma: std::array::from_fn(|i| s.sigma[i] * deg(i)),
            z: s.z,
        }),
    }
}

fn chain_camera_document(c: &ChainPose) -> ChainCameraDocument {
    let m = &c.mc;
    ChainCameraDocument {
        angles_deg: deg3(m.nominal.angles_rad()),
        angles_sigma_deg: deg3(m.angles_sigma_rad),
        angles_singular: m.angles_singular,
        covariance_tangent: crate::contract::covariance_deg_rows(&m.covariance_tangent),
        linear: LinearDocument {
            angles_sigma_deg: c.linear.angles_sigma_rad.map(deg3),
            covariance_tangent: crate::contract::covariance_deg_rows(&c.linear.covariance_tangent),
            position_sigma_mm: c.linear.position_sigma_mm.into(),
            tangent_sigma_deg: deg3(c.linear.tangent_sigma_rad),
        },
        name: c.camera.name(),
        position_mm: m.nominal.position_mm.into(),
        position_sigma_mm: m.position_sigma_mm.into(),
        tangent_sigma_deg: deg3(m.tangent_sigma_rad),
    }
}

fn layout_document(l: &LayoutResult) -> LayoutDocument {
    let observers = l
        .grid
        .observers
        .iter()
        .zip(&l.layout.observers)
        .zip(&l.result.observer_covariance)
        .map(|((o, lo), c)| {
            let s = sigmas(c);
            ObserverDocument {
                covariance_tangent: crate::contract::covariance_deg_rows(c),
                from: match lo.noise {
                    ObserverNoise::From(c) => Some(c.name()),
                    ObserverNoise::Given(_) => None,
                },
                name: o.name.clone(),
                position_mm: o.position_mm.into(),
                sigma_angles_deg: deg3(s.angles_rad),
                sigma_position_mm: s.position_mm.into(),
            }
        })
        .collect();
    LayoutDocument {
        correlated: l.result.correlated,
        description: l.layout.description.clone(),
        dir: format!("grid/{}", l.layout.slug()),
        name: l.layout.name.clone(),
        observers,
        sensitivity: l.sensitivity.clone(),
        summary: l.summary.clone(),
        verdict: l.verdict.clone(),
    }
}

/// `measure` of `results.json`: the per-epoch and joint matrices of A's bundle covariance are in
/// `measure/a_covariance.json` (what `crashrig covariance --out` writes); here its numbers and σ
/// per epoch.
fn measure_document(m: &crate::measure_step::MeasureResult) -> MeasureDocument {
    let a_covariance = m.a_covariance.as_ref().map(|a| {
        let d = a.document();
        ACovarianceSummary {
            control_points: d.control_points,
            epoch_sigmas: d.epoch_sigmas,
            file: "measure/a_covariance.json",
            frames: d.frames,
            intrinsics: d.intrinsics,
            mm_per_unit: d.mm_per_unit,
            observations: d.observations,
            parameters: d.parameters,
            pixel_sigma_px: d.pixel_sigma_px,
            points_left_out: d.points_left_out,
            redundancy: d.redundancy,
            sigma0_px: d.sigma0_px,
        }
    });
    MeasureDocument {
        a_covariance,
        dir: "measure",
        summary: m.summary.clone(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// A layout whose grid row y = 0 lies on the line through both observers: those 8 points
    /// are degenerate, blank, counted as not below the threshold and left out of the medians.
    #[test]
    fn degenerate_points_are_blank_and_kept_out_of_the_summary() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let cut = text.find("[[layout]]").unwrap();
        let layout = r#"
[[layout]]
name = "on_a_line"
x_mm = [400.0, 1800.0, 8]
y_mm = [-500.0, 500.0, 3]
z_mm = [0.0, 0.0, 1]
[[layout.observer]]
position_mm = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[layout.observer]]
position_mm = [2200.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;
        let study = Study::from_toml_str(&format!("{}{layout}", &text[..cut]), &path).unwrap();
        let options = Options {
            samples: Some(40),
            no_sensitivity: true,
            ..Options::default()
        };
        let r = run_study(&study, &options).unwrap();
        let l = &r.layouts[0];
        assert_eq!(l.summary.degenerate_points, 8);
        let finite: Vec<f64> = l
            .result
            .points
            .iter()
            .filter(|p| p.point.y != 0.0)
            .map(|p| p.sigma_max_mm)
            .collect();
        assert!(
            l.result
                .points
                .iter()
                .filter(|p| p.point.y == 0.0)
                .all(|p| p.sigma_max_mm.is_nan())
        );
        assert!(finite.iter().all(|s| s.is_finite()));
        assert_eq!(
            l.summary.median_sigma_max_mm,
            crashrig_stats::summary::median(&finite).unwrap_or(f64::NAN)
        );
        let below = finite
            .iter()
            .filter(|s| **s < l.summary.threshold_mm)
            .count();
        assert_eq!(l.summary.fraction_below_threshold, below as f64 / 24.0);
        assert!(crashrig_grid::summary::grid_csv(&l.result).contains("\n400,0,0,,,,\n"));
    }

    fn observer(noise: ObserverNoise, position_mm: [f64; 3]) -> crate::study_file::Observer {
        crate::study_file::Observer {
            name: "o".into(),
            position_mm: Vector3::from(position_mm),
            noise,
            fixed: None,
        }
    }

    #[test]
    fn resolve_correlated_defaults_to_the_physical_model_at_the_chain_cameras() {
        use ChainCamera::{Inward, Outward, Tie};
        let chain = [
            (Outward, Vector3::new(0.0, 0.0, 0.0)),
            (Inward, Vector3::new(100.0, 0.0, 0.0)),
            (Tie, Vector3::new(900.0, 500.0, 0.0)),
        ];
        let given = || ObserverNoise::Given(Mat6::identity());
        let layout = |correlated, observers| Layout {
            name: "l".into(),
            description: String::new(),
            x_mm: (0.0, 1.0, 2),
            y_mm: (0.0, 1.0, 2),
            z_mm: (0.0, 0.0, 1),
            threshold_mm: 5.0,
            pixel: None,
            correlated,
            observers,
        };
        let at_cameras = || {
            vec![
                observer(ObserverNoise::From(Inward), [100.0, 0.0, 0.9]),
                observer(ObserverNoise::From(Tie), [900.0, 500.0, 0.0]),
                observer(given(), [0.0, 900.0, 0.0]),
            ]
        };
        // Default: two aimed `from` observers, each within 1 mm of its camera: joint draws.
        assert!(resolve_correlated(&layout(None, at_cameras()), &chain));
        // The explicit key wins both ways.
        assert!(!resolve_correlated(
            &layout(Some(false), at_cameras()),
            &chain
        ));
        assert!(resolve_correlated(&layout(Some(true), vec![]), &chain));
        // One observer 1.1 mm away from its camera: the chain and the grid are not one frame.
        let mut off = at_cameras();
        off[0].position_mm.z = 1.1;
        assert!(!resolve_correlated(&layout(None, off), &chain));
        // Only one chain-fed observer: nothing is shared, independent.
        let mut one = at_cameras();
        one[1].noise = given();
        assert!(!resolve_correlated(&layout(None, one), &chain));
        // A fixed `from` observer is drawn independently and does not count (nor veto).
        let mut fixed = at_cameras();
        fixed[1].fixed = Some(Box::new(crashrig_mc::FixedCamera {
            rotation: nalgebra::Matrix3::identity(),
            angles_rad: Vector3::zeros(),
            lens: crashrig_camera::Camera::new(
                crashrig_camera::ModelId::Pinhole,
                100,
                50,
                vec![100.0, 100.0, 50.0, 25.0],
            )
            .unwrap(),
            pixel_sigma_px: 0.0,
        }));
        assert!(!resolve_correlated(&layout(None, fixed.clone()), &chain));
        fixed.push(observer(ObserverNoise::From(Outward), [0.0, 0.0, 0.0]));
        assert!(resolve_correlated(&layout(None, fixed.clone()), &chain));
        fixed[1].position_mm.x = 5000.0;
        assert!(resolve_correlated(&layout(None, fixed), &chain));
    }

    /// On the own project: a layout whose observers stand at the inward and tie cameras'
    /// nominal world positions runs the joint (rigid-body) model without any key — the same
    /// bits as `correlated = true` —, `correlated = false` opts out, and observers 2 mm away
    /// from their camera stay independent.
    #[test]
    fn chain_fed_layout_defaults_to_joint_draws_and_false_opts_out() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let head = &text[..text.find("[[layout]]").unwrap()];
        let options = Options {
            samples: Some(40),
            no_sensitivity: true,
            ..Options::default()
        };
        let given = "sigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]";
        let probe = format!(
            "{head}[[layout]]\nname = \"probe\"\nx_mm = [400.0, 500.0, 2]\ny_mm = [-500.0, 500.0, 2]\nz_mm = [0.0, 0.0, 1]\n[[layout.observer]]\nposition_mm = [0.0, 100.0, 0.0]\n{given}\n[[layout.observer]]\nposition_mm = [0.0, -100.0, 0.0]\n{given}\n"
        );
        let r = run_study(&Study::from_toml_str(&probe, &path).unwrap(), &options).unwrap();
        let at = |c: ChainCamera| {
            r.chain
                .iter()
                .find(|p| p.camera == c)
                .unwrap()
                .mc
                .nominal
                .position_mm
        };
        let (b, c) = (at(ChainCamera::Inward), at(ChainCamera::Tie));
        // A 2 × 2 grid 1 m to the side of the B–C baseline (rays well apart).
        let d = Vector3::new(c.x - b.x, c.y - b.y, 0.0).normalize();
        let centre = (b + c) / 2.0 + Vector3::new(-d.y, d.x, 0.0) * 1000.0;
        let v = |p: Vector3<f64>| format!("[{}, {}, {}]", p.x, p.y, p.z);
        let layout = |name: &str, key: &str, shift: f64| {
            format!(
                "[[layout]]\nname = \"{name}\"\n{key}\nx_mm = [{}, {}, 2]\ny_mm = [{}, {}, 2]\nz_mm = [{z}, {z}, 1]\n[[layout.observer]]\nposition_mm = {}\nfrom = \"inward\"\n[[layout.observer]]\nposition_mm = {}\nfrom = \"tie\"\n",
                centre.x - 100.0,
                centre.x + 100.0,
                centre.y - 100.0,
                centre.y + 100.0,
                v(b + Vector3::new(0.0, 0.0, shift)),
                v(c),
                z = centre.z,
            )
        };
        let text = format!(
            "{head}{}{}{}{}",
            layout("default", "", 0.0),
            layout("joint", "correlated = true", 0.0),
            layout("independent", "correlated = false", 0.0),
            layout("off_by_2mm", "", 2.0),
        );
        let r = run_study(&Study::from_toml_str(&text, &path).unwrap(), &options).unwrap();
        let model: Vec<bool> = r.layouts.iter().map(|l| l.result.correlated).collect();
        assert_eq!(model, [true, true, false, false]);
        let sigmas = |i: usize| -> Vec<u64> {
            r.layouts[i]
                .result
                .points
                .iter()
                .map(|p| p.sigma_max_mm.to_bits())
                .collect()
        };
        assert_eq!(sigmas(0), sigmas(1), "the default is the joint model");
        assert_ne!(
            sigmas(0),
            sigmas(2),
            "correlated = false draws independently"
        );
        // The verdict states the independence assumption, and why, for exactly those two.
        let note = crate::report::independent_chain_observers_note(&r).unwrap();
        assert!(
            note.starts_with(
                "Assumption of independent (`correlated = false`), off_by_2mm (observers not at their chain cameras):"
            ),
            "{note}"
        );
    }
}
