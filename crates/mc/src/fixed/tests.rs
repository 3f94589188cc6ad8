//! Tests of the fixed-observer path: first order against finite differences, the undistortion
//! against the camera crate, aimed = fixed-at-the-point, visibility at the image border,
//! determinism, not-measurable layouts and every documented scenario error.

use super::*;
use crate::kernel::normal::LANES;
use crate::kernel::simd::Width;
use crate::view::*;
use crate::{GridStudy, Scenario};
use crashrig_camera::{Camera as Lens, ModelId};
use std::path::Path;

const MIXED: &str = r#"
seed = 7
samples = 4000
rotation_noise = "tangent"
[grid]
x_mm = [900.0, 1500.0, 3]
y_mm = [-200.0, 200.0, 2]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
name = "rear"
aim = "fixed"
position_mm = [200.0, 0.0, 100.0]
look_at_mm = [1200.0, 0.0, 0.0]
camera = { model = "OPENCV", width = 2560, height = 1440, params = [1600.0, 1610.0, 1280.3, 719.6, -0.08, 0.02, 0.0005, -0.0003] }
pixel_sigma_px = 0.5
sigma_position_mm = [1.5, 1.2, 1.0]
sigma_angles_deg = [0.01, 0.02, 0.012]
[[grid.observer]]
name = "door"
aim = "fixed"
position_mm = [1300.0, -700.0, 150.0]
angles_deg = [-100.0, 0.0, 0.0]
camera = { model = "OPENCV_FISHEYE", width = 1920, height = 1080, params = [700.0, 702.0, 955.0, 545.0, 0.05, -0.01, 0.002, -0.001] }
pixel_sigma_px = 0.8
sigma_position_mm = [2.0, 2.0, 2.0]
sigma_angles_deg = [0.02, 0.02, 0.02]
[[grid.observer]]
name = "aimed"
position_mm = [2200.0, 500.0, 200.0]
sigma_position_mm = [1.0, 1.2, 1.0]
sigma_angles_deg = [0.01, 0.015, 0.01]
"#;

fn parse(text: &str) -> Result<Scenario, Error> {
    Scenario::from_toml_str(text, Path::new("s.toml"))
}

fn setup_of(s: &Scenario) -> (Vec<nalgebra::Matrix6<f64>>, Vec<crate::RotationNoise>, Grid) {
    let g = s.grid.clone().unwrap();
    let mut cov = Vec::new();
    let mut kinds = Vec::new();
    for o in &g.observers {
        match o.sigma {
            crate::ObserverSigma::Given(p) => {
                let d = nalgebra::Vector6::new(
                    p.position_mm.x,
                    p.position_mm.y,
                    p.position_mm.z,
                    p.angles_rad.x,
                    p.angles_rad.y,
                    p.angles_rad.z,
                );
                cov.push(nalgebra::Matrix6::from_diagonal(&d.component_mul(&d)));
                kinds.push(s.rotation_noise);
            }
            crate::ObserverSigma::Covariance(m) => {
                cov.push(m);
                kinds.push(crate::RotationNoise::Tangent);
            }
            crate::ObserverSigma::From(_) => unreachable!("no chain in these tests"),
        }
    }
    (cov, kinds, g)
}

/// First order against central differences of the exact perturbed intersection, for a mixed
/// layout (fixed OPENCV, fixed OPENCV_FISHEYE, aimed with grid pixel noise), tangent and euler.
#[test]
fn fixed_linear_covariance_matches_finite_differences() {
    for noise in ["tangent", "euler"] {
        let text = MIXED
            .replace(
                "rotation_noise = \"tangent\"",
                &format!("rotation_noise = \"{noise}\""),
            )
            .replace(
                "[grid]\n",
                "[grid]\npixel_sigma_px = 0.4\nfocal_px = 1500.0\n",
            );
        let s = parse(&text).unwrap();
        let (cov, kinds, grid) = setup_of(&s);
        let setup = Setup {
            grid: &grid,
            covariance: &cov,
            kinds: &kinds,
            pixel: grid.pixel,
            chain: None,
        };
        let point = Vector3::new(1200.0, -200.0, 0.0);
        let v = views(&setup, &point).unwrap();
        assert_eq!(v.len(), 3, "all three see the point");
        let nin = NORMALS_PER_VIEW * v.len();
        // The nominal intersection is the grid point (true projections, no noise).
        let x0 = intersect_perturbed(&v, &vec![0.0; nin]);
        assert!((x0 - point).norm() < 1e-8, "{x0} vs {point}");
        // Input scales: h relative to each input's σ (linear part dominates; the error of a
        // central difference is O(h²)).
        let mut cov = Matrix3::zeros();
        for (j, view) in v.iter().enumerate() {
            let mut jac = nalgebra::DMatrix::zeros(3, NORMALS_PER_VIEW);
            for q in 0..NORMALS_PER_VIEW {
                let h = if q < 3 {
                    1e-3
                } else if q < 6 {
                    1e-7
                } else {
                    1e-3
                };
                let mut d = vec![0.0; nin];
                d[NORMALS_PER_VIEW * j + q] = h;
                let xp = intersect_perturbed(&v, &d);
                d[NORMALS_PER_VIEW * j + q] = -h;
                let xm = intersect_perturbed(&v, &d);
                jac.set_column(q, &((xp - xm) / (2.0 * h)));
            }
            let sp = view.l * view.l.transpose();
            let mut s8 = nalgebra::DMatrix::zeros(8, 8);
            s8.view_mut((0, 0), (6, 6)).copy_from(&sp);
            s8[(6, 6)] = view.sigma_px * view.sigma_px;
            s8[(7, 7)] = view.sigma_px * view.sigma_px;
            let c = &jac * s8 * jac.transpose();
            cov += Matrix3::from_fn(|r, k| c[(r, k)]);
        }
        let lin = linear_covariance(&v, &point);
        let rel = (lin - cov).norm() / cov.norm();
        // Central differences with these steps are accurate to ~1e-7 relative.
        assert!(
            rel < 1e-5,
            "{noise}: relative difference {rel}\n{lin}\n{cov}"
        );
    }
}

/// The draw loop's undistortion (predictor + chord-Newton) equals the camera crate's
/// unprojection (COLMAP's Newton iteration) for distorted lenses, and is exact for a pinhole.
#[test]
fn fixed_undistort_matches_camera_crate() {
    let s = parse(MIXED).unwrap();
    let (cov, kinds, grid) = setup_of(&s);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let point = Vector3::new(1200.0, -200.0, 0.0);
    let vs = views(&setup, &point).unwrap();
    let mut checked = 0;
    for v in vs.iter().filter(|v| v.full_lens.is_some()) {
        let lens = v.full_lens.unwrap();
        for du in [
            Vector2::new(0.0, 0.0),
            Vector2::new(0.7, -1.3),
            Vector2::new(-3.0, 2.5),
            Vector2::new(12.0, -9.0),
        ] {
            let ours = undistort(v, du);
            let theirs = lens.cam_from_img(&(v.u0 + du)).unwrap().normalized;
            // COLMAP stops at ‖step‖² < 1e-10; compare through the exact projection instead:
            // our ray reprojects within UNDISTORT_RESIDUAL_PX of the observed pixel.
            let back = lens
                .img_from_cam(&Vector3::new(ours.x, ours.y, 1.0))
                .unwrap();
            assert!((back - (v.u0 + du)).norm() < UNDISTORT_RESIDUAL_PX);
            assert!((ours - theirs).norm() < 1e-8, "{ours} vs {theirs}");
            checked += 1;
        }
    }
    assert_eq!(checked, 8);
}

/// Visibility follows COLMAP's pixel convention: `0 ≤ u < width`, `0 ≤ v < height`, in front.
#[test]
fn fixed_visibility_at_image_border() {
    let lens = Lens::new(ModelId::Pinhole, 100, 50, vec![100.0, 100.0, 50.0, 25.0]).unwrap();
    let cam = crate::model::FixedCamera {
        rotation: Matrix3::identity(), // looking along world +z
        angles_rad: Vector3::zeros(),
        lens,
        pixel_sigma_px: 0.0,
    };
    let c = Vector3::zeros();
    // u = 100·x/z + 50, v = 100·y/z + 25 at z = 1000 mm.
    let at = |u: f64, v: f64| Vector3::new((u - 50.0) * 10.0, (v - 25.0) * 10.0, 1000.0);
    assert!(
        sight(&cam, &c, &at(0.0, 0.0)).is_some(),
        "corner (0, 0) is inside"
    );
    assert!(sight(&cam, &c, &at(99.999, 49.999)).is_some());
    assert!(
        sight(&cam, &c, &at(100.0, 10.0)).is_none(),
        "u = width is outside"
    );
    assert!(
        sight(&cam, &c, &at(10.0, 50.0)).is_none(),
        "v = height is outside"
    );
    assert!(sight(&cam, &c, &at(-0.001, 10.0)).is_none());
    let behind = Vector3::new(0.0, 0.0, -1000.0);
    assert!(sight(&cam, &c, &behind).is_none(), "behind the camera");
    let (u, n0, jinv) = sight(&cam, &c, &at(30.0, 40.0)).unwrap();
    assert!((u - Vector2::new(30.0, 40.0)).norm() < 1e-9);
    assert!((n0 - Vector2::new(-0.2, 0.15)).norm() < 1e-12);
    assert!((jinv - Matrix2::identity() / 100.0).norm() < 1e-15);
}

/// Aimed observers with pixel noise (grid `pixel_sigma_px`, `focal_px`) and fixed PINHOLE
/// observers aimed at the point (`look_at_mm` = the point, principal point at the image centre)
/// are the same measurement: same first order (to rounding), same Monte Carlo σ (within the
/// standard error of two independent 40 000-draw runs).
#[test]
fn fixed_aimed_at_point_equals_aimed_observer() {
    let point = [1200.0, 300.0, 150.0];
    let obs = [
        (
            [200.0, 0.0, 0.0],
            "[1.5, 1.4, 1.3]",
            "[0.011, 0.012, 0.013]",
        ),
        (
            [1300.0, -700.0, 0.0],
            "[2.5, 2.4, 2.6]",
            "[0.023, 0.022, 0.024]",
        ),
    ];
    let header = format!(
        "seed = 3\nsamples = 40000\n[grid]\nx_mm = [{x}, {x}, 1]\ny_mm = [{y}, {y}, 1]\nz_mm = [{z}, {z}, 1]\n",
        x = point[0],
        y = point[1],
        z = point[2]
    );
    let mut aimed = header.clone() + "pixel_sigma_px = 0.7\nfocal_px = 1600.0\n";
    let mut fixed = header;
    for (p, sp, sa) in obs {
        let pos = format!("[{}, {}, {}]", p[0], p[1], p[2]);
        aimed += &format!(
            "[[grid.observer]]\nposition_mm = {pos}\nsigma_position_mm = {sp}\nsigma_angles_deg = {sa}\n"
        );
        fixed += &format!(
            "[[grid.observer]]\naim = \"fixed\"\nposition_mm = {pos}\nlook_at_mm = [{}, {}, {}]\n\
             camera = {{ model = \"PINHOLE\", width = 2560, height = 1440, params = [1600.0, 1600.0, 1280.0, 720.0] }}\n\
             pixel_sigma_px = 0.7\nsigma_position_mm = {sp}\nsigma_angles_deg = {sa}\n",
            point[0], point[1], point[2]
        );
    }
    let run = |text: &str| {
        let s = parse(text).unwrap();
        let study = GridStudy::new(&s, s.samples, s.seed).unwrap();
        study
            .run(&crate::RunOptions::samples(s.samples, s.seed), None)
            .unwrap()
            .points[0]
            .clone()
    };
    let a = run(&aimed);
    let f = run(&fixed);
    assert_eq!(f.observers_seen, 2);
    // First order: the same Jacobians and inputs (relative 1e-9: rounding of the look-at and
    // of the projection of the point onto the principal point).
    let rel = (a.linear_covariance - f.linear_covariance).norm() / a.linear_covariance.norm();
    assert!(rel < 1e-9, "linear covariances differ by {rel}");
    // Monte Carlo: independent streams (different kernels), n = 40 000 each: the SE of the
    // ratio of two σ is √(2/(2(n−1))) = 0.50 %; 2.5 % is 5 SE.
    for k in 0..3 {
        let ratio = f.sigma_mm[k] / a.sigma_mm[k];
        assert!(
            (ratio - 1.0).abs() < 0.025,
            "σ[{k}]: fixed {} aimed {}",
            f.sigma_mm[k],
            a.sigma_mm[k]
        );
    }
    // Both agree with the first order here (small noise): MC/linear within 2.5 %.
    let lin = f.linear_sigma_mm();
    for k in 0..3 {
        assert!((f.sigma_mm[k] / lin[k] - 1.0).abs() < 0.025);
    }
}

/// The same seed gives bit-identical results on 1 and 2 threads (fixed path).
#[test]
fn fixed_deterministic_across_threads() {
    let s = parse(MIXED).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let study = GridStudy::new(&s, 5000, 11).unwrap();
            study
                .run(&crate::RunOptions::samples(5000, 11), None)
                .unwrap()
        })
    };
    let (a, b) = (run(1), run(2));
    for (p, q) in a.points.iter().zip(&b.points) {
        assert_eq!(p.observers_seen, q.observers_seen);
        assert_eq!(p.sigma_mm.map(f64::to_bits), q.sigma_mm.map(f64::to_bits));
        assert_eq!(p.count, q.count);
    }
    assert!(
        a.points
            .iter()
            .all(|p| p.count == 5000 && p.observers_seen == 3)
    );
}

/// Two fixed cameras looking away from each other's fields: no point is seen twice; every
/// point is reported not measurable (NaN σ), none below the threshold.
#[test]
fn fixed_layout_without_overlap_is_all_unmeasurable() {
    let text = r#"
samples = 100
[grid]
x_mm = [1000.0, 1200.0, 3]
y_mm = [-100.0, 100.0, 3]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
aim = "fixed"
position_mm = [0.0, 0.0, 0.0]
look_at_mm = [1000.0, 0.0, 0.0]
camera = { model = "SIMPLE_PINHOLE", width = 640, height = 480, params = [500.0, 320.0, 240.0] }
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
aim = "fixed"
position_mm = [3000.0, 0.0, 0.0]
look_at_mm = [4000.0, 0.0, 0.0]
camera = { model = "SIMPLE_PINHOLE", width = 640, height = 480, params = [500.0, 320.0, 240.0] }
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;
    let s = parse(text).unwrap();
    let r = GridStudy::new(&s, 100, 1)
        .unwrap()
        .run(&crate::RunOptions::samples(100, 1), None)
        .unwrap();
    assert_eq!(r.points.len(), 9);
    for p in &r.points {
        assert_eq!(
            p.observers_seen, 1,
            "only the first camera sees {}",
            p.point
        );
        assert!(!p.is_measurable());
        assert!(p.sigma_max_mm.is_nan() && p.linear_sigma_max_mm().is_nan());
        assert_eq!(p.count, 0);
    }
    assert_eq!(r.fraction_measurable(), 0.0);
    assert_eq!(r.fraction_below(5.0), 0.0);
}

/// The field-of-view footprint margin: positive inside the image, its zero at the border.
#[test]
fn fixed_footprint_margin_zero_at_border() {
    let s = parse(MIXED).unwrap();
    let g = s.grid.unwrap();
    let rear = &g.observers[0];
    let Aim::Fixed(f) = &rear.aim else { panic!() };
    // A point on the rear camera's optical axis: margin = min(cx, w − cx, cy, h − cy).
    let on_axis = rear.position_mm + f.rotation.column(2).into_owned() * 1000.0;
    let m = footprint_margin_px(rear, &on_axis).unwrap();
    assert!((m - 719.6).abs() < 1e-6, "{m}");
    let behind = rear.position_mm - f.rotation.column(2).into_owned() * 1000.0;
    assert!(footprint_margin_px(rear, &behind).unwrap() < 0.0);
    assert_eq!(
        footprint_margin_px(&g.observers[2], &on_axis),
        None,
        "aimed: no footprint"
    );
}

/// Every documented bad input is an error naming the key and its line.
#[test]
fn fixed_scenario_errors_name_key_and_line() {
    let cases: [(&str, &str, &str); 9] = [
        (
            "\"OPENCV\", width = 2560",
            "\"OPENCV_X\", width = 2560",
            "unknown COLMAP camera model",
        ),
        (
            "-0.08, 0.02, 0.0005, -0.0003]",
            "-0.08, 0.02, 0.0005]",
            "needs 8 parameters, got 7",
        ),
        (
            "width = 2560",
            "width = 0",
            "width and height must be positive",
        ),
        (
            "height = 1440",
            "height = 0",
            "width and height must be positive",
        ),
        ("look_at_mm = [1200.0, 0.0, 0.0]\n", "", "needs angles_deg"),
        (
            "look_at_mm = [1200.0, 0.0, 0.0]\n",
            "look_at_mm = [1200.0, 0.0, 0.0]\nangles_deg = [0.0, 0.0, 0.0]\n",
            "not both",
        ),
        (
            "aim = \"fixed\"\nposition_mm = [200.0",
            "aim = \"fixe\"\nposition_mm = [200.0",
            "must be \"point\" or \"fixed\"",
        ),
        (
            "pixel_sigma_px = 0.5",
            "pixel_sigma_px = -0.5",
            "not negative",
        ),
        (
            "params = [1600.0, 1610.0",
            "params = [-1600.0, 1610.0",
            "invalid parameter fx",
        ),
    ];
    for (from, to, msg) in cases {
        let text = MIXED.replacen(from, to, 1);
        assert_ne!(text, MIXED, "{from}");
        let err = parse(&text).unwrap_err();
        let shown = crashrig_input::message::error_line(&err);
        assert!(shown.starts_with("s.toml:"), "{shown}");
        assert!(shown.contains("grid.observer[0]"), "{shown}");
        assert!(shown.contains(msg), "{shown} lacks {msg}");
        let Error::Located { line, .. } = err else {
            panic!("{shown}")
        };
        // The line is inside the first observer's table (lines 9–18 of MIXED).
        assert!((9..=18).contains(&line), "{shown}");
    }
    // Fixed-only keys on an aimed observer.
    let text = MIXED.replace(
        "name = \"aimed\"\n",
        "name = \"aimed\"\npixel_sigma_px = 1.0\n",
    );
    let shown = crashrig_input::message::error_line(&parse(&text).unwrap_err());
    assert!(shown.contains("grid.observer[2].pixel_sigma_px"), "{shown}");
    // camera_from: a model directory that does not exist, and a missing camera id.
    let text = MIXED.replacen(
        "camera = { model = \"OPENCV\", width = 2560, height = 1440, params = [1600.0, 1610.0, 1280.3, 719.6, -0.08, 0.02, 0.0005, -0.0003] }",
        "camera_from = \"no/such/model:1\"",
        1,
    );
    let shown = crashrig_input::message::error_line(&parse(&text).unwrap_err());
    assert!(shown.contains("grid.observer[0].camera_from"), "{shown}");
}

/// `camera_from` takes a camera of a COLMAP model (path relative to the scenario file).
#[test]
fn fixed_camera_from_colmap_model() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/colmap");
    let dir = std::fs::read_dir(&fixtures)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| crashrig_colmap::Reconstruction::read(p).is_ok())
        .expect("a readable COLMAP model in fixtures/colmap");
    let model = crashrig_colmap::Reconstruction::read(&dir).unwrap();
    let rec = model
        .cameras()
        .iter()
        .find(|c| c.camera.validate().is_ok() && c.camera.model != ModelId::Equirectangular)
        .expect("a valid camera");
    let name = dir.file_name().unwrap().to_str().unwrap();
    let text = MIXED.replacen(
        "camera = { model = \"OPENCV\", width = 2560, height = 1440, params = [1600.0, 1610.0, 1280.3, 719.6, -0.08, 0.02, 0.0005, -0.0003] }",
        &format!("camera_from = \"{name}:{}\"", rec.camera_id),
        1,
    );
    let s = Scenario::from_toml_str(&text, &fixtures.join("scenario.toml")).unwrap();
    let Aim::Fixed(f) = &s.grid.unwrap().observers[0].aim else {
        panic!()
    };
    assert_eq!(f.lens, rec.camera);
    let text = text.replace(
        &format!("{name}:{}", rec.camera_id),
        &format!("{name}:{}", 999_999),
    );
    let shown = crashrig_input::message::error_line(
        &Scenario::from_toml_str(&text, &fixtures.join("scenario.toml")).unwrap_err(),
    );
    assert!(shown.contains("has no camera 999999"), "{shown}");
}

/// The written-out projection of the radial-tangential lenses equals the camera crate's, and
/// the tangent DLT rows without a rotation matrix equal those of the perturbed matrix.
#[test]
fn fixed_fast_lens_and_rows_match_reference_forms() {
    let lenses = [
        (ModelId::SimpleRadial, vec![900.0, 500.0, 400.0, -0.12]),
        (ModelId::Radial, vec![900.0, 500.0, 400.0, -0.12, 0.03]),
        (
            ModelId::OpenCv,
            vec![900.0, 910.0, 500.0, 400.0, -0.12, 0.03, 0.001, -0.002],
        ),
        (
            ModelId::FullOpenCv,
            vec![
                900.0, 910.0, 500.0, 400.0, -0.12, 0.03, 0.001, -0.002, 0.01, 0.05, -0.01, 0.002,
            ],
        ),
    ];
    for (model, params) in lenses {
        let lens = Lens::new(model, 1000, 800, params).unwrap();
        let fast = FastLens::of(&lens).unwrap();
        for n in [
            Vector2::new(0.0, 0.0),
            Vector2::new(0.3, -0.2),
            Vector2::new(-0.45, 0.35),
            Vector2::new(0.05, 0.41),
        ] {
            let theirs = lens.img_from_cam(&Vector3::new(n.x, n.y, 1.0)).unwrap();
            let ours = fast.img_from_normalized(n);
            assert!((ours - theirs).norm() < 1e-9, "{model}: {ours} vs {theirs}");
        }
    }
    assert!(
        FastLens::of(&Lens::new(ModelId::Fov, 10, 10, vec![5.0, 5.0, 5.0, 5.0, 0.5]).unwrap())
            .is_none()
    );
    // Rows: Rodrigues on two vectors = rows of R̄·exp_matrix(w).
    let s = parse(MIXED).unwrap();
    let (cov, kinds, grid) = setup_of(&s);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let v = views(&setup, &Vector3::new(1200.0, -200.0, 0.0)).unwrap()[0];
    for w in [[1e-4, -2e-4, 3e-4], [0.02, 0.01, -0.015], [0.3, -0.2, 0.5]] {
        let d = Vector6::new(0.5, -0.3, 0.2, w[0], w[1], w[2]);
        let x = Vector2::new(0.12, -0.07);
        let (mut a, mut b) = (Normal3::default(), Normal3::default());
        add_rows_tangent(&mut a, &v, &d, x);
        let (r, c) = perturbed_pose(&v, &d);
        b.add_view(&r, &c, x.x, x.y);
        // Both exact; add a third row set so the 3×3 system is regular and compare solutions.
        for n in [&mut a, &mut b] {
            n.add_row(&Vector3::new(0.0, 0.0, 1.0), &Vector3::new(0.0, 0.0, 7.0));
        }
        let (xa, xb) = (a.solve(), b.solve());
        assert!((xa - xb).norm() < 1e-9 * xa.norm().max(1.0), "{xa} vs {xb}");
    }
}

/// Correlated mode: two fixed observers take the joint draw of two chain cameras that share
/// cam1's position error (the link is exact, no rotation noise): every draw moves both cameras
/// by the same δC, so the intersected point moves by exactly δC and its σ is cam1's 1 mm per
/// axis (20 000 draws: standard error of σ 0.5 %, 2.5 % = 5 SE).
#[test]
fn fixed_correlated_rigid_shift_moves_point_by_shift() {
    let text = r#"
samples = 20000
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [1000.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
[grid]
correlated = true
x_mm = [400.0, 600.0, 2]
y_mm = [900.0, 1100.0, 2]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
aim = "fixed"
position_mm = [0.0, 0.0, 0.0]
look_at_mm = [500.0, 1000.0, 0.0]
camera = { model = "PINHOLE", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0] }
sigma_from = "cam1"
[[grid.observer]]
aim = "fixed"
position_mm = [1000.0, 0.0, 0.0]
look_at_mm = [500.0, 1000.0, 0.0]
camera = { model = "PINHOLE", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0] }
sigma_from = "cam2"
"#;
    let s = parse(text).unwrap();
    let study = GridStudy::new(&s, s.samples, 9).unwrap();
    let r = study
        .run(&crate::RunOptions::samples(s.samples, 9), None)
        .unwrap();
    assert!(r.correlated);
    for p in &r.points {
        assert_eq!(p.observers_seen, 2);
        for k in 0..3 {
            assert!(
                (p.sigma_mm[k] - 1.0).abs() < 0.025,
                "σ[{k}] = {} at {}",
                p.sigma_mm[k],
                p.point
            );
        }
    }
    // Drawn independently the two shifts do not cancel: the point moves differently.
    let ind = study
        .independent()
        .run(&crate::RunOptions::samples(s.samples, 9), None)
        .unwrap();
    assert!(
        ind.points
            .iter()
            .any(|p| (p.sigma_max_mm - 1.0).abs() > 0.1)
    );
}

/// Adaptive stopping on the fixed path: measurable points stop after ≥ 4 batches and within
/// `max_samples`; not-measurable points draw nothing.
#[test]
fn fixed_adaptive_stops_and_skips_unmeasurable() {
    let text = MIXED.replace(
        "[grid]\n",
        "[grid]\n[grid.adaptive]\ntolerance_mm = 0.05\nbatch = 500\nmax_samples = 20000\n",
    );
    // Move the adaptive table's keys after the grid keys (TOML: a sub-table ends the table).
    let text = text.replace(
        "[grid]\n[grid.adaptive]\ntolerance_mm = 0.05\nbatch = 500\nmax_samples = 20000\nx_mm = [900.0, 1500.0, 3]\ny_mm = [-200.0, 200.0, 2]\nz_mm = [0.0, 0.0, 1]\n",
        "[grid]\nx_mm = [900.0, 2100.0, 4]\ny_mm = [-200.0, 200.0, 2]\nz_mm = [0.0, 0.0, 1]\n[grid.adaptive]\ntolerance_mm = 0.05\nbatch = 500\nmax_samples = 20000\n",
    );
    // Without the aimed observer, points behind the rear camera (x < 200) are seen once.
    let text = text[..text.find("[[grid.observer]]\nname = \"aimed\"").unwrap()]
        .replace("x_mm = [900.0, 2100.0, 4]", "x_mm = [-300.0, 1500.0, 4]");
    let s = parse(&text).unwrap();
    let grid = s.grid.clone().unwrap();
    let ad = grid.adaptive.unwrap();
    let r = GridStudy::new(&s, 1000, 2)
        .unwrap()
        .run(&crate::RunOptions::adaptive(ad, 2), None)
        .unwrap();
    assert!(r.points.iter().any(|p| p.is_measurable()));
    assert!(
        r.points.iter().any(|p| !p.is_measurable()),
        "the layout has unseen points"
    );
    for p in &r.points {
        if p.is_measurable() {
            assert!(p.count >= 2000 && p.count <= 20_000, "{}", p.count);
            assert!(p.sigma_max_mm.is_finite());
        } else {
            assert_eq!(p.count, 0);
        }
    }
}

/// The fixed-path studies of the every-ISA identity test: a mixed layout (distorted OPENCV in
/// lanes, OPENCV_FISHEYE by the scalar routine, an aimed observer by the ray form), the same
/// with grid pixel noise and euler noise, 40 px pixel noise (most lanes need the scalar
/// fix-up), a full-covariance observer, and observers drawn jointly from a chain.
fn fixed_kernel_paths() -> Vec<(&'static str, GridStudy)> {
    let pixel = MIXED.replace(
        "z_mm = [0.0, 0.0, 1]",
        "z_mm = [0.0, 0.0, 1]\npixel_sigma_px = 0.5\nfocal_px = 1500.0",
    );
    let euler = pixel.replace("\"tangent\"", "\"euler\"");
    let wide = MIXED.replace("pixel_sigma_px = 0.5", "pixel_sigma_px = 40.0");
    let cov = MIXED.replace(
        "sigma_position_mm = [1.0, 1.2, 1.0]\nsigma_angles_deg = [0.01, 0.015, 0.01]",
        "covariance_tangent = [[1.0, 0.3, 0.0, 0.0, 0.001, 0.0], [0.3, 1.4, 0.2, 0.0, 0.0, 0.0], \
         [0.0, 0.2, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0001, 0.0, 0.0], \
         [0.001, 0.0, 0.0, 0.0, 0.0002, 0.00005], [0.0, 0.0, 0.0, 0.0, 0.00005, 0.0001]]",
    );
    assert_ne!(
        cov, MIXED,
        "the covariance variant must replace the aimed σ"
    );
    let mut out = Vec::new();
    for (name, text) in [
        ("mixed", MIXED.to_string()),
        ("mixed+pixel+euler", euler),
        ("wide pixel noise", wide),
        ("full covariance", cov),
        ("correlated", CORRELATED.to_string()),
    ] {
        let s = parse(&text).unwrap();
        out.push((name, GridStudy::new(&s, 2000, 1).unwrap()));
    }
    out
}

/// Two fixed PINHOLE cameras drawn jointly from a two-camera chain (correlated mode).
const CORRELATED: &str = r#"
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.02, 0.01, 0.02]
[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [1000.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [0.5, 0.5, 0.5]
sigma_angles_deg = [0.01, 0.01, 0.01]
[grid]
correlated = true
x_mm = [400.0, 600.0, 2]
y_mm = [900.0, 1100.0, 2]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
aim = "fixed"
position_mm = [0.0, 0.0, 0.0]
look_at_mm = [500.0, 1000.0, 0.0]
camera = { model = "OPENCV", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0, -0.05, 0.01, 0.0, 0.0] }
pixel_sigma_px = 0.5
sigma_from = "cam1"
[[grid.observer]]
aim = "fixed"
position_mm = [1000.0, 0.0, 0.0]
look_at_mm = [500.0, 1000.0, 0.0]
camera = { model = "PINHOLE", width = 1000, height = 1000, params = [500.0, 500.0, 500.0, 500.0] }
pixel_sigma_px = 0.5
sigma_from = "cam2"
"#;

/// The statement of `kernel/simd.rs` for the fixed path: every instruction-set level gives the same
/// bits (each available level forced and compared with the baseline, a partial final block).
#[test]
fn fixed_every_isa_gives_identical_grids() {
    use crate::Isa;
    let n = crate::CHUNK + 70;
    for (name, study) in fixed_kernel_paths() {
        let base = study
            .run(
                &crate::RunOptions {
                    isa: Isa::Baseline,
                    ..crate::RunOptions::samples(n, 9)
                },
                None,
            )
            .unwrap();
        assert!(base.points.iter().any(|p| p.is_measurable()), "{name}");
        for isa in Isa::LEVELS {
            if !isa.is_available() {
                eprintln!("{}: not available on this CPU, not compared", isa.name());
                continue;
            }
            let got = study
                .run(
                    &crate::RunOptions {
                        isa,
                        ..crate::RunOptions::samples(n, 9)
                    },
                    None,
                )
                .unwrap();
            assert_eq!(got, base, "{name}: {} differs from baseline", isa.name());
        }
    }
}

/// The block engine and the former scalar engine of the fixed path draw different numbers
/// with the same distribution: σ within 4 standard errors of a difference of two σ estimates.
#[test]
fn fixed_block_and_legacy_engines_agree_statistically() {
    let n = 20_000;
    let se = (2.0f64).sqrt() / (2.0 * (n as f64 - 1.0)).sqrt();
    for (name, study) in fixed_kernel_paths() {
        let a = study
            .run_draws(
                &crate::options::Draws::Samples(n),
                5,
                crate::schedule::Engine::Legacy,
                None,
            )
            .unwrap();
        let b = study.run(&crate::RunOptions::samples(n, 5), None).unwrap();
        for (pa, pb) in a.points.iter().zip(&b.points) {
            assert_eq!(pa.observers_seen, pb.observers_seen);
            if !pa.is_measurable() {
                continue;
            }
            for k in 0..3 {
                let s = pa.sigma_mm[k];
                assert!(
                    (pb.sigma_mm[k] - s).abs() < 4.0 * se * s,
                    "{name} σ[{k}] at {}: legacy {s}, block {}",
                    pa.point,
                    pb.sigma_mm[k]
                );
            }
        }
        assert_ne!(a, b, "{name}: the engines must draw different numbers");
    }
}

/// The undistortion in lanes: every lane within 1e-9 of the camera crate's unprojection; the
/// fixed number of chord-Newton steps alone does not reach that for 150 px offsets (so the
/// scalar fix-up is exercised and needed), and is exact for a pinhole.
#[test]
fn fixed_undistort_lanes_matches_camera_crate_with_fix_up() {
    let s = parse(&MIXED.replace("pixel_sigma_px = 0.5", "pixel_sigma_px = 150.0")).unwrap();
    let (cov, kinds, grid) = setup_of(&s);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let vs = views(&setup, &Vector3::new(1200.0, -200.0, 0.0)).unwrap();
    let mut rows = vec![[0.0; LANES]; 2];
    crate::kernel::normal::fill_block(
        crate::kernel::philox::key_of_seed(3),
        0,
        0,
        &mut rows,
        Width::Narrow,
    );
    let (ex, ey) = (rows[0], rows[1]);
    let mut checked = 0;
    for v in vs.iter().filter(|v| v.full_lens.is_some()) {
        let lens = v.full_lens.unwrap();
        let (mut x, mut y) = ([0.0; LANES], [0.0; LANES]);
        let (mut rx, mut ry) = ([0.0; LANES], [0.0; LANES]);
        undistort_lanes(v, &ex, &ey, &mut x, &mut y, LANES);
        // b = 0: no lane is fixed up (the raw lane result).
        undistort_lanes(v, &ex, &ey, &mut rx, &mut ry, 0);
        let mut raw_off = 0;
        for l in 0..LANES {
            let du = Vector2::new(ex[l], ey[l]) * v.sigma_px;
            let theirs = lens.cam_from_img(&(v.u0 + du)).unwrap().normalized;
            let ours = Vector2::new(x[l], y[l]);
            assert!(
                (ours - theirs).norm() < 1e-9,
                "lane {l}: {ours} vs {theirs}"
            );
            if v.fast.is_some() && (Vector2::new(rx[l], ry[l]) - theirs).norm() > 1e-9 {
                raw_off += 1;
            }
            checked += 1;
        }
        if v.fast.is_some() {
            assert!(raw_off > 0, "150 px offsets must need the fix-up");
        }
    }
    assert_eq!(checked, 2 * LANES);
    // A pinhole (no distortion): the predictor only, exact to rounding.
    let pin = MIXED.replace("-0.08, 0.02, 0.0005, -0.0003", "0.0, 0.0, 0.0, 0.0");
    let s = parse(&pin).unwrap();
    let (cov, kinds, grid) = setup_of(&s);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let v = views(&setup, &Vector3::new(1200.0, -200.0, 0.0)).unwrap()[0];
    assert!(v.lens.is_none());
    let (mut x, mut y) = ([0.0; LANES], [0.0; LANES]);
    undistort_lanes(&v, &ex, &ey, &mut x, &mut y, LANES);
    let lens = v.full_lens.unwrap();
    for l in 0..LANES {
        let du = Vector2::new(ex[l], ey[l]) * v.sigma_px;
        let theirs = lens.cam_from_img(&(v.u0 + du)).unwrap().normalized;
        assert!((Vector2::new(x[l], y[l]) - theirs).norm() < 1e-12);
    }
}

/// At the pixel noise of the benchmarks and the reference layout (0.5 px, OPENCV with
/// k1 = −0.08 at 1600 px focal length) the chord-Newton steps converge in every lane: the
/// result without the scalar fix-up (`b = 0`) equals the one with it, bit for bit, over
/// 64 blocks at three grid points (the claim of `docs/performance.md`); and so they do on the
/// real-study map (`benches/real_map.toml`: 0.8 px through k1 = −0.15 at 1100 px, at every
/// grid point either fixed camera sees, most near its image's corners), where two steps left
/// most corner lanes to the fix-up.
#[test]
fn fixed_undistort_lanes_need_no_fix_up_at_half_a_pixel() {
    // The observers' pose noise does not enter the undistortion: given σ instead of the chain.
    let real = crate::testdata::repo_file("benches/real_map.toml")
        .replace(
            "sigma_from = \"cam2\"",
            "sigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]",
        )
        .replace(
            "sigma_from = \"cam3\"",
            "sigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]",
        )
        .replace("correlated = true", "correlated = false");
    let real = parse(&real).unwrap();
    let (cov, kinds, grid) = setup_of(&real);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let mut rows = vec![[0.0; LANES]; 2];
    let mut seen = 0;
    for point in grid.points() {
        for v in views(&setup, &point).unwrap() {
            if v.fast.is_none() {
                continue;
            }
            for block in 0..8u64 {
                crate::kernel::normal::fill_block(
                    crate::kernel::philox::key_of_seed(5),
                    2,
                    64 * block,
                    &mut rows,
                    Width::Narrow,
                );
                let (mut x, mut y, mut rx, mut ry) =
                    ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
                undistort_lanes(&v, &rows[0], &rows[1], &mut x, &mut y, LANES);
                undistort_lanes(&v, &rows[0], &rows[1], &mut rx, &mut ry, 0);
                assert_eq!(x.map(f64::to_bits), rx.map(f64::to_bits), "{point}");
                assert_eq!(y.map(f64::to_bits), ry.map(f64::to_bits), "{point}");
            }
            seen += 1;
        }
    }
    // B sees 189 of the 221 points, C 145 (`grid` summary: 85.5 % and 65.6 %).
    assert_eq!(seen, 189 + 145);
    let s = parse(MIXED).unwrap();
    let (cov, kinds, grid) = setup_of(&s);
    let setup = Setup {
        grid: &grid,
        covariance: &cov,
        kinds: &kinds,
        pixel: None,
        chain: None,
    };
    let mut lanes = 0;
    for point in [
        Vector3::new(900.0, -200.0, 0.0),
        Vector3::new(1200.0, 200.0, 0.0),
        Vector3::new(1500.0, -200.0, 0.0),
    ] {
        let vs = views(&setup, &point).unwrap();
        let v = vs
            .iter()
            .find(|v| v.fast.is_some())
            .expect("the OPENCV view");
        assert_eq!(v.sigma_px, 0.5);
        let mut rows = vec![[0.0; LANES]; 2];
        for block in 0..64u64 {
            crate::kernel::normal::fill_block(
                crate::kernel::philox::key_of_seed(5),
                1,
                64 * block,
                &mut rows,
                Width::Narrow,
            );
            let (mut x, mut y, mut rx, mut ry) =
                ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
            undistort_lanes(v, &rows[0], &rows[1], &mut x, &mut y, LANES);
            undistort_lanes(v, &rows[0], &rows[1], &mut rx, &mut ry, 0);
            assert_eq!(x.map(f64::to_bits), rx.map(f64::to_bits));
            assert_eq!(y.map(f64::to_bits), ry.map(f64::to_bits));
            lanes += LANES;
        }
    }
    assert_eq!(lanes, 3 * 64 * LANES);
}
