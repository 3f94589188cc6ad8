//! Truth for the kinematics of `crashrig measure --cfc`:
//! - the σ of filtered displacement, velocity and acceleration against an independent NumPy
//!   Monte Carlo that filters each replicate (`fixtures/gen/kinematics_sigma_reference.py` →
//!   `fixtures/kinematics/sigma_reference.json`);
//! - coverage of the true filtered displacement, velocity and acceleration on a synthetic crash
//!   sequence (a moving car, A's pose noise, pixel noise and a trigger offset).

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Rigid3, UncertainPose, Vec3, so3};
use crashrig_measure::engine::{Epoch, Rig, Settings, measure};
use crashrig_measure::filter::{Cfc, CfcSpec, Standard};
use crashrig_measure::input::{Inward, Observation};
use crashrig_measure::kinematics::differentiate;
use nalgebra::Vector2;
use rand::RngExt;
use rand_distr::StandardNormal;
use serde_json::Value;
use std::path::Path;

const HZ: f64 = 1000.0;
const FRAME0: u64 = 100;

fn pinhole() -> Camera {
    Camera::new(
        ModelId::Pinhole,
        1000,
        1000,
        vec![1000.0, 1000.0, 500.0, 500.0],
    )
    .unwrap()
}

/// B rides on A (identity link), C 500 mm to B's right; both exact.
fn rig() -> Rig {
    let exact = |p| UncertainPose::from_sigmas(p, Vec3::zeros(), Vec3::zeros());
    Rig {
        a_from_b: exact(Rigid3::identity()),
        camera_b: pinhole(),
        c: Some((exact(Rigid3::translation(500.0, 0.0, 0.0)), pinhole())),
    }
}

fn name(i: usize) -> String {
    format!("{:06}", FRAME0 + i as u64)
}

/// The pixels of marker `x` (world) seen by B and C of a rig whose A stands at `world_from_a`.
fn observe(i: usize, world_from_a: &Rigid3, x: Vec3, noise: [f64; 4], obs: &mut Vec<Observation>) {
    for (k, (camera, offset)) in [(Inward::B, 0.0), (Inward::C, 500.0)]
        .into_iter()
        .enumerate()
    {
        let world_from_cam = world_from_a * Rigid3::translation(offset, 0.0, 0.0);
        let p = world_from_cam.inverse() * nalgebra::Point3::from(x);
        let pixel = Vector2::new(
            1000.0 * p.x / p.z + 500.0 + noise[2 * k],
            1000.0 * p.y / p.z + 500.0 + noise[2 * k + 1],
        );
        let line = 2 + obs.len() as u64;
        obs.push(Observation {
            epoch: name(i),
            camera,
            marker: "head".into(),
            pixel,
            sigma: None,
            line,
        });
    }
}

fn settings(
    samples: usize,
    seed: u64,
    class: u32,
    standard: Standard,
    pixel: f64,
    sync: f64,
) -> Settings {
    Settings {
        samples,
        seed,
        pixel_sigma_px: pixel,
        reference_epoch: None,
        frame_rate_hz: Some(HZ),
        frame_times: None,
        threshold_mm: 5.0,
        max_reprojection_px: None,
        cfc: Some(CfcSpec { class, standard }),
        sync_sigma_ms: sync,
    }
}

#[test]
fn filtered_sigma_matches_the_numpy_monte_carlo() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/kinematics/sigma_reference.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let n = doc["epochs"].as_u64().unwrap() as usize;
    let sigma_a = doc["sigma_a_centre_mm"].as_f64().unwrap();
    // A static marker; A's centre uncertain by sigma_a per axis and epoch, nothing else.
    let epochs: Vec<Epoch> = (0..n)
        .map(|i| Epoch {
            key: name(i),
            name: name(i),
            world_from_a: UncertainPose::from_sigmas(
                Rigid3::identity(),
                Vec3::repeat(sigma_a),
                Vec3::zeros(),
            ),
        })
        .collect();
    let mut obs = Vec::new();
    for i in 0..n {
        observe(
            i,
            &Rigid3::identity(),
            Vec3::new(250.0, 40.0, 2000.0),
            [0.0; 4],
            &mut obs,
        );
    }
    let samples = 4000;
    for case in doc["cases"].as_array().unwrap() {
        let class = case["cfc"].as_u64().unwrap() as u32;
        let standard = Standard::parse(case["standard"].as_str().unwrap()).unwrap();
        let m = measure(
            &epochs,
            None,
            &rig(),
            &obs,
            None,
            &settings(samples, 26, class, standard, 0.0, 0.0),
        )
        .unwrap();
        let k = m.kinematics.as_ref().unwrap();
        assert_eq!(k.rows_with_kinematics, n);
        let n_ref = case["mc_replicates"].as_f64().unwrap();
        let mut worst = 0.0_f64;
        for (q, get) in [
            (
                "d",
                (|r: &crashrig_measure::kinematics::KinRow| r.displacement_sigma_mm) as fn(&_) -> _,
            ),
            ("v", |r| r.velocity_sigma_m_s),
            ("a", |r| r.acceleration_sigma_m_s2),
        ] {
            let reference = case["mc"][q].as_array().unwrap();
            for (i, row) in k.rows.iter().enumerate() {
                let want = reference[i].as_f64().unwrap();
                let got = get(row).unwrap();
                // Two independent Monte Carlo estimates of one σ: SE(σ̂) = σ/√(2(N−1)) each.
                let se = want
                    * ((2.0 * (samples as f64 - 1.0)).recip() + (2.0 * (n_ref - 1.0)).recip())
                        .sqrt();
                for c in 0..3 {
                    let z = (got[c] - want).abs() / se.max(1e-300);
                    worst = worst.max(z);
                    assert!(
                        z < 4.5,
                        "CFC {class} {}: {q}[{i}] axis {c}: {} vs NumPy {want} ({z:.1} SE)",
                        standard.name(),
                        got[c]
                    );
                }
            }
        }
        // The filter matters: the filtered displacement σ mid-run is below the raw σ
        // (√2·sigma_a for a displacement from the reference epoch). The reference epoch's
        // draw is common to the whole series and passes the filter, so the filtered σ stays
        // above sigma_a = raw/√2: 8 % below raw for CFC 180 at 1000 frames/s (corner near
        // Nyquist), 21 % for CFC 60.
        let raw = m.rows[n / 2].displacement_sigma_mm.unwrap().x;
        let filtered = k.rows[n / 2].displacement_sigma_mm.unwrap().x;
        assert!((raw - 2f64.sqrt() * sigma_a).abs() < 0.05 * raw, "{raw}");
        let most = if class == 60 { 0.85 } else { 0.95 };
        assert!(filtered < most * raw, "{filtered} vs {raw}");
        eprintln!(
            "CFC {class} {}: worst deviation {worst:.2} SE",
            standard.name()
        );
    }
}

/// The car's (A's) centre at time t (s): 10 m/s, braking at 150 m/s² (mm).
fn car(t: f64) -> Vec3 {
    Vec3::new(10_000.0 * t - 0.5 * 150_000.0 * t * t, 0.0, 0.0)
}

/// The marker relative to the car: a head moving forward by 120 mm over 80 ms (mm).
fn head(t: f64) -> Vec3 {
    let s = (std::f64::consts::PI * t / 0.08).min(std::f64::consts::PI);
    Vec3::new(
        250.0 + 60.0 * (1.0 - s.cos()),
        40.0 - 10.0 * s.sin(),
        2000.0,
    )
}

/// Coverage of the truth at ±2σ over `trials` synthetic tests: fractions for displacement,
/// velocity, acceleration and their Monte Carlo standard errors (from the per-trial spread).
fn coverage(trials: u64, sync_ms: f64, standard: Standard) -> [(f64, f64); 3] {
    let n = 80;
    let (sigma_c, sigma_r, sigma_px) = (0.3, 0.01_f64.to_radians(), 0.2);
    let filter = Cfc::new(180, standard, HZ).unwrap();
    let times: Vec<f64> = (0..n).map(|i| (FRAME0 + i as u64) as f64 / HZ).collect();
    // The true filtered kinematics (world axes; the car's rotation is the identity).
    let truth: Vec<Vec3> = times.iter().map(|&t| car(t) + head(t)).collect();
    let d: Vec<Vec3> = truth.iter().map(|x| x - truth[0]).collect();
    let mut axes = [vec![], vec![], vec![]];
    for (c, axis) in axes.iter_mut().enumerate() {
        *axis = filter.filter(&d.iter().map(|v| v[c]).collect::<Vec<_>>());
    }
    let f_true: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new(axes[0][i], axes[1][i], axes[2][i]))
        .collect();
    let (mut v_true, mut a_true) = (Vec::new(), Vec::new());
    differentiate(&f_true, 1.0 / HZ, &mut v_true, &mut a_true);

    let mut per_trial = vec![[0.0; 3]; trials as usize];
    for trial in 0..trials {
        let mut rng = crashrig_stats::stream(77, trial);
        let mut normal = || -> f64 { rng.sample(StandardNormal) };
        let offset_s = sync_ms / 1000.0 * normal();
        let mut epochs = Vec::new();
        let mut obs = Vec::new();
        for (i, &t) in times.iter().enumerate() {
            // The inward images at t; A's image at t + offset, registered with noise.
            let true_a = Rigid3::translation(car(t).x, car(t).y, car(t).z);
            let noise = [normal(), normal(), normal(), normal()].map(|z| sigma_px * z);
            observe(i, &true_a, truth[i], noise, &mut obs);
            let seen = car(t + offset_s) + Vec3::new(normal(), normal(), normal()) * sigma_c;
            let rot = so3::exp(&(Vec3::new(normal(), normal(), normal()) * sigma_r));
            let world_from_a = crashrig_geometry::quat::rigid_from_rotation(&rot, &seen);
            epochs.push(Epoch {
                key: name(i),
                name: name(i),
                world_from_a: UncertainPose::from_sigmas(
                    world_from_a,
                    Vec3::repeat(sigma_c),
                    Vec3::repeat(sigma_r),
                ),
            });
        }
        let m = measure(
            &epochs,
            None,
            &rig(),
            &obs,
            None,
            &settings(400, trial, 180, standard, sigma_px, sync_ms),
        )
        .unwrap();
        let k = m.kinematics.unwrap();
        let mut hits = [0usize; 3];
        for (i, r) in k.rows.iter().enumerate() {
            let q = [
                (r.displacement_mm, r.displacement_sigma_mm, f_true[i]),
                (r.velocity_m_s, r.velocity_sigma_m_s, v_true[i]),
                (r.acceleration_m_s2, r.acceleration_sigma_m_s2, a_true[i]),
            ];
            for (j, (est, sd, truth)) in q.into_iter().enumerate() {
                let (est, sd) = (est.unwrap(), sd.unwrap());
                // The reference epoch's raw displacement is exact by definition; its filtered
                // value is not, and is checked like every other epoch.
                hits[j] += (0..3)
                    .filter(|&c| (est[c] - truth[c]).abs() <= 2.0 * sd[c])
                    .count();
            }
        }
        for j in 0..3 {
            per_trial[trial as usize][j] = hits[j] as f64 / (3 * n) as f64;
        }
    }
    let mut out = [(0.0, 0.0); 3];
    for (j, o) in out.iter_mut().enumerate() {
        let v: Vec<f64> = per_trial.iter().map(|p| p[j]).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0);
        *o = (mean, (var / v.len() as f64).sqrt());
    }
    out
}

/// Nominal 95.45 % for a Gaussian error at ±2σ; the Monte Carlo error of the estimate is the
/// standard error of the per-trial coverage (trials are independent, epochs within a trial are
/// not). Pass: within 3 standard errors or 1.5 percentage points of 95.45 %; where
/// `conservative_above` says so, a quantity may also cover more, up to that fraction.
fn check_coverage(c: [(f64, f64); 3], what: &str, conservative_above: [f64; 3]) {
    for ((q, (cov, se)), upper) in ["displacement", "velocity", "acceleration"]
        .iter()
        .zip(c)
        .zip(conservative_above)
    {
        eprintln!(
            "{what}: {q} coverage {:.2} % ± {:.2} %",
            100.0 * cov,
            100.0 * se
        );
        let tol = (3.0 * se).max(0.015);
        assert!(
            cov >= 0.9545 - tol && cov <= (0.9545 + tol).max(upper),
            "{what}: {q} coverage {cov} (SE {se})"
        );
    }
}

/// Exact coverage is required everywhere except for velocity and acceleration under a trigger
/// offset: interpolating along A's *registered* track carries the difference of neighbouring
/// epochs' registration noise into the shift, so their σ is conservative there (measured:
/// 96.4 % and 97.2 % at 0.5 ms with 0.3 mm registration noise; docs/KINEMATICS.md).
const EXACT: [f64; 3] = [0.0; 3];
const SYNC: [f64; 3] = [0.0, 0.985, 0.985];

#[test]
fn coverage_of_the_true_filtered_kinematics() {
    check_coverage(coverage(60, 0.0, Standard::J211), "no offset, J211", EXACT);
}

#[test]
fn coverage_with_a_trigger_offset() {
    check_coverage(
        coverage(60, 0.5, Standard::Iso6487),
        "0.5 ms offset, ISO 6487",
        SYNC,
    );
}

#[test]
#[ignore = "slow: 400 synthetic tests (cargo xtask test --slow)"]
fn coverage_many_trials() {
    check_coverage(
        coverage(400, 0.5, Standard::J211),
        "0.5 ms offset, J211, 400 trials",
        SYNC,
    );
}
