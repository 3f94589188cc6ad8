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
use crashrig_stats::{Moments, stream};
use nalgebra::{DMatrix, Matrix3, SymmetricEigen, Vector3};
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
    /// Monte Carlo propagation; rotation σ in the scenario's [`RotationNoise`] meaning).
    pub observer_sigma: Vec<PoseSigma>,
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

/// One observer aimed at one grid point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Aimed {
    pub(crate) c: Vector3<f64>,
    pub(crate) r: Matrix3<f64>,
    pub(crate) opk: Vector3<f64>,
    pub(crate) sp: Vector3<f64>,
    pub(crate) sr: Vector3<f64>,
    /// The pose noise as a factor `δ = L·ε` (today diagonal: `diag(sp, sr)`).
    pub(crate) noise: NoiseFactor,
    /// Chain camera whose joint draw this observer takes (correlated mode).
    pub(crate) source: Option<usize>,
}

/// Everything the per-draw kernel needs that is shared by all points.
#[derive(Debug, Clone)]
pub(crate) struct Ctx {
    pub(crate) noise: RotationNoise,
    /// σ of the normalized image coordinates, if pixel noise is on.
    pub(crate) pixel: Option<f64>,
    /// The chain, when at least one observer is drawn jointly from it.
    pub(crate) chain: Option<Chain>,
}

/// Prepared grid study: observers resolved, ready to run.
#[derive(Debug, Clone)]
pub struct GridStudy {
    grid: Grid,
    ctx: Ctx,
    observer_sigma: Vec<PoseSigma>,
    correlated: bool,
}

fn aim(
    grid: &Grid,
    sigmas: &[PoseSigma],
    correlated: bool,
    point: &Vector3<f64>,
) -> Result<Vec<Aimed>, Error> {
    grid.observers
        .iter()
        .zip(sigmas)
        .map(|(o, s)| {
            let r = crashrig_geometry::look_at::world_from_cam_look_at(&o.position_mm, point)?;
            let a = crashrig_geometry::opk::opk_from_rotation(&r);
            Ok(Aimed {
                c: o.position_mm,
                r: r.into_inner(),
                opk: Vector3::new(a.omega, a.phi, a.kappa),
                sp: s.position_mm,
                sr: s.angles_rad,
                noise: NoiseFactor::from_sigma(&s.position_mm, &s.angles_rad),
                source: match (correlated, o.sigma) {
                    (true, ObserverSigma::From(i)) => Some(i),
                    _ => None,
                },
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
        let chain = Chain::new(scenario);
        let needs_chain = grid
            .observers
            .iter()
            .any(|o| matches!(o.sigma, ObserverSigma::From(_)));
        let mc = if needs_chain {
            chain.monte_carlo(samples.max(CHAIN_SAMPLES_MIN), seed ^ CHAIN_SEED_SALT)
        } else {
            Vec::new()
        };
        let observer_sigma: Vec<PoseSigma> = grid
            .observers
            .iter()
            .map(|o| match o.sigma {
                ObserverSigma::Given(s) => s,
                ObserverSigma::From(i) => PoseSigma {
                    position_mm: mc[i].position_sigma_mm,
                    angles_rad: match scenario.rotation_noise {
                        RotationNoise::Tangent => mc[i].tangent_sigma_rad,
                        RotationNoise::Euler => mc[i].angles_sigma_rad,
                    },
                },
            })
            .collect();
        let correlated = grid.correlated && needs_chain;
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
                noise: scenario.rotation_noise,
                pixel: grid.pixel.map(|p| p.sigma_normalized()),
                chain: correlated.then_some(chain),
            },
            grid,
            observer_sigma,
            correlated,
        };
        Ok(study)
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
    /// Work is split into (point, chunk of [`CHUNK`] draws) tasks; task (p, k) draws from
    /// the Philox stream of `(seed, p·2²⁴ + k)` and chunks are merged in index order, so the
    /// result is bit-identical for any number of threads (and any instruction-set level).
    pub fn run(&self, samples: usize, seed: u64) -> Result<GridResult, Error> {
        self.run_with(samples, seed, Engine::from_env())
    }

    /// [`GridStudy::run`] with an explicit engine (benchmarks and tests; the legacy engine
    /// draws from the former ChaCha8 streams, so its numbers differ statistically only).
    pub fn run_with(&self, samples: usize, seed: u64, engine: Engine) -> Result<GridResult, Error> {
        let points = self.grid.points();
        let aimed: Vec<Vec<Aimed>> = points
            .iter()
            .map(|p| aim(&self.grid, &self.observer_sigma, self.correlated, p))
            .collect::<Result<_, _>>()?;
        let chunks = samples.div_ceil(CHUNK);
        let tasks: Vec<(usize, usize)> = (0..points.len())
            .flat_map(|p| (0..chunks).map(move |k| (p, k)))
            .collect();
        let parts: Vec<Acc3> = tasks
            .par_iter()
            .map(|&(p, k)| {
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
        Ok(GridResult {
            points: stats,
            observer_sigma: self.observer_sigma.clone(),
            correlated: self.correlated,
        })
    }

    /// Runs with the adaptive stopping rule of GUM-S1 §7.9 per point: batches of
    /// `adaptive.batch` draws (batch b of point p is task `p·2²⁴ + b`) until
    /// `2·s/√h ≤ tolerance` for σx, σy and σz (s = standard deviation of the h per-batch σ,
    /// at least 4 batches) or `max_samples` is reached. The reported σ is that of all draws.
    pub fn run_adaptive(
        &self,
        adaptive: &crate::scenario::Adaptive,
        seed: u64,
    ) -> Result<GridResult, Error> {
        let points = self.grid.points();
        let aimed: Vec<Vec<Aimed>> = points
            .iter()
            .map(|p| aim(&self.grid, &self.observer_sigma, self.correlated, p))
            .collect::<Result<_, _>>()?;
        let stats = points
            .par_iter()
            .enumerate()
            .map(|(p, point)| {
                let mut total = Acc3::new(*point);
                let mut batch_sigmas = Moments::<3>::new();
                let mut b = 0usize;
                loop {
                    let m = adaptive
                        .batch
                        .min(adaptive.max_samples.saturating_sub(b * adaptive.batch));
                    if m < 2 {
                        break;
                    }
                    let mut acc = Acc3::new(*point);
                    run_chunk(
                        &aimed[p],
                        &self.ctx,
                        seed,
                        task_index(p, b),
                        m,
                        &mut acc,
                        Engine::from_env(),
                    );
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
        Ok(GridResult {
            points: stats,
            observer_sigma: self.observer_sigma.clone(),
            correlated: self.correlated,
        })
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
                || crate::block::run_task(obs, ctx, key, task, m, acc),
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
pub(crate) fn intersect_perturbed(
    obs: &[Aimed],
    noise: RotationNoise,
    delta: &[f64],
) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, o) in obs.iter().enumerate() {
        let d = &delta[INPUTS_PER_OBSERVER * j..INPUTS_PER_OBSERVER * (j + 1)];
        let c = o.c + Vector3::new(d[0], d[1], d[2]);
        let w = Vector3::new(d[3], d[4], d[5]);
        let r = match noise {
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
pub(crate) fn intersection_jacobian(
    obs: &[Aimed],
    noise: RotationNoise,
    point: &Vector3<f64>,
) -> DMatrix<f64> {
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
        let g = match noise {
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

/// First-order covariance of the intersection (observers independent).
pub(crate) fn linear_covariance(obs: &[Aimed], ctx: &Ctx, point: &Vector3<f64>) -> Matrix3<f64> {
    let j = intersection_jacobian(obs, ctx.noise, point);
    let sn = ctx.pixel.unwrap_or(0.0);
    let mut var = Vec::with_capacity(j.ncols());
    for o in obs {
        var.extend(o.sp.iter().map(|s| s * s));
        var.extend(o.sr.iter().map(|s| s * s));
        var.extend([sn * sn, sn * sn]);
    }
    let js = &j * DMatrix::from_diagonal(&nalgebra::DVector::from_vec(var));
    let c = js * j.transpose();
    Matrix3::from_fn(|r, cc| c[(r, cc)])
}

#[cfg(test)]
mod tests;
