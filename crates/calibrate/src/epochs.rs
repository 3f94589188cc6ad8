//! Epochs and scale from a COLMAP model (a bundle without a rig constraint): the COLMAP
//! adapter of the calibration (moved here from `crashrig-rig`, which works on poses only).
//!
//! # Selecting cameras A and B
//! A [`CameraSelector`] (from `crashrig-colmap`, shared with `measure`) is a camera id when the
//! text is made only of digits (`"2"`), and an image-name prefix otherwise (`"cam_out/"`,
//! COLMAP's rig-config naming).
//!
//! # Pairing images into epochs
//! 1. **Shared frame**: an image of A and an image of B that belong to the same COLMAP frame
//!    form an epoch (a model with rigs and frames; if it was adjusted with the rig constraint,
//!    every epoch has the same link and the calibration refuses it).
//! 2. **Name**: the remaining images pair when their names are equal after removing the
//!    prefix (`cam_out/000123.png` ↔ `cam_in/000123.png`). For a camera-id selector the
//!    prefix is the name up to and including the first `/` (the whole name if there is none).
//!
//! Images left without a partner, or without a pose, are **reported** in [`EpochSet`], never
//! silently dropped. Epochs are ordered by their key (the name without the prefix), which is
//! the sequence order for COLMAP's zero-padded frame names.

use crate::error::Error;
use crashrig_colmap::{Image, Reconstruction};
use crashrig_rig::Epoch;
use std::collections::{BTreeMap, HashMap};

/// Relative size, against the coordinates, below which two scale-bar points coincide
/// (a few hundred ulps: the difference carries no significant digit).
const SCALE_BAR_MIN_RELATIVE_LENGTH: f64 = 1e-13;

pub use crashrig_colmap::CameraSelector;

/// The epochs of a model and what could not be paired.
#[derive(Debug, Clone, PartialEq)]
pub struct EpochSet {
    /// Epochs in key order; poses in model units.
    pub epochs: Vec<Epoch>,
    /// Number of epochs paired through a shared frame.
    pub paired_by_frame: usize,
    /// Number of epochs paired by name.
    pub paired_by_name: usize,
    /// Names of A images without a partner in B.
    pub unpaired_a: Vec<String>,
    /// Names of B images without a partner in A.
    pub unpaired_b: Vec<String>,
    /// Names of paired images whose pose is unknown (epoch skipped).
    pub without_pose: Vec<String>,
}

fn select<'m>(
    model: &'m Reconstruction,
    sel: &CameraSelector,
    role: char,
) -> Result<Vec<&'m Image>, Error> {
    if sel.is_blank() {
        return Err(Error::EmptyCamera { role });
    }
    let v: Vec<&Image> = model.images().iter().filter(|i| sel.matches(i)).collect();
    if v.is_empty() {
        return Err(Error::NoImagesForCamera {
            model: model.dir().to_path_buf(),
            role,
            selector: sel.to_string(),
            n_images: model.images().len(),
            suggestions: sel.suggestions(model.images()),
        });
    }
    Ok(v)
}

/// Pairs the images of cameras `a` and `b` into epochs (see the module doc).
///
/// # Errors
/// [`Error::EmptyCamera`] for an empty selector, [`Error::NoImagesForCamera`] when a selector
/// matches nothing (one camera absent, a wrong prefix), [`Error::OverlappingCameras`] when an image matches both, [`Error::DuplicateEpoch`]
/// when two images of one camera share a key or a frame, [`Error::NoEpochs`] when nothing pairs.
pub fn epochs_from_model(
    model: &Reconstruction,
    a: &CameraSelector,
    b: &CameraSelector,
) -> Result<EpochSet, Error> {
    let dir = model.dir().to_path_buf();
    let imgs_a = select(model, a, 'A')?;
    let imgs_b = select(model, b, 'B')?;
    if let Some(img) = imgs_a.iter().find(|i| b.matches(i)) {
        return Err(Error::OverlappingCameras {
            model: dir,
            image: img.name.clone(),
        });
    }
    // Pairs (key, A image, B image).
    let mut pairs: Vec<(String, &Image, &Image)> = Vec::new();
    let mut used_b: HashMap<u32, ()> = HashMap::new();
    let mut left_a: Vec<&Image> = Vec::new();
    let mut paired_by_frame = 0;
    for ia in &imgs_a {
        let partners: Vec<&Image> = model
            .image_frame(ia.image_id)
            .map(|f| {
                model
                    .frame_images(f)
                    .into_iter()
                    .filter(|i| b.matches(i))
                    .collect()
            })
            .unwrap_or_default();
        match partners.as_slice() {
            [] => left_a.push(ia),
            [ib] => {
                pairs.push((a.key(&ia.name).to_string(), ia, ib));
                used_b.insert(ib.image_id, ());
                paired_by_frame += 1;
            }
            [first, second, ..] => {
                return Err(Error::DuplicateEpoch {
                    model: dir,
                    role: 'B',
                    key: a.key(&ia.name).to_string(),
                    first: first.name.clone(),
                    second: second.name.clone(),
                });
            }
        }
    }
    let mut by_key_b: BTreeMap<&str, &Image> = BTreeMap::new();
    for ib in imgs_b.iter().filter(|i| !used_b.contains_key(&i.image_id)) {
        let k = b.key(&ib.name);
        if let Some(prev) = by_key_b.insert(k, ib) {
            return Err(Error::DuplicateEpoch {
                model: dir,
                role: 'B',
                key: k.to_string(),
                first: prev.name.clone(),
                second: ib.name.clone(),
            });
        }
    }
    let mut seen_a: HashMap<&str, &Image> = HashMap::new();
    let mut unpaired_a = Vec::new();
    let mut paired_by_name = 0;
    for ia in left_a {
        let k = a.key(&ia.name);
        if let Some(prev) = seen_a.insert(k, ia) {
            return Err(Error::DuplicateEpoch {
                model: dir,
                role: 'A',
                key: k.to_string(),
                first: prev.name.clone(),
                second: ia.name.clone(),
            });
        }
        match by_key_b.remove(k) {
            Some(ib) => {
                pairs.push((k.to_string(), ia, ib));
                paired_by_name += 1;
            }
            None => unpaired_a.push(ia.name.clone()),
        }
    }
    let unpaired_b: Vec<String> = by_key_b.values().map(|i| i.name.clone()).collect();
    if pairs.is_empty() {
        let hint = [('A', a), ('B', b)]
            .into_iter()
            .find_map(|(role, sel)| sel.slash_hint(model.images()).map(|h| (role, h)));
        return Err(Error::NoEpochs {
            model: dir,
            unpaired_a: unpaired_a.len(),
            unpaired_b: unpaired_b.len(),
            hint,
        });
    }
    pairs.sort_by(|x, y| x.0.cmp(&y.0));
    let mut epochs = Vec::with_capacity(pairs.len());
    let mut without_pose = Vec::new();
    for (key, ia, ib) in pairs {
        match (
            model.image_cam_from_world(ia.image_id),
            model.image_cam_from_world(ib.image_id),
        ) {
            (Some(pa), Some(pb)) => epochs.push(Epoch {
                name: key,
                a_from_world: pa,
                b_from_world: pb,
            }),
            (pa, pb) => {
                if pa.is_none() {
                    without_pose.push(ia.name.clone());
                }
                if pb.is_none() {
                    without_pose.push(ib.name.clone());
                }
            }
        }
    }
    unpaired_a.sort();
    Ok(EpochSet {
        epochs,
        paired_by_frame,
        paired_by_name,
        unpaired_a,
        unpaired_b,
        without_pose,
    })
}

/// A scale bar: two 3-D points a known distance apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleBar {
    /// First point3D id.
    pub point_1: u64,
    /// Second point3D id.
    pub point_2: u64,
    /// Their distance in model units.
    pub distance_units: f64,
    /// The known length (mm).
    pub length_mm: f64,
    /// The resulting scale, `length_mm / distance_units`.
    pub mm_per_unit: f64,
}

/// The scale of a model from two point3D ids `length_mm` apart.
///
/// # Errors
/// [`Error::InvalidScaleLength`] for a length that is not finite and positive,
/// [`Error::UnknownPoint`] for an id not in the model, [`Error::ZeroLengthScaleBar`] when the
/// points coincide.
pub fn scale_from_points(
    model: &Reconstruction,
    point_1: u64,
    point_2: u64,
    length_mm: f64,
) -> Result<ScaleBar, Error> {
    if !(length_mm.is_finite() && length_mm > 0.0) {
        return Err(Error::InvalidScaleLength {
            model: model.dir().to_path_buf(),
            length_mm,
        });
    }
    let get = |id: u64| {
        model.point3d(id).ok_or_else(|| Error::UnknownPoint {
            model: model.dir().to_path_buf(),
            point_id: id,
        })
    };
    let p = get(point_1)?.xyz;
    let q = get(point_2)?.xyz;
    let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
    let magnitude = p.iter().chain(&q).fold(1.0_f64, |m, v| m.max(v.abs()));
    if !d.is_finite() || d <= SCALE_BAR_MIN_RELATIVE_LENGTH * magnitude {
        return Err(Error::ZeroLengthScaleBar {
            model: model.dir().to_path_buf(),
            point_1,
            point_2,
            distance: d,
        });
    }
    Ok(ScaleBar {
        point_1,
        point_2,
        distance_units: d,
        length_mm,
        mm_per_unit: length_mm / d,
    })
}
