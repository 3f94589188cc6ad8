//! Fixed cameras against aimed observers, per draw, side by side in one run (issue 15: the
//! fixed path must cost at most 2× the aimed path per draw).
//!
//! Same two observer positions, same pose σ, same 5 × 5 grid (every point seen by both fixed
//! cameras, so every point is drawn in every variant), 1 thread:
//! - `aimed`: the paper's re-aiming, no pixel noise (the two-observer block kernel);
//! - `aimed_pixel`: re-aiming with 0.5 px pixel noise (the general aimed kernel);
//! - `fixed_pinhole`: fixed OPENCV cameras without distortion, 0.5 px (no refinement needed);
//! - `fixed_distorted`: fixed OPENCV cameras with k1 k2 p1 p2, 0.5 px (chord-Newton
//!   undistortion per view and draw);
//!
//! The fair comparison for a fixed camera is `aimed_pixel` (the same inputs: pose noise and
//! pixel noise, 16 normals per draw); `aimed` draws 12 normals and no pixel noise.
//!
//! Run: `cargo bench -p crashrig-benches --bench fixed`.
use crashrig_mc::{GridStudy, Isa, RunOptions, Scenario};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;

const GRID: &str = r#"
seed = 1
samples = 20000
[grid]
x_mm = [900.0, 1500.0, 5]
y_mm = [-300.0, 300.0, 5]
z_mm = [0.0, 0.0, 1]
"#;

const POSES: [(&str, &str, &str, &str); 2] = [
    (
        "[200.0, 0.0, 0.0]",
        "[1200.0, 0.0, 0.0]",
        "[1.52, 1.54, 1.52]",
        "[0.011, 0.011, 0.013]",
    ),
    (
        "[1300.0, -700.0, 0.0]",
        "[1200.0, 0.0, 0.0]",
        "[2.53, 2.51, 2.55]",
        "[0.023, 0.023, 0.024]",
    ),
];

fn scenario(kind: &str) -> String {
    let mut s = GRID.to_string();
    if kind == "aimed_pixel" {
        s += "pixel_sigma_px = 0.5\nfocal_px = 1600.0\n";
    }
    for (pos, target, sp, sa) in POSES {
        s += &format!(
            "[[grid.observer]]\nposition_mm = {pos}\nsigma_position_mm = {sp}\nsigma_angles_deg = {sa}\n"
        );
        let dist = match kind {
            "fixed_pinhole" => "0.0, 0.0, 0.0, 0.0",
            "fixed_distorted" => "-0.08, 0.02, 0.0005, -0.0003",
            _ => continue,
        };
        s += &format!(
            "aim = \"fixed\"\nlook_at_mm = {target}\npixel_sigma_px = 0.5\n\
             camera = {{ model = \"OPENCV\", width = 2560, height = 1440, params = [1000.0, 1000.0, 1280.0, 720.0, {dist}] }}\n"
        );
    }
    s
}

fn fixed_vs_aimed(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let mut g = c.benchmark_group("grid_fixed_vs_aimed_1thread");
    g.sample_size(10);
    for kind in ["aimed", "aimed_pixel", "fixed_pinhole", "fixed_distorted"] {
        let s =
            Scenario::from_toml_str(&scenario(kind), Path::new("bench.toml")).expect("scenario");
        let study = GridStudy::new(&s, s.samples, s.seed).expect("study");
        let r = study
            .run(
                &RunOptions {
                    isa: Isa::Auto,
                    ..RunOptions::samples(s.samples, s.seed)
                },
                None,
            )
            .expect("run");
        assert!(
            r.points.iter().all(|p| p.observers_seen == 2),
            "{kind}: not all seen"
        );
        let draws: u64 = r.points.iter().map(|p| p.count).sum();
        g.throughput(Throughput::Elements(draws));
        g.bench_function(kind, |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        study
                            .run(
                                &RunOptions {
                                    isa: Isa::Auto,
                                    ..RunOptions::samples(s.samples, s.seed)
                                },
                                None,
                            )
                            .expect("run"),
                    )
                })
            })
        });
    }
    g.finish();
}

criterion_group!(benches, fixed_vs_aimed);
criterion_main!(benches);
