//! Criterion benchmarks of the pose estimators on a seeded synthetic scene (300 points, 0.5 px).

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Rigid3, Vec3, opk};
use crashrig_pose::{
    Pinhole, Projector, RansacOptions, essential_5point, estimate_absolute_pose,
    estimate_relative_pose, normalize_pixels, p3p, refine_absolute_pose, refine_relative_pose,
};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Translation3, UnitQuaternion, Vector2};
use rand::{RngExt, SeedableRng, rngs::ChaCha8Rng};
use rand_distr::StandardNormal;
use std::hint::black_box;

fn b_from_world() -> Rigid3 {
    let r = opk::rotation_from_opk(0.03, -0.12, 0.05);
    let c = Vec3::new(600.0, 20.0, 100.0);
    Rigid3::from_parts(
        Translation3::from(-(r * c)),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// 300 points at 2–5 m seen by A (identity) and B, pixels with 0.5 px noise.
fn scene<C: Projector>(cam: &C) -> (Vec<Vec3>, Vec<Vector2<f64>>, Vec<Vector2<f64>>) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let b = b_from_world();
    let (mut pts, mut pa, mut pb) = (vec![], vec![], vec![]);
    let noise = |rng: &mut ChaCha8Rng| {
        let x: f64 = rng.sample(StandardNormal);
        let y: f64 = rng.sample(StandardNormal);
        Vector2::new(x, y) * 0.5
    };
    while pts.len() < 300 {
        let z = rng.random_range(2000.0..5000.0);
        let p = Vec3::new(
            rng.random_range(-0.6..0.6) * z,
            rng.random_range(-0.4..0.4) * z,
            z,
        );
        let q = b.transform_point(&p.into()).coords;
        if let (Some(xa), Some(xb)) = (cam.project(&p), cam.project(&q)) {
            pts.push(p);
            pa.push(xa + noise(&mut rng));
            pb.push(xb + noise(&mut rng));
        }
    }
    (pts, pa, pb)
}

fn benches(c: &mut Criterion) {
    let pinhole = Pinhole {
        fx: 1000.0,
        fy: 1000.0,
        cx: 800.0,
        cy: 600.0,
    };
    let opencv = Camera::new(
        ModelId::from_name("OPENCV").unwrap(),
        1600,
        1200,
        vec![1000.0, 1000.0, 800.0, 600.0, -0.08, 0.02, 0.0005, -0.0003],
    )
    .unwrap();
    let (pts, pa, pb) = scene(&pinhole);
    let all: Vec<usize> = (0..pts.len()).collect();
    let truth = b_from_world();

    let bearings: Vec<Vec3> = pb[..3]
        .iter()
        .map(|x| {
            let u = pinhole.normalized(x).unwrap();
            Vec3::new(u.x, u.y, 1.0).normalize()
        })
        .collect();
    c.bench_function("p3p", |b| {
        b.iter(|| {
            p3p(
                black_box(&[bearings[0], bearings[1], bearings[2]]),
                black_box(&[pts[0], pts[1], pts[2]]),
            )
        })
    });
    let xa = normalize_pixels(&pinhole, &pa).unwrap();
    let xb = normalize_pixels(&pinhole, &pb).unwrap();
    let a5: [Vector2<f64>; 5] = std::array::from_fn(|i| xa[i]);
    let b5: [Vector2<f64>; 5] = std::array::from_fn(|i| xb[i]);
    c.bench_function("essential_5point", |b| {
        b.iter(|| essential_5point(black_box(&a5), black_box(&b5)))
    });
    c.bench_function("refine_absolute_pose/pinhole/300", |b| {
        b.iter(|| refine_absolute_pose(&pinhole, black_box(&pb), &pts, &all, &truth).unwrap())
    });
    let (pts_o, _, pb_o) = scene(&opencv);
    c.bench_function("refine_absolute_pose/opencv/300", |b| {
        b.iter(|| refine_absolute_pose(&opencv, black_box(&pb_o), &pts_o, &all, &truth).unwrap())
    });
    c.bench_function("estimate_absolute_pose/opencv/300", |b| {
        b.iter(|| {
            estimate_absolute_pose(&opencv, black_box(&pb_o), &pts_o, &RansacOptions::new(3))
                .unwrap()
        })
    });
    let unit = Rigid3::from_parts(
        Translation3::from(truth.translation.vector.normalize()),
        truth.rotation,
    );
    c.bench_function("refine_relative_pose/300", |b| {
        b.iter(|| refine_relative_pose(black_box(&xa), &xb, &all, &unit).unwrap())
    });
    c.bench_function("estimate_relative_pose/300", |b| {
        b.iter(|| {
            estimate_relative_pose(black_box(&xa), &xb, 1000.0, &RansacOptions::new(3)).unwrap()
        })
    });
}

criterion_group!(pose, benches);
criterion_main!(pose);
