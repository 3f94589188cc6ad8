//! Rough per-call timings of projection, Jacobians and undistortion.
//! Run: `cargo run --release -p crashrig-camera --example timing`.

use std::hint::black_box;
use std::time::Instant;

use crashrig_camera::{Camera, ModelId};
use nalgebra::Vector3;

fn time(label: &str, n: usize, mut f: impl FnMut(usize)) {
    let t = Instant::now();
    for i in 0..n {
        f(i);
    }
    let ns = t.elapsed().as_secs_f64() * 1e9 / n as f64;
    println!("{label:<48} {ns:8.1} ns/call");
}

fn main() -> Result<(), crashrig_camera::Error> {
    let n = 200_000;
    let cams = [
        Camera::new(
            ModelId::OpenCv,
            1024,
            768,
            vec![1000.0, 1000.0, 512.0, 384.0, -0.1, 0.01, 1e-3, -5e-4],
        )?,
        Camera::new(
            ModelId::FullOpenCv,
            1024,
            768,
            vec![
                1000.0, 1000.0, 512.0, 384.0, -0.1, 0.01, 1e-3, -5e-4, 0.005, 0.03, -0.01, 0.002,
            ],
        )?,
        Camera::new(
            ModelId::RadTanThinPrismFisheye,
            1024,
            768,
            vec![
                350.0, 350.0, 512.0, 384.0, 0.06, -0.015, 4e-3, -8e-4, 1.5e-4, -4e-5, 1e-3, -8e-4,
                1.5e-3, -4e-4, -1e-3, 3e-4,
            ],
        )?,
    ];
    let pts: Vec<Vector3<f64>> = (0..64)
        .map(|i| {
            let a = (i % 8) as f64 / 7.0 - 0.5;
            let b = (i / 8) as f64 / 7.0 - 0.5;
            Vector3::new(0.8 * a, 0.6 * b, 1.0) * 3.0
        })
        .collect();
    for cam in &cams {
        let m = cam.model.name();
        let pxs: Vec<_> = pts
            .iter()
            .map(|p| cam.img_from_cam(p).expect("in front"))
            .collect();
        time(&format!("{m} img_from_cam"), n, |i| {
            black_box(cam.img_from_cam(black_box(&pts[i % 64])).ok());
        });
        time(&format!("{m} dx_img_from_cam_point"), n, |i| {
            black_box(cam.dx_img_from_cam_point(black_box(&pts[i % 64])).ok());
        });
        time(&format!("{m} dx_img_from_params"), n, |i| {
            black_box(cam.dx_img_from_params(black_box(&pts[i % 64])).ok());
        });
        time(&format!("{m} cam_from_img"), n, |i| {
            black_box(cam.cam_from_img(black_box(&pxs[i % 64])).ok());
        });
    }
    Ok(())
}
