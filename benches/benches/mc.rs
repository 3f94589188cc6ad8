//! Criterion benchmarks of the Monte Carlo engine: the random-number source, the
//! two-observer forward-intersection kernel, each kernel path (tangent, euler, full covariance,
//! pixel noise, three observers, chain-drawn observers), the grid, and the chain propagation.
//!
//! Throughput is reported per draw (`Throughput::Elements`), so criterion prints draws/s.
//! Single-threaded numbers come from a 1-thread rayon pool; the 2-thread grid uses a 2-thread
//! pool. See docs/performance.md for the numbers and the roofline note.
use crashrig_benches::{
    CHAIN, TWO_OBSERVERS, engine_name, engines, kernel_paths, one_point_kernel,
};
use crashrig_mc::{Chain, Engine, GridStudy, Isa, Scenario};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::hint::black_box;
use std::path::Path;

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

fn normals(c: &mut Criterion) {
    let mut g = c.benchmark_group("rng");
    let n = 12_288u64;
    g.throughput(Throughput::Elements(n));
    g.bench_function("chacha8_standard_normal", |b| {
        let mut rng = crashrig_stats::stream(1, 0);
        b.iter(|| {
            let mut s = 0.0f64;
            for _ in 0..n {
                s += rng.sample::<f64, _>(StandardNormal);
            }
            black_box(s)
        })
    });
    g.bench_function("chacha8_fast_normal", |b| {
        let mut rng = crashrig_stats::stream(1, 0);
        let nd = crashrig_mc::FastNormal::new();
        let mut buf = [0.0f64; 12];
        b.iter(|| {
            let mut s = 0.0f64;
            for _ in 0..n / 12 {
                nd.fill(&mut rng, &mut buf);
                s += buf.iter().sum::<f64>();
            }
            black_box(s)
        })
    });
    for isa in crashrig_mc::Isa::LEVELS {
        if !isa.is_available() {
            continue;
        }
        g.bench_function(format!("philox_box_muller_{}", isa.name()), |b| {
            let mut rows = vec![[0.0f64; crashrig_mc::bench::BLOCK]; 12];
            let blocks = n / (12 * crashrig_mc::bench::BLOCK as u64);
            let mut draw0 = 0u64;
            b.iter(|| {
                let mut s = 0.0f64;
                for _ in 0..blocks {
                    crashrig_mc::bench::philox_normals(isa, 1, 0, draw0, &mut rows);
                    draw0 += crashrig_mc::bench::BLOCK as u64;
                    s += rows[0][0] + rows[11][63];
                }
                black_box(s)
            })
        });
    }
    g.bench_function("chacha8_u64", |b| {
        let mut rng = crashrig_stats::stream(1, 0);
        b.iter(|| {
            let mut s = 0u64;
            for _ in 0..n {
                s = s.wrapping_add(rng.random::<u64>());
            }
            black_box(s)
        })
    });
    g.finish();
}

fn kernel(c: &mut Criterion) {
    // One grid point, many draws: the per-draw cost of the two-observer kernel.
    let sc =
        Scenario::from_toml_str(&one_point_kernel(), Path::new("bench.toml")).expect("scenario");
    let study = GridStudy::new(&sc, 0, 0).expect("study");
    let n = 64 * 4096;
    let one = pool(1);
    let mut g = c.benchmark_group("kernel");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    for engine in engines() {
        g.bench_function(
            format!("two_observers_1thread/{}", engine_name(engine)),
            |b| b.iter(|| one.install(|| black_box(study.run_with(n, 7, engine).expect("run")))),
        );
    }
    g.finish();
}

fn paths(c: &mut Criterion) {
    // One grid point per kernel path (`crashrig_benches::kernel_paths`), one thread, every
    // engine: the per-draw cost of each path.
    let n = 16 * 4096;
    let one = pool(1);
    let mut g = c.benchmark_group("paths_1thread");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    for (name, toml) in kernel_paths() {
        let sc = Scenario::from_toml_str(&toml, Path::new("bench.toml")).expect("scenario");
        let study = GridStudy::new(&sc, 0, 0).expect("study");
        for engine in engines() {
            g.bench_function(format!("{name}/{}", engine_name(engine)), |b| {
                b.iter(|| one.install(|| black_box(study.run_with(n, 7, engine).expect("run"))))
            });
        }
    }
    g.finish();
}

fn grid(c: &mut Criterion) {
    let sc = Scenario::from_toml_str(TWO_OBSERVERS, Path::new("bench.toml")).expect("scenario");
    let study = GridStudy::new(&sc, 0, 0).expect("study");
    let samples = 4096;
    let points = 17 * 13;
    let mut g = c.benchmark_group("grid_221_points");
    g.throughput(Throughput::Elements((samples * points) as u64));
    g.sample_size(10);
    for threads in [1usize, 2] {
        let p = pool(threads);
        for engine in [Engine::Legacy, Engine::Simd(Isa::Auto)] {
            let id = format!("{}/threads", engine_name(engine));
            g.bench_with_input(BenchmarkId::new(id, threads), &threads, |b, _| {
                b.iter(|| p.install(|| black_box(study.run_with(samples, 3, engine).expect("run"))))
            });
        }
    }
    g.finish();
}

fn chain(c: &mut Criterion) {
    let sc = Scenario::from_toml_str(CHAIN, Path::new("bench.toml")).expect("scenario");
    let ch = Chain::new(&sc);
    let n = 100_000;
    let mut g = c.benchmark_group("chain_3_cameras");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    for threads in [1usize, 2] {
        let p = pool(threads);
        for engine in [Engine::Legacy, Engine::Simd(Isa::Auto)] {
            let id = format!("{}/threads", engine_name(engine));
            g.bench_with_input(BenchmarkId::new(id, threads), &threads, |b, _| {
                b.iter(|| p.install(|| black_box(ch.monte_carlo_with(n, 3, engine))))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, normals, kernel, paths, grid, chain);
criterion_main!(benches);
