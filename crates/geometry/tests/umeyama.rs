//! Umeyama alignment: exact recovery, reflections, degenerate inputs.

use approx::assert_relative_eq;
use crashrig_geometry::umeyama::{Sim3, align};
use crashrig_geometry::{Error, Vec3, so3};
use crashrig_testkit::strategies::{rot3, vec3_in};
use proptest::prelude::*;

fn points() -> Vec<Vec3> {
    vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(100.0, 0.0, 10.0),
        Vec3::new(0.0, 200.0, -30.0),
        Vec3::new(50.0, 60.0, 300.0),
        Vec3::new(-80.0, 20.0, 40.0),
    ]
}

#[test]
fn align_nominal_similarity() {
    let truth = Sim3 {
        scale: 2.5,
        rotation: so3::exp(&Vec3::new(0.3, -1.0, 2.0)),
        translation: Vec3::new(1000.0, -50.0, 20.0),
    };
    let src = points();
    let dst: Vec<Vec3> = src.iter().map(|p| truth.transform_point(p)).collect();
    let est = align(&src, &dst, true).unwrap();
    // Noise-free, well-conditioned: rounding at the 1e3 mm scale.
    assert_relative_eq!(est.scale, truth.scale, epsilon = 1e-12);
    assert_relative_eq!(
        *est.rotation.matrix(),
        *truth.rotation.matrix(),
        epsilon = 1e-12
    );
    assert_relative_eq!(est.translation, truth.translation, epsilon = 1e-9);
}

#[test]
fn align_rigid_keeps_unit_scale() {
    let r = so3::exp(&Vec3::new(-0.7, 0.2, 0.1));
    let t = Vec3::new(5.0, 6.0, 7.0);
    let src = points();
    let dst: Vec<Vec3> = src.iter().map(|p| r * p + t).collect();
    let est = align(&src, &dst, false).unwrap();
    assert_relative_eq!(est.scale, 1.0, epsilon = 0.0);
    assert_relative_eq!(*est.rotation.matrix(), *r.matrix(), epsilon = 1e-12);
    assert_relative_eq!(est.translation, t, epsilon = 1e-10);
}

#[test]
fn align_coplanar_points_proper_rotation() {
    // Coplanar points: the cross-covariance has rank 2, and an unlucky SVD sign gives
    // det(U Vᵀ) = −1 for a proper rotation; the fix must still return the true rotation.
    let src = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::new(0.0, 50.0, 0.0),
        Vec3::new(70.0, 80.0, 0.0),
    ];
    for w in [
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(2.0, -1.0, 0.3),
        Vec3::new(0.0, 3.0, 0.0),
    ] {
        let r = so3::exp(&w);
        let dst: Vec<Vec3> = src.iter().map(|p| r * p).collect();
        let est = align(&src, &dst, true).unwrap();
        assert_relative_eq!(*est.rotation.matrix(), *r.matrix(), epsilon = 1e-12);
        assert_relative_eq!(est.scale, 1.0, epsilon = 1e-12);
    }
}

#[test]
fn align_reflection_gives_proper_rotation() {
    // dst is a mirror image of src (x → −x): no rotation fits exactly; the result must still be
    // a proper rotation (det +1), and no better than the best orthogonal map.
    let src = points();
    let dst: Vec<Vec3> = src.iter().map(|p| Vec3::new(-p.x, p.y, p.z)).collect();
    let est = align(&src, &dst, false).unwrap();
    assert_relative_eq!(est.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
    let cost = |s: &Sim3| -> f64 {
        src.iter()
            .zip(&dst)
            .map(|(a, b)| (s.transform_point(a) - b).norm_squared())
            .sum()
    };
    // The identity is a valid rotation too: the optimum cannot be worse.
    let identity = Sim3 {
        scale: 1.0,
        rotation: crashrig_geometry::Rot3::identity(),
        translation: dst.iter().sum::<Vec3>() / 5.0 - src.iter().sum::<Vec3>() / 5.0,
    };
    assert!(cost(&est) <= cost(&identity) * (1.0 + 1e-12));
}

#[test]
fn align_errors() {
    let src = points();
    assert_eq!(
        align(&src, &src[..4], true),
        Err(Error::LengthMismatch { left: 5, right: 4 })
    );
    assert_eq!(
        align(&src[..2], &src[..2], true),
        Err(Error::TooFewPoints {
            needed: 3,
            found: 2
        })
    );
    let collinear: Vec<Vec3> = (0..5)
        .map(|i| Vec3::new(f64::from(i), 2.0 * f64::from(i), 0.0))
        .collect();
    assert!(matches!(
        align(&collinear, &collinear, true),
        Err(Error::Degenerate { .. })
    ));
    let mut bad = src.clone();
    bad[1].y = f64::NAN;
    assert!(matches!(
        align(&bad, &src, true),
        Err(Error::NonFinite { .. })
    ));
}

proptest! {
    #[test]
    fn align_recovers_random_similarity(r in rot3(), t in vec3_in(1e4), s in 0.01..100.0f64) {
        let src = points();
        let dst: Vec<Vec3> = src.iter().map(|p| r * p * s + t).collect();
        let est = align(&src, &dst, true).unwrap();
        assert_relative_eq!(est.scale, s, max_relative = 1e-10);
        assert_relative_eq!(*est.rotation.matrix(), *r.matrix(), epsilon = 1e-10);
        // |t| up to 1.7e4 mm, scaled points up to 3e4 mm.
        assert_relative_eq!(est.translation, t, epsilon = 1e-7);
    }
}
