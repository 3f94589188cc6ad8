//! Tests of the grid study: closed form, Jacobian, linear agreement, determinism,
//! correlation, pixel noise and adaptive stopping.
#![allow(clippy::needless_range_loop)] // index loops mirror the per-axis formulas

use super::*;
use crate::Scenario;
use crate::schedule::{ADAPTIVE_MIN_BATCHES, adaptive_draws, adaptive_stable};
use approx::assert_abs_diff_eq;
use crashrig_stats::Moments;
use std::path::Path;

fn scenario(extra_grid: &str, obs: &str, cameras: &str, noise: &str) -> Scenario {
    let text = format!(
        r#"
seed = 3
samples = 4000
rotation_noise = "{noise}"
{cameras}
[grid]
x_mm = [0.0, 0.0, 1]
y_mm = [1000.0, 1000.0, 1]
z_mm = [0.0, 0.0, 1]
{extra_grid}
{obs}
"#
    );
    Scenario::from_toml_str(&text, Path::new("g.toml")).unwrap()
}

const TWO_OBS: &str = r#"
[[grid.observer]]
position_mm = [-600.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[[grid.observer]]
position_mm = [600.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;

#[test]
fn grid_nominal_symmetric_closed_form() {
    // Two cameras at (±b, 0, 0) aim at (0, D, 0) with angle noise σ only. Each ray moves
    // sideways by ρσ in both directions normal to it, so (β = atan(b/D), ρ = √(b²+D²)):
    // σx = ρσ/(√2 cos β), σy = ρσ/(√2 sin β), σz = ρσ/√2.
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let n = 200_000;
    let r = study.run(&crate::RunOptions::samples(n, 42), None).unwrap();
    let p = &r.points[0];
    let (b, d, s) = (600.0f64, 1000.0f64, 0.01f64.to_radians());
    let rho = b.hypot(d);
    let beta = (b / d).atan();
    let expect = [
        rho * s / (2f64.sqrt() * beta.cos()),
        rho * s / (2f64.sqrt() * beta.sin()),
        rho * s / 2f64.sqrt(),
    ];
    // 3 standard errors of a σ estimate: 3σ/√(2(n−1)).
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for k in 0..3 {
        assert_abs_diff_eq!(p.sigma_mm[k], expect[k], epsilon = 3.0 * se * expect[k]);
        // The linear covariance is the closed form up to rounding.
        assert_abs_diff_eq!(
            p.linear_sigma_mm()[k],
            expect[k],
            epsilon = 1e-12 * expect[k]
        );
    }
    assert_eq!(p.count, n as u64);
}

fn aimed_for(sc: &Scenario) -> (Vec<Aimed>, Vector3<f64>) {
    let g = sc.grid.as_ref().unwrap();
    let p = g.points()[0];
    let study = GridStudy::new(sc, 0, 0).unwrap();
    (study.aim_all(&[p]).unwrap().remove(0), p)
}

#[test]
fn intersection_jacobian_nominal_matches_finite_differences() {
    let obs3 = format!(
        "{TWO_OBS}\n[[grid.observer]]\nposition_mm = [100.0, -300.0, 400.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n"
    );
    for noise in [RotationNoise::Tangent, RotationNoise::Euler] {
        let name = if noise == RotationNoise::Tangent {
            "tangent"
        } else {
            "euler"
        };
        let sc = scenario("", &obs3, "", name);
        let (obs, p) = aimed_for(&sc);
        let j = intersection_jacobian(&obs, &p);
        let n = INPUTS_PER_OBSERVER * obs.len();
        let x0 = intersect_perturbed(&obs, &vec![0.0; n]);
        assert_abs_diff_eq!(x0, p, epsilon = 1e-9);
        for col in 0..n {
            // Step 1e-3 mm for positions, 1e-7 for angles / normalized coordinates.
            let h = if col % INPUTS_PER_OBSERVER < 3 {
                1e-3
            } else {
                1e-7
            };
            let mut dp = vec![0.0; n];
            let mut dm = vec![0.0; n];
            dp[col] = h;
            dm[col] = -h;
            let fd = (intersect_perturbed(&obs, &dp) - intersect_perturbed(&obs, &dm)) / (2.0 * h);
            for r in 0..3 {
                // Truncation O(h²) plus rounding ε·|X|/h ≈ 1e-16·1e3/1e-7 ≈ 1e-6 mm/rad on
                // columns of size ~1e3.
                assert_abs_diff_eq!(
                    fd[r],
                    j[(r, col)],
                    epsilon = 1e-5 * (1.0 + j[(r, col)].abs())
                );
            }
        }
    }
}

#[test]
fn grid_monte_carlo_matches_linear_for_every_noise_kind() {
    let obs = TWO_OBS.replace("[0.0, 0.0, 0.0]", "[0.8, 0.5, 1.2]");
    for (extra, noise) in [
        ("", "tangent"),
        ("", "euler"),
        ("pixel_sigma_px = 0.5\nfocal_px = 1500.0", "tangent"),
        ("pixel_sigma_px = 0.5\nfocal_px = 1500.0", "euler"),
    ] {
        let sc = scenario(extra, &obs, "", noise);
        let study = GridStudy::new(&sc, 0, 0).unwrap();
        let n = 60_000;
        let p = &study
            .run(&crate::RunOptions::samples(n, 8), None)
            .unwrap()
            .points[0];
        let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
        for k in 0..3 {
            let l = p.linear_sigma_mm()[k];
            assert_abs_diff_eq!(p.sigma_mm[k], l, epsilon = 3.0 * se * l);
        }
    }
}

#[test]
fn grid_pixel_noise_only_matches_linear() {
    let obs = TWO_OBS.replace(
        "sigma_angles_deg = [0.01, 0.01, 0.01]",
        "sigma_angles_deg = [0.0, 0.0, 0.0]",
    );
    let sc = scenario(
        "pixel_sigma_px = 1.0\nfocal_px = 1000.0",
        &obs,
        "",
        "tangent",
    );
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let n = 60_000;
    let p = &study
        .run(&crate::RunOptions::samples(n, 8), None)
        .unwrap()
        .points[0];
    // A pixel error of σ/f rad moves each ray sideways like a rotation of the same size:
    // the closed form of the symmetric test with σ = 1/1000 rad.
    let (b, d, s) = (600.0f64, 1000.0f64, 1e-3f64);
    let rho = b.hypot(d);
    let expect_z = rho * s / 2f64.sqrt();
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    assert_abs_diff_eq!(p.sigma_mm.z, expect_z, epsilon = 3.0 * se * expect_z);
}

#[test]
fn grid_same_for_one_and_two_threads() {
    let sc = scenario("", TWO_OBS, "", "tangent");
    let mut sc = sc;
    let g = sc.grid.as_mut().unwrap();
    g.x = crate::Axis {
        start: -200.0,
        stop: 200.0,
        count: 3,
    };
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let run = |t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| {
                study
                    .run(&crate::RunOptions::samples(2 * crate::CHUNK + 5, 77), None)
                    .unwrap()
            })
    };
    assert_eq!(run(1), run(2));
}

const SHARED_CHAIN: &str = r#"
[[camera]]
name = "root"
position_mm = [0.0, -500.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
[[camera]]
name = "a"
parent = "root"
position_mm = [-600.0, 500.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
[[camera]]
name = "b"
parent = "root"
position_mm = [600.0, 500.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [0.0, 0.0, 0.0]
sigma_angles_deg = [0.0, 0.0, 0.0]
"#;

const FROM_OBS: &str = r#"
[[grid.observer]]
position_mm = [-600.0, 0.0, 0.0]
sigma_from = "a"
[[grid.observer]]
position_mm = [600.0, 0.0, 0.0]
sigma_from = "b"
"#;

#[test]
fn grid_correlated_shared_translation_is_exact() {
    // Both observers hang off one root with 1 mm position noise and no other noise: drawn
    // jointly they shift rigidly, so the intersected point moves by exactly the root's
    // shift and σx = σy = σz = 1 mm. Drawn independently the two shifts partly cancel
    // and partly amplify (σx = 1/(√2 cos β) etc.), so the maps differ.
    let sc = scenario("correlated = true", FROM_OBS, SHARED_CHAIN, "tangent");
    let study = GridStudy::new(&sc, 20_000, 1).unwrap();
    let n = 40_000;
    let corr = study.run(&crate::RunOptions::samples(n, 5), None).unwrap();
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for k in 0..3 {
        assert_abs_diff_eq!(corr.points[0].sigma_mm[k], 1.0, epsilon = 3.0 * se);
    }
    let ind = study
        .independent()
        .run(&crate::RunOptions::samples(n, 5), None)
        .unwrap();
    let beta = (600.0f64 / 1000.0).atan();
    // Independent 1 mm shifts; the closed form with lateral σ = 1 mm per ray.
    let expect_y = 1.0 / (2f64.sqrt() * beta.sin());
    // The along-ray components do not count, only the normal ones: σy = σ_normal/(√2 sin β).
    assert_abs_diff_eq!(
        ind.points[0].sigma_mm.y,
        expect_y,
        epsilon = 3.0 * se * expect_y
    );
    assert!(ind.points[0].sigma_mm.y > 1.3 * corr.points[0].sigma_mm.y);
}

#[test]
fn grid_adaptive_stops_within_tolerance() {
    let sc = scenario(
        "[grid.adaptive]\ntolerance_mm = 0.01\nbatch = 500\nmax_samples = 200000",
        TWO_OBS,
        "",
        "tangent",
    );
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let a = sc.grid.as_ref().unwrap().adaptive.unwrap();
    let r = study.run(&crate::RunOptions::adaptive(a, 4), None).unwrap();
    let p = &r.points[0];
    assert!(p.count >= 2000 && p.count < 200_000, "count {}", p.count);
    assert_eq!(p.count % 500, 0);
    // The result agrees with the closed form to the requested tolerance (2u ≤ δ ⇒ ~95 %
    // coverage of δ around the estimate; allow 2δ for the bound being on batch σ).
    let expect_y =
        1000f64.hypot(600.0) * 0.01f64.to_radians() / (2f64.sqrt() * (0.6f64).atan().sin());
    assert_abs_diff_eq!(p.sigma_mm.y, expect_y, epsilon = 0.02);
    // Deterministic.
    assert_eq!(
        r,
        study.run(&crate::RunOptions::adaptive(a, 4), None).unwrap()
    );
}

#[test]
fn ellipsoid_semi_axes_nominal() {
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let p = &study
        .run(&crate::RunOptions::samples(20_000, 1), None)
        .unwrap()
        .points[0];
    let ax = p.ellipsoid_semi_axes_mm();
    // The symmetric geometry has axes along x, y, z: semi-axes are the sorted σ.
    let mut s: Vec<f64> = p.sigma_mm.iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    for k in 0..3 {
        // Off-diagonal sample covariance ~ σ²/√n perturbs the eigenvalues at second order.
        assert_abs_diff_eq!(ax[k], s[k], epsilon = 0.02 * s[k]);
    }
}

/// Worst-direction σ: √ of the largest covariance eigenvalue. With σx = σy = 2 mm and
/// correlation 0.75 between x and y (covariance [[4, 3, 0], [3, 4, 0], [0, 0, 1]] mm², eigenvalues
/// 7, 1, 1), σ_max is 2 mm but the point is √7 mm uncertain along the diagonal x = y.
#[test]
fn sigma_worst_is_the_largest_eigen_axis() {
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let mut p = study
        .run(&crate::RunOptions::samples(100, 1), None)
        .unwrap()
        .points[0]
        .clone();
    p.covariance = Matrix3::new(4.0, 3.0, 0.0, 3.0, 4.0, 0.0, 0.0, 0.0, 1.0);
    p.sigma_mm = Vector3::new(2.0, 2.0, 1.0);
    p.sigma_max_mm = 2.0;
    assert_abs_diff_eq!(p.sigma_worst_mm(), 7f64.sqrt(), epsilon = 1e-12);
    // Not measurable (or blanked as degenerate): NaN, never a number.
    p.sigma_max_mm = f64::NAN;
    assert!(p.sigma_worst_mm().is_nan());
    p.sigma_max_mm = 2.0;
    p.covariance[(0, 0)] = f64::NAN;
    assert!(p.sigma_worst_mm().is_nan());
}

#[test]
#[ignore = "slow: 4·10⁶ draws; run by `cargo xtask test --slow`"]
fn slow_grid_closed_form_large_n() {
    // The closed form of `grid_nominal_symmetric_closed_form` at 4·10⁶ draws: 3 SE is
    // 0.1 % of σ, small enough to see a bias of the kernel or of the normals.
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let n = 4_000_000;
    let p = &study
        .run(&crate::RunOptions::samples(n, 4242), None)
        .unwrap()
        .points[0];
    let (b, d, s) = (600.0f64, 1000.0f64, 0.01f64.to_radians());
    let rho = b.hypot(d);
    let beta = (b / d).atan();
    let expect = [
        rho * s / (2f64.sqrt() * beta.cos()),
        rho * s / (2f64.sqrt() * beta.sin()),
        rho * s / 2f64.sqrt(),
    ];
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for k in 0..3 {
        assert_abs_diff_eq!(p.sigma_mm[k], expect[k], epsilon = 3.0 * se * expect[k]);
    }
}

/// Studies covering every path of the block kernel: tangent, euler, pixel noise (both),
/// three observers, observers drawn jointly from the chain.
fn kernel_paths() -> Vec<(&'static str, GridStudy)> {
    let obs3 = format!(
        "{}\n[[grid.observer]]\nposition_mm = [100.0, -300.0, 400.0]\nsigma_position_mm = [1.0, 0.5, 2.0]\nsigma_angles_deg = [0.02, 0.01, 0.03]\n",
        TWO_OBS.replace("[0.0, 0.0, 0.0]", "[0.8, 0.5, 1.2]")
    );
    let pixel = "pixel_sigma_px = 0.5\nfocal_px = 1500.0";
    let mut out = Vec::new();
    for (name, extra, obs, cams, noise) in [
        ("tangent", "", obs3.as_str(), "", "tangent"),
        ("euler", "", obs3.as_str(), "", "euler"),
        ("tangent+pixel", pixel, obs3.as_str(), "", "tangent"),
        ("euler+pixel", pixel, obs3.as_str(), "", "euler"),
        (
            "correlated",
            "correlated = true",
            FROM_OBS,
            SHARED_CHAIN,
            "tangent",
        ),
    ] {
        let mut sc = scenario(extra, obs, cams, noise);
        let g = sc.grid.as_mut().unwrap();
        g.x = crate::Axis {
            start: -200.0,
            stop: 200.0,
            count: 2,
        };
        out.push((name, GridStudy::new(&sc, 2000, 1).unwrap()));
    }
    out
}

#[test]
fn every_isa_gives_identical_grids() {
    // The statement of `kernel/simd.rs`: every instruction-set level gives the same bits. Each
    // available level is forced and compared with the baseline (SSE2 on x86-64), on every
    // kernel path, with a partial final block.
    let n = crate::CHUNK + 70;
    for (name, study) in kernel_paths() {
        let base = study
            .run(
                &crate::RunOptions {
                    isa: crate::Isa::Baseline,
                    ..crate::RunOptions::samples(n, 9)
                },
                None,
            )
            .unwrap();
        for isa in crate::Isa::LEVELS {
            if !isa.is_available() {
                eprintln!("{}: not available on this CPU, not compared", isa.name());
                continue;
            }
            let got = study
                .run(
                    &crate::RunOptions {
                        isa,
                        ..crate::RunOptions::samples(n, 9)
                    },
                    None,
                )
                .unwrap();
            assert_eq!(got, base, "{name}: {} differs from baseline", isa.name());
        }
    }
}

#[test]
fn wide_and_narrow_loop_shapes_give_identical_grids() {
    // `simd::Width` only chooses loop shapes (Philox round by round over 32 lanes and fused
    // observer passes on AVX-512; lane by lane and stage by stage otherwise): the same bits.
    // Forced narrow on the best level of this CPU; aimed, pixel and chain-drawn paths. (On a
    // CPU without AVX-512 both runs are narrow; `fill_block_is_identical_for_both_widths`
    // still compares the two shapes of the generator there.)
    use crate::kernel::simd::FORCE_NARROW;
    use std::sync::atomic::Ordering::Relaxed;
    let n = crate::CHUNK + 70;
    for (name, study) in kernel_paths() {
        let auto = study
            .run(
                &crate::RunOptions {
                    isa: crate::Isa::Auto,
                    ..crate::RunOptions::samples(n, 9)
                },
                None,
            )
            .unwrap();
        FORCE_NARROW.store(true, Relaxed);
        let narrow = study.run(
            &crate::RunOptions {
                isa: crate::Isa::Auto,
                ..crate::RunOptions::samples(n, 9)
            },
            None,
        );
        FORCE_NARROW.store(false, Relaxed);
        assert_eq!(auto, narrow.unwrap(), "{name}: the loop shapes differ");
    }
}

#[test]
fn legacy_and_simd_engines_agree_statistically() {
    // Two engines, independent random numbers: the σ of each path agree within 4 standard
    // errors of a difference of two σ estimates (√2 · σ/√(2(n−1))).
    let n = 40_000;
    let se = (2.0f64).sqrt() / (2.0 * (n as f64 - 1.0)).sqrt();
    for (name, study) in kernel_paths() {
        let a = study
            .run_draws(
                &crate::options::Draws::Samples(n),
                5,
                crate::schedule::Engine::Legacy,
                None,
            )
            .unwrap();
        let b = study.run(&crate::RunOptions::samples(n, 5), None).unwrap();
        for (pa, pb) in a.points.iter().zip(&b.points) {
            for k in 0..3 {
                let s = pa.sigma_mm[k];
                assert_abs_diff_eq!(pb.sigma_mm[k], s, epsilon = 4.0 * se * s);
            }
        }
        assert_ne!(a, b, "{name}: the engines must draw different numbers");
    }
}

/// The draws of one chunk with the given observers (test access to the kernel).
fn chunk(obs: &[Aimed], ctx: &Ctx, m: usize) -> Acc3 {
    let mut acc = Acc3::new(Vector3::new(0.0, 1000.0, 0.0));
    run_chunk(
        obs,
        ctx,
        77,
        3,
        m,
        &mut acc,
        crate::schedule::Engine::Simd(crate::Isa::Auto),
    );
    acc
}

fn plain_ctx(pixel: Option<f64>) -> Ctx {
    Ctx {
        pixel,
        chain: None,
        chain_jacobians: Vec::new(),
    }
}

/// The observers with their rotation noise kind set to `kind`.
fn with_kind(obs: &[Aimed], kind: RotationNoise) -> Vec<Aimed> {
    obs.iter().map(|a| Aimed { kind, ..*a }).collect()
}

#[test]
fn full_factor_with_diagonal_entries_matches_diagonal_path_bitwise() {
    // δ = L·ε summed over the whole lower triangle equals σ∘ε exactly when the
    // off-diagonal entries are zero (adding zeros is exact): the general path is the same
    // model as the fast diagonal one, bit for bit.
    let obs = TWO_OBS.replace("[0.0, 0.0, 0.0]", "[0.8, 0.5, 1.2]");
    for noise in [RotationNoise::Tangent, RotationNoise::Euler] {
        for pixel in [None, Some(3e-4)] {
            let sc = scenario("", &obs, "", "tangent");
            let (aimed, _) = aimed_for(&sc);
            let aimed = with_kind(&aimed, noise);
            let full: Vec<Aimed> = aimed
                .iter()
                .map(|a| Aimed {
                    noise: a.noise.without_shortcut(),
                    ..*a
                })
                .collect();
            let ctx = plain_ctx(pixel);
            assert_eq!(chunk(&aimed, &ctx, 1000), chunk(&full, &ctx, 1000));
        }
    }
}

#[test]
fn full_factor_nominal_matches_linear_propagation() {
    // A covariance with position–rotation and rotation–rotation correlations (the
    // uncertain-poses model): Monte Carlo σ against J Σ Jᵀ, Σ = L Lᵀ per observer. The
    // correlations change σ by far more than the tolerance, so the test sees them.
    let sc = scenario("", TWO_OBS, "", "tangent");
    let (aimed, p) = aimed_for(&sc);
    let mut l = nalgebra::Matrix6::<f64>::zeros();
    // ρ·σ_rot ≈ 0.4 mm, comparable to the 0.5 mm position σ, so that correlating a rotation
    // with a shift moves the ray markedly more (or less) than either alone.
    let s_rot = 0.02f64.to_radians();
    for i in 0..3 {
        l[(i, i)] = 0.5;
        l[(i + 3, i + 3)] = s_rot;
    }
    // Rotation about the camera's y axis (the ray swings sideways) with the world x shift,
    // about its x axis (the ray swings up/down) with the z shift, and one rotation–rotation
    // term.
    l[(4, 0)] = 1.5 * s_rot;
    l[(3, 2)] = -1.5 * s_rot;
    l[(4, 3)] = -0.9 * s_rot;
    l[(5, 1)] = 0.5 * s_rot;
    let obs: Vec<Aimed> = aimed
        .iter()
        .map(|a| Aimed {
            noise: crate::kernel::lanes::NoiseFactor::from_lower(&l),
            ..*a
        })
        .collect();
    let ctx = plain_ctx(None);
    let n = 4 * crate::CHUNK;
    let mut acc = Acc3::new(p);
    for k in 0..4 {
        let mut part = Acc3::new(p);
        run_chunk(
            &obs,
            &ctx,
            21,
            k,
            crate::CHUNK,
            &mut part,
            crate::schedule::Engine::Simd(crate::Isa::Auto),
        );
        acc.merge(&part);
    }
    let j = intersection_jacobian(&obs, &p);
    let cov6 = l * l.transpose();
    let mut sin = DMatrix::zeros(j.ncols(), j.ncols());
    for k in 0..obs.len() {
        let b = INPUTS_PER_OBSERVER * k;
        sin.view_mut((b, b), (6, 6)).copy_from(&cov6);
    }
    let lin = &j * &sin * j.transpose();
    let diag_only = {
        let mut d = sin.clone();
        for r in 0..d.nrows() {
            for c in 0..d.ncols() {
                if r != c {
                    d[(r, c)] = 0.0;
                }
            }
        }
        &j * d * j.transpose()
    };
    let sd = acc.std_dev();
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    let mut sensitive = false;
    for k in 0..3 {
        let want = lin[(k, k)].sqrt();
        assert_abs_diff_eq!(sd[k], want, epsilon = 4.0 * se * want);
        sensitive |= (diag_only[(k, k)].sqrt() - want).abs() > 10.0 * se * want;
    }
    assert!(
        sensitive,
        "the correlations must matter for this test to mean anything"
    );
}

/// JCGM 101 §7.9.2: δ = ½·10^l with u = c·10^l, c an ndig-digit integer.
#[test]
fn ndig_tolerance_known_answers() {
    use crate::model::ndig_tolerance;
    // The standard's example: u = 0.01234 mm, ndig = 2 → 12 × 10⁻³ → δ = 0.0005 mm.
    let cases = [
        (0.01234, 2, 0.0005),
        (0.01234, 1, 0.005),
        (0.01234, 3, 0.00005),
        (1.0, 2, 0.05),
        (9.99, 2, 0.05),
        (10.0, 2, 0.5),
        (0.001, 1, 0.0005),
        (123.4, 3, 0.5),
        (0.0999, 2, 0.0005),
    ];
    for (u, ndig, delta) in cases {
        let got = ndig_tolerance(u, ndig);
        assert!(
            (got - delta).abs() <= 1e-12 * delta,
            "u = {u}, ndig = {ndig}: δ = {got}, expected {delta}"
        );
    }
    assert_eq!(ndig_tolerance(0.0, 2), 0.0);
    assert!(ndig_tolerance(f64::NAN, 2).is_nan());
    assert!(ndig_tolerance(-1.0, 2).is_nan());
}

fn adaptive(tolerance: crate::Tolerance, batch: usize, max_samples: usize) -> crate::Adaptive {
    crate::Adaptive {
        tolerance,
        batch,
        max_samples,
    }
}

/// Batch `b` of `m` draws: the same ±1 pattern on every axis (σ of every batch the same),
/// centred at `offset(b)` on every axis.
fn pattern_batch(m: usize, offset: f64, acc: &mut Acc3) {
    for i in 0..m {
        let e = if i % 2 == 0 { 1.0 } else { -1.0 };
        acc.push(&Vector3::from_element(offset + e));
    }
}

/// Only the mean moves between batches: a rule that stabilised σ alone would stop at the
/// fourth batch; JCGM 101 §7.9.4 also needs the estimate stable, so the point runs on.
#[test]
fn adaptive_mean_instability_alone_keeps_a_point_running() {
    let ad = adaptive(crate::Tolerance::AbsoluteMm(0.01), 100, 10_000);
    let p = Vector3::zeros();
    // Batch means alternate ±0.1 mm: s ≈ 0.1, 2·s/√h ≤ 0.01 would need h ≥ 400 > 100 batches.
    let (total, converged) = adaptive_draws(&p, &ad, |b, m, acc| {
        pattern_batch(m, if b % 2 == 0 { 0.1 } else { -0.1 }, acc)
    });
    assert!(!converged);
    assert_eq!(total.count(), 10_000);
    // Control: the same batches with a fixed mean stop at the first check.
    let (total, converged) = adaptive_draws(&p, &ad, |_, m, acc| pattern_batch(m, 0.1, acc));
    assert!(converged);
    assert_eq!(total.count(), (ADAPTIVE_MIN_BATCHES * 100) as u64);
}

/// The stopping test at the boundary, in both tolerance modes: h = 4 batches whose σ of axis
/// x alternate c ± a have a standard deviation s = a·√(4/3), so `2·s/√h = s`.
#[test]
fn adaptive_stable_known_boundary() {
    let run = |s_target: f64, pooled: f64, tol: crate::Tolerance| {
        let a = s_target / (4.0f64 / 3.0).sqrt();
        let mut m = Moments::<6>::new();
        for k in 0..4 {
            let sx = pooled + if k % 2 == 0 { a } else { -a };
            m.push(&[5.0, 6.0, 7.0, sx, pooled, pooled]);
        }
        adaptive_stable(
            &m,
            &Vector3::from_element(pooled),
            &adaptive(tol, 100, 1000),
        )
    };
    // ndig = 2 at u = 0.01234 mm: δ = 0.0005 mm.
    let ndig = crate::Tolerance::SignificantDigits(2);
    assert!(run(0.00049, 0.01234, ndig));
    assert!(!run(0.00051, 0.01234, ndig));
    // ndig = 1: δ = 0.005 mm.
    assert!(run(0.0049, 0.01234, crate::Tolerance::SignificantDigits(1)));
    // Absolute 0.0005 mm whatever u.
    let abs = crate::Tolerance::AbsoluteMm(0.0005);
    assert!(run(0.00049, 3.0, abs));
    assert!(!run(0.00051, 3.0, abs));
}

/// `ndig` end to end: the point stops when σ is known to ndig digits, and the result agrees
/// with the closed form to that δ.
#[test]
fn grid_adaptive_ndig_stops_within_significant_digits() {
    let sc = scenario(
        "[grid.adaptive]\nndig = 2\nbatch = 1000\nmax_samples = 1000000",
        TWO_OBS,
        "",
        "tangent",
    );
    let a = sc.grid.as_ref().unwrap().adaptive.unwrap();
    assert_eq!(a.tolerance, crate::Tolerance::SignificantDigits(2));
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let r = study.run(&crate::RunOptions::adaptive(a, 4), None).unwrap();
    let p = &r.points[0];
    assert_eq!(p.converged, Some(true));
    assert!(p.count >= 4000 && p.count < 1_000_000, "count {}", p.count);
    let expect_y =
        1000f64.hypot(600.0) * 0.01f64.to_radians() / (2f64.sqrt() * (0.6f64).atan().sin());
    // σy ≈ 0.280 mm = 28 × 10⁻² → δ = 0.005 mm; the stopping rule bounds 2 standard errors
    // of the batch σ by δ, so 3δ is a > 3-standard-error band.
    let delta = crate::ndig_tolerance(expect_y, 2);
    assert!((delta - 0.005).abs() < 1e-15, "δ = {delta}");
    assert_abs_diff_eq!(p.sigma_mm.y, expect_y, epsilon = 3.0 * delta);
}

/// `[grid.adaptive]` takes exactly one of `tolerance_mm` and `ndig`.
#[test]
fn adaptive_keys_exactly_one_tolerance() {
    let parse = |body: &str| {
        let text = format!(
            "[grid]\nx_mm = [0.0, 0.0, 1]\ny_mm = [1000.0, 1000.0, 1]\nz_mm = [0.0, 0.0, 1]\n[grid.adaptive]\n{body}\n{TWO_OBS}"
        );
        Scenario::from_toml_str(&text, Path::new("g.toml"))
            .map(|s| s.grid.unwrap().adaptive.unwrap())
    };
    assert_eq!(
        parse("tolerance_mm = 0.1").unwrap().tolerance,
        crate::Tolerance::AbsoluteMm(0.1)
    );
    assert_eq!(
        parse("ndig = 3").unwrap().tolerance,
        crate::Tolerance::SignificantDigits(3)
    );
    for (body, key) in [
        ("batch = 500", "`grid.adaptive`"),
        ("tolerance_mm = 0.1\nndig = 2", "`grid.adaptive.ndig`"),
        ("ndig = 0", "`grid.adaptive.ndig`"),
        ("ndig = 16", "`grid.adaptive.ndig`"),
        ("ndig = 2.5", "g.toml:6"),
    ] {
        let e = crashrig_input::message::error_line(&parse(body).unwrap_err());
        assert!(e.contains("g.toml") && e.contains(key), "{body}: {e}");
    }
}

/// Records the `(done, total)` reports of a run.
struct Recorder(std::sync::Mutex<Vec<(usize, usize)>>);

impl Recorder {
    fn new() -> Self {
        Self(std::sync::Mutex::new(Vec::new()))
    }

    fn report(&self, d: usize, t: usize) {
        self.0.lock().unwrap().push((d, t));
    }

    /// Every report within `total`, and the largest one at `total`.
    fn assert_complete(&self, total: usize) {
        let seen = self.0.lock().unwrap();
        assert!(!seen.is_empty());
        assert!(seen.iter().all(|&(d, t)| t == total && d <= t), "{seen:?}");
        assert_eq!(seen.iter().map(|r| r.0).max(), Some(total));
    }
}

const FIXED_TWO: &str = r#"
[[grid.observer]]
name = "rear"
aim = "fixed"
position_mm = [200.0, 0.0, 100.0]
look_at_mm = [1200.0, 0.0, 0.0]
camera = { model = "OPENCV", width = 2560, height = 1440, params = [1600.0, 1610.0, 1280.3, 719.6, -0.08, 0.02, 0.0005, -0.0003] }
pixel_sigma_px = 0.5
sigma_position_mm = [1.5, 1.2, 1.0]
sigma_angles_deg = [0.01, 0.02, 0.012]
[[grid.observer]]
name = "door"
aim = "fixed"
position_mm = [1300.0, -700.0, 150.0]
angles_deg = [-100.0, 0.0, 0.0]
camera = { model = "OPENCV_FISHEYE", width = 1920, height = 1080, params = [700.0, 702.0, 955.0, 545.0, 0.05, -0.01, 0.002, -0.001] }
pixel_sigma_px = 0.8
sigma_position_mm = [2.0, 2.0, 2.0]
sigma_angles_deg = [0.02, 0.02, 0.02]
"#;

/// Progress reports never change a result (bit-identical with and without a callback), stay
/// within their totals and reach them: aimed and fixed observers, fixed and adaptive draws,
/// and the chain propagation.
#[test]
fn progress_reports_complete_and_results_unchanged() {
    let grid = |adaptive: &str, obs: &str| {
        let text = format!(
            "seed = 5\nsamples = 9000\n[grid]\nx_mm = [900.0, 1500.0, 3]\ny_mm = [-200.0, 200.0, 2]\nz_mm = [0.0, 0.0, 1]\n{adaptive}\n{obs}"
        );
        Scenario::from_toml_str(&text, Path::new("p.toml")).unwrap()
    };
    let aimed_obs = TWO_OBS.replace("600.0, 0.0, 0.0", "600.0, 0.0, 300.0");
    let adaptive = "[grid.adaptive]\ntolerance_mm = 0.05\nbatch = 500\nmax_samples = 5000";
    for sc in [
        grid("", &aimed_obs),
        grid(adaptive, &aimed_obs),
        grid("", FIXED_TWO),
        grid(adaptive, FIXED_TWO),
    ] {
        let study = GridStudy::new(&sc, sc.samples, sc.seed).unwrap();
        let rec = Recorder::new();
        let report = |d: usize, t: usize| rec.report(d, t);
        let with = study.run(&study.options(), Some(&report)).unwrap();
        assert_eq!(with, study.run(&study.options(), None).unwrap());
        rec.assert_complete(6);
        // One report per measurable point (when its last chunk or batch is done), then the
        // final one.
        let measurable = with.points.iter().filter(|p| p.is_measurable()).count();
        assert!(measurable > 0);
        assert_eq!(rec.0.lock().unwrap().len(), measurable + 1);
    }
    // The chain: 9 000 draws are 3 chunks of CHUNK = 4096.
    let sc = scenario(
        "",
        TWO_OBS,
        "[[camera]]\nname = \"a\"\nposition_mm = [0.0, 0.0, 0.0]\nangles_deg = [0.0, 0.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.1, 0.1, 0.1]\n",
        "tangent",
    );
    let chain = Chain::new(&sc);
    let rec = Recorder::new();
    let report = |d: usize, t: usize| rec.report(d, t);
    let options = crate::ChainOptions::new(9000, 3);
    let with = chain.monte_carlo(&options, Some(&report)).unwrap();
    assert_eq!(with, chain.monte_carlo(&options, None).unwrap());
    rec.assert_complete(3);
    // One report per chunk plus the final one.
    assert_eq!(rec.0.lock().unwrap().len(), 4);
}

/// A monitor that cancels once `after` reports have arrived.
struct StopAfter {
    after: usize,
    seen: std::sync::atomic::AtomicUsize,
}

impl StopAfter {
    fn new(after: usize) -> Self {
        Self {
            after,
            seen: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    fn seen(&self) -> usize {
        self.seen.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl crashrig_stats::progress::Monitor for StopAfter {
    fn report(&self, _: usize, _: usize) {
        self.seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    fn cancelled(&self) -> bool {
        self.seen() >= self.after
    }
}

/// A monitor that cancels makes both entries return the typed `Cancelled` error, and no unit
/// of work starts after it said so (one thread: the points of the first unit that finishes
/// any — a group of [`crate::map::GROUP`] points' last chunk, or an adaptive point, or a
/// chain chunk — are the only reports): aimed and fixed observers, fixed and adaptive draws,
/// and the chain. The grid has more points than a group, so work is left to skip.
#[test]
fn cancelled_runs_return_cancelled_and_stop_working() {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let grid = |adaptive: &str, obs: &str| {
        let text = format!(
            "seed = 5\nsamples = 9000\n[grid]\nx_mm = [900.0, 1500.0, 9]\ny_mm = [-200.0, 200.0, 2]\nz_mm = [0.0, 0.0, 1]\n{adaptive}\n{obs}"
        );
        Scenario::from_toml_str(&text, Path::new("p.toml")).unwrap()
    };
    let aimed_obs = TWO_OBS.replace("600.0, 0.0, 0.0", "600.0, 0.0, 300.0");
    let adaptive = "[grid.adaptive]\ntolerance_mm = 0.05\nbatch = 500\nmax_samples = 5000";
    for (sc, first_unit) in [
        (grid("", &aimed_obs), crate::map::GROUP),
        (grid(adaptive, &aimed_obs), 1),
        (grid("", FIXED_TWO), crate::map::GROUP),
        (grid(adaptive, FIXED_TWO), 1),
    ] {
        let study = GridStudy::new(&sc, sc.samples, sc.seed).unwrap();
        assert!(study.grid().points().len() > crate::map::GROUP);
        for after in [0, 1] {
            let stop = StopAfter::new(after);
            let r = one.install(|| study.run(&study.options(), Some(&stop)));
            assert!(matches!(r, Err(Error::Cancelled(_))), "{r:?}");
            assert_eq!(stop.seen(), after * first_unit);
        }
    }
    let sc = scenario(
        "",
        TWO_OBS,
        "[[camera]]\nname = \"a\"\nposition_mm = [0.0, 0.0, 0.0]\nangles_deg = [0.0, 0.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.1, 0.1, 0.1]\n",
        "tangent",
    );
    let chain = Chain::new(&sc);
    for after in [0, 1] {
        let stop = StopAfter::new(after);
        let r = one.install(|| chain.monte_carlo(&crate::ChainOptions::new(9000, 3), Some(&stop)));
        assert!(matches!(r, Err(Error::Cancelled(_))), "{r:?}");
        assert_eq!(stop.seen(), after);
    }
}

/// Every selection of points (the shards of `--shard i/N`: ranges across groups and windows of
/// the scheduler) and every thread count gives each point the bits of the whole map: in
/// correlated mode a point's draws are its own stream plus the map's chain draw of each
/// replicate, whoever else is drawn with it. Aimed and fixed observers, correlated and
/// independent, a partial last chunk.
#[test]
fn every_selection_and_thread_count_gives_the_whole_maps_bits() {
    let aimed = Scenario::from_toml_str(
        &crate::testdata::repo_file("fixtures/scenarios/three_cameras_correlated.toml"),
        Path::new("c.toml"),
    )
    .unwrap();
    let fixed =
        Scenario::from_toml_str(&crate::testdata::real_map_small(), Path::new("r.toml")).unwrap();
    let pool = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
    };
    for sc in [aimed, fixed] {
        let study = GridStudy::new(&sc, 2000, 1).unwrap();
        for s in [study.clone(), study.independent()] {
            let o = crate::RunOptions::samples(crate::CHUNK + 100, 3);
            let whole = pool(2).install(|| s.run(&o, None).unwrap());
            assert_eq!(pool(1).install(|| s.run(&o, None).unwrap()), whole);
            let n = whole.points.len();
            for g in [crate::map::GROUP, crate::map::CHAIN_GROUP] {
                for r in [0..1, 0..g + 1, 3..g + 5, g - 1..n.min(2 * g + 3), n - 2..n] {
                    let r = r.start.min(n)..r.end.min(n);
                    let part = pool(2).install(|| s.with_points(r.clone()).unwrap().run(&o, None));
                    assert_eq!(part.unwrap().points, whole.points[r.clone()], "{r:?}");
                }
            }
        }
    }
}

/// The adaptive rule draws the same replicates as a fixed number of draws: batch b of point p
/// is task `p·2²⁴ + b` with replicates `b·batch ..` (the map's chain draw of each replicate in
/// correlated mode), so with batches of one chunk, stopping at `max_samples`, it gives the
/// fixed run's statistics bit for bit (aimed and fixed observers, correlated).
#[test]
fn adaptive_batches_of_a_chunk_are_the_fixed_runs_draws() {
    let aimed = Scenario::from_toml_str(
        &crate::testdata::repo_file("fixtures/scenarios/three_cameras_correlated.toml"),
        Path::new("c.toml"),
    )
    .unwrap();
    let fixed =
        Scenario::from_toml_str(&crate::testdata::real_map_small(), Path::new("r.toml")).unwrap();
    let n = ADAPTIVE_MIN_BATCHES * crate::CHUNK;
    for sc in [aimed, fixed] {
        let study = GridStudy::new(&sc, 2000, 1)
            .unwrap()
            .with_points(3..9)
            .unwrap();
        let fixed_run = study.run(&crate::RunOptions::samples(n, 5), None).unwrap();
        // A tolerance no batch meets: every point stops at max_samples.
        let ad = adaptive(crate::Tolerance::AbsoluteMm(1e-6), crate::CHUNK, n);
        let adaptive_run = study
            .run(&crate::RunOptions::adaptive(ad, 5), None)
            .unwrap();
        assert!(adaptive_run.correlated);
        for (a, f) in adaptive_run.points.iter().zip(&fixed_run.points) {
            assert_eq!(a.converged, Some(false));
            assert_eq!(
                (a.count, a.mean_mm, a.covariance),
                (f.count, f.mean_mm, f.covariance)
            );
        }
    }
}
