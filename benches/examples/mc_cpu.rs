//! Fixed amounts of Monte Carlo work (the scenarios of `benches/mc.rs`, from this crate's
//! library), one instruction-set level at a time, for timing with CPU-time tools
//! (`/usr/bin/time -f %U`, `perf stat -e task-clock`) on a shared machine, where criterion's
//! wall-clock numbers absorb other jobs' load.
//!
//! `cargo run --release -p crashrig-benches --example mc_cpu -- WHAT ENGINE MILLIONS`
//! with WHAT = `normals` | `ziggurat` (a vectorised ziggurat's fast path, timing only) | `kernel` | `chain` | a kernel path of
//! [`crashrig_benches::kernel_paths`] (`study`, `full_covariance`, `correlated`, …) |
//! `real_map` (the whole map of [`crashrig_benches::real_map`], correlated) |
//! `real_map_independent` (its independent companion) | `real_map_both` (both, as
//! `crashrig grid` runs them), ENGINE = `baseline` | `v3` | `v4` | `auto`, MILLIONS = draws
//! (normals for `normals`; point-draws for the maps, spread over their 221 points) in
//! millions. Runs on one thread and prints the rate per second of wall time and per second of
//! the process's CPU time (Linux). Grid paths time `GridStudy::run` only (the study is set up
//! before the clock starts).
use crashrig_benches::{CHAIN, kernel_paths, level_of_name, one_point_kernel, real_map};
use crashrig_mc::{Chain, ChainOptions, GridStudy, Isa, RunOptions, Scenario};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("kernel");
    let isa = args
        .get(1)
        .and_then(|n| level_of_name(n))
        .unwrap_or(Isa::Auto);
    let millions: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let n = (millions * 1e6) as usize;
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("pool");
    // Grid paths: the study (and, in correlated mode, its chain propagation) is set up before
    // the clock starts, as in the criterion benches.
    let study = (!matches!(what, "normals" | "ziggurat" | "chain")).then(|| {
        let toml = if what.starts_with("real_map") {
            real_map()
        } else {
            kernel_paths()
                .into_iter()
                .find(|(name, _)| *name == what)
                .map_or_else(one_point_kernel, |(_, t)| t)
        };
        let sc = Scenario::from_toml_str(&toml, Path::new("kernel.toml")).expect("scenario");
        GridStudy::new(&sc, 0, 0).expect("study")
    });
    let mut exact = String::new();
    let (t, cpu0) = (Instant::now(), process_cpu_ns());
    match (what, study) {
        ("normals" | "ziggurat", _) => {
            // 28 rows: the independent real map's normals per point-draw.
            let mut s = 0.0;
            let b = crashrig_mc::bench::BLOCK;
            let mut rows = vec![[0.0; crashrig_mc::bench::BLOCK]; 28];
            for k in 0..n / (28 * b) {
                if what == "normals" {
                    crashrig_mc::bench::philox_normals(isa, 1, 0, (k * b) as u64, &mut rows);
                } else {
                    crashrig_mc::bench::philox_ziggurat_normals(
                        isa,
                        1,
                        0,
                        (k * b) as u64,
                        &mut rows,
                    );
                }
                s += rows[0][0] + rows[27][b - 1];
            }
            black_box(s);
        }
        (_, Some(study)) => {
            let points = study.grid().points().len();
            let options = RunOptions {
                isa,
                ..RunOptions::samples(n / points, 7)
            };
            let mut runs = vec![];
            if what != "real_map_independent" {
                runs.push(study.run(&options, None).expect("run"));
            }
            if matches!(what, "real_map_independent" | "real_map_both") {
                runs.push(study.independent().run(&options, None).expect("run"));
            }
            // The exact result (shortest round-trip digits): before/after bit-identity.
            for r in runs {
                let p = &r.points[0];
                exact += &format!("\n  mean {:?}\n  covariance {:?}", p.mean_mm, p.covariance);
            }
        }
        _ => {
            let sc = Scenario::from_toml_str(CHAIN, Path::new("chain.toml")).expect("scenario");
            black_box(
                Chain::new(&sc)
                    .monte_carlo(
                        &ChainOptions {
                            isa,
                            ..ChainOptions::new(n, 3)
                        },
                        None,
                    )
                    .expect("run"),
            );
        }
    }
    let s = t.elapsed().as_secs_f64();
    let cpu = match (cpu0, process_cpu_ns()) {
        (Some(a), Some(b)) => format!(
            ", {:.3} M per CPU-s",
            n as f64 / ((b - a) as f64 * 1e-9) / 1e6
        ),
        _ => String::new(),
    };
    println!(
        "{what} {}: {:.3} M/s wall ({n} in {s:.3} s){cpu}{exact}",
        args.get(1).map(String::as_str).unwrap_or("auto"),
        n as f64 / s / 1e6
    );
}

/// CPU time of this process (ns, the sum over its threads) where Linux reports it
/// (`/proc/self/task/*/schedstat`): on a machine shared with other jobs it moves much less
/// than the wall clock.
fn process_cpu_ns() -> Option<u64> {
    let mut total = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let s = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += s.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}
