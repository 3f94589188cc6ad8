//! The bound on every number of a model, checked on reading (`docs/LIMITS.md`, "COLMAP model
//! values"): a pose translation of 1e308 made `calibrate` print `null` with exit 0, as the
//! statistics of such a number overflow. Model units are the reconstruction's own (metres,
//! millimetres, arbitrary), so the bound is far beyond any real scene:
//! [`MAX_MODEL_VALUE`] model units (or pixels, for the image coordinates and the camera
//! parameters), and every number finite.

use std::path::Path;

use crate::error::{Error, Result};
use crate::record::{CameraRecord, Frame, Image, Point3D, RawPose, Rig};

/// The largest magnitude of any number of a model: pose translations and quaternion
/// components, 3-D point coordinates and errors, 2-D point coordinates, camera parameters.
/// 10¹² model units is a million kilometres in metres, a thousand in millimetres; squares and
/// sums of such values over millions of records stay far from overflow, also scaled to mm by
/// the largest `--mm-per-unit` (10⁹).
pub const MAX_MODEL_VALUE: f64 = 1e12;

fn ok(x: f64) -> bool {
    x.is_finite() && x.abs() <= MAX_MODEL_VALUE
}

fn pose_ok(p: &RawPose) -> bool {
    p.qvec.iter().chain(&p.tvec).all(|x| ok(*x))
}

/// The first number beyond the bound, in file order: cameras, rigs, frames (not for a legacy
/// model: they are its images' poses), images, points3D. The error names the file and the
/// record (the line, for text, is added by the caller).
pub(crate) fn check(
    cameras: (&[CameraRecord], &Path),
    rigs: (&[Rig], &Path),
    frames: Option<(&[Frame], &Path)>,
    images: (&[Image], &Path),
    points: (&[Point3D], &Path),
) -> Result<()> {
    let bad = |path: &Path, record: usize, what: &'static str, id: u64| Error::Invariant {
        path: path.to_path_buf(),
        record,
        line: None,
        what,
        id,
    };
    for (i, c) in cameras.0.iter().enumerate() {
        if !c.camera.params.iter().all(|x| ok(*x)) {
            return Err(bad(
                cameras.1,
                i,
                "a camera parameter is not finite or beyond ±1e12 (docs/LIMITS.md)",
                c.camera_id.into(),
            ));
        }
    }
    for (i, r) in rigs.0.iter().enumerate() {
        if r.sensors
            .iter()
            .flat_map(|s| &s.sensor_from_rig)
            .any(|p| !pose_ok(p))
        {
            return Err(bad(
                rigs.1,
                i,
                "a sensor_from_rig number is not finite or beyond ±1e12 model units (docs/LIMITS.md)",
                r.rig_id.into(),
            ));
        }
    }
    if let Some((frames, path)) = frames {
        for (i, f) in frames.iter().enumerate() {
            if !pose_ok(&f.rig_from_world) {
                return Err(bad(
                    path,
                    i,
                    "a rig_from_world number is not finite or beyond ±1e12 model units (docs/LIMITS.md)",
                    f.frame_id.into(),
                ));
            }
        }
    }
    for (i, im) in images.0.iter().enumerate() {
        if !pose_ok(&im.stored_cam_from_world) {
            return Err(bad(
                images.1,
                i,
                "a cam_from_world number is not finite or beyond ±1e12 model units (docs/LIMITS.md)",
                im.image_id.into(),
            ));
        }
        if !im.points2d.iter().all(|p| p.xy.iter().all(|x| ok(*x))) {
            return Err(bad(
                images.1,
                i,
                "a point2D coordinate is not finite or beyond ±1e12 px (docs/LIMITS.md)",
                im.image_id.into(),
            ));
        }
    }
    for (i, p) in points.0.iter().enumerate() {
        if !(p.xyz.iter().all(|x| ok(*x)) && ok(p.error)) {
            return Err(bad(
                points.1,
                i,
                "a point3D coordinate or error is not finite or beyond ±1e12 model units (docs/LIMITS.md)",
                p.point3d_id,
            ));
        }
    }
    Ok(())
}
