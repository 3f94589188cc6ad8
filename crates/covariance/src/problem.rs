//! The unknowns and observations taken from a COLMAP model: frames (one pose each), cameras
//! (their free intrinsics), 3-D points (free, fixed control, or control with a prior) and the
//! observations that enter the information matrix.

use crate::jacobian::project;
use crate::{ControlPoints, Error, Intrinsics};
use crashrig_camera::Camera;
use crashrig_colmap::{CameraSelector, Reconstruction, epoch_name};
use crashrig_geometry::{Rigid3, Vec3};
use nalgebra::Vector2;
use std::collections::{BTreeMap, HashMap};

/// A frame: one pose unknown (6 parameters).
#[derive(Debug, Clone)]
pub(crate) struct FrameBlock {
    /// `rig_from_world` at the model's estimate.
    pub rig_from_world: Rigid3,
    /// The first image of the frame (for messages).
    pub label: String,
}

/// A camera: its free intrinsics.
#[derive(Debug, Clone)]
pub(crate) struct CameraBlock {
    pub camera_id: u32,
    pub camera: Camera,
    /// Indices (COLMAP order) of the parameters that are unknowns.
    pub free: Vec<usize>,
    /// Offset of the first free parameter in the reduced system.
    pub offset: usize,
}

/// An image that contributes observations.
#[derive(Debug, Clone)]
pub(crate) struct ImageEntry {
    pub name: String,
    pub frame: usize,
    pub camera: usize,
    pub sensor_from_rig: Rigid3,
}

/// How a 3-D point enters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PointKind {
    /// An unknown, eliminated by the Schur complement.
    Free,
    /// A control point held fixed.
    Fixed,
    /// A control point with a prior σ (model units) on each axis; eliminated like a free point.
    Prior(f64),
}

/// A 3-D point with its observations `obs[start..end]`.
#[derive(Debug, Clone)]
pub(crate) struct PointEntry {
    pub xyz: Vec3,
    pub kind: PointKind,
    pub start: usize,
    pub end: usize,
}

/// One observation: the image (its residual entered `Problem::sum_sq` at build time).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Obs {
    pub image: usize,
}

/// A point of the model that lies on the projection centre of an image observing it: its ray
/// there is undefined (any direction), so it is left out with all its observations.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointAtCameraCentre {
    /// The COLMAP `point3D_id`.
    pub point3d_id: u64,
    /// The images on whose projection centre it lies (model order).
    pub images: Vec<String>,
}

/// A point closer to the projection centre of an image that observes it than this fraction of
/// the model's median viewing distance (over all observations) lies "on" that centre. Such a
/// point is inside the lens (1 mm from the centre in a scene seen from 10 m): no photograph
/// shows it, its ray is undefined, and its Jacobians are 10⁴ × (and more) those of a real
/// observation, which would swamp the reduced system.
pub const CAMERA_CENTRE_FRACTION: f64 = 1e-4;

/// One epoch of camera A.
#[derive(Debug, Clone)]
pub(crate) struct AEpoch {
    pub key: String,
    pub name: String,
    pub image: usize,
}

/// Everything the information matrix needs.
#[derive(Debug, Clone)]
pub(crate) struct Problem {
    pub frames: Vec<FrameBlock>,
    pub cameras: Vec<CameraBlock>,
    pub images: Vec<ImageEntry>,
    pub points: Vec<PointEntry>,
    pub obs: Vec<Obs>,
    /// A's epochs in key order.
    pub a_epochs: Vec<AEpoch>,
    /// Number of reduced-system unknowns (6 per frame + free intrinsics).
    pub n_reduced: usize,
    /// Σ r² over the observations (px²).
    pub sum_sq: f64,
    /// Observations left out because they cannot be projected at the model's estimate.
    pub rejected: usize,
    /// Points of the model left out (observed by fewer than two registered images and not a
    /// control point).
    pub points_left_out: usize,
    /// Control points used: (point3D_id, position in model units, kind).
    pub control: Vec<(u64, Vec3, PointKind)>,
    /// Free points left out because they lie on the centre of an image that observes them.
    pub at_camera_centre: Vec<PointAtCameraCentre>,
}

impl Problem {
    /// 3 unknowns per eliminated point.
    pub fn n_point_params(&self) -> usize {
        3 * self
            .points
            .iter()
            .filter(|p| p.kind == PointKind::Free)
            .count()
    }
}

/// The free parameter indices of a camera under `mode`.
pub(crate) fn free_params(camera: &Camera, mode: Intrinsics) -> Vec<usize> {
    let m = camera.model;
    match mode {
        Intrinsics::Fixed => Vec::new(),
        Intrinsics::All => (0..m.num_params()).collect(),
        Intrinsics::Colmap => {
            let pp = m.principal_point_idxs();
            if m == crashrig_camera::ModelId::Equirectangular {
                return Vec::new();
            }
            (0..m.num_params()).filter(|i| !pp.contains(i)).collect()
        }
    }
}

/// Builds the problem: A's epochs, frames, cameras, points and observations.
pub(crate) fn build(
    model: &Reconstruction,
    camera_a: &CameraSelector,
    control: &ControlPoints,
    mm_per_unit: f64,
    mode: Intrinsics,
) -> Result<Problem, Error> {
    let control_kind = control_kinds(model, control, mm_per_unit)?;

    let Registered {
        frames,
        cameras,
        mut images,
        image_idx,
    } = registered(model, mode);

    let near_centre = CAMERA_CENTRE_FRACTION
        * median_viewing_distance(model, &image_idx, &images, &frames).unwrap_or(0.0);
    let mut at_camera_centre = Vec::new();

    // Observations per point, at the model's estimate.
    let mut points = Vec::new();
    let mut obs = Vec::with_capacity(model.num_observations());
    let mut sum_sq = 0.0;
    let mut rejected = 0;
    let mut points_left_out = 0;
    let mut control_used = Vec::new();
    // A canonical order (points by id, each track by image and 2-D point, images by id), so
    // that the sums of the information matrix, and so the covariance to its last bit, do not
    // depend on the order of the model's files (issue 47).
    let mut by_id: Vec<&crashrig_colmap::Point3D> = model.points3d().iter().collect();
    by_id.sort_by_key(|p| p.point3d_id);
    let mut track: Vec<crashrig_colmap::TrackElement> = Vec::new();
    for p in by_id {
        track.clear();
        track.extend(p.track.iter().cloned());
        track.sort_by_key(|t| (t.image_id, t.point2d_idx));
        let xyz = Vec3::from(p.xyz);
        let kind = control_kind
            .get(&p.point3d_id)
            .copied()
            .unwrap_or(PointKind::Free);
        let centres = images_at_centre(&p.track, &xyz, &image_idx, &images, &frames, near_centre);
        if !centres.is_empty() {
            let names = centres.iter().map(|&i| images[i].name.clone()).collect();
            if kind != PointKind::Free {
                return Err(control_at_centre(model, control, p.point3d_id, names));
            }
            at_camera_centre.push(PointAtCameraCentre {
                point3d_id: p.point3d_id,
                images: names,
            });
            continue;
        }
        let start = obs.len();
        let mut sq = 0.0;
        for t in &track {
            let Some(&i) = image_idx.get(&t.image_id) else {
                continue;
            };
            let Some(xy) = model
                .image(t.image_id)
                .and_then(|im| im.points2d.get(t.point2d_idx as usize))
                .map(|p2| Vector2::from(p2.xy))
            else {
                continue;
            };
            let e = &images[i];
            let fr = &frames[e.frame];
            match project(
                &cameras[e.camera].camera,
                &e.sensor_from_rig,
                &fr.rig_from_world,
                &xyz,
            ) {
                Ok(pr) if finite(&pr) => {
                    sq += (xy - pr.pixel).norm_squared();
                    obs.push(Obs { image: i });
                }
                _ => rejected += 1,
            }
        }
        let n = obs.len() - start;
        let keep = match kind {
            PointKind::Free => n >= 2,
            PointKind::Fixed | PointKind::Prior(_) => n >= 1,
        };
        if !keep {
            obs.truncate(start);
            if kind == PointKind::Free {
                points_left_out += 1;
            }
            continue;
        }
        if kind != PointKind::Free {
            control_used.push((p.point3d_id, xyz, kind));
        }
        sum_sq += sq;
        points.push(PointEntry {
            xyz,
            kind,
            start,
            end: obs.len(),
        });
    }

    // Frames and cameras without any observation are dropped (their images carry nothing).
    let mut frame_used = vec![false; frames.len()];
    let mut camera_used = vec![false; cameras.len()];
    for o in &obs {
        frame_used[images[o.image].frame] = true;
        camera_used[images[o.image].camera] = true;
    }

    let a_epochs = a_epochs(model, camera_a, &image_idx, &images, &frame_used)
        .map_err(|e| with_centre_hint(e, model, &at_camera_centre))?;

    // Renumber frames and cameras to the used ones.
    let (frames, frame_map) = compact(frames, &frame_used);
    let (mut cameras, camera_map) = compact(cameras, &camera_used);
    for im in &mut images {
        im.frame = frame_map[im.frame].unwrap_or(usize::MAX);
        im.camera = camera_map[im.camera].unwrap_or(usize::MAX);
    }
    let mut offset = 6 * frames.len();
    for c in &mut cameras {
        c.offset = offset;
        offset += c.free.len();
    }
    Ok(Problem {
        frames,
        cameras,
        images,
        points,
        obs,
        a_epochs,
        n_reduced: offset,
        sum_sq,
        rejected,
        points_left_out,
        control: control_used,
        at_camera_centre,
    })
}

/// True when the projection and all its Jacobians are finite numbers.
fn finite(pr: &crate::jacobian::Projection) -> bool {
    pr.pixel.iter().all(|v| v.is_finite())
        && pr.d_pose.iter().all(|v| v.is_finite())
        && pr.d_point.iter().all(|v| v.is_finite())
        && pr.d_params.iter().all(|v| v.is_finite())
}

/// `x` in the camera axes of image `e` (model units): its distance from the projection centre
/// is the norm.
fn cam_point(e: &ImageEntry, frame: &FrameBlock, x: &Vec3) -> Vec3 {
    let x_rig = frame.rig_from_world * nalgebra::Point3::from(*x);
    (e.sensor_from_rig * x_rig).coords
}

/// The median distance between an observed point and the projection centre of the registered
/// image observing it, over all observations (the scene's scale as the cameras see it); `None`
/// without observations.
fn median_viewing_distance(
    model: &Reconstruction,
    image_idx: &HashMap<u32, usize>,
    images: &[ImageEntry],
    frames: &[FrameBlock],
) -> Option<f64> {
    let mut d: Vec<f64> = Vec::with_capacity(model.num_observations());
    for p in model.points3d() {
        let xyz = Vec3::from(p.xyz);
        for t in &p.track {
            if let Some(&i) = image_idx.get(&t.image_id) {
                let e = &images[i];
                let v = cam_point(e, &frames[e.frame], &xyz).norm();
                if v.is_finite() {
                    d.push(v);
                }
            }
        }
    }
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// The registered images of `track` on whose projection centre `x` lies (closer than
/// `near_centre`), each once, in track order.
fn images_at_centre(
    track: &[crashrig_colmap::TrackElement],
    x: &Vec3,
    image_idx: &HashMap<u32, usize>,
    images: &[ImageEntry],
    frames: &[FrameBlock],
    near_centre: f64,
) -> Vec<usize> {
    let mut out = Vec::new();
    for t in track {
        let Some(&i) = image_idx.get(&t.image_id) else {
            continue;
        };
        let e = &images[i];
        if cam_point(e, &frames[e.frame], x).norm() <= near_centre && !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// The error for a control point that lies on the projection centre of an image observing it
/// (the lab's datum would rest on an undefined ray): names the file, the line and the images.
fn control_at_centre(
    model: &Reconstruction,
    control: &ControlPoints,
    id: u64,
    images: Vec<String>,
) -> Error {
    let line = control
        .points
        .iter()
        .find(|c| c.point3d_id == id)
        .map_or(1, |c| c.line);
    Error::ControlCsv {
        path: control.path.clone(),
        line,
        problem: format!(
            "control point {id} lies on the projection centre of {} of the model {} that \
             observes it (closer than {CAMERA_CENTRE_FRACTION:e} of the median viewing \
             distance): its ray there is undefined; choose another control point",
            name_list("image", &images, 3),
            model.dir().display()
        ),
    }
}

/// `image `a`` / `images `a`, `b` and 2 more`: at most `shown` names, then a count.
pub(crate) fn name_list(what: &str, names: &[String], shown: usize) -> String {
    let mut s = String::from(what);
    if names.len() != 1 {
        s.push('s');
    }
    for (k, n) in names.iter().take(shown).enumerate() {
        s.push_str(if k == 0 { " " } else { ", " });
        s.push_str(&format!("`{n}`"));
    }
    if names.len() > shown {
        s.push_str(&format!(" and {} more", names.len() - shown));
    }
    s
}

/// The kind of every control point (fixed, or a prior σ in model units); every id must be a
/// point of the model.
fn control_kinds(
    model: &Reconstruction,
    control: &ControlPoints,
    mm_per_unit: f64,
) -> Result<HashMap<u64, PointKind>, Error> {
    let mut control_kind: HashMap<u64, PointKind> = HashMap::new();
    for cp in &control.points {
        if model.point3d(cp.point3d_id).is_none() {
            return Err(Error::ControlCsv {
                path: control.path.clone(),
                line: cp.line,
                problem: format!(
                    "point3D_id {} is not a point of the model {}",
                    cp.point3d_id,
                    model.dir().display()
                ),
            });
        }
        let kind = if cp.sigma_mm > 0.0 {
            PointKind::Prior(cp.sigma_mm / mm_per_unit)
        } else {
            PointKind::Fixed
        };
        control_kind.insert(cp.point3d_id, kind);
    }

    Ok(control_kind)
}

/// The model's registered images, grouped by frame, with their cameras.
struct Registered {
    frames: Vec<FrameBlock>,
    cameras: Vec<CameraBlock>,
    images: Vec<ImageEntry>,
    image_idx: HashMap<u32, usize>,
}

/// Registered images, grouped by frame (an image without pose, frame or camera is left out).
fn registered(model: &Reconstruction, mode: Intrinsics) -> Registered {
    let mut frames: Vec<FrameBlock> = Vec::new();
    let mut frame_idx: HashMap<u32, usize> = HashMap::new();
    let mut cameras: Vec<CameraBlock> = Vec::new();
    let mut camera_idx: HashMap<u32, usize> = HashMap::new();
    let mut images: Vec<ImageEntry> = Vec::new();
    let mut image_idx: HashMap<u32, usize> = HashMap::new();
    let mut by_id: Vec<&crashrig_colmap::Image> = model.images().iter().collect();
    by_id.sort_by_key(|i| i.image_id);
    for img in by_id {
        let (Some(cam_from_world), Some(frame)) = (
            model.image_cam_from_world(img.image_id),
            model.image_frame(img.image_id),
        ) else {
            continue;
        };
        let Some(rig_from_world) = frame.rig_from_world.to_rigid() else {
            continue;
        };
        let Some(cam_rec) = model.camera(img.camera_id) else {
            continue;
        };
        let f = *frame_idx.entry(frame.frame_id).or_insert_with(|| {
            frames.push(FrameBlock {
                rig_from_world,
                label: img.name.clone(),
            });
            frames.len() - 1
        });
        let c = *camera_idx.entry(img.camera_id).or_insert_with(|| {
            cameras.push(CameraBlock {
                camera_id: img.camera_id,
                camera: cam_rec.camera.clone(),
                free: free_params(&cam_rec.camera, mode),
                offset: 0,
            });
            cameras.len() - 1
        });
        image_idx.insert(img.image_id, images.len());
        images.push(ImageEntry {
            name: img.name.clone(),
            frame: f,
            camera: c,
            sensor_from_rig: cam_from_world * rig_from_world.inverse(),
        });
    }

    Registered {
        frames,
        cameras,
        images,
        image_idx,
    }
}

/// Camera A's epochs (measure's naming); each must be a registered image with observations.
fn a_epochs(
    model: &Reconstruction,
    camera_a: &CameraSelector,
    image_idx: &HashMap<u32, usize>,
    images: &[ImageEntry],
    frame_used: &[bool],
) -> Result<Vec<AEpoch>, Error> {
    let cam_err = |problem: String| Error::Camera {
        model: model.dir().to_path_buf(),
        selector: camera_a.to_string(),
        problem,
    };
    let mut by_key: BTreeMap<String, (String, Option<usize>)> = BTreeMap::new();
    let mut names: BTreeMap<String, String> = BTreeMap::new();
    for img in model.images().iter().filter(|i| camera_a.matches(i)) {
        let key = camera_a.key(&img.name).to_string();
        let name = epoch_name(&key).to_string();
        if let Some(other) = names.insert(name.clone(), img.name.clone()) {
            return Err(cam_err(format!(
                "images `{other}` and `{}` are both epoch `{name}`",
                img.name
            )));
        }
        by_key.insert(
            key,
            (img.name.clone(), image_idx.get(&img.image_id).copied()),
        );
    }
    if by_key.is_empty() {
        let hint = camera_a.suggestions(model.images());
        return Err(cam_err(format!(
            "no image of the model's {} matches{}",
            model.images().len(),
            if hint.is_empty() {
                String::new()
            } else {
                format!("; {hint}")
            }
        )));
    }
    let mut a_epochs = Vec::new();
    for (key, (image_name, idx)) in by_key {
        let Some(i) = idx.filter(|&i| frame_used[images[i].frame]) else {
            return Err(cam_err(format!(
                "image `{image_name}` has no observation of a point seen twice or of a control \
                 point (or no pose): its covariance is not determined"
            )));
        };
        a_epochs.push(AEpoch {
            name: epoch_name(&key).to_string(),
            key,
            image: i,
        });
    }

    Ok(a_epochs)
}

/// A camera-A error about an image without observations, completed with how many of the
/// points it observes were left out for lying on a camera centre (the cause, when there are).
fn with_centre_hint(e: Error, model: &Reconstruction, at_centre: &[PointAtCameraCentre]) -> Error {
    let Error::Camera {
        model: dir,
        selector,
        problem,
    } = e
    else {
        return e;
    };
    let image = model
        .images()
        .iter()
        .find(|im| problem.contains(&format!("image `{}`", im.name)));
    let left_out = image.map_or(0, |im| {
        at_centre
            .iter()
            .filter(|p| {
                model
                    .point3d(p.point3d_id)
                    .is_some_and(|pt| pt.track.iter().any(|t| t.image_id == im.image_id))
            })
            .count()
    });
    let problem = if left_out > 0 {
        format!(
            "{problem}; {left_out} of the points it observes lie on the projection centre of an \
             image that observes them and were left out"
        )
    } else {
        problem
    };
    Error::Camera {
        model: dir,
        selector,
        problem,
    }
}

/// Keeps the used items; returns them and the old → new index map.
fn compact<T>(items: Vec<T>, used: &[bool]) -> (Vec<T>, Vec<Option<usize>>) {
    let mut map = vec![None; items.len()];
    let mut out = Vec::new();
    for (i, it) in items.into_iter().enumerate() {
        if used[i] {
            map[i] = Some(out.len());
            out.push(it);
        }
    }
    (out, map)
}
