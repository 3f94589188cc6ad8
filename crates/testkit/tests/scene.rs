//! Tests of the synthetic scene generators.

use approx::assert_relative_eq;
use crashrig_geometry::opk;
use crashrig_testkit::pose::assert_rigid_near;
use crashrig_testkit::scene::{paper_a_from_b, rig_sequence, stereo_a_from_b, two_view_scene};
use nalgebra::Point3;

#[test]
fn paper_a_from_b_nominal() {
    let link = paper_a_from_b();
    let angles = opk::opk_from_rotation(&link.rotation.to_rotation_matrix());
    // opk round trip of the paper's angles, well away from gimbal lock: ~1e-15 rad.
    assert_relative_eq!(angles.omega.to_degrees(), 179.92, epsilon = 1e-10);
    assert_relative_eq!(angles.phi.to_degrees(), -0.09, epsilon = 1e-10);
    assert_relative_eq!(angles.kappa.to_degrees(), 179.76, epsilon = 1e-10);
    assert_relative_eq!(link.translation.vector.x, 61.98);
}

#[test]
fn rig_sequence_noise_free_reproduces_link() {
    let link = stereo_a_from_b();
    let epochs = rig_sequence(1, 10, &link, 0.0, 0.0);
    assert_eq!(epochs.len(), 10);
    for e in &epochs {
        // Two compositions of poses up to ~3500 mm from the origin: rounding ~1e-12 relative.
        assert_rigid_near(
            &(e.a_from_world * e.b_from_world.inverse()),
            &link,
            1e-12,
            1e-10,
        );
    }
}

#[test]
fn rig_sequence_same_seed_identical() {
    let link = paper_a_from_b();
    let a = rig_sequence(5, 4, &link, 1e-3, 0.5);
    let b = rig_sequence(5, 4, &link, 1e-3, 0.5);
    let c = rig_sequence(6, 4, &link, 1e-3, 0.5);
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn two_view_scene_nominal() {
    let scene = two_view_scene(3, &stereo_a_from_b(), 20, (1000.0, 3000.0), 0.0).unwrap();
    assert_eq!(scene.points_world.len(), 20);
    for ((p, a), b) in scene
        .points_world
        .iter()
        .zip(&scene.normalized_a)
        .zip(&scene.normalized_b)
    {
        for (pose, obs) in [(scene.a_from_world, a), (scene.b_from_world, b)] {
            let pc = pose * Point3::from(*p);
            assert!(pc.z > 0.0);
            // Noise-free projection: rounding only.
            assert_relative_eq!(pc.x / pc.z, obs.x, epsilon = 1e-12);
            assert_relative_eq!(pc.y / pc.z, obs.y, epsilon = 1e-12);
        }
    }
}

#[test]
fn two_view_scene_impossible_visibility() {
    // The paper's cameras look in opposite directions: no common points.
    let r = two_view_scene(3, &paper_a_from_b(), 5, (1000.0, 3000.0), 0.0);
    assert!(r.is_err());
}
