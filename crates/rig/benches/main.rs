//! criterion benchmarks of the rig calibration: epoch statistics and the rig-constrained
//! refinement (dense normal equations of 6 + 6n unknowns, faer Cholesky) for n epochs.

use crashrig_geometry::{Rigid3, Rot3, Vec3, opk::rotation_from_opk, so3};
use crashrig_rig::{Epoch, RefineOptions, link_statistics, links_of, refine};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Translation3, UnitQuaternion};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::hint::black_box;

fn pose(r: Rot3, t: Vec3) -> Rigid3 {
    Rigid3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// `n` epochs of the paper's rig, both poses with 0.5 mrad / 1.5 mm noise (seeded).
fn epochs(n: usize, seed: u64) -> Vec<Epoch> {
    let mut rng = crashrig_stats::stream(seed, 0);
    let link = pose(
        rotation_from_opk(
            179.92f64.to_radians(),
            -0.09f64.to_radians(),
            179.76f64.to_radians(),
        ),
        Vec3::new(61.98, -1.71, 179.76),
    );
    (0..n)
        .map(|i| {
            let s = i as f64 / n as f64;
            let world_from_a = pose(
                rotation_from_opk(-1.5 + 0.1 * s, 0.3 * s, 1.0 - s),
                Vec3::new(4000.0 * s - 2000.0, 500.0 * s, 1200.0),
            );
            let mut noisy = |w: Rigid3| {
                let mut g = || -> f64 { rng.sample(StandardNormal) };
                let d = Vec3::new(g(), g(), g()) * 5e-4;
                let c = Vec3::new(g(), g(), g()) * 1.5;
                pose(
                    w.rotation.to_rotation_matrix() * so3::exp(&d),
                    w.translation.vector + c,
                )
                .inverse()
            };
            Epoch {
                name: format!("{i:06}"),
                a_from_world: noisy(world_from_a),
                b_from_world: noisy(world_from_a * link),
            }
        })
        .collect()
}

fn bench_statistics(c: &mut Criterion) {
    let e = epochs(140, 1);
    c.bench_function("link_statistics/140", |b| {
        b.iter(|| link_statistics(&links_of(black_box(&e), 1.0).unwrap()).unwrap())
    });
}

fn bench_refine(c: &mut Criterion) {
    let mut g = c.benchmark_group("refine");
    g.sample_size(10);
    for n in [20usize, 140] {
        let e = epochs(n, 2);
        g.bench_with_input(BenchmarkId::from_parameter(n), &e, |b, e| {
            b.iter(|| refine(black_box(e), 1.0, &RefineOptions::default(), None).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench_statistics, bench_refine);
criterion_main!(benches);
