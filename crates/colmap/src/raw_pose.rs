//! The one place where file records become `crashrig-geometry` types (normalized poses).

use crashrig_geometry::{Rigid3, quat};

use crate::record::RawPose;

impl RawPose {
    /// The pose as a [`Rigid3`] `b_from_a`, quaternion normalized; `None` when the quaternion
    /// is zero or non-finite or the translation is non-finite.
    pub fn to_rigid(&self) -> Option<Rigid3> {
        quat::rigid_from_colmap(self.qvec, self.tvec).ok()
    }

    /// The stored doubles of a [`Rigid3`] (unit quaternion `w, x, y, z`, translation).
    pub fn from_rigid(p: &Rigid3) -> RawPose {
        let (qvec, tvec) = quat::colmap_from_rigid(p);
        RawPose { qvec, tvec }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use crashrig_geometry::{Vec3, projection_center};

    #[test]
    fn to_rigid_nominal() {
        // 90° about z, stored unnormalized (×2) with w first: x_cam = R x_world + t.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let p = RawPose {
            qvec: [2.0 * h, 0.0, 0.0, 2.0 * h],
            tvec: [1.0, 2.0, 3.0],
        };
        let r = p.to_rigid().expect("valid pose");
        let x = r * nalgebra::Point3::new(1.0, 0.0, 0.0);
        // Exact up to a few ulps of the normalisation.
        assert_abs_diff_eq!(x.coords, Vec3::new(1.0, 3.0, 3.0), epsilon = 1e-15);
        let c = projection_center(&r);
        assert_abs_diff_eq!(
            (r * nalgebra::Point3::from(c)).coords,
            Vec3::zeros(),
            epsilon = 1e-15
        );
        let back = RawPose::from_rigid(&r);
        assert_abs_diff_eq!(back.qvec[0], h, epsilon = 1e-15);
        assert_abs_diff_eq!(back.qvec[3], h, epsilon = 1e-15);
    }

    #[test]
    fn to_rigid_rejects_zero_quaternion() {
        let p = RawPose {
            qvec: [0.0; 4],
            tvec: [0.0; 3],
        };
        assert!(p.to_rigid().is_none());
        let q = RawPose {
            qvec: [1.0, 0.0, 0.0, 0.0],
            tvec: [f64::NAN, 0.0, 0.0],
        };
        assert!(q.to_rigid().is_none());
    }
}
