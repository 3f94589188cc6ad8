//! The one place where file records become `crashrig-geometry` types (normalized poses).

use crashrig_geometry::{Rigid3, quat};

use crate::record::RawPose;

impl RawPose {
    /// The pose as a [`Rigid3`] `b_from_a`, quaternion normalized; `None` when the quaternion
    /// is zero or non-finite or the translation is non-finite.
    pub fn to_rigid(&self) -> Option<Rigid3> {
        quat::rigid_from_colmap(self.qvec, self.tvec).ok()
    }

    /// The 3×4 matrix `[R | t]` that COLMAP and pycolmap give for this pose as stored
    /// (`Rigid3d::ToMatrix`): `R` is Eigen's `toRotationMatrix()` of the quaternion **as read**.
    /// COLMAP ≥ 3.11 does not normalise a quaternion on reading (3.9–3.10 did), only where a
    /// computation assumes a unit one (bundle adjustment, pose estimation), so for a stored
    /// quaternion of norm `1 + ε` this `R` is `(1+ε)²·R̂ + (1 − (1+ε)²)·I`, not the rotation
    /// [`RawPose::to_rigid`] gives (the commands use that one).
    pub fn colmap_matrix(&self) -> [[f64; 4]; 3] {
        let [w, x, y, z] = self.qvec;
        // Eigen's QuaternionBase::toRotationMatrix, term by term.
        let (tx, ty, tz) = (2.0 * x, 2.0 * y, 2.0 * z);
        let (twx, twy, twz) = (tx * w, ty * w, tz * w);
        let (txx, txy, txz) = (tx * x, ty * x, tz * x);
        let (tyy, tyz, tzz) = (ty * y, tz * y, tz * z);
        let t = self.tvec;
        [
            [1.0 - (tyy + tzz), txy - twz, txz + twy, t[0]],
            [txy + twz, 1.0 - (txx + tzz), tyz - twx, t[1]],
            [txz - twy, tyz + twx, 1.0 - (txx + tyy), t[2]],
        ]
    }

    /// COLMAP's composition `self ∘ b_from_a` of two stored poses (`Rigid3d operator*`): the
    /// quaternion product, normalised; the translation `t_self + q_self · t_b_from_a` with the
    /// quaternion as stored (Eigen's `_transformVector`).
    pub fn colmap_compose(&self, b_from_a: &RawPose) -> RawPose {
        let [w1, x1, y1, z1] = self.qvec;
        let [w2, x2, y2, z2] = b_from_a.qvec;
        // Eigen's quat_product (Hamilton).
        let q = [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 + y1 * w2 + z1 * x2 - x1 * z2,
            w1 * z2 + z1 * w2 + x1 * y2 - y1 * x2,
        ];
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        let q = if n > 0.0 { q.map(|c| c / n) } else { q };
        // Eigen's _transformVector: uv = 2 (v × t); t + w·uv + v × uv.
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let (v, t) = ([x1, y1, z1], b_from_a.tvec);
        let uv = cross(v, t).map(|c| c + c);
        let vuv = cross(v, uv);
        let rotated = [0, 1, 2].map(|i| t[i] + w1 * uv[i] + vuv[i]);
        RawPose {
            qvec: q,
            tvec: [0, 1, 2].map(|i| self.tvec[i] + rotated[i]),
        }
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

    /// A stored quaternion of norm s: COLMAP's matrix is s²·R̂ + (1 − s²)·I (Eigen's formula
    /// assumes a unit quaternion); for s = 1 it is the rotation of `to_rigid`.
    #[test]
    fn colmap_matrix_of_a_non_unit_quaternion_is_eigens() {
        let unit = [0.9_f64, 0.1, -0.3, 0.2];
        let n = unit.iter().map(|c| c * c).sum::<f64>().sqrt();
        let unit = unit.map(|c| c / n);
        let t = [1.0, 2.0, 3.0];
        let r = RawPose {
            qvec: unit,
            tvec: t,
        }
        .to_rigid()
        .unwrap()
        .to_matrix();
        for s in [1.0, 1.0 + 4e-7, 2.0] {
            let m = RawPose {
                qvec: unit.map(|c| c * s),
                tvec: t,
            }
            .colmap_matrix();
            for i in 0..3 {
                for j in 0..3 {
                    let want = s * s * r[(i, j)] + if i == j { 1.0 - s * s } else { 0.0 };
                    assert_abs_diff_eq!(m[i][j], want, epsilon = 1e-14);
                }
                assert_eq!(m[i][3], t[i]);
            }
        }
    }

    /// COLMAP's composition of unit quaternions is the composition of the rigid transforms;
    /// with a non-unit `self` the rotation is still normalised, the translation is not.
    #[test]
    fn colmap_compose_of_unit_poses_is_the_rigid_product() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let a = RawPose {
            qvec: [h, h, 0.0, 0.0],
            tvec: [0.1, -0.2, 0.3],
        };
        let b = RawPose {
            qvec: [0.5, 0.5, -0.5, 0.5],
            tvec: [1.0, 2.0, 3.0],
        };
        let c = a.colmap_compose(&b).to_rigid().unwrap();
        let want = a.to_rigid().unwrap() * b.to_rigid().unwrap();
        assert_abs_diff_eq!(c.to_matrix(), want.to_matrix(), epsilon = 1e-15);
        let a2 = RawPose {
            qvec: a.qvec.map(|q| 2.0 * q),
            tvec: a.tvec,
        };
        let c2 = a2.colmap_compose(&b);
        let norm = c2.qvec.iter().map(|q| q * q).sum::<f64>().sqrt();
        assert_abs_diff_eq!(norm, 1.0, epsilon = 1e-15);
        // t = t_a + M(q_a)·t_b with M = 4R − 3I for the doubled quaternion.
        let m = a2.colmap_matrix();
        for (i, row) in m.iter().enumerate() {
            let want = a.tvec[i] + row.iter().zip(&b.tvec).map(|(r, t)| r * t).sum::<f64>();
            assert_abs_diff_eq!(c2.tvec[i], want, epsilon = 1e-14);
        }
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
