//! Observations with their own σ (`sigma_u_px,sigma_v_px[,rho_uv]` in the observations CSV):
//! the position covariance of the Monte Carlo against an independent first-order propagation of
//! each row's own 2 × 2 Σ through the lens and the intersection (finite differences of
//! undistort-then-DLT), the fallback to `pixel_sigma_px` for rows with empty cells, and the
//! errors of the reader.

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::triangulate::{self, View};
use crashrig_geometry::{Mat3, Rigid3, UncertainPose, Vec3, quat, so3};
use crashrig_measure::engine::{Epoch, Measurement, Rig, Settings, measure};
use crashrig_measure::input::{self, CameraNames, Observation};
use nalgebra::{Matrix2, Matrix3x4, Vector2};
use std::path::Path;

/// Replicates of the Monte Carlo; the standard error of a sample σ is σ/√(2(n − 1)) = 0.50 %.
const SAMPLES: usize = 20_000;

/// A lens with real distortion (OPENCV: k1, k2, p1, p2), so the σ must go through it.
fn lens() -> Camera {
    Camera::new(
        ModelId::OpenCv,
        2000,
        1500,
        vec![1800.0, 1790.0, 1000.0, 750.0, -0.18, 0.05, 0.001, -0.0008],
    )
    .unwrap()
}

/// B at A (identity), C 600 mm to its right turned 20° towards B; everything certain, so the
/// only randomness is the pixel noise.
fn rig() -> Rig {
    let r = so3::exp(&Vec3::new(0.0, -20.0_f64.to_radians(), 0.0));
    Rig {
        a_from_b: UncertainPose::certain(Rigid3::identity()),
        camera_b: lens(),
        c: Some((
            UncertainPose::certain(quat::rigid_from_rotation(&r, &Vec3::new(600.0, 0.0, 0.0))),
            lens(),
        )),
    }
}

fn epochs(n: usize) -> Vec<Epoch> {
    (0..n)
        .map(|i| Epoch {
            key: format!("{i:04}.png"),
            name: format!("{i:04}"),
            world_from_a: UncertainPose::certain(Rigid3::identity()),
        })
        .collect()
}

fn settings(pixel_sigma_px: f64) -> Settings {
    Settings {
        samples: SAMPLES,
        seed: 5,
        pixel_sigma_px,
        reference_epoch: None,
        frame_rate_hz: None,
        frame_times: None,
        threshold_mm: 5.0,
        max_reprojection_px: None,
        cfc: None,
        sync_sigma_ms: 0.0,
    }
}

/// `cam_from_world` of B and C (A is the world).
fn cam_from_world(rig: &Rig) -> [Rigid3; 2] {
    let world_from_b = rig.a_from_b.b_from_a;
    let world_from_c = world_from_b * rig.c.as_ref().unwrap().0.b_from_a;
    [world_from_b.inverse(), world_from_c.inverse()]
}

/// The true pixel of `x` (world, mm) in both cameras, through the lens.
fn pixels(rig: &Rig, x: &Vec3) -> [Vector2<f64>; 2] {
    cam_from_world(rig).map(|p| {
        let c = p * nalgebra::Point3::from(*x);
        lens().img_from_cam(&c.coords).unwrap()
    })
}

/// The reference estimator, built here from the pieces: undistort each pixel (the camera
/// crate's Newton iteration), then the linear least squares of the two rays.
fn position(rig: &Rig, px: [Vector2<f64>; 2]) -> Vec3 {
    let views: Vec<View> = cam_from_world(rig)
        .into_iter()
        .zip(px)
        .map(|(p, uv)| View {
            cam_from_world: p,
            normalized: lens().cam_from_img(&uv).unwrap().normalized,
        })
        .collect();
    triangulate::dlt(&views).unwrap()
}

/// First-order covariance of the position: `G·blockdiag(Σ_B, Σ_C)·Gᵀ`, with `G = ∂X/∂(u_B,
/// v_B, u_C, v_C)` by central differences (h = 10⁻³ px; the truncation error, O(h²) relative,
/// is far below the Monte Carlo's 0.5 %).
fn first_order(rig: &Rig, x: &Vec3, sigma: [Matrix2<f64>; 2]) -> Mat3 {
    let px = pixels(rig, x);
    let h = 1e-3;
    let mut g = Matrix3x4::zeros();
    for k in 0..4 {
        let (cam, axis) = (k / 2, k % 2);
        let mut plus = px;
        let mut minus = px;
        plus[cam][axis] += h;
        minus[cam][axis] -= h;
        let d = (position(rig, plus) - position(rig, minus)) / (2.0 * h);
        g.set_column(k, &d);
    }
    let mut s = nalgebra::Matrix4::zeros();
    s.fixed_view_mut::<2, 2>(0, 0).copy_from(&sigma[0]);
    s.fixed_view_mut::<2, 2>(2, 2).copy_from(&sigma[1]);
    g * s * g.transpose()
}

fn covariance(su: f64, sv: f64, rho: f64) -> Matrix2<f64> {
    input::PixelSigma {
        sigma_u_px: su,
        sigma_v_px: sv,
        rho_uv: rho,
    }
    .covariance()
}

/// Writes `text` as an observations CSV in a fresh directory and reads it.
fn read(text: &str) -> Result<Vec<Observation>, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("observations.csv");
    std::fs::write(&path, text).unwrap();
    let names = CameraNames {
        b_id: None,
        c_id: None,
        has_c: true,
    };
    input::read_observations(&path, &names).map_err(|e| e.to_string())
}

/// A marker: its name, its world position (mm) and the (σu, σv, ρ) of its B and C pixels
/// (`None`: the row's σ cells are empty).
type Marker = (&'static str, Vec3, [Option<(f64, f64, f64)>; 2]);

fn markers() -> Vec<Marker> {
    vec![
        // Anisotropic and correlated, different in B and C.
        (
            "knee",
            Vec3::new(150.0, 80.0, 1500.0),
            [Some((0.2, 0.1, 0.5)), Some((0.12, 0.25, -0.6))],
        ),
        // The same place as `knee` in the image (another epoch) with Σ × 10² (σ × 10).
        (
            "knee_blurred",
            Vec3::new(150.0, 80.0, 1500.0),
            [Some((2.0, 1.0, 0.5)), Some((1.2, 2.5, -0.6))],
        ),
        // Far off-axis, where the distortion is strong.
        (
            "shoulder",
            Vec3::new(-500.0, -350.0, 1400.0),
            [Some((0.3, 0.3, 0.0)), Some((0.15, 0.4, 0.3))],
        ),
        // Empty cells in B: `pixel_sigma_px` (0.4 px, isotropic) there.
        (
            "belt",
            Vec3::new(300.0, 250.0, 1800.0),
            [None, Some((0.05, 0.05, 0.0))],
        ),
    ]
}

/// One epoch per marker (so `knee` and `knee_blurred` can sit at the same pixels).
fn observations_csv(rig: &Rig, markers: &[Marker]) -> String {
    let mut text = String::from("epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,rho_uv\n");
    for (e, (name, x, sigmas)) in markers.iter().enumerate() {
        for ((camera, px), s) in ["B", "C"].into_iter().zip(pixels(rig, x)).zip(sigmas) {
            let cells = match s {
                Some((su, sv, rho)) => format!("{su},{sv},{rho}"),
                None => ",,".into(),
            };
            text += &format!("{e:04},{camera},{name},{:.17},{:.17},{cells}\n", px.x, px.y);
        }
    }
    text
}

fn run(rig: &Rig, obs: &[Observation], pixel_sigma_px: f64) -> Measurement {
    measure(&epochs(4), None, rig, obs, None, &settings(pixel_sigma_px)).unwrap()
}

/// Each row's Monte Carlo covariance against its first-order value: every σ within 4 standard
/// errors (σ/√(2(n − 1)), 0.5 % at 20 000 draws: a 2 % tolerance), every correlation within 4
/// of its standard errors ((1 − r²)/√(n − 1)); the row 10× the σ has 10× the position σ.
#[test]
fn position_covariance_follows_each_observations_own_sigma() {
    let rig = rig();
    let markers = markers();
    let obs = read(&observations_csv(&rig, &markers)).unwrap();
    let fallback = 0.4;
    let m = run(&rig, &obs, fallback);
    assert_eq!(m.rows.len(), markers.len());
    let n = SAMPLES as f64;
    let mut sigma_of = std::collections::BTreeMap::new();
    for row in &m.rows {
        let name = m.markers[row.marker].as_str();
        let (_, x, sigmas) = markers.iter().find(|k| k.0 == name).unwrap();
        let sigma = sigmas.map(|s| match s {
            Some((su, sv, rho)) => covariance(su, sv, rho),
            None => covariance(fallback, fallback, 0.0),
        });
        let want = first_order(&rig, x, sigma);
        let got = row.covariance_mm2.unwrap();
        assert_eq!(row.draws, SAMPLES as u64);
        assert!((row.position_mm.unwrap() - x).norm() < 1e-6, "{name}");
        for i in 0..3 {
            let (s_got, s_want) = (got[(i, i)].sqrt(), want[(i, i)].sqrt());
            let se = s_want / (2.0 * (n - 1.0)).sqrt();
            assert!(
                (s_got - s_want).abs() < 4.0 * se,
                "{name} σ axis {i}: {s_got} vs first order {s_want} ± {se}"
            );
            for j in i + 1..3 {
                let r_got = got[(i, j)] / (got[(i, i)] * got[(j, j)]).sqrt();
                let r_want = want[(i, j)] / (want[(i, i)] * want[(j, j)]).sqrt();
                let se = (1.0 - r_want * r_want) / (n - 1.0).sqrt();
                assert!(
                    (r_got - r_want).abs() < 4.0 * se,
                    "{name} correlation {i}{j}: {r_got} vs first order {r_want} ± {se}"
                );
            }
        }
        sigma_of.insert(name, row.sigma_mm.unwrap());
    }
    // The blurred copy: 10× the σ of every pixel → 10× the σ of every axis (first order
    // exactly; the two rows' draws are independent, so the ratio's SE is √2 × 0.5 % × 10).
    let (blurred, sharp) = (sigma_of["knee_blurred"], sigma_of["knee"]);
    for (k, (b, s)) in blurred.iter().zip(sharp.iter()).enumerate() {
        let ratio = b / s;
        let se = 10.0 * (2.0_f64 / (2.0 * (n - 1.0))).sqrt();
        assert!(
            (ratio - 10.0).abs() < 4.0 * se,
            "axis {k}: σ ratio {ratio} for pixel σ × 10 (± {se})"
        );
    }
}

/// The independent reference is itself checked: the first-order covariance of a row whose
/// cameras have isotropic σ equals the geometry crate's closed form of the DLT covariance for
/// a pinhole (no lens: σ in normalized units is σ_px/f).
#[test]
fn the_first_order_reference_agrees_with_the_closed_form_for_a_pinhole() {
    let pinhole = Camera::new(
        ModelId::Pinhole,
        2000,
        1500,
        vec![1800.0, 1800.0, 1000.0, 750.0],
    )
    .unwrap();
    let x = Vec3::new(150.0, 80.0, 1500.0);
    let mut rig = rig();
    rig.camera_b = pinhole.clone();
    rig.c.as_mut().unwrap().1 = pinhole.clone();
    // The reference functions use `lens()`; build this one by hand with the pinhole.
    let cams = cam_from_world(&rig);
    let px = cams.map(|p| {
        pinhole
            .img_from_cam(&(p * nalgebra::Point3::from(x)).coords)
            .unwrap()
    });
    let pos = |px: [Vector2<f64>; 2]| {
        let views: Vec<View> = cams
            .into_iter()
            .zip(px)
            .map(|(p, uv)| View {
                cam_from_world: p,
                normalized: pinhole.cam_from_img(&uv).unwrap().normalized,
            })
            .collect();
        triangulate::dlt(&views).unwrap()
    };
    let h = 1e-3;
    let mut g = Matrix3x4::zeros();
    for k in 0..4 {
        let (mut p, mut q) = (px, px);
        p[k / 2][k % 2] += h;
        q[k / 2][k % 2] -= h;
        g.set_column(k, &((pos(p) - pos(q)) / (2.0 * h)));
    }
    let s = 0.3;
    let fd = g * g.transpose() * (s * s);
    let views: Vec<View> = cams
        .into_iter()
        .zip(px)
        .map(|(p, uv)| View {
            cam_from_world: p,
            normalized: pinhole.cam_from_img(&uv).unwrap().normalized,
        })
        .collect();
    let closed = triangulate::dlt_covariance(&views, &x, s / 1800.0).unwrap();
    assert!(
        (fd - closed).amax() < 1e-6 * closed.amax(),
        "{fd} vs {closed}"
    );
}

/// Without σ columns every row is as before; σ cells equal to `pixel_sigma_px` (ρ empty) give
/// the same rows bit for bit; the columns with every cell empty too.
#[test]
fn sigma_cells_equal_to_the_typed_sigma_change_nothing() {
    let rig = rig();
    let markers = markers();
    let typed = 0.25;
    let plain: String = observations_csv(&rig, &markers)
        .lines()
        .map(|l| l.rsplitn(4, ',').last().unwrap().to_string() + "\n")
        .collect();
    assert!(plain.starts_with("epoch,camera,marker,u_px,v_px\n"));
    let explicit: String = plain
        .lines()
        .enumerate()
        .map(|(i, l)| match i {
            0 => format!("{l},sigma_u_px,sigma_v_px,rho_uv\n"),
            _ => format!("{l},{typed},{typed},\n"),
        })
        .collect();
    let empty: String = plain
        .lines()
        .enumerate()
        .map(|(i, l)| match i {
            0 => format!("{l},sigma_v_px,sigma_u_px\n"),
            _ => format!("{l},,\n"),
        })
        .collect();
    let mut fewer = settings(typed);
    fewer.samples = 500;
    let with = |text: &str| {
        let obs = read(text).unwrap();
        measure(&epochs(4), None, &rig, &obs, None, &fewer).unwrap()
    };
    let base = with(&plain);
    assert_eq!(base.rows.len(), markers.len());
    assert_eq!(with(&explicit), base);
    assert_eq!(with(&empty), base);
    assert!(read(&plain).unwrap().iter().all(|o| o.sigma.is_none()));
}

#[test]
fn sigma_columns_are_read_per_row() {
    let obs = read(
        "epoch,marker,camera,u_px,v_px,rho_uv,sigma_v_px,sigma_u_px\n\
         0001,head,B,10,20,-0.25,0.5,0.125\n\
         0001,head,C,10,20,,0.5,0.125\n\
         0002,head,B,10,20,,,\n",
    )
    .unwrap();
    let s = |su, sv, rho| {
        Some(input::PixelSigma {
            sigma_u_px: su,
            sigma_v_px: sv,
            rho_uv: rho,
        })
    };
    assert_eq!(obs[0].sigma, s(0.125, 0.5, -0.25));
    assert_eq!(obs[1].sigma, s(0.125, 0.5, 0.0));
    assert_eq!(obs[2].sigma, None);
    // The factor reproduces the covariance.
    let p = obs[0].sigma.unwrap();
    let l = p.factor();
    assert!((l * l.transpose() - p.covariance()).amax() < 1e-15);
    assert_eq!(p.covariance()[(0, 1)], -0.25 * 0.125 * 0.5);
}

#[test]
fn bad_sigma_cells_are_errors_naming_file_and_line() {
    let head = "epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,rho_uv\n";
    let ok = "0001,B,head,10,20,0.1,0.1,0\n";
    let cases = [
        (
            "0001,C,head,10,20,0,0.1,0\n",
            ":3: sigma_u_px is 0: a pixel σ must be a finite number > 0 (px)",
        ),
        (
            "0001,C,head,10,20,0.1,-0.2,\n",
            ":3: sigma_v_px is -0.2: a pixel σ must be a finite number > 0 (px)",
        ),
        (
            "0001,C,head,10,20,NaN,0.1,\n",
            ":3: sigma_u_px is NaN: a pixel σ must be a finite number > 0 (px)",
        ),
        (
            "0001,C,head,10,20,inf,0.1,\n",
            ":3: sigma_u_px is inf: a pixel σ must be a finite number > 0 (px)",
        ),
        (
            "0001,C,head,10,20,0.1,0.1,1\n",
            ":3: rho_uv is 1: a correlation must be a finite number with |ρ| < 1",
        ),
        (
            "0001,C,head,10,20,0.1,0.1,-1.5\n",
            ":3: rho_uv is -1.5: a correlation must be a finite number with |ρ| < 1",
        ),
        (
            "0001,C,head,10,20,0.1,0.1,x\n",
            ":3: rho_uv `x` is not a number",
        ),
        (
            "0001,C,head,10,20,0.1,,\n",
            ":3: sigma_v_px is empty but the other σ of the row is given (give both, or neither for --pixel-sigma-px)",
        ),
        (
            "0001,C,head,10,20,,,0.3\n",
            ":3: rho_uv is `0.3` but sigma_u_px and sigma_v_px are empty (a correlation needs its two σ)",
        ),
        (
            "0001,C,head,10,20,0.1px,0.1,\n",
            ":3: sigma_u_px `0.1px` is not a number",
        ),
    ];
    for (line, want) in cases {
        let e = read(&format!("{head}{ok}{line}")).unwrap_err();
        assert!(
            e.contains("observations.csv") && e.ends_with(want),
            "{e} ≠ …{want}"
        );
    }
    let headers = [
        (
            "epoch,camera,marker,u_px,v_px,sigma_u_px\n",
            ":1: column `sigma_u_px` without `sigma_v_px` (give both σ columns, or neither)",
        ),
        (
            "epoch,camera,marker,u_px,v_px,sigma_v_px,rho_uv\n",
            ":1: column `sigma_v_px` without `sigma_u_px` (give both σ columns, or neither)",
        ),
        (
            "epoch,camera,marker,u_px,v_px,rho_uv\n",
            ":1: column `rho_uv` without `sigma_u_px` and `sigma_v_px` (the correlation of the two σ)",
        ),
        (
            "epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,sigma_u_px\n",
            ":1: column `sigma_u_px` appears twice",
        ),
        (
            "epoch,camera,marker,u_px,v_px,sigma_w_px\n",
            ":1: unknown column `sigma_w_px` (the columns are epoch,camera,marker,u_px,v_px and optionally sigma_u_px,sigma_v_px,rho_uv)",
        ),
    ];
    for (header, want) in headers {
        let e = read(&format!("{header}0001,B,head,10,20,0.1,0.1\n")).unwrap_err();
        assert!(e.ends_with(want), "{e} ≠ …{want}");
    }
}

/// The fixture as `track` writes it (`camera` B/C, all three σ columns) reads, and a file path
/// in an error is the one given.
#[test]
fn the_error_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tracked.csv");
    std::fs::write(
        &path,
        "epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,rho_uv\n0001,B,m,1,2,0,1,0\n",
    )
    .unwrap();
    let names = CameraNames {
        b_id: None,
        c_id: None,
        has_c: false,
    };
    let e = input::read_observations(Path::new(&path), &names)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&path.display().to_string()) && e.contains(":2: sigma_u_px is 0"),
        "{e}"
    );
}
