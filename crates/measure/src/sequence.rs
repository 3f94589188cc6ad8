//! The sequence in a COLMAP model: camera A's per-epoch poses and the inward cameras'
//! intrinsics.
//!
//! A camera is selected like `calibrate` selects it: a text made only of digits is a COLMAP
//! camera id, anything else an image-name prefix. The **epoch key** of an image of A is its
//! name without the prefix (for a camera id: without everything up to and including the first
//! `/`); the **epoch name** is the key without its extension (`cam_out/000123.png` → key
//! `000123.png`, name `000123`). Epochs are ordered by key, the sequence order for zero-padded
//! frame names. The **frame number** of an epoch is the last run of digits in its name.

use crate::Error;
use crashrig_camera::Camera;
use crashrig_colmap::{Image, Reconstruction};
use crashrig_geometry::Rigid3;
use std::collections::BTreeMap;

pub use crashrig_colmap::CameraSelector;

/// The epoch name of a key (one definition, in `crashrig_colmap`, shared with `covariance`).
pub use crashrig_colmap::epoch_name;

/// The frame number of an epoch name: its last run of ASCII digits (`run3_000123` → 123).
pub fn frame_number(name: &str) -> Option<u64> {
    let bytes = name.as_bytes();
    let end = bytes.iter().rposition(|b| b.is_ascii_digit())? + 1;
    let start = bytes[..end]
        .iter()
        .rposition(|b| !b.is_ascii_digit())
        .map_or(0, |i| i + 1);
    name[start..end].parse().ok()
}

/// One image of camera A with its pose.
#[derive(Debug, Clone, PartialEq)]
pub struct APose {
    /// Epoch key: the image name without A's prefix.
    pub key: String,
    /// Epoch name: the key without its extension.
    pub name: String,
    /// `world_from_A` in mm (model units × `mm_per_unit`).
    pub world_from_a: Rigid3,
}

/// Camera A's images in a model, ordered by key.
#[derive(Debug, Clone, PartialEq)]
pub struct ASequence {
    /// Images with a pose, in key order.
    pub poses: Vec<APose>,
    /// Names of A's images without a pose (their epochs cannot be measured).
    pub without_pose: Vec<String>,
}

/// Camera A's per-epoch `world_from_A` (mm) from the model.
///
/// # Errors
/// [`Error::Camera`] when the selector matches no image, or two images share an epoch name;
/// [`Error::Setting`] for a non-positive or non-finite `mm_per_unit`.
pub fn a_sequence(
    model: &Reconstruction,
    a: &CameraSelector,
    mm_per_unit: f64,
) -> Result<ASequence, Error> {
    if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
        return Err(Error::Setting {
            name: "--mm-per-unit",
            problem: format!("{mm_per_unit} is not a positive number"),
        });
    }
    let cam_err = |problem: String| Error::Camera {
        model: model.dir().to_path_buf(),
        role: 'A',
        selector: a.to_string(),
        problem,
    };
    let mut by_key: BTreeMap<String, &Image> = BTreeMap::new();
    let mut names: BTreeMap<String, String> = BTreeMap::new();
    for img in model.images().iter().filter(|i| a.matches(i)) {
        let key = a.key(&img.name).to_string();
        let name = epoch_name(&key).to_string();
        if let Some(other) = names.insert(name.clone(), img.name.clone()) {
            return Err(cam_err(format!(
                "images `{other}` and `{}` are both epoch `{name}`",
                img.name
            )));
        }
        by_key.insert(key, img);
    }
    if by_key.is_empty() {
        return Err(cam_err(format!(
            "no image of the model's {} matches",
            model.images().len()
        )));
    }
    let mut poses = Vec::new();
    let mut without_pose = Vec::new();
    for (key, img) in by_key {
        match model.image_cam_from_world(img.image_id) {
            Some(a_from_world) => {
                let mut world_from_a = a_from_world.inverse();
                world_from_a.translation.vector *= mm_per_unit;
                poses.push(APose {
                    name: epoch_name(&key).to_string(),
                    key,
                    world_from_a,
                });
            }
            None => without_pose.push(img.name.clone()),
        }
    }
    Ok(ASequence {
        poses,
        without_pose,
    })
}

/// The camera selectors of a measurement checked against `model` before any work, as
/// [`crate::run`] checks them first: camera A selects images with distinct epoch names, B and
/// (when given) C each select one camera. A front end that runs other steps before the
/// measurement (the study) calls it up front, so a wrong camera is reported before hours of work.
///
/// # Errors
/// [`Error::Camera`] naming the role and what is wrong.
pub fn check_cameras(
    model: &Reconstruction,
    camera_a: &str,
    camera_b: &str,
    camera_c: Option<&str>,
) -> Result<(), Error> {
    a_sequence(model, &CameraSelector::parse(camera_a), 1.0)?;
    inward_camera(model, &CameraSelector::parse(camera_b), 'B')?;
    if let Some(c) = camera_c {
        inward_camera(model, &CameraSelector::parse(c), 'C')?;
    }
    Ok(())
}

/// The intrinsics of an inward camera and its COLMAP camera id.
///
/// A camera id must exist in `cameras.*`; a prefix must match images that all use one camera.
///
/// # Errors
/// [`Error::Camera`] naming the role and what is wrong.
pub fn inward_camera(
    model: &Reconstruction,
    selector: &CameraSelector,
    role: char,
) -> Result<(u32, Camera), Error> {
    let err = |problem: String| Error::Camera {
        model: model.dir().to_path_buf(),
        role,
        selector: selector.to_string(),
        problem,
    };
    let id = match selector {
        CameraSelector::CameraId(id) => *id,
        CameraSelector::Prefix(_) => {
            let mut ids: Vec<u32> = model
                .images()
                .iter()
                .filter(|i| selector.matches(i))
                .map(|i| i.camera_id)
                .collect();
            ids.sort_unstable();
            ids.dedup();
            match ids.as_slice() {
                [] => return Err(err("no image matches the prefix".into())),
                [id] => *id,
                _ => {
                    return Err(err(format!(
                        "the images of the prefix use several cameras ({ids:?}); give a camera id"
                    )));
                }
            }
        }
    };
    let rec = model
        .camera(id)
        .ok_or_else(|| err(format!("the model has no camera {id}")))?;
    Ok((id, rec.camera.clone()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epoch_name_and_frame_number() {
        assert_eq!(epoch_name("000123.png"), "000123");
        assert_eq!(epoch_name("run.1/000123"), "run.1/000123");
        assert_eq!(epoch_name("a/b.c.jpg"), "a/b.c");
        assert_eq!(epoch_name(".hidden"), ".hidden");
        assert_eq!(frame_number("000123"), Some(123));
        assert_eq!(frame_number("run3_0042"), Some(42));
        assert_eq!(frame_number("x12y"), Some(12));
        assert_eq!(frame_number("abc"), None);
    }
}
