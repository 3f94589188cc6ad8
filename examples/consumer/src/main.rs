//! A consumer of the packaged crashrig crates, outside the workspace: the three kinds of user.
//!
//! 1. A lab's pipeline projecting with `crashrig-camera`: an OPENCV camera against pycolmap's
//!    projections (`fixtures/camera/goldens.json`).
//! 2. A tool reading COLMAP models with `crashrig-colmap` (no default features): a bundled
//!    binary model against pycolmap's reading of it (`fixtures/colmap/rig_opencv/bin`).
//! 3. Someone running the Monte Carlo core `crashrig-mc` alone (no default features): a chain
//!    and a one-point grid whose σ are known in closed form.
//!
//! Usage: `crashrig-consumer FIXTURES_DIR` (the workspace's `fixtures/`); `cargo xtask consumer`
//! runs it. Every check panics with what differed; success prints one line per check.

use crashrig_camera::{Camera, ModelId};
use crashrig_colmap::Reconstruction;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3, projection_center};
use crashrig_mc::{Axis, ChainBuilder, ChainOptions, GridBuilder, RunOptions};
use nalgebra::{Vector2, Vector3};
use serde_json::Value;
use std::path::Path;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn main() -> Result<()> {
    let fixtures = std::env::args_os()
        .nth(1)
        .ok_or("usage: crashrig-consumer FIXTURES_DIR")?;
    let fixtures = Path::new(&fixtures);
    let n = project_opencv(fixtures)?;
    println!(
        "consumer: crashrig-camera: {n} OPENCV projections agree with pycolmap (1e-9 px, rejects included)"
    );
    let n = read_model(fixtures)?;
    println!("consumer: crashrig-colmap: {n} image centres agree with pycolmap to 1e-13");
    let (chain, grid) = engine()?;
    println!(
        "consumer: crashrig-mc: cam2 σ {chain:.4?} mm (closed form {:.4} mm per axis), grid point σ \
         {grid:.4?} mm (closed form 1, 1, {:.4} mm), within 4 standard errors",
        1.25f64.sqrt(),
        0.5f64.sqrt()
    );
    Ok(())
}

fn json(path: &Path) -> Result<Value> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(serde_json::from_str(&text)?)
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

/// pycolmap's projections of the OPENCV camera of `camera/goldens.json`, through
/// `crashrig_camera::Camera` (the bound is the camera crate's own golden test's, 1e-9 px).
fn project_opencv(fixtures: &Path) -> Result<usize> {
    let goldens = json(&fixtures.join("camera/goldens.json"))?;
    let g = goldens["colmap"]
        .as_array()
        .expect("colmap section")
        .iter()
        .find(|c| c["model"] == "OPENCV")
        .expect("an OPENCV camera in the goldens");
    let size = |k: &str| g[k].as_u64().expect("a size");
    let camera = Camera::new(
        ModelId::from_name("OPENCV")?,
        size("width"),
        size("height"),
        f64s(&g["params"]),
    )?;
    let cases = g["project"].as_array().expect("project cases");
    for case in cases {
        let p = Vector3::from_column_slice(&f64s(&case["point"]));
        let ours = camera.img_from_cam(&p);
        if case["pixel"].is_null() {
            // Behind the camera or on its plane: pycolmap rejects it, so must we.
            assert!(
                ours.is_err(),
                "{p:?}: pycolmap rejects, crashrig gave {ours:?}"
            );
            continue;
        }
        let want = Vector2::from_column_slice(&f64s(&case["pixel"]));
        let got = ours.unwrap_or_else(|r| panic!("{p:?} rejected ({r}), pycolmap projects it"));
        assert!(
            (got - want).norm() < 1e-9,
            "OPENCV projection of {p:?}: {got:?}, pycolmap {want:?}"
        );
    }
    assert!(cases.len() >= 10, "the goldens hold {} cases", cases.len());
    Ok(cases.len())
}

/// A bundled binary model (2 rigs × 2 OPENCV cameras, 8 images) read with the models-only
/// build, against pycolmap's reading (`golden.json`; the colmap crate's own bound, 1e-13).
fn read_model(fixtures: &Path) -> Result<usize> {
    let dir = fixtures.join("colmap/rig_opencv/bin");
    let model = Reconstruction::read(&dir)?;
    let golden = json(&dir.join("golden.json"))?;
    let images = golden["images"].as_array().expect("images");
    assert_eq!(model.images().len(), images.len(), "number of images");
    for g in images {
        let id = g["id"].as_u64().expect("an id") as u32;
        let pose = model
            .image_cam_from_world(id)
            .unwrap_or_else(|| panic!("image {id} has no pose"));
        let c = f64s(&g["center"]);
        let got = projection_center(&pose);
        assert!(
            (got - Vec3::new(c[0], c[1], c[2])).norm() < 1e-13,
            "image {id}: centre {got:?}, pycolmap {c:?}"
        );
    }
    Ok(images.len())
}

/// Within 4 standard errors of a σ estimated from `n` normal draws (SE = σ/√(2(n−1))).
fn assert_sigma(what: &str, got: f64, want: f64, n: usize) {
    let se = want / (2.0 * (n as f64 - 1.0)).sqrt();
    assert!(
        (got - want).abs() < 4.0 * se,
        "{what}: σ {got} mm, closed form {want} mm (4 SE = {} mm)",
        4.0 * se
    );
}

/// The engine alone. A chain: cam1 with 1 mm position noise, cam2 linked to it with 0.5 mm,
/// no rotation noise, so cam2's world position σ is √(1² + 0.5²) per axis. A grid: one point
/// at the origin seen along +x from (−1000, 0, 0) and along +y from (0, −1000, 0) by observers
/// with 1 mm position noise; their rays cross at the closest point (x, y, z) = (δ₂ₓ, δ₁ᵧ,
/// (δ₁z + δ₂z)/2), so σ = (1, 1, 1/√2) mm.
fn engine() -> Result<(Vector3<f64>, Vector3<f64>)> {
    let position_only =
        |mm: f64, pose: Rigid3| UncertainPose::from_sigmas(pose, Vec3::repeat(mm), Vec3::zeros());
    let mut b = ChainBuilder::new();
    let cam1 = b.world("cam1", position_only(1.0, Rigid3::identity()))?;
    let cam2 = b.link(
        "cam2",
        cam1,
        position_only(0.5, Rigid3::translation(62.0, 0.0, 180.0)),
    )?;
    let chain = b.build();
    let n = 40_000;
    let mc = chain.monte_carlo(&ChainOptions::new(n, 11), None)?;
    let lin = chain.linear();
    let k = cam2.index();
    let want = (1.0f64 + 0.25).sqrt();
    for axis in 0..3 {
        let linear = lin[k].position_sigma_mm[axis];
        assert!(
            (linear - want).abs() < 1e-12,
            "cam2 first-order σ {linear}, want {want}"
        );
        assert_sigma("cam2 Monte Carlo", mc[k].position_sigma_mm[axis], want, n);
    }

    let at = |v: f64| Axis {
        start: v,
        stop: v,
        count: 1,
    };
    let mut covariance = Mat6::zeros();
    covariance.fixed_view_mut::<3, 3>(0, 0).fill_diagonal(1.0);
    let samples = 40_000;
    let study = GridBuilder::new(at(0.0), at(0.0), at(0.0))
        .observer("along x", Vector3::new(-1000.0, 0.0, 0.0), covariance)
        .observer("along y", Vector3::new(0.0, -1000.0, 0.0), covariance)
        .build(samples, 5)?;
    let result = study.run(&RunOptions::samples(samples, 5), None)?;
    let p = &result.points[0];
    let want = Vector3::new(1.0, 1.0, 0.5f64.sqrt());
    for axis in 0..3 {
        let linear = p.linear_covariance[(axis, axis)].sqrt();
        assert!(
            (linear - want[axis]).abs() < 1e-9,
            "grid first-order σ {linear}, want {}",
            want[axis]
        );
        assert_sigma("grid Monte Carlo", p.sigma_mm[axis], want[axis], samples);
    }
    Ok((mc[k].position_sigma_mm, p.sigma_mm))
}
