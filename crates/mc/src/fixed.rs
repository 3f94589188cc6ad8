//! Grid studies with fixed observers (`aim = "fixed"`): cameras bolted in place with a real
//! lens, in any mix with aimed observers.
//!
//! Per grid point, every observer that *sees* the point becomes a [`View`] (`crate::view`:
//! visibility, the lens, the undistortion): an aimed observer always sees it (the paper's
//! re-aiming: nominal rotation = look-at, the point at the principal point, pixel noise
//! `N(0, σ_px/focal_px)` in normalized coordinates from the grid's `pixel_sigma_px`/`focal_px`);
//! a fixed observer where its lens sees the point.
//!
//! Each draw (per view): the pose error `δ = L·ε` (centre + δ₁₋₃ in world axes, `R̄·Exp(δ₄₋₆)`
//! about the camera's own axes, or ω φ κ + δ₄₋₆ for `euler` noise), the true pixel plus
//! `N(0, σ_px)` per axis, taken back through the lens to normalized coordinates, and the two
//! DLT rows of the perturbed camera; the views' rows are solved together (inhomogeneous DLT).
//! Points seen by fewer than two observers are *not measurable*: NaN σ, `observers_seen < 2`.
//!
//! The draws run on the vectorised block engine (`crate::block`: Philox + Box–Muller normals,
//! blocks of 64 draws in lanes, compiled per instruction-set level) with every other grid
//! path: a fixed view is an `Observation::Lens`, whose per-lane normalized coordinates come
//! from `crate::view::undistort_lanes`.
//!
//! Scheduling, streams and determinism are the aimed path's (`crate::map`): [`FixedPath`]
//! prepares a point's views. The tests keep the former
//! scalar loop (ChaCha8 + ziggurat, `run_chunk_fixed`) as a statistical cross-check.

use crate::block::{Observation, ObserverSpec};
use crate::chain::Chain;
use crate::error::Error;
use crate::kernel::accumulate::Acc3;
use crate::kernel::lanes::NoiseFactor;
#[cfg(test)]
use crate::kernel::normal::LANES;
#[cfg(test)]
use crate::kernel::{Normal3, exp_matrix, rot_opk};
use crate::map::{MapPath, Planned};
use crate::model::{Aim, FixedCamera, Grid, PixelNoise, RotationNoise};
use crate::result::PointStats;
#[cfg(test)]
use crate::view::undistort;
use crate::view::{FastLens, View, is_linear, sight};
use crashrig_geometry::triangulate::dlt_rows;
#[cfg(test)]
use nalgebra::Vector6;
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector2, Vector3};

/// Normals per view and draw: 6 pose + 2 pixel.
#[cfg(test)]
const NORMALS_PER_VIEW: usize = 8;

/// What the fixed path needs from a prepared [`crate::GridStudy`].
pub(crate) struct Setup<'a> {
    /// The grid.
    pub(crate) grid: &'a Grid,
    /// Resolved pose-noise covariance of each observer (mm, rad; rotation block in the
    /// meaning of its `kinds` entry).
    pub(crate) covariance: &'a [Matrix6<f64>],
    /// Rotation-noise meaning of each observer's covariance.
    pub(crate) kinds: &'a [RotationNoise],
    /// The grid's pixel noise (aimed observers).
    pub(crate) pixel: Option<PixelNoise>,
    /// The chain, in correlated mode.
    pub(crate) chain: Option<&'a Chain>,
}

/// Lower factor `L` (`L·Lᵀ = Σ`) of an observer's pose-noise covariance (mm, rad; order δC,
/// δθ): `crashrig_geometry::uncertain::psd_factor` (for independent σ it is `diag(σ)`
/// exactly).
fn factor_of(covariance: &Matrix6<f64>) -> Matrix6<f64> {
    crashrig_geometry::uncertain::psd_factor(covariance)
}

#[cfg(test)]
fn is_diagonal(l: &Matrix6<f64>) -> bool {
    (0..6).all(|i| (0..6).all(|j| i == j || l[(i, j)] == 0.0))
}

/// The views of every observer that sees `point`.
pub(crate) fn views<'a>(setup: &Setup<'a>, point: &Vector3<f64>) -> Result<Vec<View<'a>>, Error> {
    let mut out = Vec::with_capacity(setup.grid.observers.len());
    for k in 0..setup.grid.observers.len() {
        if let Some(v) = view_of(setup, k, point)? {
            out.push(v);
        }
    }
    Ok(out)
}

/// The view of observer `k` of `point`, or `None` when it does not see the point.
fn view_of<'a>(
    setup: &Setup<'a>,
    k: usize,
    point: &Vector3<f64>,
) -> Result<Option<View<'a>>, Error> {
    let o = &setup.grid.observers[k];
    let source = match (setup.chain, o.sigma) {
        (Some(_), crate::model::ObserverSigma::From(i)) => Some(i),
        _ => None,
    };
    let noise = Noise {
        l: factor_of(&setup.covariance[k]),
        // A chain draw is always a tangent (body-axis) rotation error.
        euler: setup.kinds[k] == RotationNoise::Euler && source.is_none(),
        source,
    };
    match &o.aim {
        Aim::Point => aimed_view(setup, &o.position_mm, noise, point).map(Some),
        Aim::Fixed(f) => Ok(fixed_view(f, &o.position_mm, noise, point)),
    }
}

/// An observer's pose noise as a view carries it.
#[derive(Debug, Clone, Copy)]
struct Noise {
    l: Matrix6<f64>,
    euler: bool,
    source: Option<usize>,
}

/// An aimed observer at `c` re-aimed at `point`: observed at the principal point, pixel noise
/// (if any) from the grid's `pixel_sigma_px` at `focal_px`.
fn aimed_view<'a>(
    setup: &Setup<'a>,
    c: &Vector3<f64>,
    noise: Noise,
    point: &Vector3<f64>,
) -> Result<View<'a>, Error> {
    let r = crashrig_geometry::look_at::world_from_cam_look_at(c, point)?;
    let a = crashrig_geometry::opk::opk_from_rotation(&r);
    let (sigma_px, focal) = setup.pixel.map_or((0.0, 1.0), |p| (p.sigma_px, p.focal_px));
    Ok(View {
        c: *c,
        r: r.into_inner(),
        opk: Vector3::new(a.omega, a.phi, a.kappa),
        l: noise.l,
        #[cfg(test)]
        diag: is_diagonal(&noise.l).then(|| noise.l.diagonal()),
        euler: noise.euler,
        n0: Vector2::zeros(),
        u0: Vector2::zeros(),
        jinv: Matrix2::identity() / focal,
        sigma_px,
        lens: None,
        fast: None,
        full_lens: None,
        source: noise.source,
    })
}

/// A fixed camera at `c` looking at `point` through its lens, or `None` when it does not see
/// it ([`sight`]).
fn fixed_view<'a>(
    f: &'a FixedCamera,
    c: &Vector3<f64>,
    noise: Noise,
    point: &Vector3<f64>,
) -> Option<View<'a>> {
    let (u0, n0, jinv) = sight(f, c, point)?;
    Some(View {
        c: *c,
        r: f.rotation,
        opk: f.angles_rad,
        l: noise.l,
        #[cfg(test)]
        diag: is_diagonal(&noise.l).then(|| noise.l.diagonal()),
        euler: noise.euler,
        n0,
        u0,
        jinv,
        sigma_px: f.pixel_sigma_px,
        lens: (!is_linear(&f.lens)).then_some(&f.lens),
        fast: FastLens::of(&f.lens),
        full_lens: Some(&f.lens),
        source: noise.source,
    })
}

/// The block engine's description of view `v` (`chain`: correlated mode; `pixel`: σ of the
/// aimed views' normalized coordinates).
fn spec<'a>(v: &View<'a>, chain: Option<&Chain>, pixel: Option<f64>) -> ObserverSpec<'a> {
    let source = v.source.filter(|_| chain.is_some());
    ObserverSpec {
        c: v.c,
        r: v.r,
        opk: v.opk,
        noise: NoiseFactor::from_lower(&v.l),
        tangent: !v.euler,
        source,
        observation: match v.full_lens {
            Some(_) => Observation::Lens(*v),
            None => pixel.map_or(Observation::Ray, Observation::Normalized),
        },
    }
}

/// The perturbed rotation and centre of view `v` for the pose error `d` (independent noise).
#[cfg(test)]
fn perturbed_pose(v: &View<'_>, d: &Vector6<f64>) -> (Matrix3<f64>, Vector3<f64>) {
    let c = v.c + Vector3::new(d[0], d[1], d[2]);
    let w = Vector3::new(d[3], d[4], d[5]);
    let r = if v.euler {
        rot_opk(&(v.opk + w))
    } else {
        v.r * exp_matrix(&w)
    };
    (r, c)
}

/// The two DLT rows of view `v` with tangent pose error `d` and observation `x`, without
/// forming the perturbed rotation: `a = R̄·Exp(w)·(−1, 0, x)`, `b = R̄·Exp(w)·(0, −1, y)`, with
/// `Exp(w)·q = q + s (w × q) + c w × (w × q)` (Rodrigues; exact, as `exp_matrix`).
#[cfg(test)]
fn add_rows_tangent(n: &mut Normal3, v: &View<'_>, d: &Vector6<f64>, x: Vector2<f64>) {
    let c = v.c + Vector3::new(d[0], d[1], d[2]);
    let w = Vector3::new(d[3], d[4], d[5]);
    let (s, cc) = crate::kernel::sinc_cosc(w.norm_squared());
    let rot = |q: Vector3<f64>| {
        let wq = w.cross(&q);
        v.r * (q + wq * s + w.cross(&wq) * cc)
    };
    n.add_row(&rot(Vector3::new(-1.0, 0.0, x.x)), &c);
    n.add_row(&rot(Vector3::new(0.0, -1.0, x.y)), &c);
}

/// The intersected point for explicit perturbations: per view 6 pose values (mm, rad) and 2
/// pixel offsets (px). The same model as the draw loop.
#[cfg(test)]
pub(crate) fn intersect_perturbed(views: &[View<'_>], delta: &[f64]) -> Vector3<f64> {
    let mut n = Normal3::default();
    for (j, v) in views.iter().enumerate() {
        let d = &delta[NORMALS_PER_VIEW * j..NORMALS_PER_VIEW * (j + 1)];
        let delta = Vector6::from_column_slice(&d[..6]);
        let x = undistort(v, Vector2::new(d[6], d[7]));
        if v.euler {
            let (r, c) = perturbed_pose(v, &delta);
            n.add_view(&r, &c, x.x, x.y);
        } else {
            add_rows_tangent(&mut n, v, &delta, x);
        }
    }
    n.solve()
}

/// The former scalar engine of the fixed path (tests only, the statistical cross-check
/// baseline): `m` draws of one grid point into `acc`: blocks of [`LANES`] draws, the normals of
/// a block drawn row by row (row `8j + k`: view j's pose component k < 6, pixel axis k − 6), no
/// allocation except the per-call block buffer, no `Result` in the loop.
#[cfg(test)]
pub(crate) fn run_chunk_fixed<R: rand::Rng>(
    views: &[View<'_>],
    chain: Option<&Chain>,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let nd = crate::kernel::ziggurat::FastNormal::new();
    let rows = NORMALS_PER_VIEW * views.len();
    let mut e = vec![[0.0f64; LANES]; rows];
    let mut eps = vec![0.0; chain.map_or(0, |c| 6 * c.len())];
    let mut drawn = chain.map_or_else(Vec::new, |c| c.nominal().to_vec());
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        for row in e.iter_mut() {
            nd.fill(rng, row);
        }
        #[allow(clippy::needless_range_loop)] // lane d indexes the 8 normal rows of each view
        for d in 0..b {
            if let Some(chain) = chain {
                chain.draw_into(rng, &mut eps, &mut drawn);
            }
            let mut n = Normal3::default();
            for (j, v) in views.iter().enumerate() {
                let k = NORMALS_PER_VIEW * j;
                let (r, c) = match (v.source, chain) {
                    (Some(i), Some(chain)) => {
                        // The chain camera's error as a rigid body: the same centre shift and
                        // the same world-frame rotation.
                        let nom = &chain.nominal()[i];
                        let dr = drawn[i].rotation * nom.rotation.transpose();
                        (dr * v.r, v.c + (drawn[i].position_mm - nom.position_mm))
                    }
                    _ => {
                        let eps6 = Vector6::from_fn(|q, _| e[k + q][d]);
                        let delta = match v.diag {
                            Some(sd) => sd.component_mul(&eps6),
                            None => v.l * eps6,
                        };
                        let du = Vector2::new(e[k + 6][d], e[k + 7][d]) * v.sigma_px;
                        let x = undistort(v, du);
                        if v.euler {
                            let (r, c) = perturbed_pose(v, &delta);
                            n.add_view(&r, &c, x.x, x.y);
                        } else {
                            add_rows_tangent(&mut n, v, &delta, x);
                        }
                        continue;
                    }
                };
                let du = Vector2::new(e[k + 6][d], e[k + 7][d]) * v.sigma_px;
                let x = undistort(v, du);
                n.add_view(&r, &c, x.x, x.y);
            }
            acc.push(&n.solve());
        }
        done += b;
    }
}

/// First-order covariance (mm²) of the intersection of `views` at `point` (observers
/// independent): pose noise through the DLT, pixel noise through the lens's Jacobian.
///
/// With rows `a = x·c₃ − c₁`, `b = y·c₃ − c₂` (zero residual at the nominal) and
/// `A = Σ(aaᵀ + bbᵀ)`: `dX = A⁻¹ Σ_rows [a aᵀ δC − a (δa·(X − C))]`.
pub(crate) fn linear_covariance(views: &[View<'_>], point: &Vector3<f64>) -> Matrix3<f64> {
    let rows = |v: &View<'_>, r: &Matrix3<f64>| dlt_rows(r, v.n0.x, v.n0.y);
    let mut a = Matrix3::zeros();
    for v in views {
        for q in rows(v, &v.r) {
            a += q * q.transpose();
        }
    }
    let Some(ai) = a.try_inverse() else {
        return Matrix3::from_element(f64::NAN);
    };
    let mut cov = Matrix3::zeros();
    for v in views {
        let (jp, jpx) = view_jacobian(v, point, &ai);
        let sp = v.l * v.l.transpose();
        cov += jp * sp * jp.transpose() + jpx * jpx.transpose() * (v.sigma_px * v.sigma_px);
    }
    cov
}

/// `ai·A·∂X/∂(pose)` (3 × 6) and `ai·A·∂X/∂(pixel)` (3 × 2) of view `v` at `point` (`A`: the
/// DLT normal matrix): `ai = A⁻¹` gives the Jacobian itself, the identity gives the factors of
/// a [`LinearTerm`].
fn view_jacobian(
    v: &View<'_>,
    point: &Vector3<f64>,
    ai: &Matrix3<f64>,
) -> (nalgebra::Matrix3x6<f64>, nalgebra::Matrix3x2<f64>) {
    let rows = |v: &View<'_>, r: &Matrix3<f64>| dlt_rows(r, v.n0.x, v.n0.y);
    let ai = *ai;
    {
        let [ra, rb] = rows(v, &v.r);
        let xc = point - v.c;
        // Pose block (3 × 6): centre, then rotation.
        let mut jp = nalgebra::Matrix3x6::zeros();
        let jc = ai * (ra * ra.transpose() + rb * rb.transpose());
        jp.fixed_view_mut::<3, 3>(0, 0).copy_from(&jc);
        let drs: [Matrix3<f64>; 3] = if v.euler {
            crashrig_geometry::opk::d_rotation_d_opk(v.opk.x, v.opk.y, v.opk.z)
        } else {
            [0, 1, 2].map(|m| v.r * Vector3::ith(m, 1.0).cross_matrix())
        };
        for (m, dr) in drs.iter().enumerate() {
            let [da, db] = rows(v, dr);
            let col = -(ai * (ra * da.dot(&xc) + rb * db.dot(&xc)));
            jp.set_column(3 + m, &col);
        }
        // Pixel block (3 × 2): normalized x, y, then through ∂normalized/∂pixel.
        let c3 = v.r.column(2).into_owned();
        let g = -c3.dot(&xc);
        let jn = nalgebra::Matrix3x2::from_columns(&[ai * ra * g, ai * rb * g]);
        let jpx = jn * v.jinv;
        (jp, jpx)
    }
}

/// One observer's additive share of the first-order covariance of the forward intersection at
/// a grid point (observers independent). With the DLT normal matrix `A = Σⱼ normalⱼ` and
/// `N = Σⱼ noiseⱼ`, the intersection's first-order covariance is `A⁻¹ N A⁻¹`
/// ([`LinearTerm::covariance`]): a layout's covariance is a sum over its observers, so a search
/// over layouts adds 3 × 3 matrices instead of re-deriving Jacobians (`docs/PLACE.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearTerm {
    /// This view's rows of the DLT normal matrix, `aaᵀ + bbᵀ` (`I − ddᵀ` for an aimed view).
    pub normal: Matrix3<f64>,
    /// `K Σ Kᵀ + σ²_px K_px K_pxᵀ`: the view's pose covariance Σ and pixel noise through the
    /// derivatives `K` of the DLT right-hand side (the Jacobian without the `A⁻¹`).
    pub noise: Matrix3<f64>,
}

impl LinearTerm {
    /// The zero term (no observer).
    pub fn zero() -> Self {
        LinearTerm {
            normal: Matrix3::zeros(),
            noise: Matrix3::zeros(),
        }
    }

    /// Adds another observer's term.
    pub fn add(&mut self, other: &LinearTerm) {
        self.normal += other.normal;
        self.noise += other.noise;
    }

    /// The first-order covariance `A⁻¹ N A⁻¹` (mm²) of a sum of terms; NaN when `A` is
    /// singular (fewer than two independent lines of sight).
    pub fn covariance(&self) -> Matrix3<f64> {
        match self.normal.try_inverse() {
            Some(ai) => ai * self.noise * ai.transpose(),
            None => Matrix3::from_element(f64::NAN),
        }
    }
}

/// The [`LinearTerm`] of every observer of `setup` at `point`, `None` where it does not see
/// the point.
pub(crate) fn linear_terms(
    setup: &Setup<'_>,
    point: &Vector3<f64>,
) -> Result<Vec<Option<LinearTerm>>, Error> {
    (0..setup.grid.observers.len())
        .map(|k| {
            Ok(view_of(setup, k, point)?.map(|v| {
                let [ra, rb] = dlt_rows(&v.r, v.n0.x, v.n0.y);
                let (jp, jpx) = view_jacobian(&v, point, &Matrix3::identity());
                let sp = v.l * v.l.transpose();
                LinearTerm {
                    normal: ra * ra.transpose() + rb * rb.transpose(),
                    noise: jp * sp * jp.transpose()
                        + jpx * jpx.transpose() * (v.sigma_px * v.sigma_px),
                }
            }))
        })
        .collect()
}

pub(crate) fn not_measurable(point: &Vector3<f64>, seen: usize) -> PointStats {
    let nan3 = Vector3::from_element(f64::NAN);
    PointStats {
        point: *point,
        count: 0,
        mean_mm: nan3,
        covariance: Matrix3::from_element(f64::NAN),
        sigma_mm: nan3,
        sigma_max_mm: f64::NAN,
        linear_covariance: Matrix3::from_element(f64::NAN),
        observers_seen: seen,
        converged: None,
    }
}

fn finish(point: &Vector3<f64>, views: &[View<'_>], m: &Acc3) -> PointStats {
    let sigma = m.std_dev();
    PointStats {
        point: *point,
        count: m.count(),
        mean_mm: m.mean(),
        covariance: m.covariance(),
        sigma_mm: sigma,
        sigma_max_mm: sigma.max(),
        linear_covariance: linear_covariance(views, point),
        observers_seen: views.len(),
        converged: None,
    }
}

/// The path of a map with fixed observers (and any aimed ones): each point's views.
pub(crate) struct FixedPath<'s, 'a> {
    setup: &'s Setup<'a>,
    points: &'s [Vector3<f64>],
    /// σ of the aimed views' normalized coordinates.
    pixel: Option<f64>,
}

impl<'s, 'a> FixedPath<'s, 'a> {
    /// The fixed path of `setup` at `points`.
    pub(crate) fn new(setup: &'s Setup<'a>, points: &'s [Vector3<f64>]) -> Self {
        FixedPath {
            setup,
            points,
            pixel: setup.pixel.map(|p| p.sigma_normalized()),
        }
    }
}

impl<'a> MapPath<'a> for FixedPath<'_, 'a> {
    type Extra = Vec<View<'a>>;

    fn plan(&self, p: usize) -> Result<Planned<'a, Vec<View<'a>>>, Error> {
        let vs = views(self.setup, &self.points[p])?;
        let chain = self.setup.chain;
        Ok(Planned {
            kernel: crate::block::layout(vs.iter().map(|v| spec(v, chain, self.pixel)), chain),
            extra: vs,
        })
    }

    fn finish(
        &self,
        p: usize,
        planned: &Planned<'a, Vec<View<'a>>>,
        draws: Option<&Acc3>,
    ) -> PointStats {
        let (point, views) = (&self.points[p], &planned.extra);
        match draws {
            Some(m) if views.len() >= 2 => finish(point, views, m),
            _ => not_measurable(point, views.len()),
        }
    }

    #[cfg(test)]
    fn legacy(&self, extra: &Vec<View<'a>>, seed: u64, task: u64, m: usize, acc: &mut Acc3) {
        let mut rng = crashrig_stats::stream(seed, task);
        run_chunk_fixed(extra, self.setup.chain, &mut rng, m, acc);
    }
}

#[cfg(test)]
mod tests;
