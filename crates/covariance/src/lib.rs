//! Camera A's per-epoch pose covariance **from the bundle**: the input that `crashrig measure
//! --a-covariance` and a study take, so that nobody has to type A's σ by hand.
//!
//! # Method
//! 1. Every reprojection residual of the model (all registered images, all tracks, COLMAP's
//!    camera models and pixel convention) is linearised at the model's estimate with exact
//!    Jacobians ([`jacobian`]). Unknowns: one pose per frame (images of a COLMAP ≥ 3.12 frame
//!    share their rig's pose; each image's `sensor_from_rig` is held at its model value; a
//!    legacy model has one frame per image), the free intrinsics of each camera
//!    ([`Intrinsics`]), and every 3-D point seen by at least two registered images. A point
//!    on the projection centre of an image observing it (closer than
//!    [`CAMERA_CENTRE_FRACTION`] of the median viewing distance: its ray is undefined) is left
//!    out with one warning ([`CovarianceResult::points_at_camera_centre`]).
//! 2. The points are eliminated by the Schur complement one 3×3 block at a time (never a dense
//!    point block): `S = U − Σⱼ Wⱼ Vⱼ⁻¹ Wⱼᵀ` over poses and intrinsics, dense (faer), memory
//!    linear in the observations plus `S` itself.
//! 3. The datum is the lab's control points: held fixed (`sigma_mm` 0) or with a prior
//!    `N(model position, σ²)` per axis. Fewer than three non-collinear control points in any
//!    connected part of the model, or any direction left undetermined (the Jacobi-scaled `S`'s
//!    smallest eigenvalue below [`RANK_TOLERANCE`] (or `n·ε`) times its largest, the error
//!    naming the unknowns it moves), is an [`Error`], never an infinite or arbitrary
//!    covariance.
//! 4. Intrinsics are marginalised: A's pose covariance is the pose block of `S⁻¹`.
//! 5. The pixel σ is given, or the a-posteriori `σ̂₀ = sqrt(Σ r² / (2·n_obs − n_params))`.
//!
//! Output: for every epoch of A (named as `measure` names them), `world_from_A` with its
//! contract tangent covariance (centre in world axes, rotation about A's own axes), and the
//! joint 6n×6n covariance of all epochs.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! Four images in a ring look at a 3 m cube of points; the eight corners are fixed control
//! points.
//! ```
//! use crashrig_colmap::CameraSelector;
//! use crashrig_covariance::{ControlPoints, Intrinsics, Options, covariance, synthetic};
//!
//! let scene = synthetic::ring_scene(4, 1.0);
//! let control = ControlPoints::from_ids("corners", &scene.control_ids, 0.0);
//! let options = Options {
//!     camera_a: CameraSelector::parse("cam_out/"),
//!     mm_per_unit: 1000.0,
//!     pixel_sigma_px: Some(0.5),
//!     intrinsics: Intrinsics::All,
//! };
//! let r = covariance(&scene.model, &control, &options)?;
//! assert_eq!(r.epochs.len(), 4);
//! assert_eq!(r.epochs[0].name, "0000");
//! let s = r.epochs[0].world_from_a.sigma_position();
//! assert!(s.iter().all(|v| v.is_finite() && *v > 0.0 && *v < 100.0));
//! # Ok::<(), crashrig_covariance::Error>(())
//! ```

pub mod contract;
mod control;
mod error;
mod gauge;
pub mod jacobian;
mod problem;
mod solve;
pub mod synthetic;

pub use control::{ControlPoint, ControlPoints, MAX_CONTROL_POINTS, read_control_points};
pub use error::Error;
pub use problem::{CAMERA_CENTRE_FRACTION, PointAtCameraCentre};
pub use solve::RANK_TOLERANCE;

use crashrig_colmap::{CameraSelector, Reconstruction};
use crashrig_geometry::{Mat3, Mat6, Rigid3, UncertainPose, so3};
use crashrig_stats::progress::Counter;
pub use crashrig_stats::progress::{Cancelled, Monitor};
use nalgebra::DMatrix;
use std::path::PathBuf;

/// Most pose and intrinsic unknowns of the dense reduced system (checked before it is
/// allocated: three n × n matrices of f64, about 1.5 GB at this bound; ~1 300 frames).
pub const MAX_REDUCED_UNKNOWNS: usize = 8_000;

/// Which intrinsics are unknowns (and so marginalised).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Intrinsics {
    /// Every parameter of every camera's model, principal point included (default).
    All,
    /// What COLMAP's bundle adjustment refines by default: focal length(s) and distortion.
    Colmap,
    /// None: the intrinsics are held constant.
    Fixed,
}

impl Intrinsics {
    /// The name used on the command line and in the output (`all`, `colmap`, `fixed`).
    pub fn name(self) -> &'static str {
        match self {
            Intrinsics::All => "all",
            Intrinsics::Colmap => "colmap",
            Intrinsics::Fixed => "fixed",
        }
    }

    /// Parses `all`, `colmap` or `fixed`.
    pub fn parse(text: &str) -> Option<Intrinsics> {
        [Intrinsics::All, Intrinsics::Colmap, Intrinsics::Fixed]
            .into_iter()
            .find(|i| i.name() == text)
    }
}

/// The model's scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    /// Millimetres per model unit.
    MmPerUnit(f64),
    /// Two point3D ids a known distance apart.
    ScaleBar {
        /// The two points.
        points: [u64; 2],
        /// Their distance in mm.
        length_mm: f64,
    },
}

impl Scale {
    /// The scale the options give: a factor or a scale bar, one of them required.
    ///
    /// # Errors
    /// [`Error::Usage`] (names in `spelling`): neither or both given, a bar without its
    /// length or points, a factor out of range.
    pub fn from_options(
        options: &crashrig_input::options::ScaleOptions,
        spelling: crashrig_input::options::Spelling,
    ) -> Result<Scale, Error> {
        use crashrig_input::options::GivenScale;
        match options.required(spelling) {
            Ok(GivenScale::MmPerUnit(f)) => Ok(Scale::MmPerUnit(f)),
            Ok(GivenScale::ScaleBar { points, length_mm }) => {
                Ok(Scale::ScaleBar { points, length_mm })
            }
            Err(e) => Err(Error::Usage(e.to_string())),
        }
    }
}

/// What `crashrig covariance` needs.
#[derive(Debug, Clone, PartialEq)]
pub struct CovarianceConfig {
    /// The COLMAP model directory.
    pub model: PathBuf,
    /// Camera A: an image-name prefix or a camera id.
    pub camera_a: String,
    /// The control-point CSV.
    pub control_points: PathBuf,
    /// Model units → mm.
    pub scale: Scale,
    /// The pixel σ; `None`: the a-posteriori σ̂₀.
    pub pixel_sigma_px: Option<f64>,
    /// Which intrinsics are unknowns.
    pub intrinsics: Intrinsics,
}

/// The settings of [`covariance`] on a model already read.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Camera A's images.
    pub camera_a: CameraSelector,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// The pixel σ; `None`: the a-posteriori σ̂₀.
    pub pixel_sigma_px: Option<f64>,
    /// Which intrinsics are unknowns.
    pub intrinsics: Intrinsics,
}

/// One epoch of A.
#[derive(Debug, Clone, PartialEq)]
pub struct EpochCovariance {
    /// The epoch name (`measure`'s: the key without its extension).
    pub name: String,
    /// The epoch key (the image name without A's prefix).
    pub key: String,
    /// The image name.
    pub image: String,
    /// `world_from_A` (mm) with its tangent covariance (mm, rad).
    pub world_from_a: UncertainPose,
}

/// The result of [`covariance`].
#[derive(Debug, Clone, PartialEq)]
pub struct CovarianceResult {
    /// A's epochs in key order.
    pub epochs: Vec<EpochCovariance>,
    /// Joint covariance of all epochs in the contract's units (mm, deg), 6n×6n, epoch order
    /// as [`CovarianceResult::epochs`].
    pub joint_deg: DMatrix<f64>,
    /// The a-posteriori σ̂₀ of the model's residuals (px).
    pub sigma0_px: f64,
    /// The pixel σ used (given, or σ̂₀).
    pub pixel_sigma_px: f64,
    /// Observations used.
    pub observations: usize,
    /// Unknowns: 6 per frame, the free intrinsics, 3 per eliminated free point.
    pub parameters: usize,
    /// Redundancy `2·observations − parameters`.
    pub redundancy: i64,
    /// Control points observed (used for the datum).
    pub control_points: usize,
    /// Which intrinsics were marginalised.
    pub intrinsics: Intrinsics,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// Frames (pose unknowns) in the system.
    pub frames: usize,
    /// Points of the model left out: seen by fewer than two registered images and not a
    /// control point (they carry no information on the poses).
    pub points_left_out: usize,
    /// Points of the model left out because they lie on the projection centre of an image that
    /// observes them (closer than [`CAMERA_CENTRE_FRACTION`] of the median viewing distance):
    /// their rays there are undefined. Not counted in [`Self::points_left_out`].
    pub points_at_camera_centre: Vec<PointAtCameraCentre>,
    /// Things the user should know (one line each).
    pub warnings: Vec<String>,
}

/// Reads the model and the control points of `config` and computes the covariance.
///
/// `monitor` (optional) gets `(done, `[`PHASES`]`)` as each phase ends (inputs read, system
/// built, points eliminated, inverted) and is asked between phases whether to stop. The
/// result does not depend on it; nothing is written here (front ends write the document).
///
/// # Errors
/// Any [`Error`]: unreadable files, bad control points, a datum that leaves a gauge freedom,
/// a singular system; [`Error::Cancelled`] when `monitor` asked to stop.
pub fn run(
    config: &CovarianceConfig,
    monitor: Option<&dyn Monitor>,
) -> Result<CovarianceResult, Error> {
    let phases = Counter::monitored(monitor, PHASES);
    let model = Reconstruction::read(&config.model)?;
    let control = read_control_points(&config.control_points)?;
    let mm_per_unit = mm_per_unit(&model, &config.scale)?;
    let options = Options {
        camera_a: CameraSelector::parse(&config.camera_a),
        mm_per_unit,
        pixel_sigma_px: config.pixel_sigma_px,
        intrinsics: config.intrinsics,
    };
    phases.add(1);
    phases.check()?;
    covariance_in_phases(&model, &control, &options, &phases)
}

/// The phases [`run`] reports: inputs read, system built, points eliminated (the Schur
/// complement), inverted (A's covariance assembled).
pub const PHASES: usize = 4;

/// Model units → mm from a [`Scale`].
///
/// # Errors
/// [`Error::Setting`]: a factor or length that is not a positive finite number, a scale point
/// that is not in the model, two scale points at the same place.
pub fn mm_per_unit(model: &Reconstruction, scale: &Scale) -> Result<f64, Error> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    match *scale {
        Scale::MmPerUnit(f) if positive(f) => Ok(f),
        Scale::MmPerUnit(f) => Err(Error::Setting {
            name: "--mm-per-unit",
            problem: format!("{f} is not a positive number"),
        }),
        Scale::ScaleBar { points, length_mm } => {
            if !positive(length_mm) {
                return Err(Error::Setting {
                    name: "--scale-length-mm",
                    problem: format!("{length_mm} is not a positive length (mm)"),
                });
            }
            let xyz = |id: u64| {
                model
                    .point3d(id)
                    .map(|p| nalgebra::Vector3::from(p.xyz))
                    .ok_or_else(|| Error::Setting {
                        name: "--scale-points",
                        problem: format!(
                            "point3D_id {id} is not a point of the model {}",
                            model.dir().display()
                        ),
                    })
            };
            let d = (xyz(points[0])? - xyz(points[1])?).norm();
            if !positive(d) {
                return Err(Error::Setting {
                    name: "--scale-points",
                    problem: format!("points {} and {} coincide", points[0], points[1]),
                });
            }
            Ok(length_mm / d)
        }
    }
}

/// The covariance of A's per-epoch poses on a model already read.
///
/// # Errors
/// As [`run`].
pub fn covariance(
    model: &Reconstruction,
    control: &ControlPoints,
    options: &Options,
) -> Result<CovarianceResult, Error> {
    covariance_in_phases(model, control, options, &Counter::silent())
}

/// [`covariance`] counting its last three [`PHASES`] on `phases` and stopping between them
/// when its monitor asks to.
fn covariance_in_phases(
    model: &Reconstruction,
    control: &ControlPoints,
    options: &Options,
    phases: &Counter<'_>,
) -> Result<CovarianceResult, Error> {
    check_options(options)?;
    let p = problem::build(
        model,
        &options.camera_a,
        control,
        options.mm_per_unit,
        options.intrinsics,
    )?;
    gauge::check(&p, &control.path)?;
    if p.n_reduced > MAX_REDUCED_UNKNOWNS {
        return Err(Error::Setting {
            name: "MODEL_DIR",
            problem: format!(
                "{} frames and {} free intrinsics make {} pose and intrinsic unknowns, more \
                 than the {MAX_REDUCED_UNKNOWNS} that the dense reduced system holds (~{} GB)",
                p.frames.len(),
                p.n_reduced - 6 * p.frames.len(),
                p.n_reduced,
                3 * MAX_REDUCED_UNKNOWNS * MAX_REDUCED_UNKNOWNS * 8 / 1_000_000_000
            ),
        });
    }
    let observations = p.obs.len();
    let parameters = p.n_reduced + p.n_point_params();
    let redundancy = 2 * observations as i64 - parameters as i64;
    let sigma0_px = if redundancy > 0 {
        (p.sum_sq / redundancy as f64).sqrt()
    } else {
        f64::NAN
    };
    let pixel_sigma_px = match options.pixel_sigma_px {
        Some(s) => s,
        None if redundancy <= 0 => {
            return Err(Error::Singular {
                model: model.dir().to_path_buf(),
                problem: format!(
                    "{observations} observations for {parameters} unknowns leave no redundancy \
                     to estimate σ̂₀"
                ),
            });
        }
        None if !(sigma0_px.is_finite() && sigma0_px > 0.0) => {
            return Err(Error::Setting {
                name: "--pixel-sigma-px",
                problem: "the model's residuals are all zero (σ̂₀ = 0): give the pixel σ".into(),
            });
        }
        None => sigma0_px,
    };
    phases.add(1);
    phases.check()?;
    let s = solve::reduced_information(&p, pixel_sigma_px);
    phases.add(1);
    phases.check()?;
    let cols: Vec<usize> = p
        .a_epochs
        .iter()
        .flat_map(|e| {
            let f = p.images[e.image].frame;
            6 * f..6 * f + 6
        })
        .collect();
    let x = solve::inverse_columns(&p, &s, &cols, model.dir())?;
    phases.add(1);
    let n = p.a_epochs.len();
    // Frame tangent → A's tangent (mm, rad) per epoch.
    let maps: Vec<Mat6> = p
        .a_epochs
        .iter()
        .map(|e| a_from_frame_tangent(&p, e.image, options.mm_per_unit))
        .collect();
    let mut joint = DMatrix::<f64>::zeros(6 * n, 6 * n);
    for (i, mi) in maps.iter().enumerate() {
        for (j, mj) in maps.iter().enumerate() {
            let block = Mat6::from_fn(|a, b| x[(cols[6 * i + a], 6 * j + b)]);
            let out = mi * block * mj.transpose();
            joint.view_mut((6 * i, 6 * j), (6, 6)).copy_from(&out);
        }
    }
    let joint = (&joint + joint.transpose()) * 0.5;
    let deg = 180.0 / std::f64::consts::PI;
    let unit = |k: usize| if k % 6 >= 3 { deg } else { 1.0 };
    let joint_deg = DMatrix::from_fn(6 * n, 6 * n, |a, b| joint[(a, b)] * unit(a) * unit(b));
    if joint_deg.iter().any(|v| !v.is_finite()) || (0..6 * n).any(|k| joint[(k, k)] <= 0.0) {
        return Err(Error::Singular {
            model: model.dir().to_path_buf(),
            problem: "the covariance is not finite and positive (numerically singular system)"
                .into(),
        });
    }
    let mut epochs = Vec::with_capacity(n);
    for (i, e) in p.a_epochs.iter().enumerate() {
        let im = &p.images[e.image];
        let cam_from_world = im.sensor_from_rig * p.frames[im.frame].rig_from_world;
        let mut world_from_a = cam_from_world.inverse();
        world_from_a.translation.vector *= options.mm_per_unit;
        let cov = Mat6::from_fn(|a, b| joint[(6 * i + a, 6 * i + b)]);
        let world_from_a =
            UncertainPose::new(world_from_a, cov).map_err(|problem| Error::Singular {
                model: model.dir().to_path_buf(),
                problem: format!("epoch {}: covariance {problem:?}", e.name),
            })?;
        epochs.push(EpochCovariance {
            name: e.name.clone(),
            key: e.key.clone(),
            image: im.name.clone(),
            world_from_a,
        });
    }
    let mut warnings = Vec::new();
    if let Some(w) = centre_warning(&p.at_camera_centre) {
        warnings.push(w);
    }
    if p.rejected > 0 {
        warnings.push(format!(
            "{} observation(s) cannot be projected at the model's estimate (behind the camera \
             or outside the lens model's domain) and were left out",
            p.rejected
        ));
    }
    Ok(CovarianceResult {
        epochs,
        joint_deg,
        sigma0_px,
        pixel_sigma_px,
        observations,
        parameters,
        redundancy,
        control_points: p.control.len(),
        intrinsics: options.intrinsics,
        mm_per_unit: options.mm_per_unit,
        frames: p.frames.len(),
        points_left_out: p.points_left_out,
        points_at_camera_centre: p.at_camera_centre,
        warnings,
    })
}

/// Points listed in the warning about points on a camera centre before "and N more".
const CENTRE_POINTS_SHOWN: usize = 5;

/// The one warning line about points left out because they lie on a camera centre: their ids
/// and images (the first [`CENTRE_POINTS_SHOWN`] points, two images each, then counts).
fn centre_warning(points: &[PointAtCameraCentre]) -> Option<String> {
    if points.is_empty() {
        return None;
    }
    let listed: Vec<String> = points
        .iter()
        .take(CENTRE_POINTS_SHOWN)
        .map(|p| {
            format!(
                "{} ({})",
                p.point3d_id,
                problem::name_list("image", &p.images, 2)
            )
        })
        .collect();
    let more = match points.len().saturating_sub(CENTRE_POINTS_SHOWN) {
        0 => String::new(),
        n => format!(" and {n} more"),
    };
    Some(format!(
        "{} point(s) lie on the projection centre of an image that observes them (their rays \
         there are undefined) and were left out: point3D {}{more}",
        points.len(),
        listed.join(", ")
    ))
}

/// The unit and range checks of `options` (each error names its flag).
fn check_options(options: &Options) -> Result<(), Error> {
    if options.camera_a.is_blank() {
        return Err(Error::Setting {
            name: "--camera",
            problem: "is empty: name camera A (an image-name prefix such as `cam_out/`, or a \
                      camera id); an empty prefix would make every image camera A"
                .into(),
        });
    }
    if !(options.mm_per_unit.is_finite() && options.mm_per_unit > 0.0) {
        return Err(Error::Setting {
            name: "--mm-per-unit",
            problem: format!("{} is not a positive number", options.mm_per_unit),
        });
    }
    if let Some(s) = options.pixel_sigma_px
        && !(s.is_finite() && s > 0.0)
    {
        return Err(Error::Setting {
            name: "--pixel-sigma-px",
            problem: format!("{s} is not a positive number (px)"),
        });
    }
    Ok(())
}

/// The 6×6 map from the frame's tangent (model units, rad) to `world_from_A`'s tangent (mm,
/// rad) for one image: `δC_A = δC + R̄_world_from_rig·(c × δθ)·(−1)`, `δθ_A = R_A_from_rig·δθ`,
/// with `c` A's centre in the rig's axes.
fn a_from_frame_tangent(p: &problem::Problem, image: usize, mm_per_unit: f64) -> Mat6 {
    let im = &p.images[image];
    let s: &Rigid3 = &im.sensor_from_rig;
    let r_s: Mat3 = s.rotation.to_rotation_matrix().into_inner();
    let c = -(r_s.transpose() * s.translation.vector);
    let r_wr: Mat3 = p.frames[im.frame]
        .rig_from_world
        .rotation
        .inverse()
        .to_rotation_matrix()
        .into_inner();
    let mut m = Mat6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(Mat3::identity() * mm_per_unit));
    m.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-(r_wr * so3::hat(&c)) * mm_per_unit));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&r_s);
    m
}

impl CovarianceResult {
    /// The JSON document of `crashrig covariance` (what `measure --a-covariance` reads) as
    /// typed structs.
    pub fn document(&self) -> contract::CovarianceDocument {
        let rows = |m: &Mat6| -> [[f64; 6]; 6] {
            std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
        };
        let epochs = self
            .epochs
            .iter()
            .map(|e| (e.name.clone(), rows(&e.world_from_a.covariance_deg())))
            .collect();
        let epoch_sigmas = self
            .epochs
            .iter()
            .map(|e| {
                let sp = e.world_from_a.sigma_position();
                let sr = e.world_from_a.sigma_rotation().map(f64::to_degrees);
                let c = e.world_from_a.center();
                contract::EpochSigmas {
                    image: e.image.clone(),
                    name: e.name.clone(),
                    position_mm: [c.x, c.y, c.z],
                    sigma_position_mm: [sp.x, sp.y, sp.z],
                    sigma_angles_deg: [sr.x, sr.y, sr.z],
                }
            })
            .collect();
        let n = self.joint_deg.nrows();
        contract::CovarianceDocument {
            control_points: self.control_points,
            epoch_sigmas,
            epochs,
            frames: self.frames,
            intrinsics: self.intrinsics.name(),
            joint: contract::JointCovariance {
                covariance_tangent: (0..n)
                    .map(|i| (0..n).map(|j| self.joint_deg[(i, j)]).collect())
                    .collect(),
                epochs: self.epochs.iter().map(|e| e.name.clone()).collect(),
            },
            mm_per_unit: self.mm_per_unit,
            observations: self.observations,
            parameters: self.parameters,
            pixel_sigma_px: self.pixel_sigma_px,
            points_at_camera_centre: self
                .points_at_camera_centre
                .iter()
                .map(|p| contract::PointAtCentre {
                    images: p.images.clone(),
                    point3d_id: p.point3d_id,
                })
                .collect(),
            points_left_out: self.points_left_out,
            redundancy: self.redundancy,
            sigma0_px: self.sigma0_px.is_finite().then_some(self.sigma0_px),
        }
    }

    /// [`Self::document`] as a JSON value (the same bytes when printed).
    pub fn to_json(&self) -> serde_json::Value {
        // Infallible: every map key is a string.
        serde_json::to_value(self.document()).unwrap_or(serde_json::Value::Null)
    }

    /// The file `--out` holds (what `measure --a-covariance` reads): [`Self::to_json`] pretty
    /// printed, with a final newline.
    pub fn json_text(&self) -> String {
        // Infallible: a JSON value always prints.
        let mut text = serde_json::to_string_pretty(&self.to_json()).unwrap_or_default();
        text.push('\n');
        text
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
