//! The forward-intersection study over a grid: per point, observers aim at it, are perturbed
//! and intersected; streaming statistics, linear propagation and adaptive stopping.

use crate::block::{Aimed, Ctx};
use crate::chain::{Chain, WorldPose};
use crate::error::Error;
use crate::fixed::LinearTerm;
use crate::kernel::Isa;
#[cfg(test)]
use crate::kernel::Normal3;
use crate::kernel::accumulate::Acc3;
use crate::kernel::lanes::NoiseFactor;
#[cfg(test)]
use crate::kernel::{exp_matrix, rot_opk};
use crate::map::{MapPath, MapRun, Planned};
use crate::model::{Grid, ObserverSigma, PoseSigma, RotationNoise, Scenario};
use crate::options::{ChainOptions, Draws, RunOptions};
use crate::result::{GridResult, PointStats};
use crate::schedule::{CHUNK, Engine, PointTicks};
use crashrig_geometry::uncertain::psd_factor;
use crashrig_stats::progress::Monitor;
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3, Vector6};

/// The resolved noise of one observer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ObserverNoise {
    /// Covariance (mm, rad), rotation block in `noise`'s meaning.
    covariance: Matrix6<f64>,
    noise: RotationNoise,
}

impl ObserverNoise {
    fn sigma(&self) -> PoseSigma {
        let d = |i: usize| self.covariance[(i, i)].max(0.0).sqrt();
        PoseSigma {
            position_mm: Vector3::new(d(0), d(1), d(2)),
            angles_rad: Vector3::new(d(3), d(4), d(5)),
        }
    }
}
/// Prepared grid study: observers resolved, ready to run.
#[derive(Debug, Clone)]
pub struct GridStudy {
    grid: Grid,
    ctx: Ctx,
    observer_noise: Vec<ObserverNoise>,
    correlated: bool,
    /// Nominal world poses of the chain (for correlated observers).
    chain_nominal: Vec<WorldPose>,
    samples: usize,
    seed: u64,
    /// Only these grid points are run (a shard of the grid); `None`: all.
    selection: Option<std::ops::Range<usize>>,
}

fn aim(
    grid: &Grid,
    noises: &[ObserverNoise],
    correlated: bool,
    chain_nominal: &[WorldPose],
    point: &Vector3<f64>,
) -> Result<Vec<Aimed>, Error> {
    grid.observers
        .iter()
        .zip(noises)
        .map(|(o, s)| {
            let source = match (correlated, o.sigma) {
                (true, ObserverSigma::From(i)) => Some(i),
                _ => None,
            };
            // A correlated observer stands at its chain camera's nominal centre (validated to
            // within 1 mm of its `position_mm`).
            let c = source.map_or(o.position_mm, |i| chain_nominal[i].position_mm);
            let r = crashrig_geometry::look_at::world_from_cam_look_at(&c, point)?;
            let a = crashrig_geometry::opk::opk_from_rotation(&r);
            let r = r.into_inner();
            let chain_to_own = source.map_or(Matrix3::identity(), |i| {
                r.transpose() * chain_nominal[i].rotation
            });
            // The covariance in the observer's own frame: the chain camera's body-axis
            // rotation error θ acts as `chain_to_own·θ` on a correlated observer.
            let mut t = Matrix6::identity();
            t.fixed_view_mut::<3, 3>(3, 3).copy_from(&chain_to_own);
            let covariance = t * s.covariance * t.transpose();
            let sigma = s.sigma();
            let diagonal = (0..6).all(|i| (0..6).all(|j| i == j || s.covariance[(i, j)] == 0.0));
            Ok(Aimed {
                c,
                r,
                opk: Vector3::new(a.omega, a.phi, a.kappa),
                #[cfg(test)]
                sp: sigma.position_mm,
                #[cfg(test)]
                sr: sigma.angles_rad,
                // A chain draw is always a tangent (body-axis) rotation error.
                kind: if source.is_some() {
                    RotationNoise::Tangent
                } else {
                    s.noise
                },
                noise: if diagonal {
                    NoiseFactor::from_sigma(&sigma.position_mm, &sigma.angles_rad)
                } else {
                    NoiseFactor::from_lower(&psd_factor(&s.covariance))
                },
                covariance,
                source,
                chain_to_own,
            })
        })
        .collect()
}

impl GridStudy {
    /// Prepares the study of `scenario`'s grid. `sigma_from` observers get the σ of the chain's
    /// Monte Carlo propagation (max(`samples`, [`CHAIN_SAMPLES_MIN`]) draws, a seed derived
    /// from `seed`), tangent σ for `tangent` noise
    /// and ω φ κ σ for `euler` noise.
    pub fn new(scenario: &Scenario, samples: usize, seed: u64) -> Result<Self, Error> {
        let grid = scenario.grid.clone().ok_or(Error::NoGrid)?;
        crate::degenerate::check_layout(&grid)?;
        let chain = Chain::new(scenario);
        Self::assemble(grid, chain, scenario.rotation_noise, samples, seed)
    }

    pub(crate) fn assemble(
        grid: Grid,
        chain: Chain,
        rotation_noise: RotationNoise,
        samples: usize,
        seed: u64,
    ) -> Result<Self, Error> {
        let needs_chain = grid
            .observers
            .iter()
            .any(|o| matches!(o.sigma, ObserverSigma::From(_)));
        let mc = if needs_chain {
            let options = ChainOptions::new(samples.max(CHAIN_SAMPLES_MIN), seed ^ CHAIN_SEED_SALT);
            match rotation_noise {
                // Only the tangent covariances are used (no ω φ κ statistics to compute).
                RotationNoise::Tangent => chain.monte_carlo_tangent(&options)?,
                RotationNoise::Euler => chain.monte_carlo(&options, None)?,
            }
        } else {
            Vec::new()
        };
        let observer_noise: Vec<ObserverNoise> = grid
            .observers
            .iter()
            .map(|o| match o.sigma {
                ObserverSigma::Given(s) => {
                    let d = Vector6::new(
                        s.position_mm.x,
                        s.position_mm.y,
                        s.position_mm.z,
                        s.angles_rad.x,
                        s.angles_rad.y,
                        s.angles_rad.z,
                    );
                    ObserverNoise {
                        covariance: Matrix6::from_diagonal(&d.component_mul(&d)),
                        noise: rotation_noise,
                    }
                }
                ObserverSigma::Covariance(m) => ObserverNoise {
                    covariance: m,
                    noise: RotationNoise::Tangent,
                },
                // The chain camera's full propagated world covariance: tangent (centre in
                // world axes, rotation about its own axes) for tangent noise, of (centre,
                // ω φ κ) for Euler noise — except where the camera's ω φ κ are at gimbal lock
                // and have no covariance: the tangent one then, with tangent noise.
                ObserverSigma::From(i) => match rotation_noise {
                    RotationNoise::Euler if mc[i].angles_singular => ObserverNoise {
                        covariance: mc[i].covariance_tangent,
                        noise: RotationNoise::Tangent,
                    },
                    RotationNoise::Tangent => ObserverNoise {
                        covariance: mc[i].covariance_tangent,
                        noise: RotationNoise::Tangent,
                    },
                    RotationNoise::Euler => ObserverNoise {
                        covariance: mc[i].covariance,
                        noise: RotationNoise::Euler,
                    },
                },
            })
            .collect();
        let correlated = grid.correlated && needs_chain;
        let chain_nominal = chain.nominal().to_vec();
        // Normals per draw must fit the Philox slots of a draw (4 normals per slot).
        let normals = 8 * grid.observers.len() + if correlated { 6 * chain.len() } else { 0 };
        if normals > 4 * crate::kernel::philox::MAX_SLOTS {
            return Err(Error::Invalid {
                key: "grid.observer".to_string(),
                problem: "too many observers and cameras for the Monte Carlo engine (at most 2¹⁸ normals per draw)",
            });
        }
        let study = GridStudy {
            ctx: Ctx {
                pixel: grid.pixel.map(|p| p.sigma_normalized()),
                chain_jacobians: if correlated {
                    chain.jacobians()
                } else {
                    Vec::new()
                },
                chain: correlated.then_some(chain),
            },
            grid,
            observer_noise,
            correlated,
            chain_nominal,
            samples,
            seed,
            selection: None,
        };
        Ok(study)
    }

    /// The settings this study was built with: its grid's adaptive rule when it has one, else
    /// its samples per point; its seed; the CPU's best instruction-set level. What
    /// `study.run(&study.options(), None)` runs.
    pub fn options(&self) -> RunOptions {
        let draws = match self.grid.adaptive {
            Some(a) => Draws::Adaptive(a),
            None => Draws::Samples(self.samples),
        };
        RunOptions {
            draws,
            seed: self.seed,
            isa: Isa::Auto,
        }
    }

    /// Draws per point this study was built with.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Seed this study was built with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Every observer aimed at each of `points` (tests).
    #[cfg(test)]
    pub(crate) fn aim_all(&self, points: &[Vector3<f64>]) -> Result<Vec<Vec<Aimed>>, Error> {
        points
            .iter()
            .map(|p| {
                aim(
                    &self.grid,
                    &self.observer_noise,
                    self.correlated,
                    &self.chain_nominal,
                    p,
                )
            })
            .collect()
    }

    fn result(&self, points: Vec<PointStats>) -> GridResult {
        GridResult {
            points,
            observer_sigma: self.observer_noise.iter().map(|n| n.sigma()).collect(),
            observer_covariance: self.observer_noise.iter().map(|n| n.covariance).collect(),
            correlated: self.correlated,
        }
    }

    /// The same study with correlation switched off (observers drawn independently with
    /// their propagated σ), to measure how much the correlation changes the map.
    pub fn independent(&self) -> Self {
        let mut s = self.clone();
        s.correlated = false;
        s.ctx.chain = None;
        s.ctx.chain_jacobians = Vec::new();
        s
    }

    /// The chain its observers are drawn from jointly (correlated mode).
    pub(crate) fn chain(&self) -> Option<&Chain> {
        self.ctx.chain.as_ref()
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The same study restricted to the grid points `points` (indices into
    /// [`Grid::points`]): every run then computes only those points and its
    /// [`GridResult::points`] holds them in order. A point's draws come from its own streams
    /// (task `p·2²⁴ + k` of its global index `p`), so its statistics are bit-identical to the
    /// same point's in a run of the whole grid — the basis of `--shard i/N`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when `points` reaches past the grid.
    pub fn with_points(&self, points: std::ops::Range<usize>) -> Result<Self, Error> {
        if points.start > points.end || points.end > self.grid.points().len() {
            return Err(Error::Invalid {
                key: "grid".to_string(),
                problem: "the selected points reach past the grid",
            });
        }
        let mut s = self.clone();
        s.selection = Some(points);
        Ok(s)
    }

    /// The selected points (all by default) and the global index of the first.
    fn selected_points(&self) -> (usize, Vec<Vector3<f64>>) {
        let mut all = self.grid.points();
        match &self.selection {
            Some(r) => (r.start, all.drain(r.clone()).collect()),
            None => (0, all),
        }
    }

    /// Runs the study: `options.draws` per point ([`Draws::Samples`], or the adaptive rule of
    /// [`Draws::Adaptive`]) under `options.seed`, compiled for `options.isa`.
    ///
    /// Work is split into (point, chunk of [`CHUNK`](crate::CHUNK) draws) tasks; task (p, k)
    /// draws from the Philox stream of `(seed, p·2²⁴ + k)` and chunks are merged in index
    /// order, so the result is bit-identical for any number of threads and any instruction-set
    /// level. The adaptive rule (GUM-S1 §7.9) runs per point batches of `adaptive.batch` draws
    /// (batch b of point p is task `p·2²⁴ + b`) until the mean coordinate and the σ of every
    /// axis are stable (`2·s/√h ≤ δ`, see [`crate::Adaptive`]; at least
    /// [`ADAPTIVE_MIN_BATCHES`](crate::ADAPTIVE_MIN_BATCHES) batches) or `max_samples` is
    /// reached; the reported mean and σ are those of all draws.
    ///
    /// `monitor` (optional) gets `(points done, points)` (a point counts when its last chunk or
    /// batch is done) and is asked before each chunk (adaptive: each point) whether the call
    /// was cancelled; the result is the same with and without it.
    ///
    /// # Errors
    /// An aimed observer that cannot aim at a point ([`Error::VerticalAim`], …);
    /// [`Error::Cancelled`] when `monitor` cancelled the run.
    pub fn run(
        &self,
        options: &RunOptions,
        monitor: Option<&dyn Monitor>,
    ) -> Result<GridResult, Error> {
        let engine = Engine::Simd(options.isa);
        self.run_draws(&options.draws, options.seed, engine, monitor)
    }

    /// The draws of `draws` on the selected points with `engine` (see [`GridStudy::run`]): a
    /// fixed number per point, or the adaptive rule per point.
    pub(crate) fn run_draws(
        &self,
        draws: &Draws,
        seed: u64,
        engine: Engine,
        monitor: Option<&dyn Monitor>,
    ) -> Result<GridResult, Error> {
        let (first, points) = self.selected_points();
        let ticks_per_point = match draws {
            Draws::Samples(samples) => samples.div_ceil(CHUNK),
            Draws::Adaptive(_) => 1,
        };
        let ticks = PointTicks::new(monitor, points.len(), ticks_per_point);
        let run = MapRun {
            chain: self.ctx.chain.as_ref(),
            seed,
            engine,
            ticks: &ticks,
            first,
        };
        let stats = if self.has_fixed() {
            let (covariance, kinds) = self.resolved();
            let setup = self.setup(&covariance, &kinds, self.ctx.chain.as_ref());
            let path = crate::fixed::FixedPath::new(&setup, &points);
            crate::map::run_draws(&path, &run, &points, draws)
        } else {
            crate::map::run_draws(&AimedPath::new(self, &points), &run, &points, draws)
        };
        ticks.cancelled()?;
        let stats = stats?;
        ticks.finish();
        Ok(self.result(stats))
    }

    /// Whether any observer is fixed (`aim = "fixed"`): then `fixed.rs` prepares the points.
    pub(crate) fn has_fixed(&self) -> bool {
        self.grid
            .observers
            .iter()
            .any(|o| o.aim != crate::model::Aim::Point)
    }

    /// Each observer's resolved covariance and its rotation-noise meaning.
    pub(crate) fn resolved(&self) -> (Vec<Matrix6<f64>>, Vec<RotationNoise>) {
        (
            self.observer_noise.iter().map(|n| n.covariance).collect(),
            self.observer_noise.iter().map(|n| n.noise).collect(),
        )
    }

    /// What the fixed path needs of this study.
    pub(crate) fn setup<'s>(
        &'s self,
        covariance: &'s [Matrix6<f64>],
        kinds: &'s [RotationNoise],
        chain: Option<&'s Chain>,
    ) -> crate::fixed::Setup<'s> {
        crate::fixed::Setup {
            grid: &self.grid,
            covariance,
            kinds,
            pixel: self.grid.pixel,
            chain,
        }
    }

    /// Each observer's additive share of the first-order covariance at `point` (`None` where
    /// a fixed observer does not see it), every observer independent with its resolved noise
    /// (the `sigma_from` covariance even in correlated mode): the first-order covariance of a
    /// sub-layout is [`LinearTerm::covariance`] of the sum of its observers' terms, which
    /// `crashrig place` searches on.
    ///
    /// # Errors
    /// An aimed observer that cannot aim at `point` (straight above or below it).
    pub fn linear_terms(&self, point: &Vector3<f64>) -> Result<Vec<Option<LinearTerm>>, Error> {
        let (covariance, kinds) = self.resolved();
        crate::fixed::linear_terms(&self.setup(&covariance, &kinds, None), point)
    }

    fn finish(&self, point: &Vector3<f64>, aimed: &[Aimed], m: &Acc3) -> PointStats {
        let sigma = m.std_dev();
        PointStats {
            point: *point,
            count: m.count(),
            mean_mm: m.mean(),
            covariance: m.covariance(),
            sigma_mm: sigma,
            sigma_max_mm: sigma.max(),
            linear_covariance: linear_covariance(aimed, &self.ctx, point),
            observers_seen: aimed.len(),
            converged: None,
        }
    }
}

/// Smallest number of chain draws used to resolve `sigma_from` (σ to ≈ 0.2 %).
pub const CHAIN_SAMPLES_MIN: usize = 100_000;

/// Salt of the seed of the chain propagation that resolves `sigma_from`.
const CHAIN_SEED_SALT: u64 = 0x5EED_C4A1_0000_0001;

/// The aimed path of a map (no fixed observer): each point's observers aimed at it.
pub(crate) struct AimedPath<'s> {
    study: &'s GridStudy,
    points: &'s [Vector3<f64>],
}

impl<'s> AimedPath<'s> {
    pub(crate) fn new(study: &'s GridStudy, points: &'s [Vector3<f64>]) -> Self {
        AimedPath { study, points }
    }
}

impl<'s> MapPath<'s> for AimedPath<'s> {
    type Extra = Vec<Aimed>;

    fn plan(&self, p: usize) -> Result<Planned<'s, Vec<Aimed>>, Error> {
        let s = self.study;
        let aimed = aim(
            &s.grid,
            &s.observer_noise,
            s.correlated,
            &s.chain_nominal,
            &self.points[p],
        )?;
        Ok(Planned {
            kernel: crate::block::prepare(&aimed, &s.ctx),
            extra: aimed,
        })
    }

    fn finish(
        &self,
        p: usize,
        planned: &Planned<'s, Vec<Aimed>>,
        draws: Option<&Acc3>,
    ) -> PointStats {
        let point = &self.points[p];
        match draws {
            Some(m) => self.study.finish(point, &planned.extra, m),
            None => crate::fixed::not_measurable(point, planned.extra.len()),
        }
    }

    #[cfg(test)]
    fn legacy(&self, extra: &Vec<Aimed>, seed: u64, task: u64, m: usize, acc: &mut Acc3) {
        let mut rng = crashrig_stats::stream(seed, task);
        legacy::run_chunk(extra, &self.study.ctx, &mut rng, m, acc);
    }
}

/// `m` draws of one grid point (task `task` of the run seeded `seed`, replicates `0 .. m`)
/// into `acc` (tests: the kernel of one point).
#[cfg(test)]
pub(crate) fn run_chunk(
    obs: &[Aimed],
    ctx: &Ctx,
    seed: u64,
    task: u64,
    m: usize,
    acc: &mut Acc3,
    engine: Engine,
) {
    let ticks = PointTicks::new(None, 1, 1);
    let run = MapRun {
        chain: ctx.chain.as_ref(),
        seed,
        engine,
        ticks: &ticks,
        first: 0,
    };
    if engine == Engine::Legacy {
        let mut rng = crashrig_stats::stream(seed, task);
        legacy::run_chunk(obs, ctx, &mut rng, m, acc);
        return;
    }
    let kernel = crate::block::prepare(obs, ctx);
    let part = crate::map::draw_points(&run, &[(&kernel, task)], &[acc.shift()], 0, m).remove(0);
    acc.merge(&part);
}

/// Inputs per observer of the intersection Jacobian behind the first-order map: δC (3, mm),
/// rotation (3, rad, in the scenario's noise meaning), pixel (2, normalized).
pub const INPUTS_PER_OBSERVER: usize = 8;

/// The intersected point for explicit perturbations (8 per observer, see
/// [`INPUTS_PER_OBSERVER`]): the same model as the Monte Carlo kernel.
#[cfg(test)]
pub(crate) fn intersect_perturbed(obs: &[Aimed], delta: &[f64]) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, o) in obs.iter().enumerate() {
        let d = &delta[INPUTS_PER_OBSERVER * j..INPUTS_PER_OBSERVER * (j + 1)];
        let c = o.c + Vector3::new(d[0], d[1], d[2]);
        let w = Vector3::new(d[3], d[4], d[5]);
        let r = match o.kind {
            RotationNoise::Tangent => o.r * exp_matrix(&w),
            RotationNoise::Euler => rot_opk(&(o.opk + w)),
        };
        n.add_view(&r, &c, d[6], d[7]);
    }
    n.solve()
}

/// `dX/d(inputs)` (3 × 8·n) of the intersection at the nominal configuration.
///
/// With `A = Σ(I − dⱼdⱼᵀ)`, `ρⱼ` the distance and `dⱼ` the unit ray of observer j:
/// `dX = A⁻¹ Σⱼ [(I − dⱼdⱼᵀ) δCⱼ + ρⱼ δdⱼ]`, where `δdⱼ = Rⱼ(δ × e₃)` (tangent) or
/// `Σ ∂(R e₃)/∂aₖ δaₖ` (euler), plus `ρⱼ(c₁ δx + c₂ δy)` for the pixel inputs.
pub(crate) fn intersection_jacobian(obs: &[Aimed], point: &Vector3<f64>) -> DMatrix<f64> {
    let mut a = Matrix3::zeros();
    for o in obs {
        let d = o.r.column(2).into_owned();
        a += Matrix3::identity() - d * d.transpose();
    }
    let ai = a.try_inverse().unwrap_or(Matrix3::from_element(f64::NAN));
    let mut j = DMatrix::zeros(3, INPUTS_PER_OBSERVER * obs.len());
    for (k, o) in obs.iter().enumerate() {
        let d = o.r.column(2).into_owned();
        let rho = (point - o.c).norm();
        let p = Matrix3::identity() - d * d.transpose();
        let g = match o.kind {
            // δ × e₃ = (δy, −δx, 0) = −[e₃]× δ
            RotationNoise::Tangent => o.r * (-Vector3::z().cross_matrix()),
            RotationNoise::Euler => {
                let (so, co) = o.opk.x.sin_cos();
                let (sp, cp) = o.opk.y.sin_cos();
                Matrix3::new(
                    0.0,
                    cp,
                    0.0,
                    -co * cp,
                    so * sp,
                    0.0,
                    -so * cp,
                    -co * sp,
                    0.0,
                )
            }
        };
        let pix = Matrix3::from_columns(&[
            o.r.column(0).into_owned(),
            o.r.column(1).into_owned(),
            Vector3::zeros(),
        ]);
        let base = INPUTS_PER_OBSERVER * k;
        j.view_mut((0, base), (3, 3)).copy_from(&(ai * p));
        j.view_mut((0, base + 3), (3, 3)).copy_from(&(ai * g * rho));
        let jp = ai * pix * rho;
        j.view_mut((0, base + 6), (3, 2))
            .copy_from(&jp.fixed_view::<3, 2>(0, 0));
    }
    j
}

/// First-order covariance of the intersection: each independent observer with its full
/// covariance in its own frame; observers drawn jointly from the chain (correlated mode)
/// through the chain's Jacobians, so their shared errors stay correlated:
/// `Σ = Σⱼ Jⱼ Σⱼ Jⱼᵀ + G Gᵀ` with `G = Σ_corr Jⱼ·diag(I, Lⱼᵀ R̄ⱼ)·J_chain(cⱼ)` (inputs: the
/// chain's standard normals).
pub(crate) fn linear_covariance(obs: &[Aimed], ctx: &Ctx, point: &Vector3<f64>) -> Matrix3<f64> {
    let j = intersection_jacobian(obs, point);
    let sn = ctx.pixel.unwrap_or(0.0);
    let mut inputs = DMatrix::zeros(j.ncols(), j.ncols());
    let mut shared: Option<DMatrix<f64>> = None;
    for (k, o) in obs.iter().enumerate() {
        let b = INPUTS_PER_OBSERVER * k;
        match o.source.and_then(|c| ctx.chain_jacobians.get(c)) {
            Some(jc) => {
                let mut t = DMatrix::<f64>::identity(6, 6);
                t.view_mut((3, 3), (3, 3)).copy_from(&o.chain_to_own);
                let g = j.columns(b, 6) * t * jc;
                shared = Some(match shared {
                    Some(s) => s + g,
                    None => g,
                });
            }
            None => inputs.view_mut((b, b), (6, 6)).copy_from(&o.covariance),
        }
        inputs[(b + 6, b + 6)] = sn * sn;
        inputs[(b + 7, b + 7)] = sn * sn;
    }
    let mut c = &j * inputs * j.transpose();
    if let Some(g) = shared {
        c += &g * g.transpose();
    }
    Matrix3::from_fn(|r, cc| c[(r, cc)])
}

#[cfg(test)]
mod legacy;
#[cfg(test)]
mod tests;
