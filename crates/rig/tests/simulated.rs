//! Simulated sequences in memory (issue 12): the outlier rule's false-flag rate on clean
//! sequences and its power on gross errors, the coverage of the uncertainty of the mean on
//! AR(1) sequences through `calibrate`, and the refusal of a rig-constrained (identical-link)
//! sequence. The contract's coverage grid of the uncertainty of the mean is
//! `tests/sem_coverage.rs`.
//!
//! Every sequence has the paper's geometry: link A_from_B = base (61.98, −1.71, 179.76) mm,
//! ω φ κ = (179.92, −0.09, 179.76)°, σ = (2.25, 3.08, 1.53) mm and (0.047, 0.059, 0.094)°,
//! 140 epochs; camera A moves through a 4 m lab. Each test states its binomial bound.
//! The slow versions (`cargo xtask test --slow`) give the numbers quoted in docs/CALIBRATE.md.

use crashrig_geometry::opk::rotation_from_opk;
use crashrig_geometry::{Rigid3, Vec3, Vec6, so3};
use crashrig_rig::refine::RefineOptions;
use crashrig_rig::{CalibrateOptions, Epoch, Error, calibrate, flag_outliers, links_of};
use nalgebra::{Translation3, UnitQuaternion};
use rand::RngExt;
use rand_distr::StandardNormal;

const N: usize = 140;
const BASE: [f64; 3] = [61.98, -1.71, 179.76];
const ANGLES_DEG: [f64; 3] = [179.92, -0.09, 179.76];
const SIGMA: [f64; 6] = [2.25, 3.08, 1.53, 0.047, 0.059, 0.094];

fn pose(r: crashrig_geometry::Rot3, t: Vec3) -> Rigid3 {
    Rigid3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

fn opk_pose(p: &[f64; 6]) -> Rigid3 {
    pose(
        rotation_from_opk(p[3].to_radians(), p[4].to_radians(), p[5].to_radians()),
        Vec3::new(p[0], p[1], p[2]),
    )
}

/// Camera A's pose in epoch `i` (mm): along the lab, yawing.
fn a_from_world(i: usize) -> Rigid3 {
    let s = i as f64 / N as f64;
    pose(
        rotation_from_opk(-1.5 + 0.1 * s, 0.4 * s - 0.2, 1.0 - s),
        Vec3::new(4000.0 * s - 2000.0, 500.0 * s, 1200.0),
    )
    .inverse()
}

fn epochs_of(links: &[Rigid3]) -> Vec<Epoch> {
    links
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let a = a_from_world(i);
            Epoch {
                name: format!("{i:06}"),
                a_from_world: a,
                b_from_world: l.inverse() * a,
            }
        })
        .collect()
}

/// Parameter vectors (x y z mm, ω φ κ deg) of a clean white-noise sequence.
fn clean_parameters(seed: u64, rep: u64) -> Vec<[f64; 6]> {
    let mut rng = crashrig_stats::stream(seed, rep);
    (0..N)
        .map(|_| {
            std::array::from_fn(|j| {
                let z: f64 = rng.sample(StandardNormal);
                let nominal = if j < 3 { BASE[j] } else { ANGLES_DEG[j - 3] };
                nominal + SIGMA[j] * z
            })
        })
        .collect()
}

fn flagged_sequences(seed: u64, reps: u64) -> usize {
    (0..reps)
        .filter(|&rep| {
            let links: Vec<Rigid3> = clean_parameters(seed, rep).iter().map(opk_pose).collect();
            let l = links_of(&epochs_of(&links), 1.0).unwrap();
            !flag_outliers(&l).unwrap().indices().is_empty()
        })
        .count()
}

#[test]
fn outlier_rule_false_flag_rate_fast() {
    // 200 clean sequences. The rule's nominal per-sequence rate is 0.5 % (measured 0.57 %,
    // slow test); at most 4 flagged sequences of 200: under a true rate of 1 % that happens
    // with probability 95 %; under the old |z| > 3.5 rule (≈ 50 % of sequences, numpy on
    // 4000 independent-Gaussian sequences) with probability < 1e-50.
    let flagged = flagged_sequences(2026, 200);
    assert!(flagged <= 4, "{flagged} of 200 clean sequences flagged");
}

#[test]
#[ignore = "slow: 4000 clean 140-epoch sequences"]
fn outlier_rule_false_flag_rate_slow() {
    // 4000 sequences: under a true rate of 1 % the count is 40 ± 6.3; ≤ 40 bounds the rate at
    // 1 % (and a rate of 1.4 % would exceed it with probability 97 %).
    let flagged = flagged_sequences(2027, 4000);
    eprintln!(
        "outlier rule: {flagged} of 4000 clean sequences flagged ({:.2} %)",
        flagged as f64 / 40.0
    );
    assert!(flagged <= 40, "{flagged} of 4000 clean sequences flagged");
}

/// Parameter vectors of a sequence whose noise is AR(1) with coefficient `rho` (per
/// parameter, stationary, the paper's σ) or, with `t_dof` = Some(ν), i.i.d. Student t_ν
/// scaled to the paper's σ.
fn drifting_or_heavy_parameters(
    seed: u64,
    rep: u64,
    rho: f64,
    t_dof: Option<f64>,
) -> Vec<[f64; 6]> {
    let mut rng = crashrig_stats::stream(seed, rep);
    let student = t_dof.map(|nu| {
        (
            rand_distr::StudentT::new(nu).unwrap(),
            ((nu - 2.0) / nu).sqrt(),
        )
    });
    let draw = |rng: &mut crashrig_stats::StreamRng| -> f64 {
        match &student {
            None => rng.sample(StandardNormal),
            Some((t, scale)) => rng.sample(t) * scale,
        }
    };
    let mut x: [f64; 6] = std::array::from_fn(|_| draw(&mut rng));
    let innovation = (1.0 - rho * rho).sqrt();
    (0..N)
        .map(|i| {
            if i > 0 {
                for v in x.iter_mut() {
                    *v = rho * *v + innovation * draw(&mut rng);
                }
            }
            std::array::from_fn(|j| {
                let nominal = if j < 3 { BASE[j] } else { ANGLES_DEG[j - 3] };
                nominal + SIGMA[j] * x[j]
            })
        })
        .collect()
}

fn flagged_of(seed: u64, reps: u64, rho: f64, t_dof: Option<f64>) -> usize {
    (0..reps)
        .filter(|&rep| {
            let p = drifting_or_heavy_parameters(seed, rep, rho, t_dof);
            let links: Vec<Rigid3> = p.iter().map(opk_pose).collect();
            let l = links_of(&epochs_of(&links), 1.0).unwrap();
            !flag_outliers(&l).unwrap().indices().is_empty()
        })
        .count()
}

#[test]
#[ignore = "slow: 4000 drifting and 1000 heavy-tailed clean sequences"]
fn outlier_rule_under_drift_and_heavy_tails_slow() {
    // AR(1) ρ = 0.9 drift, no gross error: the rule promises ≤ 1 % of sequences flagged
    // (nominal 0.5 % for independent Gaussian epochs); 4000 sequences, ≤ 40 bounds it at 1 %.
    let drift = flagged_of(2028, 4000, 0.9, None);
    // Student t₅ epochs (independent, heavy tails, no gross error): printed for the docs.
    let heavy = flagged_of(2029, 1000, 0.0, Some(5.0));
    eprintln!(
        "outlier rule: AR(0.9) drift {drift} of 4000 sequences flagged ({:.2} %); t5 tails {heavy} of 1000 ({:.1} %)",
        drift as f64 / 40.0,
        heavy as f64 / 10.0
    );
    assert!(drift <= 40, "{drift} of 4000 drifting sequences flagged");
}

fn gross_errors_all_flagged(reps: u64) {
    // Three gross errors of 10 σ (random epoch, parameter and sign) per sequence.
    for rep in 0..reps {
        let mut p = clean_parameters(77, rep);
        let mut rng = crashrig_stats::stream(78, rep);
        let mut injected = Vec::new();
        while injected.len() < 3 {
            let i = rng.random_range(0..N);
            if injected.contains(&i) {
                continue;
            }
            let j = rng.random_range(0..6);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            p[i][j] += sign * 10.0 * SIGMA[j];
            injected.push(i);
        }
        let links: Vec<Rigid3> = p.iter().map(opk_pose).collect();
        let l = links_of(&epochs_of(&links), 1.0).unwrap();
        let flags = flag_outliers(&l).unwrap().indices();
        for i in &injected {
            assert!(flags.contains(i), "sequence {rep}: epoch {i} not flagged");
        }
    }
}

#[test]
fn outlier_rule_flags_gross_errors_fast() {
    gross_errors_all_flagged(100);
}

#[test]
#[ignore = "slow: 2000 sequences with gross errors"]
fn outlier_rule_flags_gross_errors_slow() {
    gross_errors_all_flagged(2000);
}

/// Links with stationary AR(1) tangent noise (coefficient `rho`, σ = SIGMA on each axis):
/// centre + δc, rotation R̄·Exp(δθ) about B's axes.
fn ar1_links(seed: u64, rep: u64, rho: f64) -> (Rigid3, Vec<Rigid3>) {
    let nominal = opk_pose(&[
        BASE[0],
        BASE[1],
        BASE[2],
        ANGLES_DEG[0],
        ANGLES_DEG[1],
        ANGLES_DEG[2],
    ]);
    let sigma = Vec6::from_fn(|j, _| {
        if j < 3 {
            SIGMA[j]
        } else {
            SIGMA[j].to_radians()
        }
    });
    let mut rng = crashrig_stats::stream(seed, rep);
    let mut g = || -> f64 { rng.sample(StandardNormal) };
    let mut x = Vec6::from_fn(|_, _| g());
    let innovation = (1.0 - rho * rho).sqrt();
    let links = (0..N)
        .map(|i| {
            if i > 0 {
                x = x * rho + Vec6::from_fn(|_, _| g()) * innovation;
            }
            let d = x.component_mul(&sigma);
            let c = nominal.translation.vector + Vec3::new(d[0], d[1], d[2]);
            let r = nominal.rotation.to_rotation_matrix() * so3::exp(&Vec3::new(d[3], d[4], d[5]));
            pose(r, c)
        })
        .collect();
    (nominal, links)
}

/// Fraction of axes on which ±2 SE covers the truth: (sem rule, plain Σ/n); `reps` sequences
/// of 140 epochs with AR(1) tangent noise of coefficient `rho`.
fn coverage(seed: u64, reps: u64, rho: f64) -> (f64, f64) {
    let options = CalibrateOptions {
        refine: None,
        ..CalibrateOptions::default()
    };
    let (mut rule, mut plain, mut total) = (0usize, 0usize, 0usize);
    for rep in 0..reps {
        let (truth, links) = ar1_links(seed, rep, rho);
        let c = calibrate(&epochs_of(&links), 1.0, &options, None).unwrap();
        let e = c.link.tangent_of(&truth);
        for j in 0..6 {
            total += 1;
            if e[j].abs() <= 2.0 * c.link.covariance[(j, j)].sqrt() {
                rule += 1;
            }
            if e[j].abs() <= 2.0 * (c.epoch_spread.covariance[(j, j)] / N as f64).sqrt() {
                plain += 1;
            }
        }
    }
    (rule as f64 / total as f64, plain as f64 / total as f64)
}

#[test]
fn sem_rule_coverage_ar1_fast() {
    // AR(1) sequences of 140 epochs through `calibrate`, for each ρ the evidence of
    // docs/CALIBRATE.md names (0.9 and 0.95): 150 sequences × 6 independent axes = 900
    // intervals per ρ. The slow grid (crates/rig/tests/sem_coverage.rs, 12 000 intervals per
    // cell) measures ±2 SE coverage of about 97 % on (ρ 0.9, s 1, n 140) and 96 % on (ρ 0.95,
    // s 1, n 140), with no refusal (B equal to it); the binomial SE at 96 % over 900 intervals
    // is 0.65 %, so ≥ 93 % is more than 4 SE below both. The paper's σ/√n covers about a
    // third (a quarter at 0.95).
    for (rho, seed) in [(0.9, 90), (0.95, 95)] {
        let (rule, plain) = coverage(seed, 150, rho);
        assert!(
            rule >= 0.93,
            "ρ {rho}: ±2 SE covers {rule:.3} (σ/√n: {plain:.3})"
        );
        assert!(plain < 0.5, "ρ {rho}: σ/√n covers {plain:.3}");
    }
}

#[test]
fn sem_rule_white_noise_is_not_wildly_conservative_fast() {
    // Independent epochs, through `calibrate`: the true SE is σ/√n. Over 200 sequences × 6
    // axes (1200 intervals) ±2 SE covers 93–99.5 % (nominal ≥ 95.4 %; binomial SE at 96 % is
    // 0.57 %), and on every axis the SE is on average (over the 200 sequences: the contract's
    // statistic) at most 1.5 × the true SE (the slow table measures 1.17–1.2 at n = 140 on the
    // white-noise cells).
    let options = CalibrateOptions {
        refine: None,
        ..CalibrateOptions::default()
    };
    let (mut covered, mut total, mut ratio) = (0usize, 0usize, [0.0; 6]);
    for rep in 0..200 {
        let (truth, links) = ar1_links(91, rep, 0.0);
        let c = calibrate(&epochs_of(&links), 1.0, &options, None).unwrap();
        let e = c.link.tangent_of(&truth);
        for j in 0..6 {
            let se = c.link.covariance[(j, j)].sqrt();
            let sigma = if j < 3 {
                SIGMA[j]
            } else {
                SIGMA[j].to_radians()
            };
            ratio[j] += se / (sigma / (N as f64).sqrt()) / 200.0;
            total += 1;
            if e[j].abs() <= 2.0 * se {
                covered += 1;
            }
        }
    }
    let cov = covered as f64 / total as f64;
    assert!((0.93..=0.995).contains(&cov), "±2 SE covers {cov:.4}");
    assert!(
        ratio.iter().all(|r| *r <= 1.5),
        "mean SE / true SE per axis = {ratio:.3?}"
    );
}

#[test]
fn rig_constrained_sequence_is_refused() {
    // Identical links in every epoch (a bundle adjusted with a rig constraint).
    let link = opk_pose(&[61.98, -1.71, 179.76, 179.92, -0.09, 179.76]);
    let epochs = epochs_of(&vec![link; 30]);
    let r = calibrate(&epochs, 1.0, &CalibrateOptions::default(), None);
    match r {
        Err(Error::RigConstrained {
            n_epochs,
            spread_mm,
            spread_rad,
        }) => {
            assert_eq!(n_epochs, 30);
            // Rounding of 2 m poses: far below the numerical-zero bounds.
            assert!(
                spread_mm < 1e-9 && spread_rad < 1e-12,
                "{spread_mm} {spread_rad}"
            );
        }
        other => panic!("expected RigConstrained, got {other:?}"),
    }
    // Accepted for inspection: zero spread, Σ/n, no autocorrelation analysis.
    let options = CalibrateOptions {
        accept_rig_constrained: true,
        refine: Some(RefineOptions::default()),
        ..CalibrateOptions::default()
    };
    let c = calibrate(&epochs, 1.0, &options, None).unwrap();
    assert!(c.rig_constrained && c.drift.is_none());
    assert_eq!(c.sem.rule, crashrig_rig::sem::RULE_IID);
    assert!(c.outliers.indices().is_empty());
    // A real but tiny spread (1 µm, 1 µrad) is not numerical zero: calibrated normally.
    let tiny: Vec<Rigid3> = (0..30)
        .map(|i| {
            let d = if i % 2 == 0 { 1e-3 } else { -1e-3 };
            opk_pose(&[61.98 + d, -1.71, 179.76, 179.92 + d * 0.057, -0.09, 179.76])
        })
        .collect();
    let c = calibrate(&epochs_of(&tiny), 1.0, &CalibrateOptions::default(), None).unwrap();
    assert!(!c.rig_constrained);
}

/// Progress of `calibrate` with a monitor: with flagged epochs both refinements report, within
/// the total (2 × the weighting rounds), ending at it; the result is the same as without.
#[test]
fn calibrate_progress_covers_both_refinements_and_changes_nothing() {
    let mut p = clean_parameters(90, 0);
    p[17][0] += 20.0 * SIGMA[0];
    let links: Vec<Rigid3> = p.iter().map(opk_pose).collect();
    let epochs = epochs_of(&links);
    let options = CalibrateOptions::default();
    let seen = std::sync::Mutex::new(Vec::new());
    let report = |d: usize, t: usize| seen.lock().unwrap().push((d, t));
    let with = calibrate(&epochs, 1.0, &options, Some(&report)).unwrap();
    assert_eq!(with, calibrate(&epochs, 1.0, &options, None).unwrap());
    assert!(with.refined_without_outliers.is_some());
    let seen = seen.into_inner().unwrap();
    let total = 2 * RefineOptions::default().variance_iterations;
    assert!(seen.iter().all(|&(d, t)| t == total && d <= t), "{seen:?}");
    assert_eq!(seen.last().map(|r| r.0), Some(total));
    // Both halves report: rounds of the first refinement, then of the second.
    assert!(
        seen.iter().any(|&(d, _)| d > 0 && d < total / 2),
        "{seen:?}"
    );
    assert!(
        seen.iter().any(|&(d, _)| d > total / 2 && d < total),
        "{seen:?}"
    );
}

/// A monitor that cancels once a report reaches `after` rounds.
struct StopAt(usize, std::sync::atomic::AtomicUsize);

impl crashrig_rig::Monitor for StopAt {
    fn report(&self, done: usize, _: usize) {
        self.1.fetch_max(done, std::sync::atomic::Ordering::Relaxed);
    }
    fn cancelled(&self) -> bool {
        self.1.load(std::sync::atomic::Ordering::Relaxed) >= self.0
    }
}

/// A cancelled calibration returns `Cancelled`, from either refinement, and reports no more.
#[test]
fn calibrate_cancelled_in_either_refinement_returns_cancelled() {
    let mut p = clean_parameters(90, 0);
    p[17][0] += 20.0 * SIGMA[0];
    let epochs = epochs_of(&p.iter().map(opk_pose).collect::<Vec<_>>());
    let options = CalibrateOptions::default();
    let rounds = RefineOptions::default().variance_iterations;
    // Before the first round, and after the first refinement's rounds (in the second).
    for after in [0, rounds] {
        let stop = StopAt(after, 0.into());
        let e = calibrate(&epochs, 1.0, &options, Some(&stop)).unwrap_err();
        assert!(
            matches!(e, crashrig_rig::Error::Cancelled(_)),
            "{after}: {e}"
        );
        assert_eq!(e.to_string(), "cancelled");
        assert_eq!(stop.1.into_inner(), after);
    }
}
