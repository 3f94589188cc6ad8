//! Aim a camera: optical axis through a target with no roll (world z up, image y down).

use crate::tolerance::{MIN_DIRECTION_NORM, MIN_LOOK_AT_HORIZONTAL};
use crate::{Error, Mat3, Rot3, Vec3};

/// `R_world_from_cam` of a camera at `center` looking at `target` (both world, mm).
///
/// Camera axes (OpenCV/COLMAP): z is the optical axis `(target − center)/|…|`; y lies in the
/// vertical plane containing z and points down (negative world-z component); `x = y × z`.
/// The columns of the returned matrix are the camera axes expressed in world coordinates.
///
/// # Errors
/// [`Error::NonFinite`] for NaN input, [`Error::ZeroDirection`] if `target == center`,
/// [`Error::Degenerate`] when looking straight up or down (`|d̂ × e_z|` below
/// [`MIN_LOOK_AT_HORIZONTAL`]), where the roll is undefined.
pub fn world_from_cam_look_at(center: &Vec3, target: &Vec3) -> Result<Rot3, Error> {
    let d = target - center;
    if d.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "look-at centre or target",
        });
    }
    let norm = d.norm();
    if norm < MIN_DIRECTION_NORM {
        return Err(Error::ZeroDirection);
    }
    let z = d / norm;
    let horizontal = z.cross(&Vec3::z()).norm();
    if horizontal < MIN_LOOK_AT_HORIZONTAL {
        return Err(Error::Degenerate {
            what: "look-at direction is vertical",
            condition: horizontal,
        });
    }
    // x = normalize(z × e_z) = (z_y, −z_x, 0)/|…| is horizontal and computed without
    // cancellation; y = z × x then lies in the vertical plane through z, pointing down
    // (y·e_z = −|z × e_z| < 0), and (x, y, z) is right-handed.
    let x = Vec3::new(z.y, -z.x, 0.0) / horizontal;
    let y = z.cross(&x);
    Ok(Rot3::from_matrix_unchecked(Mat3::from_columns(&[x, y, z])))
}
