//! criterion benchmarks of the geometry kernels used per Monte Carlo draw.

use crashrig_geometry::triangulate::{View, dlt, dlt_covariance, dlt_homogeneous};
use crashrig_geometry::{Rigid3, Vec3, look_at, opk, quat, so3};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Vector2};
use rand::{RngExt, SeedableRng, rngs::ChaCha8Rng};
use std::hint::black_box;

fn views(n: usize, seed: u64) -> Vec<View> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let p = Vec3::new(100.0, -50.0, 20.0);
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-2500.0..2500.0),
                rng.random_range(-2500.0..2500.0),
                rng.random_range(100.0..800.0),
            );
            let world_from_cam = look_at::world_from_cam_look_at(&c, &Vec3::zeros()).unwrap();
            let r = world_from_cam.inverse();
            let cam_from_world: Rigid3 = quat::rigid_from_rotation(&r, &(-(r * c)));
            let pc = cam_from_world * Point3::from(p);
            View {
                cam_from_world,
                normalized: Vector2::new(pc.x / pc.z, pc.y / pc.z),
            }
        })
        .collect()
}

fn bench_triangulate(c: &mut Criterion) {
    let mut g = c.benchmark_group("triangulate");
    for n in [2usize, 5, 20] {
        let v = views(n, 7);
        g.bench_with_input(BenchmarkId::new("dlt", n), &v, |b, v| {
            b.iter(|| dlt(black_box(v)))
        });
        g.bench_with_input(BenchmarkId::new("dlt_homogeneous", n), &v, |b, v| {
            b.iter(|| dlt_homogeneous(black_box(v)))
        });
        let p = dlt(&v).unwrap();
        g.bench_with_input(BenchmarkId::new("dlt_covariance", n), &v, |b, v| {
            b.iter(|| dlt_covariance(black_box(v), black_box(&p), 1e-4))
        });
    }
    g.finish();
}

fn bench_rotations(c: &mut Criterion) {
    let w = Vec3::new(0.3, -1.2, 2.0);
    let r = so3::exp(&w);
    c.bench_function("so3_exp", |b| b.iter(|| so3::exp(black_box(&w))));
    c.bench_function("so3_log", |b| b.iter(|| so3::log(black_box(&r))));
    c.bench_function("opk_from_rotation", |b| {
        b.iter(|| opk::opk_from_rotation(black_box(&r)))
    });
    c.bench_function("rotation_from_opk", |b| {
        b.iter(|| opk::rotation_from_opk(black_box(0.3), black_box(-0.2), black_box(1.1)))
    });
    c.bench_function("look_at", |b| {
        let c0 = Vec3::new(2200.0, 0.0, 0.0);
        let t = Vec3::new(100.0, 50.0, 0.0);
        b.iter(|| look_at::world_from_cam_look_at(black_box(&c0), black_box(&t)))
    });
}

criterion_group!(benches, bench_triangulate, bench_rotations);
criterion_main!(benches);
