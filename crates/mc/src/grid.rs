//! The forward-intersection study over a grid: per point, observers aim at it, are perturbed
//! and intersected; streaming statistics, linear propagation and adaptive stopping.

use crate::accumulate::Acc3;
use crate::block::NoiseFactor;
use crate::chain::Chain;
use crate::kernel::Normal3;
#[cfg(test)]
use crate::kernel::{exp_matrix, rot_opk};
use crate::scenario::{Grid, ObserverSigma, PoseSigma, RotationNoise, Scenario};
use crate::simd::Engine;
use crate::{CHUNK, Error};
use crashrig_geometry::uncertain::psd_factor;
use crashrig_stats::progress::{Counter, Progress};
use crashrig_stats::{Moments, stream};
use nalgebra::{DMatrix, Matrix3, Matrix6, SymmetricEigen, Vector3, Vector6};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    /// First-order covariance (mm²) of the same inputs (observers drawn jointly from the chain
    /// through the chain's Jacobians, the others independent).
    pub linear_covariance: Matrix3<f64>,
    /// Observers that see the point (all of them when every observer is aimed); fewer than
    /// two: not measurable, σ and covariances NaN, `count` 0 (fixed observers, `fixed.rs`).
    pub observers_seen: usize,
    /// Adaptive runs (`[grid.adaptive]`): whether the tolerance was met before
    /// `max_samples`; `None` for a fixed number of draws.
    pub converged: Option<bool>,
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

    /// Worst-direction σ (mm): √ of the largest eigenvalue of [`PointStats::covariance`], the
    /// σ along the direction in which the point is least certain (never below
    /// [`PointStats::sigma_max_mm`]: a 5 mm promise holds in every direction only when this is
    /// below 5 mm). NaN when σ_max is NaN (not measurable, or blanked as degenerate).
    pub fn sigma_worst_mm(&self) -> f64 {
        if self.sigma_max_mm.is_finite() && self.covariance.iter().all(|v| v.is_finite()) {
            self.ellipsoid_semi_axes_mm()[0]
        } else {
            f64::NAN
        }
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
    pub(crate) c: Vector3<f64>,
    pub(crate) r: Matrix3<f64>,
    pub(crate) opk: Vector3<f64>,
    pub(crate) sp: Vector3<f64>,
    pub(crate) sr: Vector3<f64>,
    /// Rotation noise kind (a chain draw is always tangent).
    pub(crate) kind: RotationNoise,
    /// The pose noise as a factor `δ = L·ε` (diagonal fast path when independent).
    pub(crate) noise: NoiseFactor,
    /// The covariance in the observer's own frame (for the first-order map).
    pub(crate) covariance: Matrix6<f64>,
    /// Chain camera whose joint draw this observer takes (correlated mode).
    pub(crate) source: Option<usize>,
    /// Correlated mode: `Lᵀ·R̄`, mapping the chain camera's body-axis rotation error θ to this
    /// observer's own axes, so that its world rotation is `Exp(R̄·θ)·L`.
    pub(crate) chain_to_own: Matrix3<f64>,
}

/// Everything the per-draw kernel needs that is shared by all points.
#[derive(Debug, Clone)]
pub(crate) struct Ctx {
    /// σ of the normalized image coordinates, if pixel noise is on.
    pub(crate) pixel: Option<f64>,
    /// The chain, when at least one observer is drawn jointly from it.
    pub(crate) chain: Option<Chain>,
    /// [`Chain::jacobians`] of that chain (for the first-order map of correlated observers).
    pub(crate) chain_jacobians: Vec<DMatrix<f64>>,
}

/// Prepared grid study: observers resolved, ready to run.
#[derive(Debug, Clone)]
pub struct GridStudy {
    grid: Grid,
    ctx: Ctx,
    observer_noise: Vec<ObserverNoise>,
    correlated: bool,
    /// Nominal world poses of the chain (for correlated observers).
    chain_nominal: Vec<crate::WorldPose>,
    samples: usize,
    seed: u64,
}

fn aim(
    grid: &Grid,
    noises: &[ObserverNoise],
    correlated: bool,
    chain_nominal: &[crate::WorldPose],
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
        if normals > 4 * crate::philox::MAX_SLOTS {
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
        };
        Ok(study)
    }

    /// Runs the study with the draws and seed it was built with: [`GridStudy::run_adaptive`]
    /// when the grid has [`crate::Adaptive`] settings, else [`GridStudy::run`].
    ///
    /// # Errors
    /// As [`GridStudy::run`].
    pub fn evaluate(&self) -> Result<GridResult, Error> {
        self.evaluate_with_progress(None)
    }

    /// [`GridStudy::evaluate`] reporting `(points done, points)` to `progress`; the result is
    /// the same as without.
    ///
    /// # Errors
    /// As [`GridStudy::run`].
    pub fn evaluate_with_progress(
        &self,
        progress: Option<Progress<'_>>,
    ) -> Result<GridResult, Error> {
        match &self.grid.adaptive {
            Some(a) => self.run_adaptive_with_progress(a, self.seed, progress),
            None => self.run_with_progress(self.samples, self.seed, progress),
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
        s.ctx.chain_jacobians = Vec::new();
        s
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Runs `samples` draws per point.
    ///
    /// Work is split into (point, chunk of [`CHUNK`] draws) tasks; task (p, k) draws from
    /// the Philox stream of `(seed, p·2²⁴ + k)` and chunks are merged in index order, so the
    /// result is bit-identical for any number of threads (and any instruction-set level).
    pub fn run(&self, samples: usize, seed: u64) -> Result<GridResult, Error> {
        self.run_with(samples, seed, Engine::from_env())
    }

    /// [`GridStudy::run`] with an explicit engine (benchmarks and tests; the legacy engine
    /// draws from the former ChaCha8 streams, so its numbers differ statistically only).
    pub fn run_with(&self, samples: usize, seed: u64, engine: Engine) -> Result<GridResult, Error> {
        self.run_engine(samples, seed, engine, None)
    }

    /// [`GridStudy::run`] reporting `(points done, points)` to `progress` (a point counts when
    /// its last chunk of draws is done); the result is the same as without.
    ///
    /// # Errors
    /// As [`GridStudy::run`].
    pub fn run_with_progress(
        &self,
        samples: usize,
        seed: u64,
        progress: Option<Progress<'_>>,
    ) -> Result<GridResult, Error> {
        self.run_engine(samples, seed, Engine::from_env(), progress)
    }

    fn run_engine(
        &self,
        samples: usize,
        seed: u64,
        engine: Engine,
        progress: Option<Progress<'_>>,
    ) -> Result<GridResult, Error> {
        let chunks = samples.div_ceil(CHUNK);
        let points = self.grid.points();
        let ticks = PointTicks::new(progress, points.len(), chunks);
        if self.has_fixed() {
            let r = self.run_fixed(crate::fixed::Draws::Samples(samples), seed, engine, &ticks);
            ticks.finish();
            return r;
        }
        let aimed = self.aim_all(&points)?;
        // Task t = (point t / chunks, chunk t % chunks); each point's chunks merged in order.
        let mut sums: Vec<Acc3> = points.iter().map(|p| Acc3::new(*p)).collect();
        crate::ordered::map_fold_in_order(
            points.len() * chunks,
            |t| {
                let (p, k) = (t / chunks, t % chunks);
                let m = CHUNK.min(samples - k * CHUNK);
                let mut acc = Acc3::new(points[p]);
                run_chunk(
                    &aimed[p],
                    &self.ctx,
                    seed,
                    task_index(p, k),
                    m,
                    &mut acc,
                    engine,
                );
                ticks.chunk_done(p);
                acc
            },
            |t, part| sums[t / chunks].merge(&part),
        );
        ticks.finish();
        let stats = points
            .iter()
            .zip(&sums)
            .enumerate()
            .map(|(p, (point, m))| self.finish(point, &aimed[p], m))
            .collect();
        Ok(self.result(stats))
    }

    /// Runs with the adaptive stopping rule of GUM-S1 §7.9 per point: batches of
    /// `adaptive.batch` draws (batch b of point p is task `p·2²⁴ + b`) until the mean
    /// coordinate and the σ of every axis are stable (`2·s/√h ≤ δ`, see
    /// [`crate::Adaptive`]; at least [`ADAPTIVE_MIN_BATCHES`] batches) or `max_samples` is
    /// reached. The reported mean and σ are those of all draws.
    pub fn run_adaptive(
        &self,
        adaptive: &crate::scenario::Adaptive,
        seed: u64,
    ) -> Result<GridResult, Error> {
        self.run_adaptive_with_progress(adaptive, seed, None)
    }

    /// [`GridStudy::run_adaptive`] reporting `(points done, points)` to `progress`; the result
    /// is the same as without.
    ///
    /// # Errors
    /// As [`GridStudy::run`].
    pub fn run_adaptive_with_progress(
        &self,
        adaptive: &crate::scenario::Adaptive,
        seed: u64,
        progress: Option<Progress<'_>>,
    ) -> Result<GridResult, Error> {
        let points = self.grid.points();
        let ticks = PointTicks::new(progress, points.len(), 1);
        if self.has_fixed() {
            let r = self.run_fixed(
                crate::fixed::Draws::Adaptive(adaptive),
                seed,
                Engine::from_env(),
                &ticks,
            );
            ticks.finish();
            return r;
        }
        let aimed = self.aim_all(&points)?;
        let stats = points
            .par_iter()
            .enumerate()
            .map(|(p, point)| {
                let (total, converged) = adaptive_draws(point, adaptive, |b, m, acc| {
                    run_chunk(
                        &aimed[p],
                        &self.ctx,
                        seed,
                        task_index(p, b),
                        m,
                        acc,
                        Engine::from_env(),
                    )
                });
                ticks.point_done();
                PointStats {
                    converged: Some(converged),
                    ..self.finish(point, &aimed[p], &total)
                }
            })
            .collect();
        ticks.finish();
        Ok(self.result(stats))
    }

    /// Whether any observer is fixed (`aim = "fixed"`): then `fixed.rs` runs the study.
    fn has_fixed(&self) -> bool {
        self.grid
            .observers
            .iter()
            .any(|o| o.aim != crate::scenario::Aim::Point)
    }

    fn run_fixed(
        &self,
        draws: crate::fixed::Draws<'_>,
        seed: u64,
        engine: Engine,
        ticks: &PointTicks<'_>,
    ) -> Result<GridResult, Error> {
        let covariance: Vec<Matrix6<f64>> =
            self.observer_noise.iter().map(|n| n.covariance).collect();
        let kinds: Vec<RotationNoise> = self.observer_noise.iter().map(|n| n.noise).collect();
        let setup = crate::fixed::Setup {
            grid: &self.grid,
            covariance: &covariance,
            kinds: &kinds,
            pixel: self.grid.pixel,
            chain: self.ctx.chain.as_ref(),
        };
        Ok(self.result(crate::fixed::run(&setup, draws, seed, engine, ticks)?))
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

/// Progress of a grid run in grid points: a point counts when its last chunk of draws is done
/// (`chunk_done`, runs split into `chunks` tasks per point) or when it is finished whole
/// (`point_done`, adaptive runs); `finish` reports the total (points that drew nothing).
/// Without a callback every call is a no-op and nothing is allocated.
pub(crate) struct PointTicks<'a> {
    counter: Counter<'a>,
    /// Chunks still running per point (only with a callback and more than one chunk).
    left: Vec<AtomicUsize>,
}

impl<'a> PointTicks<'a> {
    pub(crate) fn new(progress: Option<Progress<'a>>, points: usize, chunks: usize) -> Self {
        let counter = Counter::new(progress, points);
        let left = if counter.is_reporting() && chunks > 1 {
            (0..points).map(|_| AtomicUsize::new(chunks)).collect()
        } else {
            Vec::new()
        };
        Self { counter, left }
    }

    /// One chunk of point `p` is done.
    pub(crate) fn chunk_done(&self, p: usize) {
        if !self.counter.is_reporting() {
            return;
        }
        match self.left.get(p) {
            Some(left) => {
                if left.fetch_sub(1, Ordering::Relaxed) == 1 {
                    self.counter.add(1);
                }
            }
            None => self.counter.add(1),
        }
    }

    /// One point is done.
    pub(crate) fn point_done(&self) {
        self.counter.add(1);
    }

    /// The run is done.
    pub(crate) fn finish(&self) {
        self.counter.finish();
    }
}

/// Smallest number of chain draws used to resolve `sigma_from` (σ to ≈ 0.2 %).
pub const CHAIN_SAMPLES_MIN: usize = 100_000;

/// Salt of the seed of the chain propagation that resolves `sigma_from`.
const CHAIN_SEED_SALT: u64 = 0x5EED_C4A1_0000_0001;

/// Smallest number of batches before the adaptive rule may stop (JCGM 101 §7.9.4 needs h ≥ 2;
/// 4 keeps the standard deviation of the batch values from being met by chance).
pub const ADAPTIVE_MIN_BATCHES: usize = 4;

/// Adaptive draws at one point: batches of `adaptive.batch` draws (batch `b` drawn by
/// `draw(b, m, acc)`) until, after at least [`ADAPTIVE_MIN_BATCHES`] batches,
/// [`adaptive_stable`] holds, or until `max_samples`. Returns all the draws and whether the
/// tolerance was met.
pub(crate) fn adaptive_draws(
    point: &Vector3<f64>,
    adaptive: &crate::scenario::Adaptive,
    mut draw: impl FnMut(usize, usize, &mut Acc3),
) -> (Acc3, bool) {
    let mut total = Acc3::new(*point);
    // Per batch: the mean coordinate (x, y, z) and the σ (x, y, z).
    let mut batches = Moments::<6>::new();
    let mut b = 0usize;
    loop {
        let m = adaptive
            .batch
            .min(adaptive.max_samples.saturating_sub(b * adaptive.batch));
        if m < 2 {
            return (total, false);
        }
        let mut acc = Acc3::new(*point);
        draw(b, m, &mut acc);
        total.merge(&acc);
        let (mean, s) = (acc.mean(), acc.std_dev());
        batches.push(&[mean.x, mean.y, mean.z, s.x, s.y, s.z]);
        b += 1;
        if b >= ADAPTIVE_MIN_BATCHES && adaptive_stable(&batches, &total.std_dev(), adaptive) {
            return (total, true);
        }
        if b * adaptive.batch >= adaptive.max_samples {
            return (total, false);
        }
    }
}

/// The stopping test of JCGM 101 §7.9.4 (k) per axis: with `h` batches and `s` the standard
/// deviation (n − 1) of a per-batch value, `2·s/√h ≤ δ` for the batch means (the estimate y)
/// and for the batch σ (its standard uncertainty u(y)) of x, y and z; δ of each axis from
/// `adaptive.tolerance` at `pooled_sigma` (σ of all the draws so far, §7.9.4 i–j). The
/// coverage-interval endpoints are not tested (the grid keeps no quantiles).
pub(crate) fn adaptive_stable(
    batches: &Moments<6>,
    pooled_sigma: &Vector3<f64>,
    adaptive: &crate::scenario::Adaptive,
) -> bool {
    let h = batches.count() as f64;
    if h < 2.0 {
        return false;
    }
    let s = batches.std_dev();
    (0..3).all(|axis| {
        let delta = adaptive.tolerance.delta_mm(pooled_sigma[axis]);
        let mean_ok = 2.0 * s[axis] / h.sqrt() <= delta;
        let sigma_ok = 2.0 * s[axis + 3] / h.sqrt() <= delta;
        mean_ok && sigma_ok
    })
}

/// The task number of chunk (or adaptive batch) `chunk` of grid point `point`: `p·2²⁴ + k`,
/// the stream of its draws (aimed and fixed paths).
#[inline]
pub(crate) fn task_index(point: usize, chunk: usize) -> u64 {
    ((point as u64) << 24) | chunk as u64
}

/// `m` draws of one grid point (task `task` of the run seeded `seed`) into `acc`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_chunk(
    obs: &[Aimed],
    ctx: &Ctx,
    seed: u64,
    task: u64,
    m: usize,
    acc: &mut Acc3,
    engine: Engine,
) {
    match engine {
        Engine::Simd(isa) => {
            let key = crate::philox::key_of_seed(seed);
            crate::simd::dispatch(
                isa,
                #[inline(always)]
                |width| crate::block::run_task(obs, ctx, key, task, m, acc, width),
            );
        }
        Engine::Legacy => {
            let mut rng = stream(seed, task);
            crate::legacy::run_chunk(obs, ctx, &mut rng, m, acc);
        }
    }
}

/// The two DLT rows of a view with rotation `r` (world_from_cam), centre `c`, observation
/// `(x, y)` in normalized coordinates.
#[inline(always)]
pub(crate) fn add_view(n: &mut Normal3, r: &Matrix3<f64>, c: &Vector3<f64>, x: f64, y: f64) {
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
        let r = match o.kind {
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
mod tests;
