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

/// The scene with one more image, `cam_pan/0001.png` (id 8 888), taken from the projection
/// centre of image `image` (index in the model's image list) turned 2° about its vertical axis
/// (a camera that panned without moving), observing every point that image observes, and with
/// `count` more points (ids from 20 001) that lie `distance` (model units) from that common
/// centre, a few degrees off the optical axis, observed by both images: points "triangulated"
/// where two images share a centre, whose rays are undefined (issue 36: real models hold 2 to
/// 42 of them, 10⁻¹¹ to 10⁻⁸ of the viewing distance from the centre). Observations are exact
/// projections (the new points' at the principal point). Returns the scene and the new ids.
pub fn with_points_at_centre(
    scene: &Scene,
    image: usize,
    count: usize,
    distance: f64,
) -> (Scene, Vec<u64>) {
    let m = &scene.model;
    let mut images = m.images().to_vec();
    let camera = m.cameras()[0].camera.clone();
    let pose = images[image]
        .stored_cam_from_world
        .to_rigid()
        .expect("a pose");
    // Turned about the camera's own y axis (vertical in the image), centre unchanged.
    let turn = so3::exp(&Vec3::new(0.0, 2.0_f64.to_radians(), 0.0));
    let r = turn * pose.rotation.to_rotation_matrix();
    let centre = pose.inverse().translation.vector;
    let pan = rigid_from_rotation(&r, &(-(r * centre)));
    let pan_id = 8_888;
    let mut points = m.points3d().to_vec();
    let mut pan_points2d = Vec::new();
    let seen: Vec<u64> = images[image]
        .points2d
        .iter()
        .filter_map(|p| p.point3d_id)
        .collect();
    for p in points.iter_mut().filter(|p| seen.contains(&p.point3d_id)) {
        let xc = pan * nalgebra::Point3::from(Vec3::from(p.xyz));
        let Ok(px) = camera.img_from_cam(&xc.coords) else {
            continue;
        };
        p.track.push(TrackElement {
            image_id: pan_id,
            point2d_idx: pan_points2d.len() as u32,
        });
        pan_points2d.push(Point2D {
            xy: [px.x, px.y],
            point3d_id: Some(p.point3d_id),
        });
    }
    let world_from_cam = pose.inverse();
    let mut ids = Vec::new();
    for k in 0..count {
        let id = 20_001 + k as u64;
        let a = 0.05 * (k as f64 + 1.0);
        let dir = Vec3::new(a.sin(), 0.5 * a.sin(), a.cos()).normalize();
        let x = world_from_cam * nalgebra::Point3::from(dir * distance);
        let principal = [camera.params[1], camera.params[2]];
        let mut track = Vec::new();
        for (image_id, points2d) in [
            (images[image].image_id, &mut images[image].points2d),
            (pan_id, &mut pan_points2d),
        ] {
            track.push(TrackElement {
                image_id,
                point2d_idx: points2d.len() as u32,
            });
            points2d.push(Point2D {
                xy: principal,
                point3d_id: Some(id),
            });
        }
        points.push(Point3D {
            point3d_id: id,
            xyz: [x.x, x.y, x.z],
            rgb: [128, 128, 128],
            error: 0.0,
            track,
        });
        ids.push(id);
    }
    images.push(Image {
        image_id: pan_id,
        stored_cam_from_world: RawPose::from_rigid(&pan),
        camera_id: 1,
        name: "cam_pan/0001.png".into(),
        points2d: pan_points2d,
    });
    (rebuilt(scene, images, points), ids)
}

/// The scene with one more image of camera A, `cam_out/9999.png` (id 9 999), that sees only
/// eight points of its own near a 3 m line in front of it (ids from 30 001; also observed by
/// the scene's first and last images, so they are tied to the rest). Points exactly on a line
/// leave the image free to turn about that line (a rotation that moves none of their
/// projections); `offset` (model units) moves every other point off the line, perpendicular to
/// it, by ± `offset`: 0 is a singular bundle, 1e-8 a numerically singular one, 0.05 a
/// well-posed one. The line runs along the image's x axis, tilted 0.2° towards its optical
/// axis.
pub fn with_line_image(scene: &Scene, offset: f64) -> Scene {
    let m = &scene.model;
    let mut images = m.images().to_vec();
    let camera = m.cameras()[0].camera.clone();
    let first = images[0].stored_cam_from_world.to_rigid().expect("a pose");
    // The new image: image 0's orientation, its centre moved 0.4 down the lab and 0.3 aside.
    let r = first.rotation;
    let centre = first.inverse().translation.vector + Vec3::new(0.3, -0.4, 0.1);
    let cam_from_world = rigid_from_rotation(
        &r.to_rotation_matrix(),
        &(-(r.to_rotation_matrix() * centre)),
    );
    let world_from_cam = cam_from_world.inverse();
    let along = Vec3::new(1.0, 0.0, 0.2_f64.to_radians().tan()).normalize();
    let new_id = 9_999;
    let last = images.len() - 1;
    let mut points = m.points3d().to_vec();
    let mut new_points2d = Vec::new();
    for k in 0..8 {
        let id = 30_001 + k as u64;
        let t = -1.5 + 3.0 * k as f64 / 7.0;
        let off = if k % 2 == 0 { offset } else { -offset };
        let x_cam = Vec3::new(0.0, 0.2, 4.5) + along * t + Vec3::new(0.0, off, 0.0);
        let x = world_from_cam * nalgebra::Point3::from(x_cam);
        let px = camera.img_from_cam(&x_cam).expect("in front");
        let mut track = vec![TrackElement {
            image_id: new_id,
            point2d_idx: new_points2d.len() as u32,
        }];
        new_points2d.push(Point2D {
            xy: [px.x, px.y],
            point3d_id: Some(id),
        });
        for j in [0, last] {
            let pose = images[j].stored_cam_from_world.to_rigid().expect("a pose");
            let xc = pose * x;
            let p = camera.img_from_cam(&xc.coords).expect("in front");
            track.push(TrackElement {
                image_id: images[j].image_id,
                point2d_idx: images[j].points2d.len() as u32,
            });
            images[j].points2d.push(Point2D {
                xy: [p.x, p.y],
                point3d_id: Some(id),
            });
        }
        points.push(Point3D {
            point3d_id: id,
            xyz: [x.x, x.y, x.z],
            rgb: [128, 128, 128],
            error: 0.0,
            track,
        });
    }
    images.push(Image {
        image_id: new_id,
        stored_cam_from_world: RawPose::from_rigid(&cam_from_world),
        camera_id: 1,
        name: "cam_out/9999.png".into(),
        points2d: new_points2d,
    });
    rebuilt(scene, images, points)
}

/// `scene`'s cameras with new images and points (legacy layout), the same control points.
fn rebuilt(scene: &Scene, images: Vec<Image>, points: Vec<Point3D>) -> Scene {
    let model = Reconstruction::from_records(
        scene.model.cameras().to_vec(),
        Vec::new(),
        Vec::new(),
        images,
        points,
    )
    .expect("a consistent synthetic model");
    Scene {
        model,
        control_ids: scene.control_ids.clone(),
    }
}
