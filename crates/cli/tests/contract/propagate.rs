//! `crashrig propagate`: JSON shape, inputs echoed, bit-identical output for any thread count.

use crate::contract::common::{
    arr3, field, fixture, json_of, run, run_env, string, uint, without_timing,
};
use approx::assert_relative_eq;
use serde_json::Value;

/// Arguments of a small propagate run on `fixtures/scenarios/<name>`.
fn args(name: &str, samples: usize, seed: u64, threads: Option<usize>) -> Vec<String> {
    let mut a = vec![
        "propagate".to_string(),
        fixture(&format!("scenarios/{name}")).display().to_string(),
        "--samples".into(),
        samples.to_string(),
        "--seed".into(),
        seed.to_string(),
        "--json".into(),
    ];
    if let Some(t) = threads {
        a.push("--threads".into());
        a.push(t.to_string());
    }
    a
}

/// Checks every field the contract names, with its type and shape; returns the cameras.
fn check_shape(v: &Value, samples: u64) -> Vec<Value> {
    assert_eq!(uint(v, "samples"), samples);
    let cams = field(v, "cameras").as_array().expect("cameras is an array");
    for c in cams {
        string(c, "name");
        for k in [
            "position_mm",
            "angles_deg",
            "position_sigma_mm",
            "angles_sigma_deg",
        ] {
            arr3(c, k);
        }
        let lin = field(c, "linear");
        arr3(lin, "position_sigma_mm");
        arr3(lin, "angles_sigma_deg");
    }
    cams.clone()
}

#[test]
fn propagate_nominal() {
    let v = json_of(&run(args("paper_chain.toml", 300, 3, None)));
    let cams = check_shape(&v, 300);
    let names: Vec<&str> = cams.iter().map(|c| string(c, "name")).collect();
    assert_eq!(
        names,
        ["cam1", "cam2", "cam3"],
        "one entry per scenario camera, in order"
    );
    // cam1 is a world pose: its first-order σ is its input σ (1 mm, 0.01°), exactly up to
    // the degree↔radian round trip (1e-12 relative).
    let lin = field(&cams[0], "linear");
    for (got, want) in [
        (arr3(lin, "position_sigma_mm"), [1.0; 3]),
        (arr3(lin, "angles_sigma_deg"), [0.01; 3]),
    ] {
        for i in 0..3 {
            assert_relative_eq!(got[i], want[i], max_relative = 1e-12);
        }
    }
    for c in &cams {
        let name = string(c, "name");
        let lin = field(c, "linear");
        for mc_key in ["position_sigma_mm", "angles_sigma_deg"] {
            let (mc, li) = (arr3(c, mc_key), arr3(lin, mc_key));
            for i in 0..3 {
                // Wrap-safe angles: cam2/cam3 have ω, κ near 180°; their σ must stay the
                // small σ of the inputs (≤ 0.03° here), never ~100°.
                // Monte Carlo vs first order: with 300 draws a sample σ has a relative
                // standard error of 1/√(2·299) ≈ 4 %, so 25 % is a 6-standard-error bound (the
                // model is nearly linear at these σ).
                assert_relative_eq!(mc[i], li[i], max_relative = 0.25);
                assert!(mc[i] > 0.0, "{name} {mc_key}[{i}] > 0");
            }
        }
    }
    // Nominal world poses: cam1 at the origin, cam2 at its link's base in cam1 = world axes.
    let p2 = arr3(&cams[1], "position_mm");
    for (g, w) in p2.iter().zip([61.98, -1.71, 179.76]) {
        assert_relative_eq!(*g, w, max_relative = 1e-12);
    }
}

#[test]
fn propagate_same_seed_any_thread_count() {
    // Contract: bit-identical output for any thread count; timing fields are dropped.
    let parse = |args: Vec<String>, env: &[(&str, &str)]| {
        let r = run_env(args, env);
        let v = without_timing(json_of(&r));
        serde_json::to_string(&v).expect("serialize")
    };
    for name in ["paper_chain.toml", "three_cameras_correlated.toml"] {
        let one = parse(args(name, 400, 5, Some(1)), &[]);
        let two = parse(args(name, 400, 5, Some(2)), &[]);
        let env = parse(args(name, 400, 5, None), &[("RAYON_NUM_THREADS", "2")]);
        assert!(one == two, "{name}: --threads 1 vs 2 differ");
        assert!(
            one == env,
            "{name}: --threads 1 vs RAYON_NUM_THREADS=2 differ"
        );
    }
}

#[test]
fn propagate_seed_changes_draws() {
    // Guards the determinism test against a constant output: another seed, other σ.
    let a = json_of(&run(args("paper_chain.toml", 200, 1, Some(1))));
    let b = json_of(&run(args("paper_chain.toml", 200, 2, Some(1))));
    let s = |v: &Value| arr3(&field(v, "cameras")[2], "position_sigma_mm");
    assert!(
        s(&a) != s(&b),
        "different seeds give different Monte Carlo σ"
    );
}
