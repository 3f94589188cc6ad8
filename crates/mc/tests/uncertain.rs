//! Uncertain poses through the chain and the grid: an independent NumPy Monte Carlo of a
//! 3-camera chain with full covariances, the rig-yaw evidence of the correlated mode, the
//! builders against the TOML front end, and full observer covariances in the grid.
#![allow(clippy::needless_range_loop)] // index loops mirror the per-entry criteria

use crashrig_geometry::uncertain::UncertainPose;
use crashrig_geometry::{Mat6, Rigid3, Vec3, quat};
use crashrig_mc::{Axis, Chain, ChainBuilder, Error, GridBuilder, GridStudy, Scenario};
use nalgebra::{Matrix6, Vector3};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/mc")
        .join(name)
}

fn mat6(v: &serde_json::Value) -> Mat6 {
    Mat6::from_fn(|i, j| v[i][j].as_f64().unwrap())
}

/// Radians → the contract's degrees on the rotation rows/columns.
fn to_deg(c: &Matrix6<f64>) -> Mat6 {
    let k = |i: usize| {
        if i < 3 {
            1.0
        } else {
            180.0 / std::f64::consts::PI
        }
    };
    Mat6::from_fn(|i, j| c[(i, j)] * k(i) * k(j))
}

/// Largest |a − b| over the entries, in units of the reference's σᵢσⱼ (the correlation
/// scale), so off-diagonal entries near zero are judged on the scale of their variables.
fn worst(a: &Mat6, b: &Mat6) -> f64 {
    let mut w = 0.0f64;
    for i in 0..6 {
        for j in 0..6 {
            let scale = (b[(i, i)] * b[(j, j)]).sqrt();
            w = w.max((a[(i, j)] - b[(i, j)]).abs() / scale);
        }
    }
    w
}

#[test]
fn numpy_reference_chain_full_covariances() {
    // fixtures/mc: a 3-camera chain with full, correlated covariances on every pose and link
    // (cam2's link at φ = −74°), propagated by an independent NumPy Monte Carlo of 2·10⁶ draws
    // (SVD-factored multivariate normals) and by central differences of the same composition.
    let sc = Scenario::from_path(&fixture("chain_reference.toml")).unwrap();
    let text = std::fs::read_to_string(fixture("chain_reference.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let chain = Chain::new(&sc);
    let n = 400_000;
    let mc = chain
        .monte_carlo(&crashrig_mc::ChainOptions::new(n, sc.seed), None)
        .unwrap();
    let lin = chain.linear();
    for (i, r) in reference["cameras"].as_array().unwrap().iter().enumerate() {
        assert_eq!(mc[i].name, r["name"].as_str().unwrap());
        let c_ref = mat6(&r["mc_covariance_tangent"]);
        let l_ref = mat6(&r["linear_covariance_tangent"]);
        let c_mc = to_deg(&mc[i].covariance_tangent);
        let c_lin = to_deg(&lin[i].covariance_tangent);
        let p_ref = Vector3::from_fn(|k, _| r["position_mm"][k].as_f64().unwrap());
        assert!((mc[i].nominal.position_mm - p_ref).norm() < 1e-9);
        // Criteria of the issue: MC σ and covariance within 2 %, linear within 3 %. Standard
        // errors: a σ estimate has relative SE 1/√(2n) (0.11 % here, 0.05 % for the
        // reference); a covariance entry has SE ≤ √((1+ρ²)/n)·σᵢσⱼ ≤ 0.22 % of σᵢσⱼ here and
        // 0.1 % for the reference. So 2 % is > 8 combined SE: a wrong factor, frame or
        // lever arm (errors of tens of %) fails, MC noise does not.
        for k in 0..6 {
            let s_ref = r["mc_sigma"][k].as_f64().unwrap();
            let s = c_mc[(k, k)].sqrt();
            assert!(
                (s / s_ref - 1.0).abs() < 0.02,
                "{} σ[{k}]: {s} vs NumPy {s_ref}",
                mc[i].name
            );
        }
        let w = worst(&c_mc, &c_ref);
        assert!(w < 0.02, "{}: MC covariance off by {w} σᵢσⱼ", mc[i].name);
        // First order against the NumPy Monte Carlo: the chain is linear to ~1e-4 for these
        // σ, so 3 % is MC error (≤ 0.1 %) plus far more than the non-linearity.
        let w = worst(&c_lin, &c_ref);
        assert!(
            w < 0.03,
            "{}: linear covariance off by {w} σᵢσⱼ",
            mc[i].name
        );
        // And against NumPy's finite-difference first order: the same quantity, computed
        // independently (truncation O(h²) ≈ 1e-8 relative, rounding ≈ 1e-9).
        let w = worst(&c_lin, &l_ref);
        assert!(w < 1e-6, "{}: linear vs NumPy FD {w}", mc[i].name);
        // The reported σ are the square roots of those diagonals.
        for k in 0..3 {
            assert!((mc[i].position_sigma_mm[k] - c_mc[(k, k)].sqrt()).abs() < 1e-9);
            let t = mc[i].tangent_sigma_rad[k].to_degrees();
            assert!((t - c_mc[(3 + k, 3 + k)].sqrt()).abs() < 1e-12);
        }
    }
}

fn axis(a: f64, b: f64, n: usize) -> Axis {
    Axis {
        start: a,
        stop: b,
        count: n,
    }
}

/// A rank-one rotation covariance: σ² about the world axis `w` for a camera whose
/// `R_world_from_cam` is `r` (the body-axis direction is `rᵀw`).
fn yaw_only(r: &nalgebra::Rotation3<f64>, sigma_rad: f64) -> Mat6 {
    let a = r.inverse() * Vector3::z();
    let mut m = Mat6::zeros();
    m.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(a * a.transpose() * sigma_rad * sigma_rad));
    m
}

#[test]
fn correlated_rig_yaw_moves_the_point_by_its_lever_arm() {
    // A rig whose only error is a pure yaw of 0.01° about the world z axis through its origin,
    // two observers carried by it (certain links), a point 1500 mm away: every draw moves all
    // cameras rigidly, so the intersected point turns with them and moves by
    // 1500 mm · 0.01° = 0.2618 mm across the line of sight. The rig's own axes are rotated
    // (ω φ κ = 30°, −50°, 80°) so the world-frame rule `R_obs = Exp(R̄·θ)·L` is exercised.
    let r = crashrig_geometry::opk::rotation_from_opk(
        30f64.to_radians(),
        (-50f64).to_radians(),
        80f64.to_radians(),
    );
    let sigma = 0.01f64.to_radians();
    let rig_pose = UncertainPose::new(
        quat::rigid_from_rotation(&r, &Vec3::zeros()),
        yaw_only(&r, sigma),
    )
    .unwrap();
    let mut b = ChainBuilder::new();
    let rig = b.world("rig", rig_pose).unwrap();
    // Links in the rig's own axes that put the observers at (0, ∓200, 0) in the world.
    let at = |p: Vec3| {
        let q = r.inverse() * p;
        UncertainPose::certain(Rigid3::translation(q.x, q.y, q.z))
    };
    let left = b
        .link("left", rig, at(Vec3::new(0.0, -200.0, 0.0)))
        .unwrap();
    let right = b
        .link("right", rig, at(Vec3::new(0.0, 200.0, 0.0)))
        .unwrap();
    let chain = b.build();
    let study = GridBuilder::new(
        axis(1500.0, 1500.0, 1),
        axis(0.0, 0.0, 1),
        axis(0.0, 0.0, 1),
    )
    .chain(chain)
    .observer_from("left", Vector3::new(0.0, -200.0, 0.0), left)
    .observer_from("right", Vector3::new(0.0, 200.0, 0.0), right)
    .correlated(true)
    .build(20_000, 11)
    .unwrap();
    let res = study.run(&study.options(), None).unwrap();
    let p = &res.points[0];
    let expect = 1500.0 * sigma;
    assert!((expect - 0.2618).abs() < 1e-4);
    // 2 % is 2.8 standard errors of a σ from 20 000 draws (1/√(2n) = 0.5 %).
    assert!(
        (p.sigma_mm.y / expect - 1.0).abs() < 0.02,
        "σy = {} mm, want {expect}",
        p.sigma_mm.y
    );
    // Along the line of sight only the second order: x = 1500·(1 − cos θ) ≈ 1500·θ²/2, whose
    // σ is 1500·σ²/√2 = 3.2e-5 mm (bound: twice that); nothing along z.
    let second = 1500.0 * sigma * sigma / 2f64.sqrt();
    assert!(p.sigma_mm.x < 2.0 * second, "{:?}", p.sigma_mm);
    assert!(p.sigma_mm.z < 1e-9, "{:?}", p.sigma_mm);
    // The first-order map carries the joint draw through the chain's Jacobians: exactly
    // 1500·σ across, nothing else (rounding only).
    let l = p.linear_sigma_mm();
    assert!((l.y / expect - 1.0).abs() < 1e-9, "{l:?}");
    assert!(l.x < 1e-9 * expect && l.z < 1e-9 * expect, "{l:?}");
}

#[test]
fn correlated_fixture_monte_carlo_matches_first_order() {
    // The bundled correlated scenario (one vehicle frame): with the shared chain errors in the
    // first-order map, Monte Carlo and first order agree point by point to the MC error
    // (3 SE of a σ estimate, 1/√(2n)) plus the non-linearity at these σ (< 0.1 %).
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/scenarios/three_cameras_correlated.toml");
    let mut sc = Scenario::from_path(&path).unwrap();
    let g = sc.grid.as_mut().unwrap();
    g.x = axis(800.0, 1600.0, 3);
    g.y = axis(-300.0, 300.0, 2);
    let n = 40_000;
    let study = GridStudy::new(&sc, n, 3).unwrap();
    let r = study
        .run(&crashrig_mc::RunOptions::samples(n, 3), None)
        .unwrap();
    assert!(r.correlated);
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    for p in &r.points {
        for k in 0..3 {
            let l = p.linear_sigma_mm()[k];
            assert!(
                (p.sigma_mm[k] / l - 1.0).abs() < 3.0 * se + 1e-3,
                "{:?} axis {k}: MC {} vs linear {l}",
                p.point,
                p.sigma_mm[k]
            );
        }
    }
    // Treating the same observers as independent misses the correlation by far more.
    let ind = study
        .independent()
        .run(&crashrig_mc::RunOptions::samples(2, 3), None)
        .unwrap();
    let off = r
        .points
        .iter()
        .zip(&ind.points)
        .map(|(c, i)| (c.sigma_max_mm / i.linear_sigma_max_mm() - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(off > 0.05, "{off}");
}

#[test]
fn correlated_observer_must_stand_at_its_camera() {
    let text = r#"
[[camera]]
name = "rig"
position_mm = [0.0, -200.0, 0.0]
angles_deg = [0.0, 90.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
[grid]
x_mm = [1500.0, 1500.0, 1]
y_mm = [0.0, 0.0, 1]
z_mm = [0.0, 0.0, 1]
correlated = true
[[grid.observer]]
position_mm = [0.0, -198.5, 0.0]
sigma_from = "rig"
[[grid.observer]]
position_mm = [0.0, 200.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;
    let err = Scenario::from_toml_str(text, Path::new("c.toml")).unwrap_err();
    let msg = crashrig_input::message::error_line(&err);
    assert!(
        msg.starts_with("c.toml:14: `grid.observer[0].position_mm`:"),
        "{msg}"
    );
    assert!(msg.contains("1.500 mm away"), "{msg}");
    // Within 1 mm it is accepted (and the observer stands exactly at the camera).
    let ok = text.replace("-198.5", "-199.5");
    Scenario::from_toml_str(&ok, Path::new("c.toml")).unwrap();
    // Without `correlated` the observer may stand anywhere.
    let free = text.replace("correlated = true", "");
    Scenario::from_toml_str(&free, Path::new("c.toml")).unwrap();
}

#[test]
fn builder_chain_equals_the_toml_front_end() {
    let sc = Scenario::from_path(&fixture("chain_reference.toml")).unwrap();
    let mut b = ChainBuilder::new();
    let mut ids = Vec::new();
    for c in &sc.cameras {
        // The fixture lists parents first, so the file index is the builder's.
        let id = match c.parent {
            None => b.world(c.name.clone(), c.pose).unwrap(),
            Some(p) => b.link(c.name.clone(), ids[p], c.pose).unwrap(),
        };
        ids.push(id);
    }
    assert_eq!(ids.iter().map(|i| i.index()).collect::<Vec<_>>(), [0, 1, 2]);
    let built = b.build();
    // Same draws, same composition: bit-identical.
    assert_eq!(
        built
            .monte_carlo(&crashrig_mc::ChainOptions::new(5000, 3), None)
            .unwrap(),
        Chain::new(&sc)
            .monte_carlo(&crashrig_mc::ChainOptions::new(5000, 3), None)
            .unwrap()
    );
    assert_eq!(built.linear(), Chain::new(&sc).linear());
}

#[test]
fn builder_rejects_duplicates_and_bad_covariances() {
    let mut b = ChainBuilder::new();
    let a = b
        .world("a", UncertainPose::certain(Rigid3::identity()))
        .unwrap();
    assert!(matches!(
        b.link("a", a, UncertainPose::certain(Rigid3::identity())),
        Err(Error::DuplicateName { .. })
    ));
    let mut bad = UncertainPose::certain(Rigid3::identity());
    bad.covariance[(0, 0)] = -1.0;
    assert!(matches!(b.link("b", a, bad), Err(Error::Covariance { .. })));
}

#[test]
fn grid_full_observer_covariance_matches_linear() {
    // Two observers with full tangent covariances (position–rotation cross terms): the
    // Monte Carlo draws δ = L·ε must reproduce the first-order map J Σ Jᵀ, which is exact
    // for these small σ up to ~1e-5; criterion 3 SE of a σ estimate (1/√(2n)).
    let full = |s: [f64; 6], rho: f64| {
        Matrix6::from_fn(|i, j| {
            if i == j {
                s[i] * s[i]
            } else {
                rho * s[i] * s[j]
            }
        })
    };
    let sp = 0.8;
    let sr = 0.02f64.to_radians();
    let study = GridBuilder::new(
        axis(300.0, 300.0, 1),
        axis(1200.0, 1200.0, 1),
        axis(100.0, 100.0, 1),
    )
    .observer(
        "a",
        Vector3::new(-600.0, 0.0, 0.0),
        full([sp, sp, sp, sr, sr, sr], 0.6),
    )
    .observer(
        "b",
        Vector3::new(700.0, 100.0, 0.0),
        full([sp, 0.5 * sp, sp, sr, 2.0 * sr, sr], -0.15),
    )
    .build(100_000, 21)
    .unwrap();
    let r = study.run(&study.options(), None).unwrap();
    let p = &r.points[0];
    let se = 1.0 / (2.0 * 99_999f64).sqrt();
    for k in 0..3 {
        let l = p.linear_sigma_mm()[k];
        assert!(
            (p.sigma_mm[k] / l - 1.0).abs() < 3.0 * se,
            "axis {k}: MC {} vs linear {l}",
            p.sigma_mm[k]
        );
    }
    // The correlations matter: with the diagonal only, σ differs by more than 10 SE.
    let diag = |m: Matrix6<f64>| Matrix6::from_diagonal(&m.diagonal());
    let study_d = GridBuilder::new(
        axis(300.0, 300.0, 1),
        axis(1200.0, 1200.0, 1),
        axis(100.0, 100.0, 1),
    )
    .observer(
        "a",
        Vector3::new(-600.0, 0.0, 0.0),
        diag(full([sp, sp, sp, sr, sr, sr], 0.6)),
    )
    .observer(
        "b",
        Vector3::new(700.0, 100.0, 0.0),
        diag(full([sp, 0.5 * sp, sp, sr, 2.0 * sr, sr], -0.15)),
    )
    .build(100_000, 21)
    .unwrap();
    let pd = &study_d.run(&study_d.options(), None).unwrap().points[0];
    let diff = (0..3)
        .map(|k| (pd.linear_sigma_mm()[k] / p.linear_sigma_mm()[k] - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(diff > 10.0 * se, "{diff}");
}

#[test]
fn sigma_from_takes_the_full_propagated_covariance() {
    let text = std::fs::read_to_string(fixture("chain_reference.toml")).unwrap()
        + r#"
[grid]
x_mm = [1000.0, 1000.0, 1]
y_mm = [2000.0, 2000.0, 1]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
position_mm = [0.0, 0.0, 0.0]
sigma_from = "cam3"
[[grid.observer]]
position_mm = [2000.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;
    let sc = Scenario::from_toml_str(&text, Path::new("s.toml")).unwrap();
    let study = GridStudy::new(&sc, 1000, 5).unwrap();
    let r = study
        .run(&crashrig_mc::RunOptions::samples(1000, 5), None)
        .unwrap();
    let got = to_deg(&r.observer_covariance[0]);
    let lin = to_deg(&Chain::new(&sc).linear()[2].covariance_tangent);
    // Propagated with ≥ 10⁵ chain draws: entries within 2 % of σᵢσⱼ (> 9 SE).
    let w = worst(&got, &lin);
    assert!(w < 0.02, "{w}");
    // It is the full matrix, not its diagonal.
    assert!(got[(0, 3)].abs() > 0.1 * (got[(0, 0)] * got[(3, 3)]).sqrt());
}

#[test]
fn diagonal_covariance_tangent_is_the_sigma_keys() {
    // `covariance_tangent = diag(σ²)` (mm², deg²) and the σ keys with tangent noise are the
    // same noise: same factor up to rounding (σ → σ² → √ and deg → rad in another order), so
    // the same draws give the same σ to ~1e-13 relative.
    let sigma = r#"sigma_position_mm = [0.5, 0.7, 0.9]
sigma_angles_deg = [0.01, 0.02, 0.03]"#;
    let cov = r#"covariance_tangent = [
  [0.25, 0, 0, 0, 0, 0],
  [0, 0.49, 0, 0, 0, 0],
  [0, 0, 0.81, 0, 0, 0],
  [0, 0, 0, 1e-4, 0, 0],
  [0, 0, 0, 0, 4e-4, 0],
  [0, 0, 0, 0, 0, 9e-4],
]"#;
    let text = |noise: &str| {
        format!(
            "[[camera]]\nname = \"a\"\nposition_mm = [1.0, 2.0, 3.0]\nangles_deg = [10.0, 20.0, 30.0]\n{noise}\n[[camera]]\nname = \"b\"\nparent = \"a\"\nposition_mm = [100.0, 0.0, 500.0]\nangles_deg = [0.0, 90.0, 0.0]\n{noise}\n"
        )
    };
    let a = Scenario::from_toml_str(&text(sigma), Path::new("a.toml")).unwrap();
    let b = Scenario::from_toml_str(&text(cov), Path::new("b.toml")).unwrap();
    let (ma, mb) = (
        Chain::new(&a)
            .monte_carlo(&crashrig_mc::ChainOptions::new(5000, 1), None)
            .unwrap(),
        Chain::new(&b)
            .monte_carlo(&crashrig_mc::ChainOptions::new(5000, 1), None)
            .unwrap(),
    );
    for (x, y) in ma.iter().zip(&mb) {
        let d = (x.covariance_tangent - y.covariance_tangent).amax();
        assert!(d <= 1e-12 * x.covariance_tangent.amax(), "{d}");
    }
}

#[test]
fn euler_sigma_from_at_gimbal_lock_takes_the_tangent_covariance() {
    // A chain camera looking along world x (φ = 90°) in an `euler` scenario: its ω φ κ have no
    // covariance, so an observer with `sigma_from` gets its tangent covariance (≥ 10⁵ chain
    // draws: the input σ within 1 %, > 4 SE) and tangent noise, and a finite map.
    let text = r#"rotation_noise = "euler"
[[camera]]
name = "fwd"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 90.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.02, 0.03]
[grid]
x_mm = [1000.0, 1000.0, 1]
y_mm = [0.0, 0.0, 1]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
position_mm = [0.0, -300.0, 0.0]
sigma_from = "fwd"
[[grid.observer]]
position_mm = [0.0, 300.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]
"#;
    let sc = Scenario::from_toml_str(text, Path::new("e.toml")).unwrap();
    let study = GridStudy::new(&sc, 2000, 1).unwrap();
    let r = study
        .run(&crashrig_mc::RunOptions::samples(2000, 1), None)
        .unwrap();
    let s = r.observer_sigma[0].angles_rad.map(f64::to_degrees);
    // Euler noise (a, b, c) on (0°, 90°, 0°): Rx(a)·Ry(90° + b)·Rz(c) = R̄·Exp(b e_y)·Exp((a + c) e_z)
    // to first order (R̄ᵀe_x = e_z), so the body-axis σ are (0, σφ, √(σω² + σκ²)).
    let want = [0.0, 0.02, (0.01f64.powi(2) + 0.03f64.powi(2)).sqrt()];
    assert!(s.x < 1e-3 * want[2], "{s:?}");
    for k in 1..3 {
        assert!((s[k] / want[k] - 1.0).abs() < 0.01, "{s:?}");
    }
    assert!(
        r.points[0].sigma_max_mm < 10.0,
        "{}",
        r.points[0].sigma_max_mm
    );
}
