//! criterion benchmark of `crashrig covariance` on the benchmark scene of issue 24: 140 epochs
//! of A, ~2 000 lab points, ~100 000 observations (generated here by
//! `crashrig_covariance::synthetic::lab_scene`, as the `lab_timing` example does), σ̂₀, all
//! intrinsics marginalised: information, Schur complement over the points, Cholesky, the
//! 840 × 840 joint covariance. The scene is built once, outside the timed loop.
//!
//! `cargo bench -p crashrig-covariance --bench main -- --sample-size 10 --measurement-time 20`

use crashrig_colmap::CameraSelector;
use crashrig_covariance::synthetic::{LabSettings, lab_scene};
use crashrig_covariance::{ControlPoints, Intrinsics, Options, covariance};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let scene = lab_scene(&LabSettings {
        epochs: 140,
        points: 2000,
        path_length: 10.0,
        noise_px: 0.3,
        seed: 24,
    });
    let control = ControlPoints::from_ids("bench", &scene.control_ids, 0.0);
    let options = Options {
        camera_a: CameraSelector::parse("cam_out/"),
        mm_per_unit: 1000.0,
        pixel_sigma_px: None,
        intrinsics: Intrinsics::All,
    };
    let mut g = c.benchmark_group("covariance");
    g.sample_size(10);
    g.bench_function("lab_140_epochs_100k_observations", |b| {
        b.iter(|| covariance(black_box(&scene.model), &control, &options).expect("covariance"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
