//! Speed of the kinematics inside the replicates (docs/performance.md): a synthetic
//! 1000-epoch × 20-marker sequence measured without and with `--cfc 180` (both standards),
//! interleaved, in one process.
//!
//! `cargo run --release -p crashrig-measure --example kinematics_bench -- [SAMPLES] [REPEATS]`

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
use crashrig_measure::engine::{Epoch, Rig, Settings, measure};
use crashrig_measure::filter::{CfcSpec, Standard};
use crashrig_measure::input::{Inward, Observation};
use nalgebra::Vector2;
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let samples: usize = args.next().map_or(500, |s| s.parse().expect("SAMPLES"));
    let repeats: usize = args.next().map_or(3, |s| s.parse().expect("REPEATS"));
    let (n_epochs, n_markers, hz) = (1000, 20, 1000.0);
    let pinhole = Camera::new(
        ModelId::Pinhole,
        1000,
        1000,
        vec![1000.0, 1000.0, 500.0, 500.0],
    )
    .expect("camera");
    let rig = Rig {
        a_from_b: UncertainPose::from_sigmas(
            Rigid3::identity(),
            Vec3::repeat(0.1),
            Vec3::repeat(1e-5),
        ),
        camera_b: pinhole.clone(),
        c: Some((
            UncertainPose::from_sigmas(
                Rigid3::translation(500.0, 0.0, 0.0),
                Vec3::repeat(0.3),
                Vec3::repeat(1e-5),
            ),
            pinhole,
        )),
    };
    let mut epochs = Vec::new();
    let mut obs = Vec::new();
    for i in 0..n_epochs {
        let t = i as f64 / hz;
        let name = format!("{:06}", i + 1);
        let car = Vec3::new(10_000.0 * t - 75_000.0 * t * t, 0.0, 0.0);
        epochs.push(Epoch {
            key: name.clone(),
            name: name.clone(),
            world_from_a: UncertainPose::from_sigmas(
                Rigid3::translation(car.x, car.y, car.z),
                Vec3::repeat(0.3),
                Vec3::repeat(1e-4),
            ),
        });
        for k in 0..n_markers {
            let rel = Vec3::new(
                -200.0 + 25.0 * k as f64 + 50.0 * (1.0 - (t * 20.0).cos()),
                -100.0 + 10.0 * k as f64,
                1800.0 + 20.0 * k as f64,
            );
            for (camera, dx) in [(Inward::B, 0.0), (Inward::C, 500.0)] {
                let p = rel - Vec3::new(dx, 0.0, 0.0);
                obs.push(Observation {
                    epoch: name.clone(),
                    camera,
                    marker: format!("m{k:02}"),
                    pixel: Vector2::new(1000.0 * p.x / p.z + 500.0, 1000.0 * p.y / p.z + 500.0),
                    sigma: None,
                    line: obs.len() as u64 + 2,
                });
            }
        }
    }
    let settings = |cfc: Option<Standard>| Settings {
        samples,
        seed: 1,
        pixel_sigma_px: 0.2,
        reference_epoch: None,
        frame_rate_hz: Some(hz),
        frame_times: None,
        threshold_mm: 5.0,
        max_reprojection_px: None,
        cfc: cfc.map(|standard| CfcSpec {
            class: 180,
            standard,
        }),
        sync_sigma_ms: 0.0,
    };
    let variants = [
        ("without --cfc", None),
        ("--cfc 180 (j211)", Some(Standard::J211)),
        ("--cfc 180 (iso6487)", Some(Standard::Iso6487)),
    ];
    let mut best = [f64::INFINITY; 3];
    for _ in 0..repeats {
        for (k, (_, cfc)) in variants.iter().enumerate() {
            let start = Instant::now();
            let m = measure(&epochs, None, &rig, &obs, None, &settings(*cfc)).expect("measure");
            best[k] = best[k].min(start.elapsed().as_secs_f64());
            assert_eq!(m.rows.len(), n_epochs * n_markers);
        }
    }
    println!(
        "{n_epochs} epochs × {n_markers} markers, {samples} samples, best of {repeats}, {} threads",
        rayon::current_num_threads()
    );
    for (k, (name, _)) in variants.iter().enumerate() {
        println!(
            "{name:>22}: {:.3} s  ratio {:.3}",
            best[k],
            best[k] / best[0]
        );
    }
    filter_stage(n_epochs, n_markers * samples.min(500), repeats);
}

/// The filter stage alone, side by side: `records` 3-axis records of `n` samples filtered as
/// three scalar records each (split, filter, reassemble: the kinematics before the change) and
/// as one 3-vector record (`Cfc::filter_into::<Vec3>`, bit-identical), one thread, best of
/// `repeats`.
fn filter_stage(n: usize, records: usize, repeats: usize) {
    use crashrig_measure::filter::Cfc;
    let x: Vec<Vec3> = (0..n)
        .map(|i| {
            let t = i as f64 / 1000.0;
            Vec3::new(50.0 * (t * 20.0).sin(), t, -3.0 * t * t)
        })
        .collect();
    for standard in [Standard::J211, Standard::Iso6487] {
        let f = Cfc::new(180, standard, 1000.0).expect("filter");
        let (mut per_axis, mut vec3) = (f64::INFINITY, f64::INFINITY);
        let mut check = (0.0, 0.0);
        for _ in 0..repeats {
            let start = Instant::now();
            let mut axes = [Vec::new(), Vec::new(), Vec::new()];
            let mut filtered = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            let (mut work, mut out) = (Vec::new(), vec![Vec3::zeros(); n]);
            for _ in 0..records {
                for (c, axis) in axes.iter_mut().enumerate() {
                    axis.clear();
                    axis.extend(x.iter().map(|v| v[c]));
                }
                for c in 0..3 {
                    f.filter_into(&axes[c], &mut filtered[c], &mut work);
                }
                for (i, o) in out.iter_mut().enumerate() {
                    *o = Vec3::new(filtered[0][i], filtered[1][i], filtered[2][i]);
                }
                check.0 += out[n / 2].x;
            }
            per_axis = per_axis.min(start.elapsed().as_secs_f64());
            let start = Instant::now();
            let mut work = Vec::new();
            for _ in 0..records {
                f.filter_into(&x, &mut out, &mut work);
                check.1 += out[n / 2].x;
            }
            vec3 = vec3.min(start.elapsed().as_secs_f64());
        }
        assert_eq!(check.0, check.1, "the two paths agree");
        println!(
            "filter stage {:>8}, {records} records × {n} samples: per axis {per_axis:.3} s, 3-vector {vec3:.3} s (ratio {:.2})",
            standard.name(),
            per_axis / vec3
        );
    }
}
