//! The COLMAP I/O edge for rotations: quaternions are `w, x, y, z` on disk (Hamilton convention).
//!
//! nalgebra stores `[x, y, z, w]` internally; these functions are the one place that converts.

use crate::tolerance::MIN_QUATERNION_NORM;
use crate::{Error, Rigid3, Rot3, Vec3};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};

/// Rotation from a `[w, x, y, z]` quaternion, normalised.
///
/// # Errors
/// [`Error::NonUnitQuaternion`] when the norm is zero, NaN or infinite.
pub fn rotation_from_wxyz(q: [f64; 4]) -> Result<UnitQuaternion<f64>, Error> {
    let quat = Quaternion::new(q[0], q[1], q[2], q[3]);
    let norm = quat.norm();
    if !norm.is_finite() || norm < MIN_QUATERNION_NORM {
        return Err(Error::NonUnitQuaternion { norm });
    }
    Ok(UnitQuaternion::new_unchecked(quat / norm))
}

/// Unit quaternion of a rotation matrix, **normalised**.
///
/// nalgebra's `UnitQuaternion::from_rotation_matrix` does not normalise its result, so a matrix
/// that is orthonormal only to rounding gives a quaternion of norm 1 ± ε, and repeated
/// conversions drift (a scale error that compounds). Use this function instead.
pub fn unit_quaternion_from_rotation(r: &Rot3) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(UnitQuaternion::from_rotation_matrix(r).into_inner())
}

/// A rigid transform `(R, t)` from a rotation matrix and a translation (mm), with the rotation
/// stored as a normalised quaternion.
pub fn rigid_from_rotation(r: &Rot3, t: &Vec3) -> Rigid3 {
    Rigid3::from_parts(Translation3::from(*t), unit_quaternion_from_rotation(r))
}

/// `[w, x, y, z]` of a unit quaternion (the sign is kept as stored).
pub fn wxyz_from_rotation(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// A rigid transform from COLMAP's `QW QX QY QZ TX TY TZ` (e.g. an image's `cam_from_world`).
///
/// # Errors
/// [`Error::NonUnitQuaternion`] for a zero/NaN quaternion, [`Error::NonFinite`] for a NaN or
/// infinite translation.
pub fn rigid_from_colmap(q_wxyz: [f64; 4], t: [f64; 3]) -> Result<Rigid3, Error> {
    let rotation = rotation_from_wxyz(q_wxyz)?;
    if t.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "translation",
        });
    }
    Ok(Rigid3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        rotation,
    ))
}

/// COLMAP's `([QW, QX, QY, QZ], [TX, TY, TZ])` of a rigid transform.
pub fn colmap_from_rigid(p: &Rigid3) -> ([f64; 4], [f64; 3]) {
    let t: Vec3 = p.translation.vector;
    (wxyz_from_rotation(&p.rotation), [t.x, t.y, t.z])
}
