//! Propagation through the camera chain: Monte Carlo draws and first-order (linear) covariance.

use crate::error::Error;
use crate::kernel::{exp_matrix, log_near_identity, rot_opk};
use crate::model::{PoseSigma, RotationNoise, Scenario};
use crate::options::ChainOptions;
use crate::schedule::{CHUNK, Engine};
use crashrig_geometry::{Rigid3, Rot3, UncertainPose, quat};
#[cfg(test)]
use crashrig_stats::Moments;
use crashrig_stats::progress::{Counter, Monitor};
use lanes::{CamPlan, CamSums};
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3, Vector6};

/// A world pose: projection centre and `R_world_from_cam`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldPose {
    /// Projection centre in the world (mm).
    pub position_mm: Vector3<f64>,
    /// `R_world_from_cam`.
    pub rotation: Matrix3<f64>,
}

impl WorldPose {
    /// ω, φ, κ (rad) of the rotation.
    pub fn angles_rad(&self) -> Vector3<f64> {
        let o = crashrig_geometry::opk::opk_from_rotation(
            &crashrig_geometry::Rot3::from_matrix_unchecked(self.rotation),
        );
        Vector3::new(o.omega, o.phi, o.kappa)
    }
}

impl WorldPose {
    /// The pose as a rigid transform `world_from_cam`.
    pub fn world_from_cam(&self) -> Rigid3 {
        quat::rigid_from_rotation(
            &Rot3::from_matrix_unchecked(self.rotation),
            &self.position_mm,
        )
    }
}

/// One camera's own pose (world) or link (parent), with the factor its draws use.
#[derive(Debug, Clone)]
struct Link {
    parent: Option<usize>,
    position_mm: Vector3<f64>,
    angles_rad: Vector3<f64>,
    rotation: Matrix3<f64>,
    noise: RotationNoise,
    /// Covariance (mm, rad; the rotation block in `noise`'s meaning).
    covariance: Matrix6<f64>,
    /// Lower-triangular `L`, `L·Lᵀ = covariance`: a draw is `δ = L·ε`.
    factor: Matrix6<f64>,
    /// `(σ position, σ rotation)` when the covariance is diagonal (the fast path `σ∘ε`).
    diagonal: Option<(Vector3<f64>, Vector3<f64>)>,
}

impl Link {
    fn new(
        parent: Option<usize>,
        pose: &UncertainPose,
        angles_rad: Vector3<f64>,
        noise: RotationNoise,
    ) -> Self {
        let rotation = match noise {
            // The Euler noise is added to the given angles: start from exactly those.
            RotationNoise::Euler => rot_opk(&angles_rad),
            RotationNoise::Tangent => pose.rotation().into_inner(),
        };
        Link {
            parent,
            position_mm: pose.center(),
            angles_rad,
            rotation,
            noise,
            covariance: pose.covariance,
            factor: pose.factor(),
            diagonal: pose
                .is_diagonal()
                .then(|| (pose.sigma_position(), pose.sigma_rotation())),
        }
    }

    /// `(δC, δθ)` of a draw from six standard normals.
    #[inline(always)]
    fn delta(&self, e: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
        match &self.diagonal {
            Some((sp, sr)) => (
                sp.component_mul(&Vector3::new(e[0], e[1], e[2])),
                sr.component_mul(&Vector3::new(e[3], e[4], e[5])),
            ),
            None => {
                let d = self.factor * Vector6::from_column_slice(e);
                (
                    d.fixed_rows::<3>(0).into_owned(),
                    d.fixed_rows::<3>(3).into_owned(),
                )
            }
        }
    }
}

/// The camera chain, ready for repeated draws: built by [`ChainBuilder`] or from a
/// [`Scenario`] ([`Chain::new`]).
#[derive(Debug, Clone)]
pub struct Chain {
    names: Vec<String>,
    links: Vec<Link>,
    order: Vec<usize>,
    nominal: Vec<WorldPose>,
}

/// Handle of a camera added to a [`ChainBuilder`]: its index in the chain (insertion order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CameraId(usize);

impl CameraId {
    /// Index of the camera in [`Chain::names`], [`Chain::monte_carlo`] and [`Chain::linear`].
    pub fn index(self) -> usize {
        self.0
    }
}

/// Builds a [`Chain`] without a scenario file: world poses and links, each an
/// [`UncertainPose`] (mm, rad). A link names its parent by the [`CameraId`] the builder
/// returned for it, so every parent exists and comes first: the chain order is correct by
/// construction.
///
/// ```
/// use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
/// use crashrig_mc::ChainBuilder;
///
/// let mut b = ChainBuilder::new();
/// let cam1 = b.world(
///     "cam1",
///     UncertainPose::from_sigmas(Rigid3::identity(), Vec3::repeat(1.0), Vec3::repeat(1e-4)),
/// )?;
/// let link = UncertainPose::certain(Rigid3::translation(0.0, 0.0, 1000.0));
/// let cam2 = b.link("cam2", cam1, link)?;
/// let chain = b.build();
/// let lin = chain.linear();
/// // 1 mm of cam1's centre plus a lever arm of 1000 mm × 1e-4 rad = 0.1 mm on x and y.
/// assert!((lin[cam2.index()].position_sigma_mm.x - 1.01f64.sqrt()).abs() < 1e-12);
/// # Ok::<(), crashrig_mc::Error>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct ChainBuilder {
    names: Vec<String>,
    links: Vec<Link>,
}

impl ChainBuilder {
    /// An empty chain.
    pub fn new() -> Self {
        Self::default()
    }

    fn add(&mut self, name: String, link: Link) -> Result<CameraId, Error> {
        if name.is_empty() {
            return Err(Error::Invalid {
                key: "camera.name".into(),
                problem: "must not be empty",
            });
        }
        if self.names.contains(&name) {
            return Err(Error::DuplicateName {
                key: "camera.name".into(),
                name,
            });
        }
        if let Err(problem) = crashrig_geometry::uncertain::check_covariance(&link.covariance) {
            return Err(Error::Covariance {
                key: format!("camera `{name}`"),
                problem,
            });
        }
        if let Some(p) = link.parent
            && p >= self.links.len()
        {
            return Err(Error::UnknownCamera {
                key: format!("camera `{name}`.parent"),
                name: format!("#{p}"),
            });
        }
        self.names.push(name);
        self.links.push(link);
        Ok(CameraId(self.links.len() - 1))
    }

    /// Adds a camera with its world pose `world_from_cam` (tangent noise).
    ///
    /// # Errors
    /// A duplicate or empty name; a covariance that is not symmetric positive semi-definite.
    pub fn world(
        &mut self,
        name: impl Into<String>,
        world_from_cam: UncertainPose,
    ) -> Result<CameraId, Error> {
        let angles = opk_of(&world_from_cam);
        self.add(
            name.into(),
            Link::new(None, &world_from_cam, angles, RotationNoise::Tangent),
        )
    }

    /// Adds a camera tied to `parent` by the link `parent_from_cam` (tangent noise; the
    /// translation is the camera's centre in the parent's axes, e.g. a `calibrate` result).
    ///
    /// # Errors
    /// As [`ChainBuilder::world`]; a `parent` from another builder that is out of range.
    pub fn link(
        &mut self,
        name: impl Into<String>,
        parent: CameraId,
        parent_from_cam: UncertainPose,
    ) -> Result<CameraId, Error> {
        let angles = opk_of(&parent_from_cam);
        self.add(
            name.into(),
            Link::new(
                Some(parent.0),
                &parent_from_cam,
                angles,
                RotationNoise::Tangent,
            ),
        )
    }

    /// Adds a camera with the legacy Euler noise: ω, φ, κ (rad) each get `N(0, σ)`, the
    /// centre independent `N(0, σ)` per axis; `parent: None` for a world pose.
    ///
    /// # Errors
    /// As [`ChainBuilder::link`]; a negative or non-finite σ.
    pub fn euler(
        &mut self,
        name: impl Into<String>,
        parent: Option<CameraId>,
        position_mm: Vector3<f64>,
        angles_rad: Vector3<f64>,
        sigma: PoseSigma,
    ) -> Result<CameraId, Error> {
        let r = crashrig_geometry::opk::rotation_from_opk(angles_rad.x, angles_rad.y, angles_rad.z);
        let pose = UncertainPose::from_sigmas(
            quat::rigid_from_rotation(&r, &position_mm),
            sigma.position_mm,
            sigma.angles_rad,
        );
        self.add(
            name.into(),
            Link::new(parent.map(|p| p.0), &pose, angles_rad, RotationNoise::Euler),
        )
    }

    /// The chain, cameras in insertion order.
    pub fn build(self) -> Chain {
        let order = (0..self.links.len()).collect();
        Chain::assemble(self.names, self.links, order)
    }
}

fn opk_of(p: &UncertainPose) -> Vector3<f64> {
    let o = crashrig_geometry::opk::opk_from_rotation(&p.rotation());
    Vector3::new(o.omega, o.phi, o.kappa)
}

/// Monte Carlo statistics of one camera's world pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseMc {
    /// Camera name.
    pub name: String,
    /// Nominal world pose.
    pub nominal: WorldPose,
    /// Draws.
    pub count: u64,
    /// Mean projection centre (mm).
    pub position_mean_mm: Vector3<f64>,
    /// σ of the projection centre (mm, world axes).
    pub position_sigma_mm: Vector3<f64>,
    /// Mean ω φ κ (rad), wrap-safe (nominal + mean of the wrapped offsets).
    pub angles_mean_rad: Vector3<f64>,
    /// σ of ω φ κ of `R_world_from_cam` (rad); offsets from the nominal are wrapped to ±π
    /// before accumulation, so a spread around ±180° is the small spread it is.
    pub angles_sigma_rad: Vector3<f64>,
    /// σ of the body-axis rotation error `log(R_nomᵀ R)` (rad).
    pub tangent_sigma_rad: Vector3<f64>,
    /// Covariance of (position mm, ω φ κ rad).
    pub covariance: Matrix6<f64>,
    /// Covariance of the world pose in the contract's tangent parametrization: centre in world
    /// axes (mm), rotation `log(R_nomᵀ·R)` about the camera's own axes (rad), n − 1.
    pub covariance_tangent: Matrix6<f64>,
    /// True when the nominal ω φ κ are at gimbal lock (|cos φ| tiny): the ω and κ statistics
    /// are then meaningless (the tangent ones are fine).
    pub angles_singular: bool,
}

impl PoseMc {
    /// The propagated world pose `world_from_cam` (nominal) with its Monte Carlo tangent
    /// covariance.
    pub fn uncertain(&self) -> UncertainPose {
        UncertainPose {
            b_from_a: self.nominal.world_from_cam(),
            covariance: self.covariance_tangent,
        }
    }
}

/// First-order propagation of one camera's world pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseLinear {
    /// Camera name.
    pub name: String,
    /// Covariance of (position mm, body-axis rotation error rad).
    pub covariance_tangent: Matrix6<f64>,
    /// σ of the projection centre (mm).
    pub position_sigma_mm: Vector3<f64>,
    /// σ of the body-axis rotation error (rad).
    pub tangent_sigma_rad: Vector3<f64>,
    /// σ of ω φ κ (rad); `None` at gimbal lock.
    pub angles_sigma_rad: Option<Vector3<f64>>,
    /// Nominal world pose.
    pub nominal: WorldPose,
}

impl PoseLinear {
    /// The propagated world pose with its first-order tangent covariance.
    pub fn uncertain(&self) -> UncertainPose {
        UncertainPose {
            b_from_a: self.nominal.world_from_cam(),
            covariance: self.covariance_tangent,
        }
    }
}

/// Body angular-rate matrix `M` of ω φ κ: `R(a + dε) = R(a)·Exp(M dε)` to first order.
pub(crate) fn opk_rate_matrix(a: &Vector3<f64>) -> Matrix3<f64> {
    let (sp, cp) = a.y.sin_cos();
    let (sk, ck) = a.z.sin_cos();
    // Rzᵀ Ryᵀ e₁ = Rzᵀ (cφ, 0, sφ) = (cφ cκ, −cφ sκ, sφ); Rzᵀ e₂ = (sκ, cκ, 0).
    Matrix3::new(cp * ck, sk, 0.0, -cp * sk, ck, 0.0, sp, 0.0, 1.0)
}

/// Wraps an angle difference to (−π, π]. Inputs are differences of two angles in (−π, π],
/// so one step of ±2π suffices (cheaper than `rem_euclid` in the per-draw loop); anything
/// else falls back to the general wrap.
#[inline]
fn wrap_pi(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if a > -PI && a <= PI {
        a
    } else if a > PI && a <= 3.0 * PI {
        a - TAU
    } else if a <= -PI && a > -3.0 * PI {
        a + TAU
    } else {
        crashrig_geometry::angles::wrap_pi(a)
    }
}

impl Chain {
    /// The chain of a scenario's cameras (file order), the TOML front end of
    /// [`ChainBuilder`]. The draw order (parents first) is derived from the `parent` links.
    ///
    /// # Panics
    /// If `scenario.cameras` was edited after validation into a parent index out of range or
    /// a cycle of parent links (a validated [`Scenario`] has neither); build such chains with
    /// [`ChainBuilder`].
    pub fn new(scenario: &Scenario) -> Self {
        let links: Vec<Link> = scenario
            .cameras
            .iter()
            .map(|c| Link::new(c.parent, &c.pose, c.angles_rad, c.rotation_noise))
            .collect();
        let order = crate::model::topological_order(&scenario.cameras)
            .expect("a validated scenario has no cycle of parent links");
        assert!(
            links
                .iter()
                .all(|l| l.parent.is_none_or(|p| p < links.len())),
            "a camera's parent index is out of range"
        );
        Chain::assemble(
            scenario.cameras.iter().map(|c| c.name.clone()).collect(),
            links,
            order,
        )
    }

    fn assemble(names: Vec<String>, links: Vec<Link>, order: Vec<usize>) -> Self {
        let mut chain = Chain {
            names,
            links,
            order,
            nominal: Vec::new(),
        };
        let zeros = vec![0.0; 6 * chain.len()];
        chain.nominal = chain.compose(&zeros);
        chain
    }

    /// Index of the camera called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Number of cameras.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// True when there is no camera.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// Camera names in file order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Nominal world poses in file order.
    pub fn nominal(&self) -> &[WorldPose] {
        &self.nominal
    }

    /// World poses for standard-normal inputs `eps` (6 per camera in chain order), each
    /// camera's perturbation being `δ = L·ε` with its covariance factor `L` (`σ∘ε` for a
    /// diagonal covariance): position x y z, then the three rotation components.
    pub fn compose(&self, eps: &[f64]) -> Vec<WorldPose> {
        let mut out = vec![
            WorldPose {
                position_mm: Vector3::zeros(),
                rotation: Matrix3::identity(),
            };
            self.len()
        ];
        self.compose_into(eps, &mut out);
        out
    }

    #[inline]
    pub(crate) fn compose_into(&self, eps: &[f64], out: &mut [WorldPose]) {
        for &i in &self.order {
            let l = &self.links[i];
            let (dp, de) = l.delta(&eps[6 * i..6 * i + 6]);
            let p = l.position_mm + dp;
            let r = match l.noise {
                RotationNoise::Tangent => l.rotation * exp_matrix(&de),
                RotationNoise::Euler => rot_opk(&(l.angles_rad + de)),
            };
            out[i] = match l.parent {
                None => WorldPose {
                    position_mm: p,
                    rotation: r,
                },
                Some(pi) => {
                    let parent = out[pi];
                    WorldPose {
                        position_mm: parent.position_mm + parent.rotation * p,
                        rotation: parent.rotation * r,
                    }
                }
            };
        }
    }

    /// One joint draw of every camera (the legacy engine of the tests): fills `eps` (6 normals
    /// per camera, drawn in topological order) and `out`.
    #[cfg(test)]
    pub(crate) fn draw_into<R: rand::Rng>(
        &self,
        rng: &mut R,
        eps: &mut [f64],
        out: &mut [WorldPose],
    ) {
        let nd = crate::kernel::ziggurat::FastNormal::new();
        for &i in &self.order {
            nd.fill(rng, &mut eps[6 * i..6 * i + 6]);
        }
        self.compose_into(eps, out);
    }

    /// The cameras in topological order (parents first).
    pub(crate) fn order(&self) -> &[usize] {
        &self.order
    }

    /// What the block loop needs, per camera in file order.
    pub(crate) fn plan(&self) -> Vec<CamPlan> {
        self.links
            .iter()
            .zip(&self.nominal)
            .map(|(l, nom)| {
                let a = nom.angles_rad();
                CamPlan {
                    parent: l.parent,
                    noise: l.noise,
                    position: [l.position_mm.x, l.position_mm.y, l.position_mm.z],
                    rotation: std::array::from_fn(|k| l.rotation[(k / 3, k % 3)]),
                    angles: crate::kernel::lanes::Trig {
                        s: std::array::from_fn(|k| l.angles_rad[k].sin()),
                        c: std::array::from_fn(|k| l.angles_rad[k].cos()),
                    },
                    // δ = L·ε (diagonal fast path when the covariance is diagonal).
                    noise_factor: crate::kernel::lanes::NoiseFactor::from_lower(&l.factor),
                    nominal_c: [nom.position_mm.x, nom.position_mm.y, nom.position_mm.z],
                    nominal_r: std::array::from_fn(|k| nom.rotation[(k / 3, k % 3)]),
                    nominal_sin: std::array::from_fn(|k| a[k].sin()),
                    nominal_cos: std::array::from_fn(|k| a[k].cos()),
                }
            })
            .collect()
    }

    /// ω φ κ of a drawn pose of camera `i` minus the nominal ones, wrapped to (−π, π].
    pub(crate) fn angle_offsets(&self, i: usize, drawn: &WorldPose) -> Vector3<f64> {
        (drawn.angles_rad() - self.nominal[i].angles_rad()).map(wrap_pi)
    }

    /// Error of a drawn pose against the nominal of camera `i`: (δC world mm, body rotation
    /// error rad) with `R = R_nom·Exp(θ)`.
    #[inline]
    pub(crate) fn error_of(&self, i: usize, drawn: &WorldPose) -> (Vector3<f64>, Vector3<f64>) {
        let nom = &self.nominal[i];
        (
            drawn.position_mm - nom.position_mm,
            log_near_identity(&(nom.rotation.transpose() * drawn.rotation)),
        )
    }

    /// Monte Carlo propagation with `options.samples` joint draws of every camera and link
    /// under `options.seed`, compiled for `options.isa`.
    ///
    /// Draws are split in chunks of [`CHUNK`](crate::CHUNK); chunk `k` is Philox task `k` of
    /// the seed and the chunks are merged in index order, so the result is bit-identical for
    /// any number of threads and any instruction-set level.
    ///
    /// `monitor` (optional) gets `(chunks done, chunks)` and is asked before each chunk
    /// whether the call was cancelled; the result is the same with and without it.
    ///
    /// # Errors
    /// [`Error::Cancelled`] when `monitor` cancelled the run (nothing else fails).
    pub fn monte_carlo(
        &self,
        options: &ChainOptions,
        monitor: Option<&dyn Monitor>,
    ) -> Result<Vec<PoseMc>, Error> {
        self.monte_carlo_engine(
            options.samples,
            options.seed,
            Engine::Simd(options.isa),
            monitor,
        )
    }

    /// [`Chain::monte_carlo`] for the tangent covariances alone (what a grid's `sigma_from`
    /// needs with tangent noise): the ω φ κ statistics of the result are NaN (`covariance`,
    /// `angles_mean_rad`, `angles_sigma_rad`); everything else is as `monte_carlo` gives it,
    /// up to the last bits of lanes whose angles `monte_carlo` recomputes by the scalar
    /// formulas (near gimbal lock).
    pub(crate) fn monte_carlo_tangent(&self, options: &ChainOptions) -> Result<Vec<PoseMc>, Error> {
        let mut r = self.run_simd::<false>(options.samples, options.seed, options.isa, None)?;
        for p in &mut r {
            p.covariance = Matrix6::from_element(f64::NAN);
            p.angles_mean_rad = Vector3::from_element(f64::NAN);
            p.angles_sigma_rad = Vector3::from_element(f64::NAN);
        }
        Ok(r)
    }

    pub(crate) fn monte_carlo_engine(
        &self,
        samples: usize,
        seed: u64,
        engine: Engine,
        monitor: Option<&dyn Monitor>,
    ) -> Result<Vec<PoseMc>, Error> {
        match engine {
            #[cfg(test)]
            Engine::Legacy => {
                let ticks = Counter::monitored(monitor, samples.div_ceil(CHUNK));
                let r = self.monte_carlo_legacy(samples, seed, &ticks);
                ticks.finish();
                Ok(r)
            }
            Engine::Simd(isa) => self.run_simd::<true>(samples, seed, isa, monitor),
        }
    }

    /// The vectorised Monte Carlo (see [`Chain::monte_carlo`]; without `ANGLES` no ω φ κ).
    fn run_simd<const ANGLES: bool>(
        &self,
        samples: usize,
        seed: u64,
        isa: crate::kernel::Isa,
        monitor: Option<&dyn Monitor>,
    ) -> Result<Vec<PoseMc>, Error> {
        let chunks = samples.div_ceil(CHUNK);
        let ticks = Counter::monitored(monitor, chunks);
        let n = self.len();
        let key = crate::kernel::philox::key_of_seed(seed);
        let mut total = vec![CamSums::new(); n];
        let stopped = std::sync::atomic::AtomicBool::new(false);
        crate::kernel::ordered::map_fold_in_order(
            chunks,
            |k| {
                if ticks.check().is_err() {
                    // Skipped: the call returns `Cancelled`.
                    stopped.store(true, std::sync::atomic::Ordering::Relaxed);
                    return Vec::new();
                }
                let m = CHUNK.min(samples - k * CHUNK);
                let part = crate::kernel::simd::dispatch(
                    isa,
                    #[inline(always)]
                    |width| lanes::run_task::<ANGLES>(self, key, k as u64, m, width),
                );
                ticks.add(1);
                part
            },
            |_, part| {
                for (t, p) in total.iter_mut().zip(&part) {
                    t.merge(p);
                }
            },
        );
        if stopped.into_inner() {
            return Err(crashrig_stats::progress::Cancelled.into());
        }
        ticks.finish();
        Ok(total
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let nom = &self.nominal[i];
                let nom_a = nom.angles_rad();
                let (mean, cov) = t.mean_cov();
                let sd = Vector6::from_fn(|r, _| cov[(r, r)].sqrt());
                PoseMc {
                    name: self.names[i].clone(),
                    nominal: *nom,
                    count: t.n,
                    position_mean_mm: nom.position_mm + mean.fixed_rows::<3>(0),
                    position_sigma_mm: sd.fixed_rows::<3>(0).into_owned(),
                    angles_mean_rad: (nom_a + mean.fixed_rows::<3>(3)).map(wrap_pi),
                    angles_sigma_rad: sd.fixed_rows::<3>(3).into_owned(),
                    tangent_sigma_rad: t.tangent_sigma(),
                    covariance: cov,
                    covariance_tangent: t.tangent_covariance(),
                    angles_singular: self.angles_singular(i),
                }
            })
            .collect())
    }

    /// The former loop (ChaCha8 streams, ziggurat normals, Welford moments per draw).
    #[cfg(test)]
    fn monte_carlo_legacy(&self, samples: usize, seed: u64, ticks: &Counter<'_>) -> Vec<PoseMc> {
        let n = self.len();
        let chunks = samples.div_ceil(CHUNK);
        let mut total = vec![(Moments::<6>::new(), Moments::<6>::new()); n];
        crate::kernel::ordered::map_fold_in_order(
            chunks,
            |k| {
                let mut rng = crashrig_stats::stream(seed, k as u64);
                let m = CHUNK.min(samples - k * CHUNK);
                let mut acc = vec![(Moments::<6>::new(), Moments::<6>::new()); n];
                let mut eps = vec![0.0; 6 * n];
                let mut out = self.nominal.clone();
                let nominal_angles: Vec<Vector3<f64>> =
                    self.nominal.iter().map(|p| p.angles_rad()).collect();
                for _ in 0..m {
                    self.draw_into(&mut rng, &mut eps, &mut out);
                    for i in 0..n {
                        let a = out[i].angles_rad() - nominal_angles[i];
                        let c = out[i].position_mm;
                        acc[i]
                            .0
                            .push(&[c.x, c.y, c.z, wrap_pi(a.x), wrap_pi(a.y), wrap_pi(a.z)]);
                        let (dc, th) = self.error_of(i, &out[i]);
                        acc[i].1.push(&[dc.x, dc.y, dc.z, th.x, th.y, th.z]);
                    }
                }
                ticks.add(1);
                acc
            },
            |_, part| {
                for (t, p) in total.iter_mut().zip(&part) {
                    t.0.merge(&p.0);
                    t.1.merge(&p.1);
                }
            },
        );
        total
            .iter()
            .enumerate()
            .map(|(i, (m, t))| {
                let nom_a = self.nominal[i].angles_rad();
                let mean = m.mean();
                let sd = m.std_dev();
                PoseMc {
                    name: self.names[i].clone(),
                    nominal: self.nominal[i],
                    count: m.count(),
                    position_mean_mm: mean.fixed_rows::<3>(0).into_owned(),
                    position_sigma_mm: sd.fixed_rows::<3>(0).into_owned(),
                    angles_mean_rad: (nom_a + mean.fixed_rows::<3>(3)).map(wrap_pi),
                    angles_sigma_rad: sd.fixed_rows::<3>(3).into_owned(),
                    tangent_sigma_rad: t.std_dev().fixed_rows::<3>(3).into_owned(),
                    covariance: m.covariance(),
                    covariance_tangent: t.covariance(),
                    angles_singular: self.angles_singular(i),
                }
            })
            .collect()
    }

    /// Jacobians `d(δC, θ)/dε` (6 × 6·len, file order) of every camera's world pose with
    /// respect to the standard-normal inputs of [`Chain::compose`], at ε = 0.
    pub fn jacobians(&self) -> Vec<DMatrix<f64>> {
        let n = self.len();
        let mut js: Vec<DMatrix<f64>> = vec![DMatrix::zeros(6, 6 * n); n];
        for &i in &self.order {
            let l = &self.links[i];
            let mut j = DMatrix::<f64>::zeros(6, 6 * n);
            // Columns of this camera's own inputs: δ = L·ε.
            let pos_cols = l.factor.fixed_rows::<3>(0).into_owned();
            let rot_cols = match l.noise {
                RotationNoise::Tangent => l.factor.fixed_rows::<3>(3).into_owned(),
                RotationNoise::Euler => {
                    opk_rate_matrix(&l.angles_rad) * l.factor.fixed_rows::<3>(3)
                }
            };
            match l.parent {
                None => {
                    j.view_mut((0, 6 * i), (3, 6)).copy_from(&pos_cols);
                    j.view_mut((3, 6 * i), (3, 6)).copy_from(&rot_cols);
                }
                Some(p) => {
                    let rp = self.nominal[p].rotation;
                    let jp = &js[p];
                    let jc = jp.rows(0, 3);
                    let jt = jp.rows(3, 3);
                    let lever = -rp * l.position_mm.cross_matrix();
                    let new_c = jc + lever * jt;
                    let new_t = l.rotation.transpose() * jt;
                    j.rows_mut(0, 3).copy_from(&new_c);
                    j.rows_mut(3, 3).copy_from(&new_t);
                    let pc = rp * pos_cols;
                    for r in 0..3 {
                        for c in 0..6 {
                            j[(r, 6 * i + c)] += pc[(r, c)];
                            j[(3 + r, 6 * i + c)] += rot_cols[(r, c)];
                        }
                    }
                }
            }
            js[i] = j;
        }
        js
    }

    /// First-order propagation: `Σ = J Jᵀ` per camera (inputs are unit normals).
    pub fn linear(&self) -> Vec<PoseLinear> {
        self.jacobians()
            .iter()
            .enumerate()
            .map(|(i, j)| {
                let cov = j * j.transpose();
                let cov6 = Matrix6::from_fn(|r, c| cov[(r, c)]);
                let ct = cov6.fixed_view::<3, 3>(3, 3).into_owned();
                let angles_sigma_rad = crashrig_geometry::opk::d_opk_d_tangent_right(
                    &crashrig_geometry::Rot3::from_matrix_unchecked(self.nominal[i].rotation),
                )
                .ok()
                .map(|d| {
                    let co = d * ct * d.transpose();
                    Vector3::new(co[(0, 0)].sqrt(), co[(1, 1)].sqrt(), co[(2, 2)].sqrt())
                });
                PoseLinear {
                    name: self.names[i].clone(),
                    covariance_tangent: cov6,
                    position_sigma_mm: Vector3::from_fn(|r, _| cov6[(r, r)].sqrt()),
                    tangent_sigma_rad: Vector3::from_fn(|r, _| cov6[(3 + r, 3 + r)].sqrt()),
                    angles_sigma_rad,
                    nominal: self.nominal[i],
                }
            })
            .collect()
    }

    /// True when camera `i`'s nominal world ω φ κ are at gimbal lock: its ω φ κ σ are
    /// undefined (its tangent covariance is not). Any ω φ κ *input* is a valid rotation.
    pub fn angles_singular(&self, i: usize) -> bool {
        crashrig_geometry::opk::opk_from_rotation(&Rot3::from_matrix_unchecked(
            self.nominal[i].rotation,
        ))
        .gimbal_lock
    }

    /// Checks that no camera's world orientation is at gimbal lock (ω φ κ σ undefined).
    pub fn check_gimbal(&self) -> Result<(), Error> {
        for (i, p) in self.nominal.iter().enumerate() {
            let o = crashrig_geometry::opk::opk_from_rotation(
                &crashrig_geometry::Rot3::from_matrix_unchecked(p.rotation),
            );
            if o.gimbal_lock {
                return Err(Error::GimbalLock {
                    name: self.names[i].clone(),
                });
            }
        }
        Ok(())
    }
}

pub(crate) mod lanes;
#[cfg(test)]
mod tests;
