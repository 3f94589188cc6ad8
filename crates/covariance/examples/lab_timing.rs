//! Whole-computation timing on the benchmark scene of issue 24: 140 epochs of A, ~2 000 lab
//! points, ~100 000 observations (the synthetic lab of `crashrig_covariance::synthetic`).
//!
//! `cargo run --release -p crashrig-covariance --example lab_timing -- [OUT_DIR [EPOCHS POINTS]]`
//! prints the scene's size and the time of `covariance` (σ̂₀, all intrinsics marginalised);
//! with OUT_DIR it also writes the model (binary) and `control_points.csv` there, for the
//! pycolmap bundle adjustment it is compared with (`fixtures/gen/covariance_bench.py`).
//! EPOCHS and POINTS (default 140 and 2000) size the scene, e.g. for the memory-against-size
//! check of docs/performance.md.

use crashrig_colmap::{CameraSelector, ModelFormat};
use crashrig_covariance::synthetic::{LabSettings, lab_scene};
use crashrig_covariance::{ControlPoints, Intrinsics, Options, covariance};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size = |k: usize, default: usize| -> Result<usize, Box<dyn std::error::Error>> {
        Ok(args
            .get(k)
            .map(|s| s.parse())
            .transpose()?
            .unwrap_or(default))
    };
    let scene = lab_scene(&LabSettings {
        epochs: size(1, 140)?,
        points: size(2, 2000)?,
        path_length: 10.0,
        noise_px: 0.3,
        seed: 24,
    });
    let m = &scene.model;
    println!(
        "scene: {} images, {} points, {} observations, {} control points",
        m.images().len(),
        m.points3d().len(),
        m.num_observations(),
        scene.control_ids.len()
    );
    if let Some(dir) = args.first() {
        let dir = std::path::PathBuf::from(dir);
        std::fs::create_dir_all(dir.join("model"))?;
        m.write(&dir.join("model"), ModelFormat::Binary)?;
        let mut csv = String::from("point3D_id,sigma_mm\n");
        for id in &scene.control_ids {
            csv.push_str(&format!("{id},0\n"));
        }
        std::fs::write(dir.join("control_points.csv"), csv)?;
    }
    let control = ControlPoints::from_ids("bench", &scene.control_ids, 0.0);
    let options = Options {
        camera_a: CameraSelector::parse("cam_out/"),
        mm_per_unit: 1000.0,
        pixel_sigma_px: None,
        intrinsics: Intrinsics::All,
    };
    for _ in 0..3 {
        let t = Instant::now();
        let r = covariance(m, &control, &options)?;
        println!(
            "covariance: {:.3} s ({} observations, {} parameters, σ̂₀ {:.3} px, σ of epoch 0: {:.3?} mm)",
            t.elapsed().as_secs_f64(),
            r.observations,
            r.parameters,
            r.sigma0_px,
            r.epochs[0].world_from_a.sigma_position().as_slice()
        );
    }
    Ok(())
}
