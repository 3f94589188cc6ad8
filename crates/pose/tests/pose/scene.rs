//! Seeded synthetic two-camera scenes in pixels.

use crashrig_geometry::{Rigid3, Vec3, opk};
use crashrig_pose::{Pinhole, Projector};
use nalgebra::{Translation3, UnitQuaternion, Vector2};
use rand::{RngExt, SeedableRng, rngs::ChaCha8Rng};
use rand_distr::StandardNormal;

/// A 1000-px pinhole camera of a 1600×1200 image.
pub fn camera() -> Pinhole {
    Pinhole {
        fx: 1000.0,
        fy: 1000.0,
        cx: 800.0,
        cy: 600.0,
    }
}

/// `B_from_world` of the standard scene (A is the world frame): B is 600 mm to the right and
/// 100 mm forward, turned a little about all axes.
pub fn b_from_world() -> Rigid3 {
    let r = opk::rotation_from_opk(0.03, -0.12, 0.05);
    let c = Vec3::new(600.0, 20.0, 100.0);
    Rigid3::from_parts(
        Translation3::from(-(r * c)),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// Noise-free scene: `n` world points seen by both cameras (inside both images, depth
/// 2000–5000 mm in A), with their exact pixels in A and B.
pub struct Scene {
    pub points: Vec<Vec3>,
    pub px_a: Vec<Vector2<f64>>,
    pub px_b: Vec<Vector2<f64>>,
}

pub fn scene<C: Projector>(seed: u64, n: usize, cam: &C, b_from_world: &Rigid3) -> Scene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut s = Scene {
        points: Vec::new(),
        px_a: Vec::new(),
        px_b: Vec::new(),
    };
    let inside = |x: &Vector2<f64>| x.x > 0.0 && x.x < 1600.0 && x.y > 0.0 && x.y < 1200.0;
    while s.points.len() < n {
        let z = rng.random_range(2000.0..5000.0);
        let p = Vec3::new(
            rng.random_range(-0.7..0.7) * z,
            rng.random_range(-0.5..0.5) * z,
            z,
        );
        let pb = b_from_world.transform_point(&p.into()).coords;
        let (Some(xa), Some(xb)) = (cam.project(&p), cam.project(&pb)) else {
            continue;
        };
        if inside(&xa) && inside(&xb) {
            s.points.push(p);
            s.px_a.push(xa);
            s.px_b.push(xb);
        }
    }
    s
}

/// Adds isotropic Gaussian pixel noise `sigma` to `px` with stream `(seed, index)`.
pub fn noisy(px: &[Vector2<f64>], sigma: f64, seed: u64, index: u64) -> Vec<Vector2<f64>> {
    let mut rng = crashrig_stats::stream(seed, index);
    px.iter()
        .map(|x| {
            let dx: f64 = rng.sample(StandardNormal);
            let dy: f64 = rng.sample(StandardNormal);
            x + Vector2::new(dx, dy) * sigma
        })
        .collect()
}
