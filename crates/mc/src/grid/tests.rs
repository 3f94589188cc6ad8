//! Tests of the grid study: closed form, Jacobian, linear agreement, determinism,
//! correlation, pixel noise and adaptive stopping.
#![allow(clippy::needless_range_loop)] // index loops mirror the per-axis formulas

use super::*;
use crate::Scenario;
use approx::assert_abs_diff_eq;
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
    let r = study.run(n, 42).unwrap();
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
        let p = &study.run(n, 8).unwrap().points[0];
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
    let p = &study.run(n, 8).unwrap().points[0];
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
            .install(|| study.run(2 * crate::CHUNK + 5, 77).unwrap())
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
    let corr = study.run(n, 5).unwrap();
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for k in 0..3 {
        assert_abs_diff_eq!(corr.points[0].sigma_mm[k], 1.0, epsilon = 3.0 * se);
    }
    let ind = study.independent().run(n, 5).unwrap();
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
    let r = study.run_adaptive(&a, 4).unwrap();
    let p = &r.points[0];
    assert!(p.count >= 2000 && p.count < 200_000, "count {}", p.count);
    assert_eq!(p.count % 500, 0);
    // The result agrees with the closed form to the requested tolerance (2u ≤ δ ⇒ ~95 %
    // coverage of δ around the estimate; allow 2δ for the bound being on batch σ).
    let expect_y =
        1000f64.hypot(600.0) * 0.01f64.to_radians() / (2f64.sqrt() * (0.6f64).atan().sin());
    assert_abs_diff_eq!(p.sigma_mm.y, expect_y, epsilon = 0.02);
    // Deterministic.
    assert_eq!(r, study.run_adaptive(&a, 4).unwrap());
}

#[test]
fn ellipsoid_semi_axes_nominal() {
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let p = &study.run(20_000, 1).unwrap().points[0];
    let ax = p.ellipsoid_semi_axes_mm();
    // The symmetric geometry has axes along x, y, z: semi-axes are the sorted σ.
    let mut s: Vec<f64> = p.sigma_mm.iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    for k in 0..3 {
        // Off-diagonal sample covariance ~ σ²/√n perturbs the eigenvalues at second order.
        assert_abs_diff_eq!(ax[k], s[k], epsilon = 0.02 * s[k]);
    }
}

#[test]
fn slow_grid_closed_form_large_n() {
    if std::env::var_os("CRASHRIG_SLOW").is_none() {
        return;
    }
    // The closed form of `grid_nominal_symmetric_closed_form` at 4·10⁶ draws: 3 SE is
    // 0.1 % of σ, small enough to see a bias of the kernel or of the normals.
    let sc = scenario("", TWO_OBS, "", "tangent");
    let study = GridStudy::new(&sc, 0, 0).unwrap();
    let n = 4_000_000;
    let p = &study.run(n, 4242).unwrap().points[0];
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
