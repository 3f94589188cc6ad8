//! The scenario file (TOML): cameras, links, noise model and the grid study.
//!
//! The format is the contract of `docs/REFERENCE.md`; every key (extensions
//! included: `covariance_tangent`, `from = "…"`, `correlated`, …) is documented in
//! `docs/SCENARIO.md`. Degrees in the file become radians here; every camera and link becomes
//! an [`UncertainPose`]. The reader is one front end of [`crate::ChainBuilder`] /
//! [`crate::GridBuilder`].

use crate::error::Error;
use crate::limits::key_line;
use crate::model::{
    Adaptive, Axis, Camera, Grid, MAX_NDIG, Observer, ObserverSigma, PixelNoise, PoseSigma,
    RotationNoise, Scenario, Tolerance, check_observers, topological_order,
};
use crashrig_geometry::uncertain::check_covariance;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, opk, quat};
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod candidates;
mod observer;
pub mod plausible;
pub use candidates::{candidates_from_toml_str, read_candidates};
pub use observer::{AimKeys, LensKeys, aim_from_keys};

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
    camera: Option<observer::LensKeys>,
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
    let axis = Axis { start, stop, count };
    match axis.problem() {
        Some(problem) => Err(Error::Invalid {
            key: key.to_string(),
            problem,
        }),
        None => Ok(axis),
    }
}

/// A TOML syntax or type error of `text` (read from `path`), located at its line and column
/// (a nesting too deep for the parser at the place it gives up) and naming the key of the value
/// it is about: the one mapping of the scenario and the candidates readers.
pub(crate) fn toml_error(e: &toml::de::Error, text: &str, path: &Path) -> Error {
    let (line, column) = e.span().map_or_else(
        || crate::limits::deep_nesting(text).unwrap_or((1, 1)),
        |span| line_col(text, span.start),
    );
    let message = e.message().trim();
    let key = e
        .span()
        .and_then(|span| crashrig_input::location::toml_value_key(text, span.start));
    Error::Toml {
        path: PathBuf::from(path),
        line,
        column,
        message: key.map_or_else(|| message.to_string(), |k| format!("`{k}`: {message}")),
    }
}

/// 1-based (line, column) of a byte offset.
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
        Self::parse(text, path, 2)
    }

    /// Reads a scenario as the base layout of `crashrig place`: like [`Scenario::from_path`],
    /// except that its `[grid]` may have fewer than two observers (the candidates add the
    /// rest).
    pub fn from_path_for_placement(path: &Path) -> Result<Self, Error> {
        let text = crate::limits::read_text(path)?;
        Self::parse(&text, path, 0)
    }

    /// [`Scenario::from_path_for_placement`] on the text of a scenario (errors name `path`).
    pub fn from_toml_str_for_placement(text: &str, path: &Path) -> Result<Self, Error> {
        Self::parse(text, path, 0)
    }

    fn parse(text: &str, path: &Path, min_observers: usize) -> Result<Self, Error> {
        crate::limits::check_document(text, path)?;
        let raw: RawScenario = toml::from_str(text).map_err(|e| toml_error(&e, text, path))?;
        let base = path.parent().unwrap_or(Path::new(""));
        let mut notes = raw_plausibility(&raw);
        let mut scenario = Self::validate(raw, base, min_observers).map_err(|e| {
            match e.key().and_then(|k| key_line(text, k)) {
                Some(line) => Error::Located {
                    path: PathBuf::from(path),
                    line,
                    source: Box::new(e),
                },
                None => e,
            }
        })?;
        notes.extend(observer_plausibility(&scenario));
        scenario.warnings = notes
            .into_iter()
            .map(|(key, message)| match key_line(text, &key) {
                Some(line) => format!("{}:{line}: `{key}` {message}", path.display()),
                None => format!("{}: `{key}` {message}", path.display()),
            })
            .collect();
        Ok(scenario)
    }

    fn validate(raw: RawScenario, base: &Path, min_observers: usize) -> Result<Self, Error> {
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
            .map(|g| validate_grid(g, &cameras, base, min_observers))
            .transpose()?;
        Ok(Scenario {
            seed: raw.seed.unwrap_or(0),
            samples,
            rotation_noise,
            cameras,
            grid,
            warnings: Vec::new(),
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

/// A camera's pose, its given ω φ κ (rad), its noise kind and the result file it came from.
type CameraPose = (UncertainPose, Vector3<f64>, RotationNoise, Option<PathBuf>);

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
        let (_, pose) = crate::reference::link_from_result_json(&file).map_err(|e| match e {
            Error::Reference { file, problem, .. } => Error::Reference {
                key: Some(k("from")),
                file,
                problem,
            },
            other => other,
        })?;
        let o = opk::opk_from_rotation(&pose.rotation());
        let angles = Vector3::new(o.omega, o.phi, o.kappa);
        return Ok((pose, angles, RotationNoise::Tangent, Some(file)));
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

/// The `[grid]` table; `min_observers` is 2 for a grid study, 0 for the base layout of
/// `crashrig place` (its candidates add the rest).
fn validate_grid(
    g: RawGrid,
    cameras: &[Camera],
    base: &Path,
    min_observers: usize,
) -> Result<Grid, Error> {
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
    if g.observer.len() < min_observers {
        return Err(Error::TooFewObservers {
            found: g.observer.len(),
        });
    }
    let observers = g
        .observer
        .iter()
        .enumerate()
        .map(|(i, o)| observer_from_raw("grid.observer", i, o, cameras, base))
        .collect::<Result<Vec<_>, _>>()?;
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
    check_observers(&grid, &grid.observers, "grid.observer", &world, &names)?;
    Ok(grid)
}

/// One observer table (`{prefix}[i]`: a scenario's `[[grid.observer]]` or a `[[candidate]]` of
/// `crashrig place`): its noise and aim; errors name `{prefix}[i].key`.
fn observer_from_raw(
    prefix: &str,
    i: usize,
    o: &RawObserver,
    cameras: &[Camera],
    base: &Path,
) -> Result<Observer, Error> {
    let k = |f: &str| format!("{prefix}[{i}].{f}");
    let sigma = match (
        &o.sigma_from,
        &o.covariance_tangent,
        o.sigma_position_mm,
        o.sigma_angles_deg,
    ) {
        (Some(name), None, None, None) => {
            let idx = cameras
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
    Ok(Observer {
        name: o.name.clone().unwrap_or_else(|| format!("obs{i}")),
        aim: observer::aim_from_raw(&format!("{prefix}[{i}]"), o, &position_mm, base)?,
        position_mm,
        sigma,
    })
}

/// The 6 × 6 numbers of a `covariance_tangent` value, when it has that shape (the validation
/// reports any other).
fn covariance_numbers(v: &toml::Value) -> Option<[[f64; 6]; 6]> {
    let rows = v.as_array().filter(|r| r.len() == 6)?;
    let mut m = [[0.0; 6]; 6];
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == 6)?;
        for (j, x) in row.iter().enumerate() {
            m[i][j] = match x {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(n) => *n as f64,
                _ => return None,
            };
        }
    }
    Some(m)
}

/// The plausibility of a pose's σ keys (`sigma_position_mm` with `sigma_angles_deg`, or
/// `covariance_tangent`): `(key, warning)`.
fn pose_sigma_note(
    prefix: &str,
    position: Option<[f64; 3]>,
    angles: Option<[f64; 3]>,
    covariance: Option<&toml::Value>,
) -> Option<(String, String)> {
    if let Some(c) = covariance.and_then(covariance_numbers) {
        let (p, a) = plausible::sigmas_of_covariance_deg(&c);
        return plausible::position_sigma(p, a)
            .map(|w| (format!("{prefix}.covariance_tangent"), w));
    }
    let p = position?;
    plausible::position_sigma(p, angles.unwrap_or([0.0; 3]))
        .map(|w| (format!("{prefix}.sigma_position_mm"), w))
}

/// Plausibility warnings that the raw keys show (`docs/LIMITS.md`, "Plausibility warnings"):
/// grid axes, σ threshold, rig links, pose σ. `(key, sentence)`.
fn raw_plausibility(raw: &RawScenario) -> Vec<(String, String)> {
    let mut notes = Vec::new();
    for (i, c) in raw.camera.iter().enumerate() {
        let k = format!("camera[{i}]");
        if c.parent.is_some()
            && let Some(p) = c.position_mm
            && let Some(w) = plausible::link_base(&Vector3::from(p))
        {
            notes.push((format!("{k}.position_mm"), w));
        }
        notes.extend(pose_sigma_note(
            &k,
            c.sigma_position_mm,
            c.sigma_angles_deg,
            c.covariance_tangent.as_ref(),
        ));
    }
    let Some(g) = &raw.grid else {
        return notes;
    };
    for (name, a) in [("x_mm", &g.x_mm), ("y_mm", &g.y_mm), ("z_mm", &g.z_mm)] {
        let count = a[2].f();
        if count.is_finite()
            && count >= 0.0
            && let Some(w) = plausible::grid_axis(a[0].f(), a[1].f(), count as usize)
        {
            notes.push((format!("grid.{name}"), w));
        }
    }
    if let Some(w) = g.threshold_mm.and_then(plausible::threshold) {
        notes.push(("grid.threshold_mm".into(), w));
    }
    for (i, o) in g.observer.iter().enumerate() {
        notes.extend(pose_sigma_note(
            &format!("grid.observer[{i}]"),
            o.sigma_position_mm,
            o.sigma_angles_deg,
            o.covariance_tangent.as_ref(),
        ));
    }
    notes
}

/// Observers near, but not at, a chain camera, another observer or the origin.
fn observer_plausibility(s: &Scenario) -> Vec<(String, String)> {
    let Some(g) = &s.grid else {
        return Vec::new();
    };
    let cameras: Vec<(String, Vector3<f64>)> = s
        .cameras
        .iter()
        .zip(s.nominal_world_poses())
        .map(|(c, p)| (format!("camera `{}`", c.name), p.translation.vector))
        .collect();
    let mut notes = Vec::new();
    for (i, o) in g.observers.iter().enumerate() {
        let others: Vec<(String, Vector3<f64>)> = g.observers[..i]
            .iter()
            .enumerate()
            .map(|(j, e)| (format!("grid.observer[{j}] `{}`", e.name), e.position_mm))
            .collect();
        if let Some(w) = plausible::observer_position(&o.position_mm, &cameras, &others) {
            notes.push((format!("grid.observer[{i}].position_mm"), w));
        }
    }
    notes
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

#[cfg(test)]
mod tests;
