//! The pixel σ checked on the test itself ([`crashrig_measure::pixel_check`]) on generated
//! sequences whose truth is known: the true tie `B_from_C`, the stated tie one draw of its σ
//! away from it, lenses with distortion, pixels the true projections (this file's own
//! projection: the camera crate's `img_from_cam` of the true poses) plus N(0, σ_true²) on each
//! axis. Calibration (honest σ → `consistent`), power (σ stated at half → `sigma_too_small`),
//! the estimate's interval coverage, the power formula of docs/MEASURE.md against simulation,
//! and the per-camera split where the geometry separates the cameras.
//!
//! Binomial bounds: with `n` sequences and a true rate `p`, the count is within `p·n ±
//! 3·√(n·p·(1 − p))` except with probability ≈ 0.3 %; each bound below states its `n`.

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Rigid3, UncertainPose, Vec3, quat, so3};
use crashrig_measure::engine::{Epoch, Rig};
use crashrig_measure::input::{Inward, Observation, PixelSigma};
use crashrig_measure::pixel_check::{self, PixelSigmaCheck, Verdict};
use crashrig_stats::{StreamRng, stream};
use nalgebra::{Rotation3, Vector2};
use rand::RngExt;
use rand_distr::StandardNormal;
use statrs::distribution::{ChiSquared, ContinuousCDF};

fn normal(rng: &mut StreamRng) -> f64 {
    rng.sample(StandardNormal)
}

/// The geometry of a generated sequence.
#[derive(Debug, Clone, Copy)]
struct Scene {
    epochs: usize,
    markers: usize,
    /// True pixel σ of B and of C (px).
    sigma_true: [f64; 2],
    /// The σ stated for B and for C (px): per observation when `per_observation`, else B's as
    /// the typed `pixel_sigma_px` (then both must be equal).
    sigma_stated: [f64; 2],
    per_observation: bool,
    /// The tie's σ (mm, deg): the stated tie is the truth moved by one draw of it.
    tie_sigma: (f64, f64),
    /// Two cameras facing each other across the car (the geometry separates them) instead of
    /// a stereo pair side by side.
    opposed: bool,
}

const SEQUENCE: Scene = Scene {
    epochs: 50,
    markers: 10,
    sigma_true: [0.2, 0.2],
    sigma_stated: [0.2, 0.2],
    per_observation: false,
    // 1 mm and 0.01° move C's rays by ≈ 0.9 px and 0.3 px at 1.5 m: comparable to the pixel
    // noise (the residuals of 0.2 px per coordinate); the check projects the tie out whatever it is.
    tie_sigma: (0.3, 0.005),
    opposed: false,
};

fn lens(f: f64) -> Camera {
    Camera::new(
        ModelId::OpenCv,
        2000,
        1500,
        vec![f, f * 0.998, 1000.0, 750.0, -0.15, 0.04, 0.0005, -0.0004],
    )
    .unwrap()
}

struct Sequence {
    epochs: Vec<Epoch>,
    rig: Rig,
    observations: Vec<Observation>,
}

/// One generated sequence (`trial` seeds it).
fn generate(s: &Scene, trial: u64) -> Sequence {
    let mut rng = stream(0x0044_0000 + trial, u64::from(s.opposed));
    let (tie_true, cam_b, cam_c) = if s.opposed {
        // B and C facing each other across the car, 2.7 m apart: C at (700, 0, 2600) mm in
        // B's frame looks back at the middle of the markers, (350, 0, 1300); a marker near one
        // camera is far from the other, so the share of each camera's error in the residuals
        // varies from marker to marker.
        let r = so3::exp(&Vec3::new(0.0, (-350.0_f64).atan2(-1300.0), 0.0));
        (
            quat::rigid_from_rotation(&r, &Vec3::new(700.0, 0.0, 2600.0)),
            lens(900.0),
            lens(950.0),
        )
    } else {
        let r = so3::exp(&Vec3::new(0.0, (-20.0_f64).to_radians(), 0.0));
        (
            quat::rigid_from_rotation(&r, &Vec3::new(600.0, 30.0, 40.0)),
            lens(1800.0),
            lens(1800.0),
        )
    };
    let (tie_mm, tie_rad) = (s.tie_sigma.0, s.tie_sigma.1.to_radians());
    let dc = Vec3::from_fn(|_, _| tie_mm * normal(&mut rng));
    let dr = Vec3::from_fn(|_, _| tie_rad * normal(&mut rng));
    let tie_stated = quat::rigid_from_rotation(
        &(tie_true.rotation.to_rotation_matrix() * Rotation3::new(dr)),
        &(tie_true.translation.vector + dc),
    );
    let rig = Rig {
        a_from_b: UncertainPose::certain(Rigid3::identity()),
        camera_b: cam_b.clone(),
        c: Some((
            UncertainPose::from_sigmas(tie_stated, Vec3::repeat(tie_mm), Vec3::repeat(tie_rad)),
            cam_c.clone(),
        )),
    };
    // Markers in B's frame: a box in front of the cameras, moving 2 mm per epoch.
    let start: Vec<Vec3> = (0..s.markers)
        .map(|_| {
            let u = |rng: &mut StreamRng| rng.random::<f64>() * 2.0 - 1.0;
            if s.opposed {
                Vec3::new(
                    350.0 + 200.0 * u(&mut rng),
                    150.0 * u(&mut rng),
                    1300.0 + 700.0 * u(&mut rng),
                )
            } else {
                Vec3::new(
                    250.0 + 350.0 * u(&mut rng),
                    250.0 * u(&mut rng),
                    1500.0 + 250.0 * u(&mut rng),
                )
            }
        })
        .collect();
    let velocity = Vec3::new(2.0, -0.5, 1.0);
    let mut epochs = Vec::with_capacity(s.epochs);
    let mut observations = Vec::new();
    for e in 0..s.epochs {
        let name = format!("{:06}", e + 1);
        epochs.push(Epoch {
            key: format!("{name}.png"),
            name: name.clone(),
            world_from_a: UncertainPose::certain(Rigid3::identity()),
        });
        for (k, x0) in start.iter().enumerate() {
            let x = x0 + velocity * e as f64;
            for (c, (camera, pose, cam)) in [
                (Inward::B, Rigid3::identity(), &cam_b),
                (Inward::C, tie_true, &cam_c),
            ]
            .into_iter()
            .enumerate()
            {
                let p = pose.inverse_transform_point(&nalgebra::Point3::from(x));
                assert!(p.z > 300.0, "{p}");
                let px = cam.img_from_cam(&p.coords).unwrap();
                assert!(
                    (0.0..2000.0).contains(&px.x) && (0.0..1500.0).contains(&px.y),
                    "{px}"
                );
                let noise = Vector2::new(normal(&mut rng), normal(&mut rng)) * s.sigma_true[c];
                observations.push(Observation {
                    epoch: name.clone(),
                    camera,
                    marker: format!("m{k:02}"),
                    pixel: px + noise,
                    sigma: s
                        .per_observation
                        .then(|| PixelSigma::isotropic(s.sigma_stated[c])),
                    line: observations.len() as u64 + 2,
                });
            }
        }
    }
    Sequence {
        epochs,
        rig,
        observations,
    }
}

fn run(s: &Scene, trial: u64) -> PixelSigmaCheck {
    let q = generate(s, trial);
    pixel_check::pixel_sigma_check(&q.epochs, &q.rig, &q.observations, s.sigma_stated[0])
        .expect("B and C with σ > 0")
}

/// `k` of `n` within `p·n ± 3·√(n·p·(1 − p))` (or at least the lower end, `at_least`).
fn binomial_lower(p: f64, n: usize) -> f64 {
    let n = n as f64;
    p * n - 3.0 * (n * p * (1.0 - p)).sqrt()
}

struct Tally {
    consistent: usize,
    too_small: usize,
    too_large: usize,
    covered: usize,
    ratio2_sum: f64,
}

fn tally(s: &Scene, trials: usize, truth_px: f64) -> Tally {
    let mut t = Tally {
        consistent: 0,
        too_small: 0,
        too_large: 0,
        covered: 0,
        ratio2_sum: 0.0,
    };
    for trial in 0..trials as u64 {
        let c = run(s, trial).common;
        match c.verdict {
            Verdict::Consistent => t.consistent += 1,
            Verdict::SigmaTooSmall => t.too_small += 1,
            Verdict::SigmaTooLarge => t.too_large += 1,
        }
        if (c.estimate_95_px.0..=c.estimate_95_px.1).contains(&truth_px) {
            t.covered += 1;
        }
        t.ratio2_sum += c.sigma_ratio * c.sigma_ratio;
    }
    t
}

/// Honest σ: `consistent` in ≥ 98 % (99 % nominal), the interval covers the true σ in 95 %
/// (nominal), the mean ratio² is 1 within its SE (`√(2/ν)/√trials`).
fn calibration(trials: usize) {
    let t = tally(&SEQUENCE, trials, 0.2);
    let n = trials as f64;
    eprintln!(
        "honest: consistent {}/{trials}, too small {}, too large {}, covered {}/{trials}, mean ratio² {:.4}",
        t.consistent,
        t.too_small,
        t.too_large,
        t.covered,
        t.ratio2_sum / n
    );
    assert!(
        t.consistent as f64 >= binomial_lower(0.99, trials).min(0.98 * n),
        "{}",
        t.consistent
    );
    assert!(
        t.covered as f64 >= binomial_lower(0.95, trials),
        "{}",
        t.covered
    );
    let nu = (SEQUENCE.epochs * SEQUENCE.markers - 5) as f64;
    let se = (2.0 / nu).sqrt() / n.sqrt();
    assert!(
        (t.ratio2_sum / n - 1.0).abs() < 4.0 * se,
        "{} ± {se}",
        t.ratio2_sum / n
    );
}

/// σ stated at half the truth: `sigma_too_small` in ≥ 95 % of the sequences (the formula says
/// 100 %: ratio 2 against a band ending at 1.12), and the estimate's interval still covers the
/// true σ in 95 %.
fn half(trials: usize) {
    let s = Scene {
        sigma_stated: [0.1, 0.1],
        ..SEQUENCE
    };
    let t = tally(&s, trials, 0.2);
    eprintln!(
        "half: too small {}/{trials}, covered {}/{trials}",
        t.too_small, t.covered
    );
    assert!(
        t.too_small as f64 >= 0.95 * trials as f64,
        "{}",
        t.too_small
    );
    assert!(
        t.covered as f64 >= binomial_lower(0.95, trials),
        "{}",
        t.covered
    );
}

/// 60 sequences: ≥ 57 `consistent` (98 % of 60 = 58.8 → the binomial bound at 99 %, 57.7 → 57
/// is not enough; the bound used is min(98 %, 3 SE below 99 %) = 57.7), coverage ≥ 3 SE below
/// 95 % (51.9 of 60).
#[test]
fn honest_sigma_is_consistent_fast() {
    calibration(60);
}

#[test]
#[ignore = "slow: 1000 generated sequences of 50 epochs × 10 markers"]
fn honest_sigma_is_consistent_slow() {
    calibration(1000);
}

#[test]
fn sigma_stated_at_half_is_too_small_fast() {
    half(40);
}

#[test]
#[ignore = "slow: 1000 generated sequences of 50 epochs × 10 markers"]
fn sigma_stated_at_half_is_too_small_slow() {
    half(1000);
}

/// Twice the stated σ: `sigma_too_large`, and per-observation σ give the same numbers as the
/// typed σ they equal.
#[test]
fn sigma_stated_at_double_is_too_large_and_per_observation_sigma_is_the_same_check() {
    let s = Scene {
        sigma_stated: [0.4, 0.4],
        ..SEQUENCE
    };
    let typed = run(&s, 3);
    assert_eq!(typed.common.verdict, Verdict::SigmaTooLarge, "{typed:?}");
    let own = run(
        &Scene {
            per_observation: true,
            ..s
        },
        3,
    );
    assert!((own.common.sigma_ratio - typed.common.sigma_ratio).abs() < 1e-12);
    assert_eq!(own.common.redundancy, typed.common.redundancy);
    // A two-camera tie has 5 directions that move the residuals (its baseline length moves
    // none): ν = 500 − 5.
    assert_eq!(typed.tie_directions, 5);
    assert_eq!(typed.common.redundancy, 495.0);
    assert!(typed.warning().unwrap().contains("sigma_too_large"));
}

/// A tie 20× looser than stated (its error 6 mm and 0.1°, moving C's rays by several px: far
/// more than the pixel noise) changes nothing: the check projects the tie's effect out. The
/// naive sum of squares of the same residuals (the tie not projected) is far off.
#[test]
fn a_wrong_tie_does_not_move_the_check() {
    let loose = Scene {
        tie_sigma: (6.0, 0.1),
        ..SEQUENCE
    };
    let mut consistent = 0;
    let mut naive_above = 0;
    let trials = 20;
    for trial in 0..trials {
        let q = generate(&loose, trial);
        let c = pixel_check::pixel_sigma_check(&q.epochs, &q.rig, &q.observations, 0.2).unwrap();
        consistent += usize::from(c.common.verdict == Verdict::Consistent);
        let r = pixel_check::residuals(&q.epochs, &q.rig, &q.observations, 0.2);
        let naive = (r.iter().map(|x| x.w * x.w).sum::<f64>() / r.len() as f64).sqrt();
        naive_above += usize::from(naive > c.common.sigma_ratio_band_99.1);
    }
    // 99 % nominal: P(fewer than 18 of 20) < 0.1 %.
    assert!(consistent >= 18, "{consistent}/{trials}");
    assert!(naive_above >= 15, "{naive_above}/{trials}");
}

/// The power of the test against a pixel σ stated too small by a factor k (true = k × stated):
/// `P = 1 − F_ν(ν·hi²/k²) + F_ν(ν·lo²/k²)` — the formula docs/MEASURE.md tabulates — against
/// the rate in generated sequences (k = 1.12 on 50 × 10, near the band's edge where the power
/// is ≈ 50 %: within 3 binomial SE of 80 sequences).
#[test]
fn power_formula_matches_simulation() {
    let nu = 495.0;
    let k: f64 = 1.12;
    let want = power(nu, k);
    let s = Scene {
        sigma_true: [0.2 * k, 0.2 * k],
        ..SEQUENCE
    };
    let trials = 80;
    let t = tally(&s, trials, 0.2 * k);
    let got = (t.too_small + t.too_large) as f64 / trials as f64;
    let se = (want * (1.0 - want) / trials as f64).sqrt();
    eprintln!("k = {k}: power {got} (formula {want:.3} ± {se:.3})");
    assert!((got - want).abs() < 3.0 * se, "{got} vs {want} ± {se}");
}

/// The probability that the check leaves its 99 % band when the true σ is k × the stated.
pub fn power(nu: f64, k: f64) -> f64 {
    let chi = ChiSquared::new(nu).unwrap();
    let (lo, hi) = pixel_check::band(nu);
    1.0 - chi.cdf(nu * hi * hi / (k * k)) + chi.cdf(nu * lo * lo / (k * k))
}

/// docs/MEASURE.md's power table, recomputed from the formula.
#[test]
fn the_power_table_of_measure_md_is_its_formula() {
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/MEASURE.md"
    ))
    .unwrap();
    let section = doc
        .split("<!-- pixel-check-power -->")
        .nth(1)
        .expect("the power table's marker in docs/MEASURE.md");
    let mut rows = 0;
    let mut wrong = Vec::new();
    for line in section
        .lines()
        .skip_while(|l| !l.starts_with("| n epochs"))
        .skip(2)
    {
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let n: f64 = cells[0].parse().unwrap();
        let m: f64 = cells[1].parse().unwrap();
        let nu = n * m - 5.0;
        let (lo, hi) = pixel_check::band(nu);
        let powers: Vec<String> = [0.5, 0.8, 1.1, 1.25, 1.5, 2.0]
            .iter()
            .map(|&k| format!("{:.0} %", 100.0 * power(nu, k)))
            .collect();
        let want = format!(
            "| {n} | {m} | {nu} | {lo:.3} … {hi:.3} | {} |",
            powers.join(" | ")
        );
        if line != want {
            wrong.push(want);
        }
        rows += 1;
    }
    assert!(
        wrong.is_empty(),
        "the rows should read:\n{}",
        wrong.join("\n")
    );
    assert!(rows >= 5, "{rows} rows");
}

/// Two cameras facing each other across the car: the residuals of markers near B are mostly
/// C's error and vice versa, so the check separates them — C stated at half its σ is
/// `sigma_too_small`, B `consistent`, each estimate's interval covers its camera's truth.
#[test]
fn opposed_cameras_are_checked_apart() {
    let s = Scene {
        markers: 20,
        sigma_true: [0.2, 0.3],
        sigma_stated: [0.2, 0.15],
        per_observation: true,
        opposed: true,
        ..SEQUENCE
    };
    let trials = 30;
    let (mut b_ok, mut c_small, mut covered) = (0, 0, [0, 0]);
    for trial in 0..trials {
        let c = run(&s, trial);
        let [b, cc] = c
            .per_camera
            .unwrap_or_else(|| panic!("{:?}", c.per_camera_note));
        b_ok += usize::from(b.verdict == Verdict::Consistent);
        c_small += usize::from(cc.verdict == Verdict::SigmaTooSmall);
        for (k, (x, truth)) in [b, cc].iter().zip(s.sigma_true).enumerate() {
            covered[k] += usize::from((x.estimate_95_px.0..=x.estimate_95_px.1).contains(&truth));
        }
    }
    eprintln!(
        "opposed: B consistent {b_ok}/{trials}, C too small {c_small}/{trials}, covered {covered:?}"
    );
    assert!(b_ok >= 27, "{b_ok}");
    assert!(c_small >= 27, "{c_small}");
    // 95 % nominal: ≥ 3 SE below of 30 (28.5 − 3.6 = 24.9).
    assert!(covered.iter().all(|&c| c >= 25), "{covered:?}");
}

/// A stereo pair side by side does not separate its cameras: `per_camera` is `None` with the
/// reason.
#[test]
fn a_side_by_side_pair_is_not_split() {
    let c = run(&SEQUENCE, 1);
    assert!(c.per_camera.is_none());
    let note = c.per_camera_note.unwrap();
    assert!(note.contains("does not separate"), "{note}");
}

/// Without camera C there is nothing to check.
#[test]
fn no_camera_c_no_check() {
    let mut q = generate(&SEQUENCE, 0);
    q.rig.c = None;
    q.observations.retain(|o| o.camera == Inward::B);
    assert!(pixel_check::pixel_sigma_check(&q.epochs, &q.rig, &q.observations, 0.2).is_none());
}

/// `--pixel-sigma-px estimate` ([`pixel_check::apply_estimate`]): the observations with the
/// estimate as their σ are, checked again, exactly consistent (ratio 1: scaling every σ by the
/// common ratio k scales every whitened residual by 1/k), and the estimate does not depend on
/// the σ that was stated. Stated at half the truth (typed) and at double (per observation).
#[test]
fn the_estimate_used_checks_out_as_honest() {
    for (stated, per_observation) in [(0.1, false), (0.4, true)] {
        let s = Scene {
            sigma_stated: [stated; 2],
            per_observation,
            ..SEQUENCE
        };
        let q = generate(&s, 7);
        let check = pixel_check::pixel_sigma_check(&q.epochs, &q.rig, &q.observations, stated)
            .expect("B and C");
        let (scaled, used) =
            pixel_check::apply_estimate(&check, &q.observations, stated).expect("ratio > 0");
        assert!(!used.per_camera, "a side-by-side pair is not split");
        assert_eq!(used.scale, [check.common.sigma_ratio; 2]);
        assert!(scaled.iter().all(|o| o.sigma.is_some()));
        // A different typed σ afterwards changes nothing: every observation has its own now.
        let again = pixel_check::pixel_sigma_check(&q.epochs, &q.rig, &scaled, 9.0).unwrap();
        let c = again.common;
        assert!((c.sigma_ratio - 1.0).abs() < 1e-9, "{}", c.sigma_ratio);
        assert_eq!(c.verdict, Verdict::Consistent);
        let rel = |a: f64, b: f64| (a - b).abs() / b;
        assert!(rel(c.estimate_px, check.common.estimate_px) < 1e-9);
        assert!(rel(c.stated_px, check.common.estimate_px) < 1e-12);
        // The truth is 0.2 px; this sequence's estimate is within its 95 % interval of it.
        let (lo, hi) = check.common.estimate_95_px;
        assert!((lo..=hi).contains(&0.2), "{lo} … {hi}");
    }
}
