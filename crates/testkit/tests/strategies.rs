//! Tests of the proptest strategies: they produce what their names promise.

use approx::assert_relative_eq;
use crashrig_testkit::strategies::{
    GIMBAL_MARGIN, RIGID3_MAX_TRANSLATION_MM, opk_away_from_gimbal, rigid3, rot3,
    rotation_vector_any, vec3_in,
};
use nalgebra::Matrix3;
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

proptest! {
    #[test]
    fn rot3_is_orthonormal(r in rot3()) {
        // Rotation from a normalised quaternion: orthonormal to a few ulps.
        assert_relative_eq!(r.matrix().transpose() * r.matrix(), Matrix3::identity(), epsilon = 1e-14);
        assert_relative_eq!(r.matrix().determinant(), 1.0, epsilon = 1e-14);
    }

    #[test]
    fn rigid3_is_bounded(t in rigid3()) {
        prop_assert!(t.translation.vector.amax() <= RIGID3_MAX_TRANSLATION_MM);
    }

    #[test]
    fn vec3_in_is_bounded(v in vec3_in(2.5)) {
        prop_assert!(v.amax() <= 2.5);
    }

    #[test]
    fn rotation_vector_any_in_log_range(w in rotation_vector_any()) {
        // Unit axis times an angle ≤ π: the norm is ≤ π up to one rounding.
        prop_assert!(w.norm() <= PI * (1.0 + 1e-15));
    }

    #[test]
    fn opk_away_from_gimbal_bounded((o, p, k) in opk_away_from_gimbal()) {
        prop_assert!(o.abs() < PI && k.abs() < PI);
        prop_assert!(p.abs() <= FRAC_PI_2 - GIMBAL_MARGIN);
    }
}
