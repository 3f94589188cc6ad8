//! Synthetic, seeded scenes: a rig sequence (epochs of two rigidly linked cameras) and a
//! two-view scene with points and normalized observations.

use crashrig_geometry::{Rigid3, Vec3, Vec6, opk, quat, se3};
use nalgebra::{Quaternion, Translation3, UnitQuaternion, Vector2};
use rand::{RngExt, SeedableRng, rngs::ChaCha8Rng};
use rand_distr::StandardNormal;

/// The paper's rig link `A_from_B` (its Tables 1/2): base (61.98, −1.71, 179.76) mm and
/// ω φ κ = (179.92, −0.09, 179.76)°.
pub fn paper_a_from_b() -> Rigid3 {
    let r = opk::rotation_from_opk(
        179.92_f64.to_radians(),
        (-0.09_f64).to_radians(),
        179.76_f64.to_radians(),
    );
    Rigid3::from_parts(
        Translation3::new(61.98, -1.71, 179.76),
        quat::unit_quaternion_from_rotation(&r),
    )
}

/// A forward-looking stereo pair `A_from_B`: B is 200 mm to the right of A, turned 5° about y.
pub fn stereo_a_from_b() -> Rigid3 {
    let r = opk::rotation_from_opk(0.0, (-5.0_f64).to_radians(), 0.0);
    Rigid3::from_parts(
        Translation3::new(200.0, 0.0, 0.0),
        quat::unit_quaternion_from_rotation(&r),
    )
}

/// One epoch of a rig sequence: both cameras' `cam_from_world` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigEpoch {
    /// `A_from_world`.
    pub a_from_world: Rigid3,
    /// `B_from_world`.
    pub b_from_world: Rigid3,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    let q = Quaternion::new(normal(rng), normal(rng), normal(rng), normal(rng));
    // Four standard normals: the direction is uniform on S³ (norm 0 has probability 0).
    UnitQuaternion::from_quaternion(q)
}

fn perturbation(rng: &mut ChaCha8Rng, sigma_rot_rad: f64, sigma_trans_mm: f64) -> Rigid3 {
    let xi = Vec6::new(
        sigma_rot_rad * normal(rng),
        sigma_rot_rad * normal(rng),
        sigma_rot_rad * normal(rng),
        sigma_trans_mm * normal(rng),
        sigma_trans_mm * normal(rng),
        sigma_trans_mm * normal(rng),
    );
    se3::exp(&xi)
}

/// `n_epochs` epochs of a rig with link `a_from_b`, seeded.
///
/// Camera A gets a random orientation and a centre within ±2000 mm; `B_from_world =
/// B_from_A·A_from_world`. Each camera pose is then perturbed independently on the left by
/// `Exp([σ_rot·ε; σ_trans·ε])` (ε standard normal), so the noise-free link is recovered
/// exactly when both sigmas are 0.
pub fn rig_sequence(
    seed: u64,
    n_epochs: usize,
    a_from_b: &Rigid3,
    sigma_rot_rad: f64,
    sigma_trans_mm: f64,
) -> Vec<RigEpoch> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let b_from_a = a_from_b.inverse();
    (0..n_epochs)
        .map(|_| {
            let rotation = random_rotation(&mut rng);
            let centre = Vec3::new(
                rng.random_range(-2000.0..2000.0),
                rng.random_range(-2000.0..2000.0),
                rng.random_range(-2000.0..2000.0),
            );
            let a_from_world =
                Rigid3::from_parts(Translation3::from(-(rotation * centre)), rotation);
            let b_from_world = b_from_a * a_from_world;
            RigEpoch {
                a_from_world: perturbation(&mut rng, sigma_rot_rad, sigma_trans_mm) * a_from_world,
                b_from_world: perturbation(&mut rng, sigma_rot_rad, sigma_trans_mm) * b_from_world,
            }
        })
        .collect()
}

/// Two cameras observing common points.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoViewScene {
    /// `A_from_world` (A is the world frame here: identity).
    pub a_from_world: Rigid3,
    /// `B_from_world`.
    pub b_from_world: Rigid3,
    /// Points in world coordinates (mm), in front of both cameras.
    pub points_world: Vec<Vec3>,
    /// Observations in A, normalized camera coordinates (with noise if requested).
    pub normalized_a: Vec<Vector2<f64>>,
    /// Observations in B, normalized camera coordinates (with noise if requested).
    pub normalized_b: Vec<Vector2<f64>>,
}

/// Failure to build a scene (testkit is test code, but still reports rather than panics).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneError {
    /// Fewer than the requested points are visible in both cameras after many tries.
    TooFewVisible {
        /// Points requested.
        requested: usize,
        /// Points found.
        found: usize,
    },
}

/// Seeded two-view scene: `n_points` points in A's field of view (|x/z|, |y/z| ≤ 0.5) at depths
/// in `depth_mm`, kept only when in front of B (depth > 1 mm and |x/z|, |y/z| ≤ 1 in B);
/// observations get isotropic Gaussian noise `sigma_normalized`.
pub fn two_view_scene(
    seed: u64,
    a_from_b: &Rigid3,
    n_points: usize,
    depth_mm: (f64, f64),
    sigma_normalized: f64,
) -> Result<TwoViewScene, SceneError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a_from_world = Rigid3::identity();
    let b_from_world = a_from_b.inverse();
    let mut scene = TwoViewScene {
        a_from_world,
        b_from_world,
        points_world: Vec::with_capacity(n_points),
        normalized_a: Vec::with_capacity(n_points),
        normalized_b: Vec::with_capacity(n_points),
    };
    let max_tries = 1000 * n_points.max(1);
    for _ in 0..max_tries {
        if scene.points_world.len() == n_points {
            break;
        }
        let (u, v) = (rng.random_range(-0.5..=0.5), rng.random_range(-0.5..=0.5));
        let depth = rng.random_range(depth_mm.0..=depth_mm.1);
        let p = Vec3::new(u * depth, v * depth, depth);
        let pb = b_from_world * nalgebra::Point3::from(p);
        if pb.z <= 1.0 || (pb.x / pb.z).abs() > 1.0 || (pb.y / pb.z).abs() > 1.0 {
            continue;
        }
        let noise = |rng: &mut ChaCha8Rng| {
            Vector2::new(
                sigma_normalized * normal(rng),
                sigma_normalized * normal(rng),
            )
        };
        scene.points_world.push(p);
        scene
            .normalized_a
            .push(Vector2::new(u, v) + noise(&mut rng));
        scene
            .normalized_b
            .push(Vector2::new(pb.x / pb.z, pb.y / pb.z) + noise(&mut rng));
    }
    if scene.points_world.len() < n_points {
        return Err(SceneError::TooFewVisible {
            requested: n_points,
            found: scene.points_world.len(),
        });
    }
    Ok(scene)
}
