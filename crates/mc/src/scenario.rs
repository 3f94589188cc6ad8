//! The scenario file (TOML): cameras, links, noise model and the grid study.
//!
//! The format is the external contract of `shared/interface.md`; every key (extensions
//! included: `covariance_tangent`, `from = "…"`, `correlated`, …) is documented in
//! `docs/SCENARIO.md`. Degrees in the file become radians here; every camera and link becomes
//! an [`UncertainPose`]. The reader is one front end of [`crate::ChainBuilder`] /
//! [`crate::GridBuilder`].

use crate::Error;
use crate::reference::ResultKind;
use crashrig_geometry::uncertain::check_covariance;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, opk, quat};
use nalgebra::{Matrix6, Vector3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod observer;
pub use observer::{Aim, FixedCamera};

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
    /// The result file a `from = "…"` link was read from (path as resolved) and its kind.
    pub from: Option<(PathBuf, ResultKind)>,
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
}

// ---------------------------------------------------------------- raw TOML ---

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScenario {
    seed: Option<u64>,
    samples: Option<i64>,
    rotation_noise: Option<String>,
    #[serde(default)]
    camera: Vec<RawCamera>,
    grid: Option<RawGrid>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    name: String,
    parent: Option<String>,
    position_mm: Option<[f64; 3]>,
    angles_deg: Option<[f64; 3]>,
    sigma_position_mm: Option<[f64; 3]>,
    sigma_angles_deg: Option<[f64; 3]>,
    covariance_tangent: Option<toml::Value>,
    from: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Num {
    I(i64),
    F(f64),
}

impl Num {
    fn f(&self) -> f64 {
        match *self {
            Num::I(i) => i as f64,
            Num::F(f) => f,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrid {
    x_mm: [Num; 3],
    y_mm: [Num; 3],
    z_mm: [Num; 3],
    threshold_mm: Option<f64>,
    pixel_sigma_px: Option<f64>,
    focal_px: Option<f64>,
    #[serde(default)]
    correlated: bool,
    adaptive: Option<RawAdaptive>,
    #[serde(default)]
    observer: Vec<RawObserver>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAdaptive {
    tolerance_mm: Option<f64>,
    ndig: Option<i64>,
    batch: Option<i64>,
    max_samples: Option<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObserver {
    name: Option<String>,
    position_mm: [f64; 3],
    sigma_position_mm: Option<[f64; 3]>,
    sigma_angles_deg: Option<[f64; 3]>,
    covariance_tangent: Option<toml::Value>,
    sigma_from: Option<String>,
    // Fixed observers (scenario/observer.rs).
    aim: Option<String>,
    angles_deg: Option<[f64; 3]>,
    look_at_mm: Option<[f64; 3]>,
    camera: Option<observer::RawLens>,
    camera_from: Option<String>,
    pixel_sigma_px: Option<f64>,
}

// -------------------------------------------------------------- validation ---

fn finite3(key: String, v: [f64; 3]) -> Result<Vector3<f64>, Error> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vector3::from(v))
    } else {
        Err(Error::Invalid {
            key,
            problem: "must be finite (no NaN or infinity)",
        })
    }
}

fn sigma3(key: String, v: [f64; 3]) -> Result<Vector3<f64>, Error> {
    let v = finite3(key.clone(), v)?;
    if v.iter().any(|x| *x < 0.0) {
        return Err(Error::Invalid {
            key,
            problem: "σ must not be negative",
        });
    }
    Ok(v)
}

fn required(key: String, v: Option<[f64; 3]>) -> Result<[f64; 3], Error> {
    v.ok_or(Error::Invalid {
        key,
        problem: "is missing",
    })
}

/// A `covariance_tangent` value: 6 rows of 6 numbers in the contract's units (mm², mm·deg,
/// deg²), symmetric and positive semi-definite; returned in mm and rad.
fn covariance_tangent(key: String, v: &toml::Value) -> Result<Mat6, Error> {
    let shape = || Error::Invalid {
        key: key.clone(),
        problem: "must be 6 rows of 6 numbers (order x y z θx θy θz; mm², mm·deg, deg²)",
    };
    let rows = v.as_array().filter(|r| r.len() == 6).ok_or_else(shape)?;
    let mut m = Mat6::zeros();
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == 6).ok_or_else(shape)?;
        for (j, x) in row.iter().enumerate() {
            m[(i, j)] = match x {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(n) => *n as f64,
                _ => return Err(shape()),
            };
        }
    }
    check_covariance(&m).map_err(|problem| Error::Covariance {
        key: key.clone(),
        problem,
    })?;
    let pose = UncertainPose::from_covariance_deg(Rigid3::identity(), m)
        .map_err(|problem| Error::Covariance { key, problem })?;
    Ok(pose.covariance)
}

fn positive(key: &str, v: f64) -> Result<f64, Error> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(Error::Invalid {
            key: key.to_string(),
            problem: "must be a finite number > 0",
        })
    }
}

fn count(key: &str, v: i64, min: i64) -> Result<usize, Error> {
    if v < min {
        return Err(Error::Invalid {
            key: key.to_string(),
            problem: match min {
                1 => "must be a positive integer",
                2 => "must be an integer ≥ 2",
                _ => "must be an integer ≥ 100",
            },
        });
    }
    usize::try_from(v).map_err(|_| Error::Invalid {
        key: key.to_string(),
        problem: "is too large",
    })
}

fn axis(key: &str, raw: &[Num; 3]) -> Result<Axis, Error> {
    let start = raw[0].f();
    let stop = raw[1].f();
    if !start.is_finite() || !stop.is_finite() {
        return Err(Error::Invalid {
            key: key.to_string(),
            problem: "start and stop must be finite",
        });
    }
    let n = match raw[2] {
        Num::I(i) => i,
        Num::F(f) if f.fract() == 0.0 && f.is_finite() => f as i64,
        Num::F(_) => {
            return Err(Error::Invalid {
                key: key.to_string(),
                problem: "the third value (count) must be a whole number",
            });
        }
    };
    let count = count(key, n, 1)?;
    if count > 1 && stop < start {
        return Err(Error::Invalid {
            key: key.to_string(),
            problem: "stop must not be below start",
        });
    }
    Ok(Axis { start, stop, count })
}

/// 1-based (line, column) of a byte offset.
/// 1-based line of a dotted scenario key such as `camera[1].position_mm`,
/// `grid.observer[0].sigma_from`, `grid.x_mm` or `seed`: the line `name = …` inside the table the
/// key's prefix names (the table's header line when the key names the table itself). Inline
/// tables and dotted keys are not searched (`None`).
pub(crate) fn key_line(text: &str, key: &str) -> Option<usize> {
    let headers: std::collections::HashSet<&str> = text.lines().filter_map(header_of).collect();
    let (base, index) = split_index(key);
    if headers.contains(base) {
        // The key names a table (or one element of an array of tables): its header line.
        return nth_header_line(text, base, index.unwrap_or(0));
    }
    let Some(dot) = key.rfind('.') else {
        // A top-level key: `key = …` before the first header.
        return text
            .lines()
            .take_while(|l| header_of(l).is_none())
            .position(|l| is_assignment_of(l, key))
            .map(|i| i + 1);
    };
    let (table_key, leaf) = (&key[..dot], &key[dot + 1..]);
    let (table, index) = split_index(table_key);
    let start = nth_header_line(text, table, index.unwrap_or(0))?;
    let found = text
        .lines()
        .enumerate()
        .skip(start)
        .take_while(|(_, l)| header_of(l).is_none())
        .find(|(_, l)| is_assignment_of(l, leaf))
        .map(|(i, _)| i + 1);
    // An absent key (a default, or a value checked against another table) points at its table.
    found.or(Some(start))
}

/// `("grid.observer", Some(1))` for `grid.observer[1]`, `("camera", None)` for `camera`.
fn split_index(key: &str) -> (&str, Option<usize>) {
    match key.strip_suffix(']').and_then(|k| k.rsplit_once('[')) {
        Some((base, i)) => (base, i.parse().ok()),
        None => (key, None),
    }
}

/// 1-based line of the `n`-th (0-based) header of table `name`.
fn nth_header_line(text: &str, name: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| header_of(l) == Some(name))
        .nth(n)
        .map(|(i, _)| i + 1)
}

/// Whether `line` assigns `name` (`name = …`).
fn is_assignment_of(line: &str, name: &str) -> bool {
    line.split_once('=')
        .is_some_and(|(lhs, _)| lhs.trim() == name)
}

/// `camera` for `[[camera]]`, `grid` for `[grid]` (comments after the header allowed).
fn header_of(line: &str) -> Option<&str> {
    let l = line.split('#').next().unwrap_or("").trim();
    if !l.starts_with('[') {
        return None;
    }
    let inner = l
        .strip_prefix("[[")
        .and_then(|r| r.strip_suffix("]]"))
        .or_else(|| l.strip_prefix('[').and_then(|r| r.strip_suffix(']')))?;
    Some(inner.trim())
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(offset, |p| offset - p - 1) + 1;
    (line, col)
}

impl Scenario {
    /// Reads and validates a scenario file.
    pub fn from_path(path: &Path) -> Result<Self, Error> {
        let text = crate::limits::read_text(path)?;
        Self::from_toml_str(&text, path)
    }

    /// Parses and validates scenario text; `path` names the file in error messages, and the
    /// files of `from = "…"` references are relative to its directory.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self, Error> {
        crate::limits::check_document(text, path)?;
        let raw: RawScenario = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or_else(
                || crate::limits::deep_nesting(text).unwrap_or((1, 1)),
                |span| line_col(text, span.start),
            );
            Error::Toml {
                path: PathBuf::from(path),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        let base = path.parent().unwrap_or(Path::new(""));
        Self::validate(raw, base).map_err(|e| match e.key().and_then(|k| key_line(text, k)) {
            Some(line) => Error::Located {
                path: PathBuf::from(path),
                line,
                source: Box::new(e),
            },
            None => e,
        })
    }

    fn validate(raw: RawScenario, base: &Path) -> Result<Self, Error> {
        let samples = count("samples", raw.samples.unwrap_or(2000), 2)?;
        let rotation_noise = match raw.rotation_noise.as_deref().unwrap_or("tangent") {
            "tangent" => RotationNoise::Tangent,
            "euler" => RotationNoise::Euler,
            _ => {
                return Err(Error::Invalid {
                    key: "rotation_noise".into(),
                    problem: "must be \"tangent\" or \"euler\"",
                });
            }
        };
        let mut cameras = Vec::with_capacity(raw.camera.len());
        for (i, c) in raw.camera.iter().enumerate() {
            let k = |f: &str| format!("camera[{i}].{f}");
            if c.name.is_empty() {
                return Err(Error::Invalid {
                    key: k("name"),
                    problem: "must not be empty",
                });
            }
            if cameras.iter().any(|o: &Camera| o.name == c.name) {
                return Err(Error::DuplicateName {
                    key: k("name"),
                    name: c.name.clone(),
                });
            }
            let (pose, angles_rad, noise, from) = camera_pose(c, &k, rotation_noise, base)?;
            cameras.push(Camera {
                name: c.name.clone(),
                parent: None,
                pose,
                angles_rad,
                rotation_noise: noise,
                from,
            });
        }
        let find = |key: String, name: &str| {
            cameras
                .iter()
                .position(|c| c.name == name)
                .ok_or(Error::UnknownCamera {
                    key,
                    name: name.to_string(),
                })
        };
        let parents: Vec<Option<usize>> = raw
            .camera
            .iter()
            .enumerate()
            .map(|(i, c)| {
                c.parent
                    .as_deref()
                    .map(|p| find(format!("camera[{i}].parent"), p))
                    .transpose()
            })
            .collect::<Result<_, _>>()?;
        for (c, p) in cameras.iter_mut().zip(&parents) {
            c.parent = *p;
        }
        topological_order(&cameras)?;
        let grid = raw
            .grid
            .map(|g| validate_grid(g, &cameras, base))
            .transpose()?;
        Ok(Scenario {
            seed: raw.seed.unwrap_or(0),
            samples,
            rotation_noise,
            cameras,
            grid,
        })
    }

    /// Nominal world poses `world_from_cam` of the cameras, in file order.
    pub fn nominal_world_poses(&self) -> Vec<Rigid3> {
        nominal_world_poses(&self.cameras)
    }

    /// Index of the camera called `name`.
    pub fn camera_index(&self, name: &str) -> Option<usize> {
        self.cameras.iter().position(|c| c.name == name)
    }
}

/// A camera's pose, its given ω φ κ (rad), its noise kind and the reference it came from.
type CameraPose = (
    UncertainPose,
    Vector3<f64>,
    RotationNoise,
    Option<(PathBuf, ResultKind)>,
);

/// The pose of one `[[camera]]`: from a `from = "…"` result, or from `position_mm` /
/// `angles_deg` with `covariance_tangent` or the σ keys.
fn camera_pose(
    c: &RawCamera,
    k: &dyn Fn(&str) -> String,
    rotation_noise: RotationNoise,
    base: &Path,
) -> Result<CameraPose, Error> {
    if let Some(f) = &c.from {
        if c.parent.is_none() {
            return Err(Error::Invalid {
                key: k("from"),
                problem: "takes a link (A_from_B) from a calibrate or bootstrap result: the camera needs a `parent`",
            });
        }
        for (name, given) in [
            ("position_mm", c.position_mm.is_some()),
            ("angles_deg", c.angles_deg.is_some()),
            ("sigma_position_mm", c.sigma_position_mm.is_some()),
            ("sigma_angles_deg", c.sigma_angles_deg.is_some()),
            ("covariance_tangent", c.covariance_tangent.is_some()),
        ] {
            if given {
                return Err(Error::Invalid {
                    key: k(name),
                    problem: "is taken from the `from` result; remove it",
                });
            }
        }
        let file = base.join(f);
        let (kind, pose) = crate::reference::link_from_result_json(&file).map_err(|e| match e {
            Error::Reference { file, problem, .. } => Error::Reference {
                key: Some(k("from")),
                file,
                problem,
            },
            other => other,
        })?;
        let o = opk::opk_from_rotation(&pose.rotation());
        let angles = Vector3::new(o.omega, o.phi, o.kappa);
        return Ok((pose, angles, RotationNoise::Tangent, Some((file, kind))));
    }
    let position = finite3(k("position_mm"), required(k("position_mm"), c.position_mm)?)?;
    let angles =
        finite3(k("angles_deg"), required(k("angles_deg"), c.angles_deg)?)?.map(f64::to_radians);
    let nominal = quat::rigid_from_rotation(
        &opk::rotation_from_opk(angles.x, angles.y, angles.z),
        &position,
    );
    match (
        &c.covariance_tangent,
        c.sigma_position_mm,
        c.sigma_angles_deg,
    ) {
        (Some(v), None, None) => {
            let covariance = covariance_tangent(k("covariance_tangent"), v)?;
            Ok((
                UncertainPose {
                    b_from_a: nominal,
                    covariance,
                },
                angles,
                RotationNoise::Tangent,
                None,
            ))
        }
        (Some(_), _, _) => Err(Error::Invalid {
            key: k("covariance_tangent"),
            problem: "give either covariance_tangent or sigma_position_mm with sigma_angles_deg, not both",
        }),
        (None, Some(p), Some(a)) => Ok((
            UncertainPose::from_sigmas(
                nominal,
                sigma3(k("sigma_position_mm"), p)?,
                sigma3(k("sigma_angles_deg"), a)?.map(f64::to_radians),
            ),
            angles,
            rotation_noise,
            None,
        )),
        (None, None, _) => Err(Error::Invalid {
            key: k("sigma_position_mm"),
            problem: "is missing (or give covariance_tangent, or `from` for a link)",
        }),
        (None, _, None) => Err(Error::Invalid {
            key: k("sigma_angles_deg"),
            problem: "is missing (or give covariance_tangent, or `from` for a link)",
        }),
    }
}

/// Nominal `world_from_cam` of every camera (file order); the parent links must be acyclic.
pub(crate) fn nominal_world_poses(cameras: &[Camera]) -> Vec<Rigid3> {
    let mut out = vec![Rigid3::identity(); cameras.len()];
    // A validated scenario has no cycle; an edited one falls back to file order.
    let order = topological_order(cameras).unwrap_or_else(|_| (0..cameras.len()).collect());
    for i in order {
        let own = cameras[i].pose.b_from_a;
        out[i] = match cameras[i].parent {
            Some(p) if p < cameras.len() => out[p] * own,
            _ => own,
        };
    }
    out
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

/// Largest distance (mm) between a correlated observer and its chain camera's nominal centre.
pub const CORRELATED_POSITION_TOLERANCE_MM: f64 = 1.0;

fn validate_grid(g: RawGrid, cameras: &[Camera], base: &Path) -> Result<Grid, Error> {
    let x = axis("grid.x_mm", &g.x_mm)?;
    let y = axis("grid.y_mm", &g.y_mm)?;
    let z = axis("grid.z_mm", &g.z_mm)?;
    let threshold_mm = positive("grid.threshold_mm", g.threshold_mm.unwrap_or(5.0))?;
    let pixel = match (g.pixel_sigma_px, g.focal_px) {
        (None, None) => None,
        (Some(s), Some(f)) => {
            if !s.is_finite() || s < 0.0 {
                return Err(Error::Invalid {
                    key: "grid.pixel_sigma_px".into(),
                    problem: "σ must be finite and not negative",
                });
            }
            Some(PixelNoise {
                sigma_px: s,
                focal_px: positive("grid.focal_px", f)?,
            })
        }
        (Some(_), None) => {
            return Err(Error::Invalid {
                key: "grid.focal_px".into(),
                problem: "is required with pixel_sigma_px",
            });
        }
        (None, Some(_)) => {
            return Err(Error::Invalid {
                key: "grid.pixel_sigma_px".into(),
                problem: "is required with focal_px",
            });
        }
    };
    let adaptive = g
        .adaptive
        .map(|a| -> Result<Adaptive, Error> {
            let batch = count("grid.adaptive.batch", a.batch.unwrap_or(1000), 100)?;
            let tolerance = match (a.tolerance_mm, a.ndig) {
                (Some(t), None) => {
                    Tolerance::AbsoluteMm(positive("grid.adaptive.tolerance_mm", t)?)
                }
                (None, Some(n)) if (1..=i64::from(MAX_NDIG)).contains(&n) => {
                    Tolerance::SignificantDigits(n as u32)
                }
                (None, Some(_)) => {
                    return Err(Error::Invalid {
                        key: "grid.adaptive.ndig".into(),
                        problem: "must be an integer from 1 to 15 (significant digits of σ)",
                    });
                }
                (Some(_), Some(_)) => {
                    return Err(Error::Invalid {
                        key: "grid.adaptive.ndig".into(),
                        problem: "give either tolerance_mm or ndig, not both",
                    });
                }
                (None, None) => {
                    return Err(Error::Invalid {
                        key: "grid.adaptive".into(),
                        problem: "give exactly one of tolerance_mm (mm) and ndig (significant digits of σ)",
                    });
                }
            };
            Ok(Adaptive {
                tolerance,
                batch,
                max_samples: count(
                    "grid.adaptive.max_samples",
                    a.max_samples.unwrap_or(1_000_000),
                    1,
                )?,
            })
        })
        .transpose()?;
    if g.observer.len() < 2 {
        return Err(Error::TooFewObservers {
            found: g.observer.len(),
        });
    }
    let mut observers = Vec::with_capacity(g.observer.len());
    for (i, o) in g.observer.iter().enumerate() {
        let k = |f: &str| format!("grid.observer[{i}].{f}");
        let sigma = match (
            &o.sigma_from,
            &o.covariance_tangent,
            o.sigma_position_mm,
            o.sigma_angles_deg,
        ) {
            (Some(name), None, None, None) => {
                let idx =
                    cameras
                        .iter()
                        .position(|c| &c.name == name)
                        .ok_or(Error::UnknownCamera {
                            key: k("sigma_from"),
                            name: name.clone(),
                        })?;
                ObserverSigma::From(idx)
            }
            (None, Some(v), None, None) => {
                ObserverSigma::Covariance(covariance_tangent(k("covariance_tangent"), v)?)
            }
            (None, None, Some(p), Some(a)) => ObserverSigma::Given(PoseSigma {
                position_mm: sigma3(k("sigma_position_mm"), p)?,
                angles_rad: sigma3(k("sigma_angles_deg"), a)?.map(f64::to_radians),
            }),
            (Some(_), _, _, _) => {
                return Err(Error::Invalid {
                    key: k("sigma_from"),
                    problem: "give one of sigma_from, covariance_tangent, or sigma_position_mm with sigma_angles_deg",
                });
            }
            (None, Some(_), _, _) => {
                return Err(Error::Invalid {
                    key: k("covariance_tangent"),
                    problem: "give either covariance_tangent or sigma_position_mm with sigma_angles_deg, not both",
                });
            }
            (None, None, None, _) => {
                return Err(Error::Invalid {
                    key: k("sigma_position_mm"),
                    problem: "is missing (or give sigma_from or covariance_tangent)",
                });
            }
            (None, None, _, None) => {
                return Err(Error::Invalid {
                    key: k("sigma_angles_deg"),
                    problem: "is missing (or give sigma_from or covariance_tangent)",
                });
            }
        };
        let position_mm = finite3(k("position_mm"), o.position_mm)?;
        observers.push(Observer {
            name: o.name.clone().unwrap_or_else(|| format!("obs{i}")),
            aim: observer::aim_from_raw(i, o, &position_mm, base)?,
            position_mm,
            sigma,
        });
    }
    let grid = Grid {
        x,
        y,
        z,
        threshold_mm,
        observers,
        pixel,
        correlated: g.correlated,
        adaptive,
    };
    let world: Vec<Vector3<f64>> = nominal_world_poses(cameras)
        .iter()
        .map(|p| p.translation.vector)
        .collect();
    let names: Vec<String> = cameras.iter().map(|c| c.name.clone()).collect();
    check_grid(&grid, &world, &names)?;
    Ok(grid)
}

/// Checks of a grid against its chain (`chain_positions`: nominal world centres, `names`):
/// at least two observers; correlated observers at their chain camera; no observer on or
/// vertically above/below a grid point.
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
    // Correlated observers stand where their chain camera is (one frame for chain and grid).
    if grid.correlated {
        for (i, o) in grid.observers.iter().enumerate() {
            if let ObserverSigma::From(c) = o.sigma {
                let nominal = chain_positions[c];
                let distance_mm = (o.position_mm - nominal).norm();
                if distance_mm > CORRELATED_POSITION_TOLERANCE_MM {
                    return Err(Error::ObserverOffChain {
                        key: format!("grid.observer[{i}].position_mm"),
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
        for (i, o) in grid.observers.iter().enumerate() {
            if o.aim != Aim::Point {
                continue; // a fixed observer does not turn: visibility decides (grid/fixed.rs)
            }
            let d = p - o.position_mm;
            let key = format!("grid.observer[{i}]");
            if d.norm() < crate::MIN_OBSERVER_DISTANCE_MM {
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

#[cfg(test)]
mod tests;
