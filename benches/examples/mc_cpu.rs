//! Fixed amounts of Monte Carlo work (the scenarios of `benches/mc.rs`, from this crate's
//! library), one instruction-set level at a time, for timing with CPU-time tools
//! (`/usr/bin/time -f %U`, `perf stat -e task-clock`) on a shared machine, where criterion's
//! wall-clock numbers absorb other jobs' load.
//!
//! `cargo run --release -p crashrig-benches --example mc_cpu -- WHAT ENGINE MILLIONS`
//! with WHAT = `normals` | `kernel` | `chain`, ENGINE = `baseline` | `v3` | `v4` | `auto`, MILLIONS = draws (normals for `normals`) in millions. Runs on one thread and prints
//! the rate per second of wall time.
use crashrig_benches::{CHAIN, level_of_name, one_point_kernel};
use crashrig_mc::{Chain, GridStudy, Isa, Scenario};
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
    let t = Instant::now();
    match what {
        "normals" => {
            let mut s = 0.0;
            let b = crashrig_mc::bench::BLOCK;
            let mut rows = vec![[0.0; crashrig_mc::bench::BLOCK]; 12];
            for k in 0..n / (12 * b) {
                crashrig_mc::bench::philox_normals(isa, 1, 0, (k * b) as u64, &mut rows);
                s += rows[0][0] + rows[11][b - 1];
            }
            black_box(s);
        }
        "chain" => {
            let sc = Scenario::from_toml_str(CHAIN, Path::new("chain.toml")).expect("scenario");
            black_box(Chain::new(&sc).monte_carlo_with(n, 3, isa));
        }
        _ => {
            let sc = Scenario::from_toml_str(&one_point_kernel(), Path::new("kernel.toml"))
                .expect("scenario");
            let study = GridStudy::new(&sc, 0, 0).expect("study");
            black_box(study.run_with(n, 7, isa).expect("run"));
        }
    }
    let s = t.elapsed().as_secs_f64();
    println!(
        "{what} {}: {:.3} M/s wall ({n} in {s:.3} s)",
        args.get(1).map(String::as_str).unwrap_or("auto"),
        n as f64 / s / 1e6
    );
}
