//! A synthetic lab sequence for examples, tests and benchmarks: camera A (`cam_out/NNNN.png`,
//! SIMPLE_RADIAL 1600×1200) moves along the world x axis in front of a lab wall of points and
//! looks at it (+y); the wall's outermost points are the control points. Observations are the
//! exact projections plus a deterministic Gaussian pixel noise.

use crashrig_camera::{Camera, ModelId};
use crashrig_colmap::{
    CameraRecord, Image, Point2D, Point3D, RawPose, Reconstruction, TrackElement,
};
use crashrig_geometry::quat::rigid_from_rotation;
use crashrig_geometry::{Rot3, Vec3, so3};

/// A generated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The model (legacy layout: one frame per image).
    pub model: Reconstruction,
    /// point3D ids of the control points.
    pub control_ids: Vec<u64>,
}

/// The scene's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabSettings {
    /// Epochs of A.
    pub epochs: usize,
    /// Points on the wall (a grid of about this many).
    pub points: usize,
    /// The path of A along x (model units, m).
    pub path_length: f64,
    /// Pixel noise σ of the observations.
    pub noise_px: f64,
    /// Seed of the noise.
    pub seed: u64,
}

/// SplitMix64: a tiny deterministic generator (no dependency needed for a test scene).
struct Mix(u64);

impl Mix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.next(), self.next());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// A small scene: `epochs` images along a 2 m path, a 6 × 4 × 3 block of points 5 m away,
/// the 8 block corners as control points.
pub fn ring_scene(epochs: usize, noise_px: f64) -> Scene {
    lab_scene(&LabSettings {
        epochs,
        points: 72,
        path_length: 2.0,
        noise_px,
        seed: 1,
    })
}

/// The lab scene of `settings`.
pub fn lab_scene(settings: &LabSettings) -> Scene {
    let camera = Camera::new(
        ModelId::SimpleRadial,
        1600,
        1200,
        vec![1400.0, 800.5, 600.5, -0.02],
    )
    .expect("valid camera");
    let mut rng = Mix(settings.seed);
    // Points: nx × nz × 3 depth layers over a 12 m × 4 m wall region 4–6 m away.
    let per_layer = (settings.points as f64 / 3.0).max(4.0);
    let nz = ((per_layer / 3.0).sqrt().round() as usize).max(2);
    let nx = ((per_layer / nz as f64).round() as usize).max(2);
    let width = 4.0 + settings.path_length;
    let mut xyz = Vec::new();
    for layer in 0..3 {
        for ix in 0..nx {
            for iz in 0..nz {
                let x = -width / 2.0 + width * ix as f64 / (nx - 1) as f64;
                let z = -1.5 + 3.0 * iz as f64 / (nz - 1) as f64;
                let y = 4.0 + layer as f64 + 0.2 * (rng.next() - 0.5);
                xyz.push(Vec3::new(x, y, z));
            }
        }
    }
    let corner = |i: usize| {
        let (layer, ix, iz) = (i / (nx * nz), (i / nz) % nx, i % nz);
        (layer == 0 || layer == 2) && (ix == 0 || ix == nx - 1) && (iz == 0 || iz == nz - 1)
    };
    let control_ids: Vec<u64> = (0..xyz.len())
        .filter(|&i| corner(i))
        .map(|i| i as u64 + 1)
        .collect();
    // Camera frame: x right = world x, y down = world −z, z forward = world y.
    let base = Rot3::from_matrix_unchecked(nalgebra::Matrix3::new(
        1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0,
    ));
    let mut images = Vec::new();
    let mut tracks: Vec<Vec<TrackElement>> = vec![Vec::new(); xyz.len()];
    for e in 0..settings.epochs {
        let t = if settings.epochs > 1 {
            e as f64 / (settings.epochs - 1) as f64
        } else {
            0.5
        };
        let centre = Vec3::new(
            settings.path_length * (t - 0.5),
            0.1 * (3.0 * t).sin(),
            0.05 * (5.0 * t).cos(),
        );
        let wobble = so3::exp(&Vec3::new(0.02 * (7.0 * t).sin(), 0.03 * t, -0.01));
        let r_cw = wobble * base;
        let cam_from_world = rigid_from_rotation(&r_cw, &(-(r_cw * centre)));
        let image_id = e as u32 + 1;
        let mut points2d = Vec::new();
        for (j, x) in xyz.iter().enumerate() {
            let xc = cam_from_world * nalgebra::Point3::from(*x);
            let Ok(px) = camera.img_from_cam(&xc.coords) else {
                continue;
            };
            if !(px.x > 0.0 && px.y > 0.0 && px.x < 1600.0 && px.y < 1200.0) {
                continue;
            }
            let noisy = [
                px.x + settings.noise_px * rng.gauss(),
                px.y + settings.noise_px * rng.gauss(),
            ];
            tracks[j].push(TrackElement {
                image_id,
                point2d_idx: points2d.len() as u32,
            });
            points2d.push(Point2D {
                xy: noisy,
                point3d_id: Some(j as u64 + 1),
            });
        }
        images.push(Image {
            image_id,
            stored_cam_from_world: RawPose::from_rigid(&cam_from_world),
            camera_id: 1,
            name: format!("cam_out/{e:04}.png"),
            points2d,
        });
    }
    let points: Vec<Point3D> = xyz
        .iter()
        .zip(tracks)
        .enumerate()
        .filter(|(_, (_, t))| !t.is_empty())
        .map(|(j, (x, track))| Point3D {
            point3d_id: j as u64 + 1,
            xyz: [x.x, x.y, x.z],
            rgb: [128, 128, 128],
            error: 0.0,
            track,
        })
        .collect();
    // Unobserved points are dropped; their 2-D references cannot exist, so ids stay valid.
    let model = Reconstruction::from_records(
        vec![CameraRecord {
            camera_id: 1,
            camera,
        }],
        Vec::new(),
        Vec::new(),
        images,
        points,
    )
    .expect("a consistent synthetic model");
    let control_ids = control_ids
        .into_iter()
        .filter(|id| model.point3d(*id).is_some())
        .collect();
    Scene { model, control_ids }
}
