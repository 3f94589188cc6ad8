//! The forward-intersection study over a grid: per point, observers aim at it, are perturbed
//! and intersected; streaming statistics, linear propagation and adaptive stopping.

use crate::accumulate::Acc3;
use crate::chain::{CameraId, Chain, WorldPose};
use crate::kernel::SMALL_ANGLE_SQ;
use crate::kernel::{Normal3, exp_e3, exp_matrix, opk_e3, rot_opk};
use crate::scenario::{
    Adaptive, Axis, Grid, Observer, ObserverSigma, PixelNoise, PoseSigma, RotationNoise, Scenario,
};
use crate::{CHUNK, Error, FastNormal};
use crashrig_geometry::uncertain::psd_factor;
use crashrig_stats::{Moments, stream};
use nalgebra::{DMatrix, Matrix3, Matrix6, SymmetricEigen, Vector3, Vector6};
use rayon::prelude::*;

/// Statistics of the intersected points at one grid point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointStats {
    /// The grid point (mm).
    pub point: Vector3<f64>,
    /// Draws used.
    pub count: u64,
    /// Mean intersected point (mm).
    pub mean_mm: Vector3<f64>,
    /// Sample covariance (mm², n − 1).
    pub covariance: Matrix3<f64>,
    /// σx, σy, σz (mm).
    pub sigma_mm: Vector3<f64>,
    /// max(σx, σy, σz) (mm).
    pub sigma_max_mm: f64,
    /// First-order covariance (mm²) of the same inputs, treating observers as independent.
    pub linear_covariance: Matrix3<f64>,
}

impl PointStats {
    /// Semi-axes (mm) of the 1σ error ellipsoid, largest first (√ of the covariance
    /// eigenvalues).
    pub fn ellipsoid_semi_axes_mm(&self) -> Vector3<f64> {
        let e = SymmetricEigen::new(self.covariance);
        let mut v: Vec<f64> = e.eigenvalues.iter().map(|l| l.max(0.0).sqrt()).collect();
        v.sort_by(|a, b| b.total_cmp(a));
        Vector3::new(v[0], v[1], v[2])
    }

    /// First-order σx, σy, σz (mm).
    pub fn linear_sigma_mm(&self) -> Vector3<f64> {
        Vector3::from_fn(|i, _| self.linear_covariance[(i, i)].sqrt())
    }

    /// First-order σ_max (mm).
    pub fn linear_sigma_max_mm(&self) -> f64 {
        self.linear_sigma_mm().max()
    }
}

/// The result of a grid study.
#[derive(Debug, Clone, PartialEq)]
pub struct GridResult {
    /// One entry per grid point, in [`Grid::points`] order.
    pub points: Vec<PointStats>,
    /// The noise each observer was given (σ of `sigma_from` cameras resolved from the chain's
    /// Monte Carlo propagation; rotation σ in the observer's [`RotationNoise`] meaning): the
    /// square roots of the diagonal of [`GridResult::observer_covariance`].
    pub observer_sigma: Vec<PoseSigma>,
    /// The full covariance of each observer's noise (mm, rad; tangent about the observer's
    /// own axes, or ω φ κ for Euler noise).
    pub observer_covariance: Vec<Matrix6<f64>>,
    /// Whether observers from the same chain were drawn jointly.
    pub correlated: bool,
}

impl GridResult {
    /// Fraction of points with σ_max below `threshold_mm`.
    pub fn fraction_below(&self, threshold_mm: f64) -> f64 {
        let n = self.points.len().max(1) as f64;
        self.points
            .iter()
            .filter(|p| p.sigma_max_mm < threshold_mm)
            .count() as f64
            / n
    }
}

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

/// One observer aimed at one grid point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Aimed {
    c: Vector3<f64>,
    r: Matrix3<f64>,
    opk: Vector3<f64>,
    sp: Vector3<f64>,
    sr: Vector3<f64>,
    noise: RotationNoise,
    /// Lower-triangular factor of a non-diagonal covariance (`None`: `σ∘ε` with `sp`, `sr`).
    factor: Option<Matrix6<f64>>,
    /// The covariance in the observer's own frame (for the first-order map).
    covariance: Matrix6<f64>,
    /// Chain camera whose joint draw this observer takes (correlated mode).
    source: Option<usize>,
    /// Correlated mode: `Lᵀ·R̄`, mapping the chain camera's body-axis rotation error θ to this
    /// observer's own axes, so that its world rotation is `Exp(R̄·θ)·L`.
    chain_to_own: Matrix3<f64>,
}

/// Everything the per-draw kernel needs that is shared by all points.
#[derive(Debug, Clone)]
pub(crate) struct Ctx {
    /// σ of the normalized image coordinates, if pixel noise is on.
    pixel: Option<f64>,
    /// The chain, when at least one observer is drawn jointly from it.
    chain: Option<Chain>,
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
                sp: sigma.position_mm,
                sr: sigma.angles_rad,
                noise: s.noise,
                factor: (!diagonal).then(|| psd_factor(&s.covariance)),
                covariance,
                source,
                chain_to_own,
            })
        })
        .collect()
}

/// Builds a [`GridStudy`] without a scenario file: the grid axes, the observers (each with a
/// covariance or taking a chain camera's propagated one), options, and the number of draws
/// and the seed, given once.
///
/// ```
/// use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
/// use crashrig_mc::{Axis, ChainBuilder, GridBuilder};
/// use nalgebra::{Matrix6, Vector3};
///
/// let mut b = ChainBuilder::new();
/// let rig = b.world(
///     "rig",
///     UncertainPose::from_sigmas(Rigid3::translation(0.0, -300.0, 0.0), Vec3::repeat(0.5), Vec3::repeat(1e-4)),
/// )?;
/// let chain = b.build();
/// let axis = |a: f64, b: f64, n: usize| Axis { start: a, stop: b, count: n };
/// let study = GridBuilder::new(axis(1000.0, 1500.0, 2), axis(0.0, 0.0, 1), axis(0.0, 0.0, 1))
///     .chain(chain)
///     .observer_from("rig", Vector3::new(0.0, -300.0, 0.0), rig)
///     .observer("door", Vector3::new(0.0, 300.0, 0.0), Matrix6::from_diagonal_element(1e-2))
///     .threshold_mm(2.0)
///     .build(2000, 7)?;
/// let result = study.evaluate()?;
/// assert_eq!(result.points.len(), 2);
/// # Ok::<(), crashrig_mc::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct GridBuilder {
    grid: Grid,
    chain: Option<Chain>,
    rotation_noise: RotationNoise,
}

impl GridBuilder {
    /// A grid over the three axes (mm), threshold 5 mm, no observer yet, no chain.
    pub fn new(x: Axis, y: Axis, z: Axis) -> Self {
        GridBuilder {
            grid: Grid {
                x,
                y,
                z,
                threshold_mm: 5.0,
                observers: Vec::new(),
                pixel: None,
                correlated: false,
                adaptive: None,
            },
            chain: None,
            rotation_noise: RotationNoise::Tangent,
        }
    }

    /// The chain the `observer_from` observers take their noise from.
    pub fn chain(mut self, chain: Chain) -> Self {
        self.chain = Some(chain);
        self
    }

    /// Threshold on σ_max (mm).
    pub fn threshold_mm(mut self, threshold_mm: f64) -> Self {
        self.grid.threshold_mm = threshold_mm;
        self
    }

    /// An observer at `position_mm` with a tangent covariance (mm, rad about its own axes).
    pub fn observer(
        mut self,
        name: impl Into<String>,
        position_mm: Vector3<f64>,
        covariance: Matrix6<f64>,
    ) -> Self {
        self.grid.observers.push(Observer {
            name: name.into(),
            position_mm,
            sigma: ObserverSigma::Covariance(covariance),
        });
        self
    }

    /// An observer taking chain camera `camera`'s propagated world covariance (or, with
    /// [`GridBuilder::correlated`], its joint draw; it must then stand at that camera).
    pub fn observer_from(
        mut self,
        name: impl Into<String>,
        position_mm: Vector3<f64>,
        camera: CameraId,
    ) -> Self {
        self.grid.observers.push(Observer {
            name: name.into(),
            position_mm,
            sigma: ObserverSigma::From(camera.index()),
        });
        self
    }

    /// Pixel noise at every observer.
    pub fn pixel_noise(mut self, pixel: PixelNoise) -> Self {
        self.grid.pixel = Some(pixel);
        self
    }

    /// Draw the `observer_from` observers jointly from the chain (world-frame errors).
    pub fn correlated(mut self, correlated: bool) -> Self {
        self.grid.correlated = correlated;
        self
    }

    /// Adaptive number of draws per point.
    pub fn adaptive(mut self, adaptive: Adaptive) -> Self {
        self.grid.adaptive = Some(adaptive);
        self
    }

    /// The prepared study with `samples` draws per point (the maximum comes from
    /// [`Adaptive`] when set) and `seed`.
    ///
    /// # Errors
    /// Fewer than two observers, an `observer_from` without a chain or with a camera not in
    /// it, a correlated observer away from its camera, an observer on or vertically above a
    /// grid point, invalid covariances.
    pub fn build(self, samples: usize, seed: u64) -> Result<GridStudy, Error> {
        let chain = self
            .chain
            .unwrap_or_else(|| crate::ChainBuilder::new().build());
        for (i, o) in self.grid.observers.iter().enumerate() {
            match o.sigma {
                ObserverSigma::From(c) if c >= chain.len() => {
                    return Err(Error::UnknownCamera {
                        key: format!("grid.observer[{i}].sigma_from"),
                        name: format!("#{c}"),
                    });
                }
                ObserverSigma::Covariance(m) => {
                    crashrig_geometry::uncertain::check_covariance(&m).map_err(|problem| {
                        Error::Covariance {
                            key: format!("grid.observer[{i}].covariance_tangent"),
                            problem,
                        }
                    })?;
                }
                _ => {}
            }
        }
        let positions: Vec<Vector3<f64>> = chain.nominal().iter().map(|p| p.position_mm).collect();
        let names: Vec<String> = chain.names().to_vec();
        crate::scenario::check_grid(&self.grid, &positions, &names)?;
        GridStudy::assemble(self.grid, chain, self.rotation_noise, samples, seed)
    }
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

    fn assemble(
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
            chain.monte_carlo(samples.max(CHAIN_SAMPLES_MIN), seed ^ CHAIN_SEED_SALT)
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
                // ω φ κ) for Euler noise.
                ObserverSigma::From(i) => match rotation_noise {
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
        let study = GridStudy {
            ctx: Ctx {
                pixel: grid.pixel.map(|p| p.sigma_normalized()),
                chain: correlated.then_some(chain),
            },
            grid,
            observer_noise,
            correlated,
            chain_nominal,
            samples,
            seed,
        };
        Ok(study)
    }

    /// Runs the study with the draws and seed it was built with: [`GridStudy::run_adaptive`]
    /// when the grid has [`Adaptive`] settings, else [`GridStudy::run`].
    ///
    /// # Errors
    /// As [`GridStudy::run`].
    pub fn evaluate(&self) -> Result<GridResult, Error> {
        match &self.grid.adaptive {
            Some(a) => self.run_adaptive(a, self.seed),
            None => self.run(self.samples, self.seed),
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

    fn aim_all(&self, points: &[Vector3<f64>]) -> Result<Vec<Vec<Aimed>>, Error> {
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
        s
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Runs `samples` draws per point.
    ///
    /// Work is split into (point, chunk of [`CHUNK`] draws) tasks; task (p, k) uses
    /// `crashrig_stats::stream(seed, p·2²⁴ + k)` and chunks are merged in index order, so the
    /// result is bit-identical for any number of threads.
    pub fn run(&self, samples: usize, seed: u64) -> Result<GridResult, Error> {
        let points = self.grid.points();
        let aimed = self.aim_all(&points)?;
        let chunks = samples.div_ceil(CHUNK);
        let tasks: Vec<(usize, usize)> = (0..points.len())
            .flat_map(|p| (0..chunks).map(move |k| (p, k)))
            .collect();
        let parts: Vec<Acc3> = tasks
            .par_iter()
            .map(|&(p, k)| {
                let mut rng = stream(seed, task_index(p, k));
                let m = CHUNK.min(samples - k * CHUNK);
                let mut acc = Acc3::new(points[p]);
                run_chunk(&aimed[p], &self.ctx, &mut rng, m, &mut acc);
                acc
            })
            .collect();
        let stats = points
            .iter()
            .enumerate()
            .map(|(p, point)| {
                let mut m = Acc3::new(*point);
                for part in &parts[p * chunks..(p + 1) * chunks] {
                    m.merge(part);
                }
                self.finish(point, &aimed[p], &m)
            })
            .collect();
        Ok(self.result(stats))
    }

    /// Runs with the adaptive stopping rule of GUM-S1 §7.9 per point: batches of
    /// `adaptive.batch` draws (batch b of point p uses `stream(seed, p·2²⁴ + b)`) until
    /// `2·s/√h ≤ tolerance` for σx, σy and σz (s = standard deviation of the h per-batch σ,
    /// at least 4 batches) or `max_samples` is reached. The reported σ is that of all draws.
    pub fn run_adaptive(
        &self,
        adaptive: &crate::scenario::Adaptive,
        seed: u64,
    ) -> Result<GridResult, Error> {
        let points = self.grid.points();
        let aimed = self.aim_all(&points)?;
        let stats = points
            .par_iter()
            .enumerate()
            .map(|(p, point)| {
                let mut total = Acc3::new(*point);
                let mut batch_sigmas = Moments::<3>::new();
                let mut b = 0usize;
                loop {
                    let mut rng = stream(seed, task_index(p, b));
                    let m = adaptive
                        .batch
                        .min(adaptive.max_samples.saturating_sub(b * adaptive.batch));
                    if m < 2 {
                        break;
                    }
                    let mut acc = Acc3::new(*point);
                    run_chunk(&aimed[p], &self.ctx, &mut rng, m, &mut acc);
                    total.merge(&acc);
                    let s = acc.std_dev();
                    batch_sigmas.push(&[s.x, s.y, s.z]);
                    b += 1;
                    let h = b as f64;
                    if b >= 4 {
                        let u = batch_sigmas.std_dev() * (2.0 / h.sqrt());
                        if u.max() <= adaptive.tolerance_mm {
                            break;
                        }
                    }
                    if b * adaptive.batch >= adaptive.max_samples {
                        break;
                    }
                }
                self.finish(point, &aimed[p], &total)
            })
            .collect();
        Ok(self.result(stats))
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
        }
    }
}

/// Smallest number of chain draws used to resolve `sigma_from` (σ to ≈ 0.2 %).
pub const CHAIN_SAMPLES_MIN: usize = 100_000;

/// Salt of the seed of the chain propagation that resolves `sigma_from`.
const CHAIN_SEED_SALT: u64 = 0x5EED_C4A1_0000_0001;

#[inline]
fn task_index(point: usize, chunk: usize) -> u64 {
    ((point as u64) << 24) | chunk as u64
}

/// `m` draws of one grid point into `acc`.
#[inline(never)]
pub(crate) fn run_chunk<R: rand::Rng>(
    obs: &[Aimed],
    ctx: &Ctx,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let nd = FastNormal::new();
    let simple = ctx.pixel.is_none()
        && ctx.chain.is_none()
        && obs
            .iter()
            .all(|o| o.noise == RotationNoise::Tangent && o.factor.is_none())
        && obs.len() == 2;
    if simple {
        run_two_observers(&obs[0], &obs[1], &nd, rng, m, acc);
        return;
    }
    let mut eps = vec![0.0; ctx.chain.as_ref().map_or(0, |c| 6 * c.len())];
    let mut drawn: Vec<WorldPose> = ctx
        .chain
        .as_ref()
        .map_or_else(Vec::new, |c| c.nominal().to_vec());
    for _ in 0..m {
        if let Some(chain) = &ctx.chain {
            chain.draw_into(rng, &mut eps, &mut drawn);
        }
        let mut n = Normal3::default();
        for o in obs {
            let (dc, rot) = match (o.source, &ctx.chain) {
                (Some(i), Some(chain)) => {
                    // World-frame rotation Exp(R̄θ) on the look-at L: L·Exp(Lᵀ R̄ θ).
                    let (dc, th) = chain.error_of(i, &drawn[i]);
                    (dc, Rot::Tangent(o.chain_to_own * th))
                }
                _ => {
                    let ep = normal3(&nd, rng);
                    let er = normal3(&nd, rng);
                    let (dp, dr) = match &o.factor {
                        None => (o.sp.component_mul(&ep), o.sr.component_mul(&er)),
                        Some(l) => {
                            let d = l * Vector6::new(ep.x, ep.y, ep.z, er.x, er.y, er.z);
                            (
                                d.fixed_rows::<3>(0).into_owned(),
                                d.fixed_rows::<3>(3).into_owned(),
                            )
                        }
                    };
                    (
                        dp,
                        match o.noise {
                            RotationNoise::Tangent => Rot::Tangent(dr),
                            RotationNoise::Euler => Rot::Euler(dr),
                        },
                    )
                }
            };
            let c = o.c + dc;
            match ctx.pixel {
                None => {
                    let d = match rot {
                        Rot::Tangent(w) => o.r * exp_e3(&w),
                        Rot::Euler(da) => opk_e3(&(o.opk + da)),
                    };
                    n.add_ray(&d, &c);
                }
                Some(s) => {
                    let (x, y) = nd.pair(rng);
                    let (x, y) = (s * x, s * y);
                    let r = match rot {
                        Rot::Tangent(w) => o.r * exp_matrix(&w),
                        Rot::Euler(da) => rot_opk(&(o.opk + da)),
                    };
                    add_view(&mut n, &r, &c, x, y);
                }
            }
        }
        acc.push(&n.solve());
    }
}

#[derive(Debug, Clone, Copy)]
enum Rot {
    Tangent(Vector3<f64>),
    Euler(Vector3<f64>),
}

#[inline(always)]
fn normal3<R: rand::Rng>(nd: &FastNormal, rng: &mut R) -> Vector3<f64> {
    let mut e = [0.0; 3];
    nd.fill(rng, &mut e);
    Vector3::from(e)
}

/// The two DLT rows of a view with rotation `r` (world_from_cam), centre `c`, observation
/// `(x, y)` in normalized coordinates.
#[inline(always)]
fn add_view(n: &mut Normal3, r: &Matrix3<f64>, c: &Vector3<f64>, x: f64, y: f64) {
    let c1 = r.column(0).into_owned();
    let c2 = r.column(1).into_owned();
    let c3 = r.column(2).into_owned();
    n.add_row(&(c3 * x - c1), c);
    n.add_row(&(c3 * y - c2), c);
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
        let r = match o.noise {
            RotationNoise::Tangent => o.r * exp_matrix(&w),
            RotationNoise::Euler => rot_opk(&(o.opk + w)),
        };
        add_view(&mut n, &r, &c, d[6], d[7]);
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
        let g = match o.noise {
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

/// First-order covariance of the intersection (observers independent, each with its full
/// covariance in its own frame).
pub(crate) fn linear_covariance(obs: &[Aimed], ctx: &Ctx, point: &Vector3<f64>) -> Matrix3<f64> {
    let j = intersection_jacobian(obs, point);
    let sn = ctx.pixel.unwrap_or(0.0);
    let mut inputs = DMatrix::zeros(j.ncols(), j.ncols());
    for (k, o) in obs.iter().enumerate() {
        let b = INPUTS_PER_OBSERVER * k;
        inputs.view_mut((b, b), (6, 6)).copy_from(&o.covariance);
        inputs[(b + 6, b + 6)] = sn * sn;
        inputs[(b + 7, b + 7)] = sn * sn;
    }
    let c = &j * inputs * j.transpose();
    Matrix3::from_fn(|r, cc| c[(r, cc)])
}

#[cfg(test)]
mod tests;

/// Draws per block of the two-observer kernel.
const LANES: usize = 64;

/// The hot path (two independent observers, tangent noise, principal point), written over
/// blocks of [`LANES`] draws in structure-of-arrays form so the compiler vectorises it.
///
/// Per block, 12 rows of [`LANES`] normals are drawn, component-major (all first components
/// of the block, then all second ones, …): observer j's position noise is rows 6j..6j+3, its
/// rotation noise rows 6j+3..6j+6. A final partial block still draws full rows and uses the
/// first lanes. A block holding an angle with θ² ≥ [`SMALL_ANGLE_SQ`] (never for realistic
/// σ) is recomputed with the exact `sin`/`cos` form.
#[inline(never)]
fn run_two_observers<R: rand::Rng>(
    o0: &Aimed,
    o1: &Aimed,
    nd: &FastNormal,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let mut e = [[0.0f64; LANES]; 12];
    let mut xs = [[0.0f64; LANES]; 3];
    let mut tmax = [0.0f64; LANES];
    let shift = acc.shift();
    let mut lanes = crate::accumulate::LaneSums::<LANES>::default();
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        for row in e.iter_mut() {
            nd.fill(rng, row);
        }
        for d in 0..LANES {
            let (d0, c0, t0) = ray_taylor(o0, &e, 0, d);
            let (d1, c1, t1) = ray_taylor(o1, &e, 6, d);
            let mut n = Normal3::default();
            n.add_ray(&d0, &c0);
            n.add_ray(&d1, &c1);
            let x = n.solve();
            xs[0][d] = x.x;
            xs[1][d] = x.y;
            xs[2][d] = x.z;
            tmax[d] = t0.max(t1);
        }
        if tmax[..b].iter().any(|t| *t >= SMALL_ANGLE_SQ) {
            for d in 0..b {
                let mut n = Normal3::default();
                for (o, k) in [(o0, 0), (o1, 6)] {
                    let ep = Vector3::new(e[k][d], e[k + 1][d], e[k + 2][d]);
                    let er = Vector3::new(e[k + 3][d], e[k + 4][d], e[k + 5][d]);
                    let c = o.c + o.sp.component_mul(&ep);
                    let dir = o.r * exp_e3(&o.sr.component_mul(&er));
                    n.add_ray(&dir, &c);
                }
                let x = n.solve();
                xs[0][d] = x.x;
                xs[1][d] = x.y;
                xs[2][d] = x.z;
            }
        }
        lanes.add(&xs, b, &shift);
        done += b;
    }
    acc.merge(&lanes.reduce(shift));
}

/// Perturbed centre and ray of an observer for lane `d` (rows `k..k+6` of `e`), with the
/// Taylor form of `Exp(w)·e₃`; also returns θ² so the caller can check the series' range.
#[inline(always)]
fn ray_taylor(
    o: &Aimed,
    e: &[[f64; LANES]; 12],
    k: usize,
    d: usize,
) -> (Vector3<f64>, Vector3<f64>, f64) {
    let c = Vector3::new(
        o.c.x + o.sp.x * e[k][d],
        o.c.y + o.sp.y * e[k + 1][d],
        o.c.z + o.sp.z * e[k + 2][d],
    );
    let w = Vector3::new(
        o.sr.x * e[k + 3][d],
        o.sr.y * e[k + 4][d],
        o.sr.z * e[k + 5][d],
    );
    let t = w.norm_squared();
    let s = 1.0 - t / 6.0 * (1.0 - t / 20.0 * (1.0 - t / 42.0));
    let cc = 0.5 * (1.0 - t / 12.0 * (1.0 - t / 30.0 * (1.0 - t / 56.0)));
    let v = Vector3::new(
        s * w.y + cc * w.x * w.z,
        -s * w.x + cc * w.y * w.z,
        1.0 + cc * (w.z * w.z - t),
    );
    (o.r * v, c, t)
}
