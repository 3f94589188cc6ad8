//! Tests of the joint errors: a rigid shared shift (known answer), the map's marginals, the σ
//! of a distance against an independent scalar simulation, and the refusals.

use super::*;
use crate::grid::{INPUTS_PER_OBSERVER, intersect_perturbed};
use crate::testdata::{real_map_small, repo_file};
use crate::{GridStudy, Scenario};
use approx::assert_abs_diff_eq;
use std::path::Path;

fn scenario(text: &str) -> Scenario {
    Scenario::from_toml_str(text, Path::new("joint.toml")).unwrap()
}

/// Two observers hanging off one root that carries all the noise (1 mm of position), drawn
/// jointly: every intersected point moves by exactly the root's shift.
const RIGID: &str = r#"
seed = 3
samples = 2000
rotation_noise = "tangent"
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
[grid]
x_mm = [-300.0, 300.0, 4]
y_mm = [800.0, 1200.0, 3]
z_mm = [0.0, 200.0, 2]
correlated = true
[[grid.observer]]
position_mm = [-600.0, 0.0, 0.0]
sigma_from = "a"
[[grid.observer]]
position_mm = [600.0, 0.0, 0.0]
sigma_from = "b"
"#;

#[test]
fn rigid_shared_shift_cancels_in_every_distance() {
    // Known answer: X_p − P_p is the root's shift s in every replicate, for every point p. So
    // every cross-covariance equals each point's own covariance (the sample covariance of s,
    // ≈ I mm²) and every distance is the nominal one: σ = 0 up to rounding. Drawn
    // independently (one draw per point), the points are uncorrelated and the distance
    // varies by about √(2·σ²).
    let study = GridStudy::new(&scenario(RIGID), 20_000, 1).unwrap();
    let n = 20_000;
    let idx = [0, 5, 13, 23];
    let j = study.joint(&idx, &RunOptions::samples(n, 9)).unwrap();
    assert_eq!(j.count, n as u64);
    let se = 1.0 / (2.0 * (n as f64 - 1.0)).sqrt();
    let own = j.cross_covariance(0, 0);
    for i in 0..3 {
        assert_abs_diff_eq!(own[(i, i)].sqrt(), 1.0, epsilon = 3.0 * se);
    }
    for a in 0..idx.len() {
        for b in 0..idx.len() {
            let c = j.cross_covariance(a, b);
            assert!((c - own).abs().max() < 1e-9, "{a} {b}: {c} vs {own}");
        }
    }
    for d in &j.distances {
        assert!(d.sigma_mm < 1e-9, "{d:?}");
        assert!((d.mean_mm - d.nominal_mm).abs() < 1e-9, "{d:?}");
    }
    assert_eq!(j.distances.len(), 6);
    let ind = study
        .independent()
        .joint(&idx, &RunOptions::samples(n, 9))
        .unwrap();
    for d in &ind.distances {
        // Two independent points of σ ≈ 1.1–2 mm per axis: the distance varies by > 1 mm.
        assert!(d.sigma_mm > 1.0, "{d:?}");
    }
    for i in 0..3 {
        // Uncorrelated: a sample correlation within 4/√n of zero.
        let c = ind.cross_covariance(0, 1)[(i, i)];
        let r = c / (ind.covariance[(i, i)] * ind.covariance[(3 + i, 3 + i)]).sqrt();
        assert!(r.abs() < 4.0 / (n as f64).sqrt(), "axis {i}: r = {r}");
    }
}

#[test]
fn joint_marginals_are_the_maps_points() {
    // The joint run draws each point exactly as the map does (its own stream and the shared
    // chain draw of each replicate): the diagonal blocks equal the map's covariances up to
    // the summation order (≈ 1e-15 relative), in correlated and independent mode, aimed-only
    // and with fixed lenses.
    let aimed = scenario(&repo_file(
        "fixtures/scenarios/three_cameras_correlated.toml",
    ));
    let n = 3 * crate::CHUNK + 17;
    for sc in [aimed, scenario(&real_map_small())] {
        let study = GridStudy::new(&sc, 2000, 1).unwrap();
        for s in [study.clone(), study.independent()] {
            let map = s.run(&RunOptions::samples(n, 4), None).unwrap();
            let idx = [1, 4, 7];
            let j = s.joint(&idx, &RunOptions::samples(n, 4)).unwrap();
            for (a, &i) in idx.iter().enumerate() {
                let want = map.points[i].covariance;
                let got = j.cross_covariance(a, a);
                assert!(
                    (got - want).abs().max() < 1e-9 * want.abs().max(),
                    "point {i}: {got} vs {want}"
                );
                assert!((j.mean_mm[a] - map.points[i].mean_mm).abs().max() < 1e-9);
            }
        }
    }
}

#[test]
fn distance_sigma_matches_an_independent_scalar_simulation() {
    // The reference draws the chain with other random numbers (ChaCha8 streams, the former
    // engine's ziggurat), composes it with the scalar formulas (`Chain::compose`), moves each observer
    // as a rigid body with its chain camera (centre shift, world rotation R·R̄ᵀ, i.e. the own-
    // axes rotation `chain_to_own·θ` with θ = log(R̄ᵀR)) and intersects each point with the
    // exact scalar model (`intersect_perturbed`): the σ of each replicate's distance must agree
    // with the joint run's within 4 standard errors of the difference of two σ estimates.
    let sc = scenario(&repo_file(
        "fixtures/scenarios/three_cameras_correlated.toml",
    ));
    let study = GridStudy::new(&sc, 20_000, 1).unwrap();
    let chain = study.chain().unwrap().clone();
    // Near and far pairs: the middle row and the corners of the 17 × 13 grid.
    let idx = [0, 110, 114, 220];
    let points: Vec<Vector3<f64>> = idx.iter().map(|&i| study.grid().points()[i]).collect();
    let obs = study.aim_all(&points).unwrap();
    let n = 40_000;
    let joint = study.joint(&idx, &RunOptions::samples(n, 5)).unwrap();
    let mut rng = crashrig_stats::stream(99, 0);
    let normals = crate::kernel::ziggurat::FastNormal::new();
    let mut eps = vec![0.0; 6 * chain.len()];
    let mut sums = vec![crashrig_stats::Moments::<1>::new(); joint.distances.len()];
    for _ in 0..n {
        normals.fill(&mut rng, &mut eps);
        let poses = chain.compose(&eps);
        let x: Vec<Vector3<f64>> = obs
            .iter()
            .map(|o| {
                let mut delta = vec![0.0; INPUTS_PER_OBSERVER * o.len()];
                for (k, a) in o.iter().enumerate() {
                    let i = a.source.expect("every observer is drawn from the chain");
                    let (dc, th) = chain.error_of(i, &poses[i]);
                    let w = a.chain_to_own * th;
                    delta[INPUTS_PER_OBSERVER * k..INPUTS_PER_OBSERVER * k + 6]
                        .copy_from_slice(&[dc.x, dc.y, dc.z, w.x, w.y, w.z]);
                }
                intersect_perturbed(o, &delta)
            })
            .collect();
        for (s, d) in sums.iter_mut().zip(&joint.distances) {
            s.push(&[(x[d.a] - x[d.b]).norm()]);
        }
    }
    let se = (2.0f64).sqrt() / (2.0 * (n as f64 - 1.0)).sqrt();
    for (s, d) in sums.iter().zip(&joint.distances) {
        let want = s.std_dev()[0];
        assert_abs_diff_eq!(d.sigma_mm, want, epsilon = 4.0 * se * want);
        assert!(
            d.sigma_mm > 0.01,
            "{d:?}: the test must see a distance error"
        );
    }
    // Sensitivity: the far pair's distance errs far less than two independent points would
    // (the shared chain error cancels), so the test can tell the two models apart.
    let far = joint.distance(0, 3).unwrap();
    let own = |a: usize| joint.cross_covariance(a, a).trace();
    assert!(far.sigma_mm < 0.8 * (own(0) + own(3)).sqrt(), "{far:?}");
}

#[test]
fn joint_refusals_name_the_problem() {
    let study = GridStudy::new(&scenario(RIGID), 2000, 1).unwrap();
    let o = RunOptions::samples(100, 1);
    let bad = |idx: &[usize], o: &RunOptions| match study.joint(idx, o) {
        Err(Error::Invalid { key, problem }) => {
            assert_eq!(key, "joint");
            problem
        }
        other => panic!("{other:?}"),
    };
    assert!(bad(&[], &o).contains("1 to 16"));
    assert!(bad(&(0..17).collect::<Vec<_>>(), &o).contains("1 to 16"));
    assert!(bad(&[1, 1], &o).contains("repeated"));
    assert!(bad(&[24], &o).contains("past the grid"));
    assert!(bad(&[0], &RunOptions::samples(1, 1)).contains("fixed number"));
    let adaptive = RunOptions::adaptive(
        crate::Adaptive {
            tolerance: crate::Tolerance::AbsoluteMm(0.1),
            batch: 100,
            max_samples: 1000,
        },
        1,
    );
    assert!(bad(&[0], &adaptive).contains("fixed number"));
    // A fixed layout's point that fewer than two cameras see.
    let text = repo_file("benches/real_map.toml");
    let cut = text
        .find("[[grid.observer]]\nname = \"rear (cam2)\"")
        .unwrap();
    let fixed = GridStudy::new(&scenario(&text[..cut]), 2000, 1).unwrap();
    let map = fixed.run(&RunOptions::samples(100, 1), None).unwrap();
    let p = map.points.iter().position(|p| !p.is_measurable()).unwrap();
    match fixed.joint(&[p], &o) {
        Err(Error::Invalid { problem, .. }) => assert!(problem.contains("fewer than two")),
        other => panic!("{other:?}"),
    }
}
