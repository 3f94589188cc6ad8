//! Criterion benchmarks of the Monte Carlo engine: the random-number source, the
//! two-observer forward-intersection kernel, each kernel path (tangent, euler, full covariance,
//! pixel noise, three observers, chain-drawn observers) and the real-study map (per
//! point-draw), the grid, and the chain propagation.
//!
//! Throughput is reported per draw (`Throughput::Elements`), so criterion prints draws/s.
//! Single-threaded numbers come from a 1-thread rayon pool; the 2-thread grid uses a 2-thread
//! pool. See docs/performance.md for the numbers and the roofline note.
use crashrig_benches::{CHAIN, TWO_OBSERVERS, kernel_paths, levels, one_point_kernel, real_map};
use crashrig_mc::{Chain, ChainOptions, GridStudy, Isa, RunOptions, Scenario};
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
    for isa in levels() {
        g.bench_function(format!("two_observers_1thread/{}", isa.name()), |b| {
            b.iter(|| {
                one.install(|| {
                    black_box(
                        study
                            .run(
                                &RunOptions {
                                    isa,
                                    ..RunOptions::samples(n, 7)
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

/// The real-study map (`crashrig_benches::real_map`): its correlated map and its independent
/// companion, as `crashrig grid` runs them, `samples` draws per point; the throughput unit
/// is the point-draw (one draw of one point in both maps).
struct RealMap {
    study: GridStudy,
    independent: GridStudy,
    samples: usize,
}

impl RealMap {
    fn new(samples: usize) -> Self {
        let sc =
            Scenario::from_toml_str(&real_map(), Path::new("real_map.toml")).expect("scenario");
        let study = GridStudy::new(&sc, 0, 0).expect("study");
        let independent = study.independent();
        RealMap {
            study,
            independent,
            samples,
        }
    }

    fn point_draws(&self) -> u64 {
        (self.study.grid().points().len() * self.samples) as u64
    }

    fn run(&self, isa: Isa) -> (crashrig_mc::GridResult, crashrig_mc::GridResult) {
        let o = RunOptions {
            isa,
            ..RunOptions::samples(self.samples, 7)
        };
        (
            self.study.run(&o, None).expect("run"),
            self.independent.run(&o, None).expect("run"),
        )
    }
}

fn paths(c: &mut Criterion) {
    // One grid point per kernel path (`crashrig_benches::kernel_paths`), one thread, every
    // level: the per-draw cost of each path; and the real-study map per point-draw.
    let n = 16 * 4096;
    let one = pool(1);
    let mut g = c.benchmark_group("paths_1thread");
    g.sample_size(10);
    let map = RealMap::new(1024);
    g.throughput(Throughput::Elements(map.point_draws()));
    for isa in levels() {
        g.bench_function(format!("real_map/{}", isa.name()), |b| {
            b.iter(|| one.install(|| black_box(map.run(isa))))
        });
    }
    g.throughput(Throughput::Elements(n as u64));
    for (name, toml) in kernel_paths() {
        let sc = Scenario::from_toml_str(&toml, Path::new("bench.toml")).expect("scenario");
        let study = GridStudy::new(&sc, 0, 0).expect("study");
        for isa in levels() {
            g.bench_function(format!("{name}/{}", isa.name()), |b| {
                b.iter(|| {
                    one.install(|| {
                        black_box(
                            study
                                .run(
                                    &RunOptions {
                                        isa,
                                        ..RunOptions::samples(n, 7)
                                    },
                                    None,
                                )
                                .expect("run"),
                        )
                    })
                })
            });
        }
    }
    g.finish();
}

fn paths_quick(c: &mut Criterion) {
    // `paths_1thread` in seconds instead of minutes: the best level only, 4 chunks of draws
    // per sample and 1 s of measurement per path (`cargo bench -p crashrig-benches --bench mc
    // -- paths_quick`); for a before/after check of a change, not for the published table.
    let n = 4 * 4096;
    let one = pool(1);
    let mut g = c.benchmark_group("paths_quick_1thread");
    g.sample_size(10);
    g.warm_up_time(std::time::Duration::from_millis(300));
    g.measurement_time(std::time::Duration::from_secs(1));
    let map = RealMap::new(512);
    g.throughput(Throughput::Elements(map.point_draws()));
    g.bench_function("real_map", |b| {
        b.iter(|| one.install(|| black_box(map.run(Isa::Auto))))
    });
    g.throughput(Throughput::Elements(n as u64));
    for (name, toml) in kernel_paths() {
        let sc = Scenario::from_toml_str(&toml, Path::new("bench.toml")).expect("scenario");
        let study = GridStudy::new(&sc, 0, 0).expect("study");
        g.bench_function(name, |b| {
            b.iter(|| {
                one.install(|| {
                    black_box(
                        study
                            .run(
                                &RunOptions {
                                    isa: Isa::Auto,
                                    ..RunOptions::samples(n, 7)
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
        g.bench_with_input(
            BenchmarkId::new("auto/threads", threads),
            &threads,
            |b, _| {
                b.iter(|| {
                    p.install(|| {
                        black_box(
                            study
                                .run(
                                    &RunOptions {
                                        isa: Isa::Auto,
                                        ..RunOptions::samples(samples, 3)
                                    },
                                    None,
                                )
                                .expect("run"),
                        )
                    })
                })
            },
        );
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
        g.bench_with_input(
            BenchmarkId::new("auto/threads", threads),
            &threads,
            |b, _| {
                b.iter(|| {
                    p.install(|| {
                        black_box(
                            ch.monte_carlo(
                                &ChainOptions {
                                    isa: Isa::Auto,
                                    ..ChainOptions::new(n, 3)
                                },
                                None,
                            )
                            .expect("run"),
                        )
                    })
                })
            },
        );
    }
    g.finish();
}

criterion_group!(benches, normals, kernel, paths, paths_quick, grid, chain);
criterion_main!(benches);
