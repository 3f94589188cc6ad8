//! The engine's vocabulary: cameras and links with their noise ([`Camera`], [`PoseSigma`],
//! [`RotationNoise`]), the grid study ([`Grid`], [`Axis`], [`Observer`], [`Aim`],
//! [`FixedCamera`], [`PixelNoise`], [`Adaptive`], [`Tolerance`]) and a whole [`Scenario`] —
//! plain validated values, whatever front end made them (the builders, the TOML reader of
//! `scenario` (feature `scenario`), the study). Lengths in mm, angles in radians.

use crate::error::Error;
use crashrig_camera::Camera as Lens;
use crashrig_geometry::UncertainPose;
use nalgebra::{Matrix3, Matrix6, Vector3};
use std::path::PathBuf;

/// How rotation noise is applied to a pose (fixed semantics, see the crate docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RotationNoise {
    /// `R · Exp([σω·ε₁, σφ·ε₂, σκ·ε₃])`: small rotations about the camera's own axes.
    Tangent,
    /// ω, φ, κ each get `N(0, σ)` added.
    Euler,
}

/// Standard deviations of a pose (independent Gaussian components).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseSigma {
    /// σ of the projection-centre coordinates (mm; world axes for a camera, parent axes for a
    /// link, world axes for an observer).
    pub position_mm: Vector3<f64>,
    /// σ of the three rotation components (rad), meaning fixed by [`RotationNoise`].
    pub angles_rad: Vector3<f64>,
}

/// One camera of the chain: a world pose (no parent) or a link `parent_from_cam`.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Unique name.
    pub name: String,
    /// Index of the parent camera in [`Scenario::cameras`], `None` for a world pose.
    pub parent: Option<usize>,
    /// The nominal `world_from_cam` (or `parent_from_cam` for a link; its translation is the
    /// projection centre / base, mm) with the covariance of its noise (mm, rad).
    ///
    /// For [`RotationNoise::Tangent`] the covariance is the contract's tangent covariance. For
    /// [`RotationNoise::Euler`] (σ keys with `rotation_noise = "euler"`) it is diagonal and
    /// its rotation block holds the variances of ω, φ, κ (rad²).
    pub pose: UncertainPose,
    /// ω, φ, κ (rad) of the nominal rotation as given (the Euler noise is added to these).
    pub angles_rad: Vector3<f64>,
    /// How this camera's rotation noise acts: `Tangent` for `covariance_tangent` and `from`,
    /// the scenario's `rotation_noise` for the σ keys.
    pub rotation_noise: RotationNoise,
    /// The result file a `from = "…"` link was read from (path as resolved; its kind,
    /// `calibrate` or `bootstrap`, decided which covariance was taken: `docs/SCENARIO.md`).
    pub from: Option<PathBuf>,
}

impl Camera {
    /// Nominal projection centre (mm): in the world, or in the parent's frame (the base).
    pub fn position_mm(&self) -> Vector3<f64> {
        self.pose.center()
    }

    /// σ of the noise components (diagonal of the covariance; mm, rad).
    pub fn sigma(&self) -> PoseSigma {
        PoseSigma {
            position_mm: self.pose.sigma_position(),
            angles_rad: self.pose.sigma_rotation(),
        }
    }
}

/// Where an observer's pose noise comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)] // a few observers per scenario; Copy is worth the bytes
pub enum ObserverSigma {
    /// Given σ values (rotation meaning from the scenario's [`RotationNoise`]).
    Given(PoseSigma),
    /// A full tangent covariance (`covariance_tangent`; mm, rad; always tangent noise).
    Covariance(Matrix6<f64>),
    /// The propagated world-pose covariance of camera `index` of the chain
    /// (`sigma_from = "name"`); with `correlated = true` the observer takes that camera's
    /// joint chain draw instead.
    From(usize),
}

/// A camera in the interior: aimed at every grid point (the paper) or fixed with a lens.
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    /// Label for plots (`name`, default `obs<i>`).
    pub name: String,
    /// Projection centre in the world (mm).
    pub position_mm: Vector3<f64>,
    /// Its noise.
    pub sigma: ObserverSigma,
    /// How it points its camera (`aim`, default `"point"`).
    pub aim: Aim,
}

/// A regularly spaced axis: `count` values from `start` to `stop`, both ends included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// First value (mm).
    pub start: f64,
    /// Last value (mm).
    pub stop: f64,
    /// Number of values (≥ 1; with 1 only `start` is used).
    pub count: usize,
}

impl Axis {
    /// What is wrong with the axis as a grid axis, if anything: the values must be finite and
    /// strictly increasing (a reversed axis, or start = stop with a count above 1, is refused;
    /// a count of 1 uses `start` alone). The one check of the scenario and study readers, made
    /// where the key is read, before any work.
    ///
    /// ```
    /// use crashrig_mc::Axis;
    /// let axis = |start, stop, count| Axis { start, stop, count };
    /// assert_eq!(axis(0.0, 2000.0, 11).problem(), None);
    /// assert_eq!(axis(500.0, 500.0, 1).problem(), None);
    /// assert!(axis(2000.0, 0.0, 11).problem().is_some());
    /// assert!(axis(500.0, 500.0, 3).problem().is_some());
    /// ```
    pub fn problem(&self) -> Option<&'static str> {
        if !(self.start.is_finite() && self.stop.is_finite()) {
            return Some("start and stop must be finite");
        }
        if self.count == 0 {
            return Some("the count must be at least 1");
        }
        if self.count == 1 {
            return None;
        }
        if self.stop < self.start {
            return Some("stop must not be below start");
        }
        if self.stop == self.start {
            return Some(
                "start = stop needs a count of 1 (the values must be strictly increasing)",
            );
        }
        // Each value `start + step·i` is within one ulp of the largest magnitude M of its exact
        // value, so a step above 4·ε·M (two ulps) keeps them strictly increasing; checked
        // without building the values (the count is not bounded yet).
        let magnitude = self.start.abs().max(self.stop.abs());
        let step = (self.stop - self.start) / (self.count - 1) as f64;
        if step <= 4.0 * f64::EPSILON * magnitude {
            return Some(
                "the values are not strictly increasing (the step is below the rounding of the numbers)",
            );
        }
        None
    }

    /// The `count` values.
    pub fn values(&self) -> Vec<f64> {
        if self.count == 1 {
            return vec![self.start];
        }
        let step = (self.stop - self.start) / (self.count - 1) as f64;
        (0..self.count)
            .map(|i| {
                if i + 1 == self.count {
                    self.stop
                } else {
                    self.start + step * i as f64
                }
            })
            .collect()
    }
}

/// Pixel measurement noise: the observation is the principal point plus `N(0, σ_px)` per
/// image axis, converted to normalized coordinates with `focal_px`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelNoise {
    /// σ of each image coordinate (px).
    pub sigma_px: f64,
    /// Focal length (px).
    pub focal_px: f64,
}

impl PixelNoise {
    /// σ in normalized image coordinates (σ_px / f).
    pub fn sigma_normalized(&self) -> f64 {
        self.sigma_px / self.focal_px
    }
}

/// Adaptive number of draws per grid point (GUM Supplement 1, JCGM 101:2008 §7.9).
///
/// Batches of [`Adaptive::batch`] draws run until, after `h ≥ 4` batches, twice the standard
/// deviation of the average of the per-batch values, `2·s/√h`, is at most the numerical
/// tolerance δ of each axis for both the per-batch mean coordinate and the per-batch σ (JCGM 101
/// §7.9.4 k, without the coverage-interval endpoints), or until [`Adaptive::max_samples`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// How δ is set: an absolute value, or JCGM 101's `ndig` significant digits of σ.
    pub tolerance: Tolerance,
    /// Draws per batch (≥ 100).
    pub batch: usize,
    /// Upper bound of draws per point.
    pub max_samples: usize,
}

/// The numerical tolerance δ of the adaptive rule (`[grid.adaptive]`: exactly one of
/// `tolerance_mm` and `ndig`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tolerance {
    /// `tolerance_mm`: δ (mm), the same for every axis and point.
    AbsoluteMm(f64),
    /// `ndig`: δ = [`ndig_tolerance`]`(σ, ndig)` of each axis's σ, recomputed from all the
    /// draws of the point after every batch (JCGM 101 §7.9.2).
    SignificantDigits(u32),
}

impl Tolerance {
    /// δ (mm) for an axis whose current standard uncertainty is `u_mm`.
    pub fn delta_mm(&self, u_mm: f64) -> f64 {
        match *self {
            Tolerance::AbsoluteMm(d) => d,
            Tolerance::SignificantDigits(ndig) => ndig_tolerance(u_mm, ndig),
        }
    }
}

/// Largest `ndig` accepted (an f64 carries about 15 significant digits).
pub const MAX_NDIG: u32 = 15;

/// JCGM 101:2008 §7.9.2: the numerical tolerance of a value `u` regarded as meaningful to
/// `ndig` significant decimal digits. Writing `u = c·10^l` with `c` an `ndig`-digit integer
/// (`10^(ndig−1) ≤ c < 10^ndig`, i.e. `l = ⌊log₁₀ u⌋ − ndig + 1`), δ = ½·10^l.
///
/// `u = 0` gives δ = 0 (an axis without spread is stable when its batches agree exactly);
/// a non-finite or negative `u` gives NaN (never met).
///
/// ```
/// use crashrig_mc::ndig_tolerance;
/// // JCGM 101 §7.9.2's example: u = 0.01234 with ndig = 2 is 12 × 10⁻³, δ = 0.0005.
/// assert!((ndig_tolerance(0.01234, 2) - 0.0005).abs() < 1e-18);
/// ```
pub fn ndig_tolerance(u: f64, ndig: u32) -> f64 {
    if u == 0.0 {
        return 0.0;
    }
    if !u.is_finite() || u < 0.0 || ndig == 0 {
        return f64::NAN;
    }
    let digits = ndig.min(MAX_NDIG) as i32;
    let mut l = u.log10().floor() as i32 - digits + 1;
    // log10 may round across a power of ten: fix l so that 10^(ndig−1) ≤ u/10^l < 10^ndig.
    let ten = |k: i32| 10f64.powi(k);
    if u >= ten(l + digits) {
        l += 1;
    } else if u < ten(l + digits - 1) {
        l -= 1;
    }
    0.5 * ten(l)
}

/// The grid study.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// x axis (mm).
    pub x: Axis,
    /// y axis (mm).
    pub y: Axis,
    /// z axis (mm); one heat map per z level.
    pub z: Axis,
    /// Threshold on σ_max (mm), default 5.
    pub threshold_mm: f64,
    /// At least two observers.
    pub observers: Vec<Observer>,
    /// Optional pixel noise (`pixel_sigma_px` and `focal_px`).
    pub pixel: Option<PixelNoise>,
    /// `correlated = true`: observers with `sigma_from` on the same chain are drawn jointly.
    pub correlated: bool,
    /// Optional adaptive number of draws (`[grid.adaptive]`).
    pub adaptive: Option<Adaptive>,
}

impl Grid {
    /// All grid points, x fastest, then y, then z (the row order of `grid.csv`).
    pub fn points(&self) -> Vec<Vector3<f64>> {
        let (xs, ys, zs) = (self.x.values(), self.y.values(), self.z.values());
        let mut out = Vec::with_capacity(xs.len() * ys.len() * zs.len());
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    out.push(Vector3::new(x, y, z));
                }
            }
        }
        out
    }
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Master seed.
    pub seed: u64,
    /// Monte Carlo draws (per grid point for the grid study).
    pub samples: usize,
    /// Rotation noise semantics.
    pub rotation_noise: RotationNoise,
    /// The cameras in file order (every `parent` index names another camera; the parent
    /// links form no cycle).
    pub cameras: Vec<Camera>,
    /// The grid study, if any.
    pub grid: Option<Grid>,
    /// Plausibility warnings found on reading (`docs/LIMITS.md`, "Plausibility warnings": a
    /// length or σ that looks typed in metres), one line each naming the file, line, key and
    /// unit, without the `warning: ` prefix. The front ends print them and carry them in their
    /// results.
    pub warnings: Vec<String>,
}

/// How an observer points its camera.
#[derive(Debug, Clone, PartialEq)]
pub enum Aim {
    /// The paper's re-aiming (`aim = "point"`, the default): the optical axis passes through
    /// every grid point, which is observed at the principal point.
    Point,
    /// A camera fixed in place (`aim = "fixed"`) with a real lens.
    Fixed(Box<FixedCamera>),
}

/// A fixed observer's orientation, lens and pixel noise.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedCamera {
    /// `R_world_from_cam` (columns: the camera's x right, y down, z forward in world axes).
    pub rotation: Matrix3<f64>,
    /// ω, φ, κ (rad) of `rotation` (`Rx(ω)·Ry(φ)·Rz(κ)`), the base of `euler` noise.
    pub angles_rad: Vector3<f64>,
    /// The lens: a COLMAP camera model with COLMAP's parameter order and pixel convention
    /// (the centre of the upper-left pixel is (0.5, 0.5)).
    pub lens: Lens,
    /// σ of each measured image coordinate (px).
    pub pixel_sigma_px: f64,
}

impl FixedCamera {
    /// The camera-frame coordinates of a world point (`R_world_from_camᵀ (X − C)`).
    pub fn cam_from_world(&self, center: &Vector3<f64>, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.transpose() * (x - center)
    }
}

/// Parents before children; a cycle is an error naming its cameras.
pub(crate) fn topological_order(cameras: &[Camera]) -> Result<Vec<usize>, Error> {
    let n = cameras.len();
    // 0 = unvisited, 1 = on the stack, 2 = done.
    let mut state = vec![0u8; n];
    let mut order = Vec::with_capacity(n);
    for start in 0..n {
        let mut path = Vec::new();
        let mut cur = Some(start);
        while let Some(i) = cur {
            match state[i] {
                2 => break,
                1 => {
                    let pos = path.iter().position(|&p| p == i).unwrap_or(0);
                    return Err(Error::Cycle {
                        cameras: path[pos..]
                            .iter()
                            .map(|&p: &usize| cameras[p].name.clone())
                            .collect(),
                    });
                }
                _ => {
                    state[i] = 1;
                    path.push(i);
                    cur = cameras[i].parent;
                }
            }
        }
        for &i in path.iter().rev() {
            state[i] = 2;
            order.push(i);
        }
    }
    Ok(order)
}

/// Smallest distance (mm) between an observer and a grid point.
pub const MIN_OBSERVER_DISTANCE_MM: f64 = 1e-6;

/// Largest distance (mm) between a correlated observer and its chain camera's nominal centre.
pub const CORRELATED_POSITION_TOLERANCE_MM: f64 = 1.0;

/// Checks of a grid against its chain (`chain_positions`: nominal world centres, `names`):
/// at least two observers, then [`check_observers`] on them (keys `grid.observer[i]`).
pub(crate) fn check_grid(
    grid: &Grid,
    chain_positions: &[Vector3<f64>],
    names: &[String],
) -> Result<(), Error> {
    if grid.observers.len() < 2 {
        return Err(Error::TooFewObservers {
            found: grid.observers.len(),
        });
    }
    check_observers(
        grid,
        &grid.observers,
        "grid.observer",
        chain_positions,
        names,
    )
}

/// Checks `observers` (errors name `{prefix}[i]`) against `grid` and its chain: correlated
/// observers at their chain camera; no aimed observer on or vertically above/below a grid
/// point. Used for a grid's own observers and for `crashrig place`'s candidates.
pub(crate) fn check_observers(
    grid: &Grid,
    observers: &[Observer],
    prefix: &str,
    chain_positions: &[Vector3<f64>],
    names: &[String],
) -> Result<(), Error> {
    // Correlated observers stand where their chain camera is (one frame for chain and grid).
    if grid.correlated {
        for (i, o) in observers.iter().enumerate() {
            if let ObserverSigma::From(c) = o.sigma {
                let nominal = chain_positions[c];
                let distance_mm = (o.position_mm - nominal).norm();
                if distance_mm > CORRELATED_POSITION_TOLERANCE_MM {
                    return Err(Error::ObserverOffChain {
                        key: format!("{prefix}[{i}].position_mm"),
                        camera: names[c].clone(),
                        nominal_mm: nominal.into(),
                        distance_mm,
                    });
                }
            }
        }
    }
    // Geometric checks against every grid point.
    for p in grid.points() {
        for (i, o) in observers.iter().enumerate() {
            if o.aim != Aim::Point {
                continue; // a fixed observer does not turn: visibility decides (grid/fixed.rs)
            }
            let d = p - o.position_mm;
            let key = format!("{prefix}[{i}]");
            if d.norm() < MIN_OBSERVER_DISTANCE_MM {
                return Err(Error::ObserverAtGridPoint {
                    key,
                    point: p.into(),
                });
            }
            if d.normalize().cross(&Vector3::z()).norm()
                < crashrig_geometry::tolerance::MIN_LOOK_AT_HORIZONTAL
            {
                return Err(Error::VerticalAim {
                    key,
                    point: p.into(),
                });
            }
        }
    }
    Ok(())
}
