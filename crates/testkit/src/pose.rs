//! Pose comparison: angular distance for the rotation, relative (or absolute at zero) translation.

use crashrig_geometry::{Rigid3, Rot3, so3};
use std::fmt;

/// Why two poses are not near each other.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PoseMismatch {
    /// The angular distance (rad) of the rotations exceeds the tolerance (or is NaN).
    Rotation {
        /// Angular distance |Log(R_expectedᵀ R_actual)| in rad.
        angle: f64,
        /// The tolerance in rad.
        tol: f64,
    },
    /// The translation difference exceeds the allowed bound (or is NaN).
    Translation {
        /// |t_actual − t_expected| (mm).
        distance: f64,
        /// The bound it was compared with (mm): `tol·|t_expected|`, or `tol` if that is zero.
        bound: f64,
    },
}

impl fmt::Display for PoseMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PoseMismatch::Rotation { angle, tol } => {
                write!(
                    f,
                    "rotation differs by {angle:e} rad (tolerance {tol:e} rad)"
                )
            }
            PoseMismatch::Translation { distance, bound } => {
                write!(
                    f,
                    "translation differs by {distance:e} mm (bound {bound:e} mm)"
                )
            }
        }
    }
}

/// Check that `actual` is near `expected` (COLMAP's `Rigid3dNear` semantics).
///
/// - Rotation: angular distance `|Log(R_expectedᵀ·R_actual)| ≤ rot_tol_rad`.
/// - Translation: `|t_a − t_e| ≤ trans_tol·|t_e|` (relative); when `t_e` is exactly zero the
///   check is absolute, `|t_a| ≤ trans_tol` (mm).
///
/// NaN anywhere never matches (comparisons are written as `!(x ≤ tol)`).
pub fn rigid_near(
    actual: &Rigid3,
    expected: &Rigid3,
    rot_tol_rad: f64,
    trans_tol: f64,
) -> Result<(), PoseMismatch> {
    let ra = actual.rotation.to_rotation_matrix();
    let re = expected.rotation.to_rotation_matrix();
    let finite_rot = ra
        .matrix()
        .iter()
        .chain(re.matrix().iter())
        .all(|v| v.is_finite());
    let angle = if finite_rot {
        so3::angular_distance(&re, &ra)
    } else {
        f64::NAN
    };
    if angle.is_nan() || angle > rot_tol_rad {
        return Err(PoseMismatch::Rotation {
            angle,
            tol: rot_tol_rad,
        });
    }
    let te = expected.translation.vector;
    let distance = (actual.translation.vector - te).norm();
    let reference = te.norm();
    let bound = if reference == 0.0 {
        trans_tol
    } else {
        trans_tol * reference
    };
    if distance.is_nan() || bound.is_nan() || distance > bound {
        return Err(PoseMismatch::Translation { distance, bound });
    }
    Ok(())
}

/// Same as [`rigid_near`] but the translation tolerance is always absolute (mm).
pub fn rigid_near_abs(
    actual: &Rigid3,
    expected: &Rigid3,
    rot_tol_rad: f64,
    trans_tol_mm: f64,
) -> Result<(), PoseMismatch> {
    // Compare against a zero-translation reference by moving both poses by −t_expected.
    let shift = nalgebra::Translation3::from(-expected.translation.vector);
    let a = Rigid3::from_parts(shift * actual.translation, actual.rotation);
    let e = Rigid3::from_parts(nalgebra::Translation3::identity(), expected.rotation);
    rigid_near(&a, &e, rot_tol_rad, trans_tol_mm)
}

/// Assert that two rotations are within `tol_rad` angular distance (NaN never matches).
#[track_caller]
pub fn assert_rot3_near(actual: &Rot3, expected: &Rot3, tol_rad: f64) {
    let finite = actual
        .matrix()
        .iter()
        .chain(expected.matrix().iter())
        .all(|v| v.is_finite());
    let angle = if finite {
        so3::angular_distance(expected, actual)
    } else {
        f64::NAN
    };
    if angle.is_nan() || angle > tol_rad {
        panic!(
            "rotations not near: angular distance {angle:e} rad (tolerance {tol_rad:e} rad)\n  actual:   {actual}\n  expected: {expected}"
        );
    }
}

/// Assert [`rigid_near`], panicking with both poses and the reason otherwise.
#[track_caller]
pub fn assert_rigid_near(actual: &Rigid3, expected: &Rigid3, rot_tol_rad: f64, trans_tol: f64) {
    if let Err(e) = rigid_near(actual, expected, rot_tol_rad, trans_tol) {
        panic!("poses not near: {e}\n  actual:   {actual}\n  expected: {expected}");
    }
}

/// Assert [`rigid_near_abs`] (absolute translation tolerance in mm).
#[track_caller]
pub fn assert_rigid_near_abs(
    actual: &Rigid3,
    expected: &Rigid3,
    rot_tol_rad: f64,
    trans_tol_mm: f64,
) {
    if let Err(e) = rigid_near_abs(actual, expected, rot_tol_rad, trans_tol_mm) {
        panic!("poses not near: {e}\n  actual:   {actual}\n  expected: {expected}");
    }
}
