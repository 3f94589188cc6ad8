//! Known answers on generated scenes: the Schur complement against the full information
//! matrix, the gauge (a model moved and rotated as a whole), fixed vs tight priors, σ̂₀.

use crashrig_colmap::{CameraSelector, Image, Point3D, Reconstruction};
use crashrig_covariance::jacobian::project;
use crashrig_covariance::synthetic::{LabSettings, lab_scene, ring_scene};
use crashrig_covariance::{ControlPoints, Intrinsics, Options, covariance};
use crashrig_geometry::quat::rigid_from_rotation;
use crashrig_geometry::{Mat3, Mat6, Rigid3, Vec3, so3};
use nalgebra::DMatrix;

use crate::common;
use common::moved;

fn options(intrinsics: Intrinsics, sigma: Option<f64>) -> Options {
    Options {
        camera_a: CameraSelector::parse("cam_out/"),
        mm_per_unit: 1000.0,
        pixel_sigma_px: sigma,
        intrinsics,
    }
}

/// The full Gauss–Newton information over poses, intrinsics and points, assembled densely and
/// inverted; A's pose blocks of the inverse, in contract units. No Schur complement, no
/// elimination: the reference for `covariance` on a small scene (legacy model, fixed control).
fn dense_reference(
    model: &Reconstruction,
    control: &[u64],
    free_intr: bool,
    sigma: f64,
) -> DMatrix<f64> {
    let images = model.images();
    let ni = images.len();
    let cam = &model.cameras()[0].camera;
    let nk = if free_intr { cam.params.len() } else { 0 };
    let pts: Vec<&Point3D> = model
        .points3d()
        .iter()
        .filter(|p| control.contains(&p.point3d_id) || p.track.len() >= 2)
        .collect();
    let free_pts: Vec<u64> = pts
        .iter()
        .filter(|p| !control.contains(&p.point3d_id))
        .map(|p| p.point3d_id)
        .collect();
    let n = 6 * ni + nk + 3 * free_pts.len();
    let mut h = DMatrix::<f64>::zeros(n, n);
    for p in &pts {
        let x = Vec3::from(p.xyz);
        for t in &p.track {
            let i = images
                .iter()
                .position(|im| im.image_id == t.image_id)
                .unwrap();
            let pose = model.image_cam_from_world(t.image_id).unwrap();
            let pr = project(cam, &Rigid3::identity(), &pose, &x).unwrap();
            let mut j = DMatrix::<f64>::zeros(2, n);
            j.view_mut((0, 6 * i), (2, 6)).copy_from(&pr.d_pose);
            if free_intr {
                j.view_mut((0, 6 * ni), (2, nk)).copy_from(&pr.d_params);
            }
            if let Some(k) = free_pts.iter().position(|&id| id == p.point3d_id) {
                j.view_mut((0, 6 * ni + nk + 3 * k), (2, 3))
                    .copy_from(&pr.d_point);
            }
            h += j.transpose() * j / (sigma * sigma);
        }
    }
    let cov = h.try_inverse().expect("full information invertible");
    // Frame tangent = world_from_cam tangent for a legacy model; scale to mm and deg.
    let deg = 1.0_f64.to_degrees();
    let u = |k: usize| if k % 6 >= 3 { deg } else { 1000.0 };
    DMatrix::from_fn(6 * ni, 6 * ni, |a, b| cov[(a, b)] * u(a) * u(b))
}

#[test]
fn schur_complement_equals_the_full_inverse() {
    let scene = ring_scene(4, 0.3);
    for (mode, free) in [(Intrinsics::All, true), (Intrinsics::Fixed, false)] {
        let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
        let r = covariance(&scene.model, &control, &options(mode, Some(0.7))).unwrap();
        let want = dense_reference(&scene.model, &scene.control_ids, free, 0.7);
        let scale = want.abs().max();
        // Both are the same linear algebra in different order: agreement to ~1e-9 relative
        // (the condition number of the full system is ~1e6).
        let diff = (&r.joint_deg - &want).abs().max();
        assert!(diff < 1e-7 * scale, "{mode:?}: {diff} vs scale {scale}");
    }
}

/// The scene moved and rotated as a whole (control points too): the covariance in the new
/// frame is the old one with the centre rows/columns rotated; the rotation block (about A's
/// own axes) is unchanged.
#[test]
fn gauge_covariance_follows_a_rigid_motion_of_the_whole_scene() {
    let scene = ring_scene(5, 0.3);
    let q = so3::exp(&Vec3::new(0.4, -1.1, 2.0));
    let t: Rigid3 = rigid_from_rotation(&q, &Vec3::new(12.0, -3.0, 40.0));
    let moved = moved(&scene.model, &t);
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let a = covariance(&scene.model, &control, &options(Intrinsics::All, Some(0.5))).unwrap();
    let b = covariance(&moved, &control, &options(Intrinsics::All, Some(0.5))).unwrap();
    let qm: Mat3 = q.into_inner();
    let mut rot = Mat6::identity();
    rot.fixed_view_mut::<3, 3>(0, 0).copy_from(&qm);
    for (ea, eb) in a.epochs.iter().zip(&b.epochs) {
        let want = rot * ea.world_from_a.covariance * rot.transpose();
        let got = eb.world_from_a.covariance;
        let scale = want.abs().max();
        assert!((got - want).abs().max() < 1e-6 * scale, "{}", ea.name);
    }
}

#[test]
fn a_tight_prior_approaches_fixed_control_and_a_loose_one_grows() {
    let scene = ring_scene(4, 0.3);
    let fixed = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let tight = ControlPoints::from_ids("t", &scene.control_ids, 1e-6);
    let loose = ControlPoints::from_ids("t", &scene.control_ids, 50.0);
    let o = options(Intrinsics::Colmap, Some(0.5));
    let f = covariance(&scene.model, &fixed, &o).unwrap();
    let t = covariance(&scene.model, &tight, &o).unwrap();
    let l = covariance(&scene.model, &loose, &o).unwrap();
    let scale = f.joint_deg.abs().max();
    // A 1e-6 mm prior against σ of ~0.1–10 mm: relative difference ~1e-10.
    assert!((&t.joint_deg - &f.joint_deg).abs().max() < 1e-6 * scale);
    for k in 0..f.joint_deg.nrows() {
        assert!(l.joint_deg[(k, k)] > f.joint_deg[(k, k)]);
    }
}

/// σ̂₀ of a model whose observations carry N(0, 0.5²) noise: the residuals are not at the
/// adjusted optimum here (the poses are the truth), so E[Σr²] = 2·n_obs·σ² and
/// σ̂₀² = Σr²/(2n − p) ≈ σ²·2n/(2n − p); with 2n ≈ 1 700 the sampling spread of Σr² is
/// sqrt(2/2n) ≈ 3.4 %: the check allows 4 standard errors.
#[test]
fn sigma0_estimates_the_pixel_noise() {
    let scene = lab_scene(&LabSettings {
        epochs: 12,
        points: 90,
        path_length: 2.0,
        noise_px: 0.5,
        seed: 7,
    });
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let r = covariance(&scene.model, &control, &options(Intrinsics::All, None)).unwrap();
    let n2 = 2.0 * r.observations as f64;
    let expected = 0.5 * (n2 / r.redundancy as f64).sqrt();
    let se = expected * (2.0 / n2).sqrt() / 2.0;
    assert!(
        (r.sigma0_px - expected).abs() < 4.0 * se,
        "{} vs {expected}",
        r.sigma0_px
    );
    assert_eq!(r.pixel_sigma_px, r.sigma0_px);
    // Given σ scales the covariance by (σ/σ̂₀)².
    let g = covariance(&scene.model, &control, &options(Intrinsics::All, Some(1.0))).unwrap();
    let k = (1.0 / r.sigma0_px).powi(2);
    let d = (&g.joint_deg - &r.joint_deg * k).abs().max();
    assert!(d < 1e-9 * g.joint_deg.abs().max());
}

#[test]
fn collinear_control_points_and_an_unobserved_epoch_are_errors() {
    let scene = ring_scene(4, 0.3);
    // Ids 1, 25, 49: the same wall column in the three depth layers (x and z equal).
    let line = ControlPoints::from_ids("line.csv", &[1, 25, 49], 0.0);
    let e = covariance(&scene.model, &line, &options(Intrinsics::Fixed, Some(0.5)))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("line.csv: ") && e.contains("collinear"),
        "{e}"
    );
    // An image of A with a pose but no observation.
    let mut images = scene.model.images().to_vec();
    let mut extra = images[0].clone();
    extra.image_id = 99;
    extra.name = "cam_out/9999.png".into();
    extra.points2d.clear();
    images.push(extra);
    let model = Reconstruction::from_records(
        scene.model.cameras().to_vec(),
        Vec::new(),
        Vec::new(),
        images,
        scene.model.points3d().to_vec(),
    )
    .unwrap();
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let e = covariance(&model, &control, &options(Intrinsics::All, Some(0.5)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cam_out/9999.png") && e.contains("no observation"),
        "{e}"
    );
}

/// Two more images of A, taken by a second camera, that see only points of their own (copies
/// of lab points under new ids, observed by nothing else): a part of the model that no control
/// point ties to the lab. Its seven similarity degrees of freedom are free — one error naming
/// the control-point file and an image of that part, never an infinite covariance.
#[test]
fn a_disconnected_pair_of_images_is_a_gauge_error_naming_the_file() {
    use crashrig_colmap::{CameraRecord, Point2D, TrackElement};
    let scene = ring_scene(4, 0.3);
    let m = &scene.model;
    let mut images = m.images().to_vec();
    let mut points = m.points3d().to_vec();
    let free = |id: u64| !scene.control_ids.contains(&id);
    let seen_by = |im: &Image| -> Vec<u64> {
        im.points2d
            .iter()
            .filter_map(|p| p.point3d_id)
            .filter(|&id| free(id))
            .collect()
    };
    let (a, b) = (&images[0], &images[1]);
    let common: Vec<u64> = seen_by(a)
        .into_iter()
        .filter(|id| seen_by(b).contains(id))
        .take(12)
        .collect();
    assert!(common.len() >= 8, "{} shared points", common.len());
    const OFFSET: u64 = 10_000;
    let mut new_points: Vec<Point3D> = common
        .iter()
        .map(|&id| {
            let p = m.point3d(id).unwrap();
            Point3D {
                point3d_id: id + OFFSET,
                xyz: p.xyz,
                rgb: p.rgb,
                error: 0.0,
                track: Vec::new(),
            }
        })
        .collect();
    for (k, src) in [a.clone(), b.clone()].into_iter().enumerate() {
        let image_id = 50 + k as u32;
        let mut points2d = Vec::new();
        for p2 in &src.points2d {
            let Some(id) = p2.point3d_id.filter(|id| common.contains(id)) else {
                continue;
            };
            let j = common.iter().position(|&c| c == id).unwrap();
            new_points[j].track.push(TrackElement {
                image_id,
                point2d_idx: points2d.len() as u32,
            });
            points2d.push(Point2D {
                xy: p2.xy,
                point3d_id: Some(id + OFFSET),
            });
        }
        images.push(Image {
            image_id,
            camera_id: 2,
            name: format!("cam_side/{k:04}.png"),
            points2d,
            ..src
        });
    }
    points.extend(new_points);
    let mut cameras = m.cameras().to_vec();
    cameras.push(CameraRecord {
        camera_id: 2,
        camera: cameras[0].camera.clone(),
    });
    let model =
        Reconstruction::from_records(cameras, Vec::new(), Vec::new(), images, points).unwrap();
    let control = ControlPoints::from_ids("lab/control.csv", &scene.control_ids, 0.0);
    for intrinsics in [Intrinsics::All, Intrinsics::Fixed] {
        let e = covariance(&model, &control, &options(intrinsics, Some(0.5)))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("lab/control.csv: ")
                && e.contains("cam_side/")
                && e.contains("0 control point(s)")
                && e.contains("disconnected"),
            "{e}"
        );
    }
}
