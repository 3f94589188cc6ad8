//! Fixed amounts of Monte Carlo work, one engine at a time, for timing with CPU-time tools
//! (`/usr/bin/time -f %U`, `perf stat -e task-clock`) on a shared machine, where criterion's
//! wall-clock numbers absorb other jobs' load.
//!
//! `cargo run --release -p crashrig-benches --example mc_cpu -- WHAT ENGINE MILLIONS`
//! with WHAT = `normals` | `kernel` | `chain`, ENGINE = `legacy` | `baseline` | `v3` | `v4` |
//! `auto`, MILLIONS = draws (normals for `normals`) in millions. Runs on one thread and prints
//! the rate per second of wall time.
use crashrig_mc::{Chain, Engine, FastNormal, GridStudy, Isa, Scenario};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

const KERNEL: &str = r#"
seed = 1
samples = 2000
[grid]
x_mm = [1000.0, 1000.0, 1]
y_mm = [300.0, 300.0, 1]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]
[[grid.observer]]
position_mm = [1300.0, -700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

const CHAIN: &str = r#"
seed = 1
samples = 1000
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [61.98, -1.71, 179.76]
angles_deg = [179.92, -0.09, 179.76]
sigma_position_mm = [0.19, 0.26, 0.13]
sigma_angles_deg = [0.004, 0.005, 0.008]
[[camera]]
name = "cam3"
parent = "cam2"
position_mm = [-900.0, 50.0, 600.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [2.0, 2.0, 2.0]
sigma_angles_deg = [0.02, 0.02, 0.02]
"#;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("kernel");
    let engine = match args.get(1).map(String::as_str).unwrap_or("auto") {
        "legacy" => Engine::Legacy,
        "baseline" => Engine::Simd(Isa::Baseline),
        "v3" => Engine::Simd(Isa::X86V3),
        "v4" => Engine::Simd(Isa::X86V4),
        _ => Engine::Simd(Isa::Auto),
    };
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
            match engine {
                Engine::Legacy => {
                    let mut rng = crashrig_stats::stream(1, 0);
                    let nd = FastNormal::new();
                    let mut buf = [0.0; 12];
                    for _ in 0..n / 12 {
                        nd.fill(&mut rng, &mut buf);
                        s += buf[0] + buf[11];
                    }
                }
                Engine::Simd(isa) => {
                    let b = crashrig_mc::bench::BLOCK;
                    let mut rows = vec![[0.0; crashrig_mc::bench::BLOCK]; 12];
                    for k in 0..n / (12 * b) {
                        crashrig_mc::bench::philox_normals(isa, 1, 0, (k * b) as u64, &mut rows);
                        s += rows[0][0] + rows[11][b - 1];
                    }
                }
            }
            black_box(s);
        }
        "chain" => {
            let sc = Scenario::from_toml_str(CHAIN, Path::new("chain.toml")).expect("scenario");
            black_box(Chain::new(&sc).monte_carlo_with(n, 3, engine));
        }
        _ => {
            let sc = Scenario::from_toml_str(KERNEL, Path::new("kernel.toml")).expect("scenario");
            let study = GridStudy::new(&sc, 0, 0).expect("study");
            black_box(study.run_with(n, 7, engine).expect("run"));
        }
    }
    let s = t.elapsed().as_secs_f64();
    println!(
        "{what} {}: {:.3} M/s wall ({n} in {s:.3} s)",
        args.get(1).map(String::as_str).unwrap_or("auto"),
        n as f64 / s / 1e6
    );
}
