//! Tests of the chain propagation: Jacobians by finite differences, Monte Carlo against
//! J Σ Jᵀ, the paper's Table 4, and thread-count independence.
#![allow(clippy::needless_range_loop)] // index loops mirror the per-axis formulas

use super::*;
use crate::CHUNK;
use crate::Scenario;
use approx::assert_abs_diff_eq;
use std::path::Path;

/// The paper's chain (Tables 1–2, §3.2–3.3): cam1 outward (1 mm / 0.01°), cam2 = cam1 +
/// calibrated link with the SEM row as σ, cam3 = cam2 + bootstrap link (2 mm / 0.02°).
/// Assumed: cam1 at the world origin with identity rotation; cam3 with identity rotation
/// relative to cam2 (only axis permutations matter for the angle σ, see docs/table3.md).
fn paper_chain(noise: &str, sigma_scale: f64) -> Scenario {
    let s = sigma_scale;
    let text = format!(
        r#"
seed = 11
samples = 1000
rotation_noise = "{noise}"
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [{a}, {a}, {a}]
sigma_angles_deg = [{b}, {b}, {b}]
[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [61.98, -1.71, 179.76]
angles_deg = [179.92, -0.09, 179.76]
sigma_position_mm = [{c1}, {c2}, {c3}]
sigma_angles_deg = [{d1}, {d2}, {d3}]
[[camera]]
name = "cam3"
parent = "cam2"
position_mm = [-900.0, 50.0, 600.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [{e}, {e}, {e}]
sigma_angles_deg = [{f}, {f}, {f}]
"#,
        a = 1.0 * s,
        b = 0.01 * s,
        c1 = 0.19 * s,
        c2 = 0.26 * s,
        c3 = 0.13 * s,
        d1 = 0.004 * s,
        d2 = 0.005 * s,
        d3 = 0.008 * s,
        e = 2.0 * s,
        f = 0.02 * s,
    );
    Scenario::from_toml_str(&text, Path::new("paper.toml")).unwrap()
}

fn error_vector(chain: &Chain, poses: &[WorldPose], i: usize) -> [f64; 6] {
    let (dc, th) = chain.error_of(i, &poses[i]);
    [dc.x, dc.y, dc.z, th.x, th.y, th.z]
}

#[test]
fn jacobians_nominal_match_finite_differences() {
    for noise in ["tangent", "euler"] {
        // Large σ so the columns are O(1) and central differences are well conditioned.
        let sc = paper_chain(noise, 10.0);
        let chain = Chain::new(&sc);
        let js = chain.jacobians();
        let n = 6 * chain.len();
        let h = 1e-5;
        for col in 0..n {
            let mut ep = vec![0.0; n];
            let mut em = vec![0.0; n];
            ep[col] = h;
            em[col] = -h;
            let (pp, pm) = (chain.compose(&ep), chain.compose(&em));
            for (i, j) in js.iter().enumerate() {
                let (a, b) = (error_vector(&chain, &pp, i), error_vector(&chain, &pm, i));
                for r in 0..6 {
                    let fd = (a[r] - b[r]) / (2.0 * h);
                    // Central difference error O(h²·f''') ≈ 1e-10 relative plus rounding
                    // ε·|f|/h ≈ 1e-10 for positions of ~1e3 mm.
                    assert_abs_diff_eq!(
                        fd,
                        j[(r, col)],
                        epsilon = 1e-7 * (1.0 + j[(r, col)].abs())
                    );
                }
            }
        }
    }
}

#[test]
fn monte_carlo_nominal_matches_linear_within_3_se() {
    // Small σ: the chain is linear to ~1e-6 relative, so J Σ Jᵀ is the exact covariance.
    let sc = paper_chain("tangent", 1.0);
    let chain = Chain::new(&sc);
    let n = 40_000;
    let mc = chain
        .monte_carlo(&crate::ChainOptions::new(n, 5), None)
        .unwrap();
    let lin = chain.linear();
    for (m, l) in mc.iter().zip(&lin) {
        // SE of a Gaussian σ estimate: σ/√(2(n−1)).
        let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
        for k in 0..3 {
            let s = l.position_sigma_mm[k];
            assert_abs_diff_eq!(m.position_sigma_mm[k], s, epsilon = 3.0 * se * s);
            let t = l.tangent_sigma_rad[k];
            assert_abs_diff_eq!(m.tangent_sigma_rad[k], t, epsilon = 3.0 * se * t);
            let a = l.angles_sigma_rad.unwrap()[k];
            assert_abs_diff_eq!(m.angles_sigma_rad[k], a, epsilon = 3.0 * se * a);
        }
    }
}

#[test]
fn table4_orientation_sigma_reproduced() {
    // Paper Table 4: cam2 0.011/0.011/0.013°, cam3 0.023/0.023/0.024° (3 decimals).
    let expect = [
        [0.01, 0.01, 0.01],
        [0.011, 0.011, 0.013],
        [0.023, 0.023, 0.024],
    ];
    for noise in ["tangent", "euler"] {
        let sc = paper_chain(noise, 1.0);
        let chain = Chain::new(&sc);
        let mc = chain
            .monte_carlo(&crate::ChainOptions::new(100_000, 2024), None)
            .unwrap();
        for (m, e) in mc.iter().zip(&expect) {
            for k in 0..3 {
                // The paper rounds to 0.001°; MC SE at n = 1e5 is ≤ 0.024°·0.0022 = 5e-5°.
                assert_abs_diff_eq!(m.angles_sigma_rad[k].to_degrees(), e[k], epsilon = 1e-3);
            }
        }
    }
}

#[test]
fn monte_carlo_same_for_one_and_two_threads() {
    let sc = paper_chain("tangent", 1.0);
    let chain = Chain::new(&sc);
    let run = |t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| {
                chain
                    .monte_carlo(&crate::ChainOptions::new(3 * crate::CHUNK + 17, 9), None)
                    .unwrap()
            })
    };
    // Bit-identical: fixed chunks, fixed merge order.
    assert_eq!(run(1), run(2));
}

#[test]
fn monte_carlo_wraps_angles_near_180() {
    // cam2's ω is 179.92°: draws cross ±180°, the σ must stay ~0.011°, not ~100°.
    let sc = paper_chain("tangent", 10.0);
    let mc = Chain::new(&sc)
        .monte_carlo(&crate::ChainOptions::new(2000, 1), None)
        .unwrap();
    assert!(mc[1].angles_sigma_rad[0].to_degrees() < 0.2);
    assert!(mc[1].angles_mean_rad[0].to_degrees().abs() > 179.0);
}

#[test]
fn check_gimbal_nominal_and_lock() {
    let sc = paper_chain("tangent", 1.0);
    assert!(Chain::new(&sc).check_gimbal().is_ok());
    // A camera looking along the world x axis (φ = 90°) is a valid input: the chain draws and
    // propagates it; only its ω φ κ *output* is singular, and says so.
    let text = r#"
[[camera]]
name = "fwd"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 90.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.02, 0.03]
"#;
    let sc = Scenario::from_toml_str(text, Path::new("fwd.toml")).unwrap();
    let chain = Chain::new(&sc);
    assert!(chain.angles_singular(0));
    assert!(matches!(
        chain.check_gimbal(),
        Err(Error::GimbalLock { .. })
    ));
    let n = 20_000;
    let mc = chain
        .monte_carlo(&crate::ChainOptions::new(n, 3), None)
        .unwrap();
    assert!(mc[0].angles_singular);
    assert!(chain.linear()[0].angles_sigma_rad.is_none());
    // The tangent σ are the inputs within 3 SE of a σ estimate (σ/√(2(n−1))).
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for (k, s) in [0.01f64, 0.02, 0.03].iter().enumerate() {
        let t = mc[0].tangent_sigma_rad[k].to_degrees();
        assert_abs_diff_eq!(t, s, epsilon = 3.0 * se * s);
    }
}

#[test]
fn wrap_pi_nominal_matches_geometry() {
    use std::f64::consts::PI;
    for a in [
        0.0, 1.0, -1.0, PI, -PI, 3.5, -3.5, 6.0, -6.0, 9.0, -9.0, 20.0, -20.0,
    ] {
        // Same branch cut (−π, π]; one subtraction of 2π differs from rem_euclid by rounding.
        assert_abs_diff_eq!(
            super::wrap_pi(a),
            crashrig_geometry::angles::wrap_pi(a),
            epsilon = 1e-14
        );
    }
}

#[test]
#[ignore = "slow: 10⁶ chain draws"]
fn slow_monte_carlo_matches_linear_large_n() {
    // `monte_carlo_nominal_matches_linear_within_3_se` at 10⁶ draws (3 SE = 0.2 % of σ).
    let sc = paper_chain("euler", 1.0);
    let chain = Chain::new(&sc);
    let n = 1_000_000;
    let mc = chain
        .monte_carlo(&crate::ChainOptions::new(n, 77), None)
        .unwrap();
    let lin = chain.linear();
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for (m, l) in mc.iter().zip(&lin) {
        for k in 0..3 {
            let s = l.position_sigma_mm[k];
            assert_abs_diff_eq!(m.position_sigma_mm[k], s, epsilon = 3.0 * se * s);
            let a = l.angles_sigma_rad.unwrap()[k];
            assert_abs_diff_eq!(m.angles_sigma_rad[k], a, epsilon = 3.0 * se * a);
        }
    }
}

#[test]
fn chain_every_isa_gives_identical_results() {
    // Forced levels against the baseline, both noise kinds, with a partial final block and
    // σ large enough (×60: 0.6° … 1.2°) that some lanes take the scalar fallback.
    for noise in ["tangent", "euler"] {
        for scale in [1.0, 60.0] {
            let chain = Chain::new(&paper_chain(noise, scale));
            let n = CHUNK + 70;
            let base = chain
                .monte_carlo(
                    &crate::ChainOptions {
                        isa: crate::Isa::Baseline,
                        ..crate::ChainOptions::new(n, 4)
                    },
                    None,
                )
                .unwrap();
            for isa in crate::Isa::LEVELS {
                if !isa.is_available() {
                    eprintln!("{}: not available on this CPU, not compared", isa.name());
                    continue;
                }
                let got = chain
                    .monte_carlo(
                        &crate::ChainOptions {
                            isa,
                            ..crate::ChainOptions::new(n, 4)
                        },
                        None,
                    )
                    .unwrap();
                assert_eq!(got, base, "{noise} ×{scale}: {} differs", isa.name());
            }
        }
    }
}

#[test]
fn chain_legacy_and_simd_agree_statistically_including_fallback_lanes() {
    // Independent random numbers; every σ (centre, ω φ κ, body-axis) of every camera agrees
    // within 4 standard errors of a difference of two σ estimates. At ×60 the link angles
    // reach θ² ≥ 10⁻³ in a good share of draws, so the scalar fallback lanes are exercised
    // (and the first-order propagation no longer applies, hence the engine comparison).
    let n = 40_000;
    let se = 2f64.sqrt() / (2.0 * (n as f64 - 1.0)).sqrt();
    for noise in ["tangent", "euler"] {
        for scale in [1.0, 60.0] {
            let chain = Chain::new(&paper_chain(noise, scale));
            let a = chain
                .monte_carlo_engine(n, 8, crate::schedule::Engine::Legacy, None)
                .unwrap();
            let b = chain
                .monte_carlo(&crate::ChainOptions::new(n, 8), None)
                .unwrap();
            for (x, y) in a.iter().zip(&b) {
                for (u, v) in [
                    (x.position_sigma_mm, y.position_sigma_mm),
                    (x.angles_sigma_rad, y.angles_sigma_rad),
                    (x.tangent_sigma_rad, y.tangent_sigma_rad),
                ] {
                    for k in 0..3 {
                        assert_abs_diff_eq!(v[k], u[k], epsilon = 4.0 * se * u[k]);
                    }
                }
            }
        }
    }
}

/// The tangent-only propagation (a grid's `sigma_from` with tangent noise) gives the same
/// tangent covariances, centres and counts as the full one: bit for bit where no lane leaves
/// the angle series (the paper's chain), to ~1e-12 relative where lanes near gimbal lock
/// (the real-study chain, cam1 at φ = −89.88°) take the scalar formulas in the full one; its
/// ω φ κ statistics are NaN.
#[test]
fn tangent_only_propagation_matches_the_full_one() {
    let real = Scenario::from_toml_str(
        &crate::testdata::repo_file("benches/real_map.toml"),
        Path::new("real_map.toml"),
    )
    .unwrap();
    for (sc, exact) in [(paper_chain("tangent", 1.0), true), (real, false)] {
        let chain = Chain::new(&sc);
        let o = crate::ChainOptions::new(3 * CHUNK + 11, 5);
        let full = chain.monte_carlo(&o, None).unwrap();
        let tangent = chain.monte_carlo_tangent(&o).unwrap();
        for (f, t) in full.iter().zip(&tangent) {
            assert_eq!(f.count, t.count);
            assert!(t.angles_sigma_rad.iter().all(|s| s.is_nan()));
            assert!(t.covariance.iter().all(|s| s.is_nan()));
            if exact {
                assert_eq!(f.covariance_tangent, t.covariance_tangent);
                assert_eq!(f.position_mean_mm, t.position_mean_mm);
            } else {
                let d = (f.covariance_tangent - t.covariance_tangent).abs().max();
                assert!(
                    d <= 1e-12 * f.covariance_tangent.abs().max(),
                    "{}: {d}",
                    f.name
                );
                assert_ne!(f.covariance_tangent, t.covariance_tangent, "fallback lanes");
            }
        }
    }
}
