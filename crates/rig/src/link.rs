//! Epochs (one image of A and one of B) and the per-epoch rig link `A_from_B`.

use crate::Error;
use crashrig_geometry::{Rigid3, Vec3, opk};

/// One epoch of the sequence: the independently estimated poses of camera A and camera B.
///
/// Poses are `cam_from_world` in **model units** (COLMAP's `images` poses); the scale to mm is
/// applied by [`link_of`].
#[derive(Debug, Clone, PartialEq)]
pub struct Epoch {
    /// Epoch name (the image name without the camera prefix, or the frame id).
    pub name: String,
    /// Pose of camera A, `A_from_world` (model units).
    pub a_from_world: Rigid3,
    /// Pose of camera B, `B_from_world` (model units).
    pub b_from_world: Rigid3,
}

/// The rig link of one epoch, `A_from_B`, in mm.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Epoch name.
    pub name: String,
    /// `A_from_B = A_from_world · (B_from_world)⁻¹`, translation in mm.
    pub a_from_b: Rigid3,
    /// Base: B's projection centre in A's frame (mm), the translation of `A_from_B`.
    pub base_mm: Vec3,
    /// ω, φ, κ of `R_A_from_B` (rad; ω, κ in (−π, π], φ in [−π/2, π/2]).
    pub angles: Vec3,
}

/// Checks a scale factor (mm per model unit): finite and positive.
pub fn check_scale(mm_per_unit: f64) -> Result<f64, Error> {
    if mm_per_unit.is_finite() && mm_per_unit > 0.0 {
        Ok(mm_per_unit)
    } else {
        Err(Error::InvalidScale { mm_per_unit })
    }
}

fn finite(p: &Rigid3) -> bool {
    p.translation.vector.iter().all(|v| v.is_finite())
        && p.rotation.coords.iter().all(|v| v.is_finite())
}

/// Checks that both poses of an epoch are finite.
pub(crate) fn check_epoch(e: &Epoch) -> Result<(), Error> {
    if !finite(&e.a_from_world) {
        return Err(Error::NonFinitePose {
            name: e.name.clone(),
            camera: 'A',
        });
    }
    if !finite(&e.b_from_world) {
        return Err(Error::NonFinitePose {
            name: e.name.clone(),
            camera: 'B',
        });
    }
    Ok(())
}

/// Scales the translation of a pose from model units to mm.
pub(crate) fn scaled(p: &Rigid3, mm_per_unit: f64) -> Rigid3 {
    let mut q = *p;
    q.translation.vector *= mm_per_unit;
    q
}

/// The link `A_from_B` of one epoch, with the base in mm (`mm_per_unit` scales model units).
///
/// # Errors
/// [`Error::InvalidScale`] for a scale that is not finite and positive,
/// [`Error::NonFinitePose`] for a pose with NaN or infinity.
pub fn link_of(epoch: &Epoch, mm_per_unit: f64) -> Result<Link, Error> {
    check_scale(mm_per_unit)?;
    check_epoch(epoch)?;
    let a_from_b = scaled(
        &(epoch.a_from_world * epoch.b_from_world.inverse()),
        mm_per_unit,
    );
    let r = a_from_b.rotation.to_rotation_matrix();
    let a = opk::opk_from_rotation(&r);
    Ok(Link {
        name: epoch.name.clone(),
        base_mm: a_from_b.translation.vector,
        angles: Vec3::new(a.omega, a.phi, a.kappa),
        a_from_b,
    })
}

/// The links of all epochs, in order.
///
/// # Errors
/// Those of [`link_of`].
pub fn links_of(epochs: &[Epoch], mm_per_unit: f64) -> Result<Vec<Link>, Error> {
    epochs.iter().map(|e| link_of(e, mm_per_unit)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use crashrig_geometry::{Rot3, opk::rotation_from_opk};
    use nalgebra::Translation3;

    fn pose(r: Rot3, t: Vec3) -> Rigid3 {
        Rigid3::from_parts(
            Translation3::from(t),
            crashrig_geometry::quat::unit_quaternion_from_rotation(&r),
        )
    }

    #[test]
    fn link_of_nominal_recovers_injected_link() {
        let r_ab = rotation_from_opk(
            179.92f64.to_radians(),
            -0.09f64.to_radians(),
            179.76f64.to_radians(),
        );
        let base = Vec3::new(61.98, -1.71, 179.76);
        let a_from_b = pose(r_ab, base);
        let a_from_world = pose(
            rotation_from_opk(0.3, -0.2, 1.1),
            Vec3::new(100.0, -50.0, 2000.0),
        );
        // B_from_world = (A_from_B)⁻¹ · A_from_world, model units = mm / 10.
        let b_from_world = a_from_b.inverse() * a_from_world;
        let e = Epoch {
            name: "000001.png".into(),
            a_from_world: scaled(&a_from_world, 0.1),
            b_from_world: scaled(&b_from_world, 0.1),
        };
        let l = link_of(&e, 10.0).unwrap();
        // Round trip through quaternion products: a few ulps of 2000 mm.
        assert_abs_diff_eq!(l.base_mm, base, epsilon = 1e-9);
        assert_abs_diff_eq!(l.angles[0].to_degrees(), 179.92, epsilon = 1e-9);
        assert_abs_diff_eq!(l.angles[1].to_degrees(), -0.09, epsilon = 1e-9);
        assert_abs_diff_eq!(l.angles[2].to_degrees(), 179.76, epsilon = 1e-9);
    }

    #[test]
    fn link_of_bad_scale_is_error() {
        let e = Epoch {
            name: "x".into(),
            a_from_world: Rigid3::identity(),
            b_from_world: Rigid3::identity(),
        };
        for s in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(link_of(&e, s), Err(Error::InvalidScale { .. })));
        }
    }

    #[test]
    fn link_of_non_finite_pose_is_error() {
        let mut b = Rigid3::identity();
        b.translation.vector.x = f64::NAN;
        let e = Epoch {
            name: "x".into(),
            a_from_world: Rigid3::identity(),
            b_from_world: b,
        };
        assert!(matches!(
            link_of(&e, 1.0),
            Err(Error::NonFinitePose { camera: 'B', .. })
        ));
    }
}

/// Helpers shared by the unit tests of this crate.
#[cfg(test)]
pub(crate) mod tests_support {
    use super::*;
    use crashrig_geometry::{Rot3, opk::rotation_from_opk};
    use nalgebra::Translation3;

    /// A rigid transform from a rotation and a translation.
    pub fn pose(r: Rot3, t: Vec3) -> Rigid3 {
        Rigid3::from_parts(
            Translation3::from(t),
            crashrig_geometry::quat::unit_quaternion_from_rotation(&r),
        )
    }

    /// A link from a base (mm) and ω φ κ (degrees).
    pub fn link(base: [f64; 3], angles_deg: [f64; 3]) -> Link {
        let r = rotation_from_opk(
            angles_deg[0].to_radians(),
            angles_deg[1].to_radians(),
            angles_deg[2].to_radians(),
        );
        let a_from_b = pose(r, Vec3::from(base));
        let a = opk::opk_from_rotation(&r);
        Link {
            name: String::new(),
            a_from_b,
            base_mm: Vec3::from(base),
            angles: Vec3::new(a.omega, a.phi, a.kappa),
        }
    }
}
