//! Wrap-safe angle statistics.

use approx::assert_relative_eq;
use crashrig_geometry::Error;
use crashrig_geometry::angles::{circular_mean, unwrap_about, wrap_pi, wrapped_stats};
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};

#[test]
fn wrap_pi_nominal() {
    assert_relative_eq!(wrap_pi(0.3), 0.3, epsilon = 0.0);
    assert_relative_eq!(wrap_pi(1.5 * PI), -0.5 * PI, epsilon = 1e-15);
    // The interval is (−π, π]: both ends map to +π.
    assert_relative_eq!(wrap_pi(PI), PI, epsilon = 0.0);
    assert_relative_eq!(wrap_pi(-PI), PI, epsilon = 0.0);
    assert_relative_eq!(wrap_pi(7.0 * PI), PI, epsilon = 1e-14);
    assert_relative_eq!(wrap_pi(-0.1 - 4.0 * TAU), -0.1, epsilon = 1e-14);
    assert!(wrap_pi(f64::NAN).is_nan());
}

#[test]
fn circular_mean_across_pi() {
    let a = [179.9f64.to_radians(), (-179.95f64).to_radians()];
    // The midpoint on the circle is 179.975°, not ~0°.
    assert_relative_eq!(
        circular_mean(&a).unwrap().to_degrees(),
        179.975,
        epsilon = 1e-10
    );
}

#[test]
fn circular_mean_errors() {
    assert_eq!(
        circular_mean(&[]),
        Err(Error::TooFewSamples {
            needed: 1,
            found: 0
        })
    );
    assert!(matches!(
        circular_mean(&[0.0, PI]),
        Err(Error::UndefinedCircularMean { .. })
    ));
    assert!(matches!(
        circular_mean(&[0.0, f64::NAN]),
        Err(Error::NonFinite { .. })
    ));
}

#[test]
fn unwrap_about_nominal() {
    let u = unwrap_about(&[(-179.95f64).to_radians(), 179.9f64.to_radians()], PI);
    assert_relative_eq!(u[0].to_degrees(), 180.05, epsilon = 1e-10);
    assert_relative_eq!(u[1].to_degrees(), 179.9, epsilon = 1e-10);
}

#[test]
fn wrapped_stats_two_values_across_pi() {
    let s = wrapped_stats(&[179.9f64.to_radians(), (-179.95f64).to_radians()]).unwrap();
    // 179.9° and 180.05°: mean 179.975°, σ = 0.15/√2 °, not ~180°.
    assert_relative_eq!(s.mean.to_degrees(), 179.975, epsilon = 1e-10);
    assert_relative_eq!(s.sigma.to_degrees(), 0.15 / 2f64.sqrt(), epsilon = 1e-10);
    assert_relative_eq!(s.sem, s.sigma / 2f64.sqrt(), epsilon = 1e-18);
    assert_eq!(s.n, 2);
}

#[test]
fn wrapped_stats_paper_omega() {
    // ω ≈ 179.92° with σ 0.047° (the paper's Table 2): values built with exactly that mean and
    // sample σ, some of which cross 180° and are stored wrapped to negative degrees.
    let z = [-1.7, -1.1, -0.6, -0.2, 0.0, 0.3, 0.5, 0.9, 1.4, 2.2, 4.0];
    let n = z.len() as f64;
    let zm = z.iter().sum::<f64>() / n;
    let zs = (z.iter().map(|v| (v - zm) * (v - zm)).sum::<f64>() / (n - 1.0)).sqrt();
    let deg: Vec<f64> = z.iter().map(|v| 179.92 + 0.047 * (v - zm) / zs).collect();
    let wrapped: Vec<f64> = deg.iter().map(|d| wrap_pi(d.to_radians())).collect();
    assert!(
        wrapped.iter().any(|a| *a < 0.0),
        "the fixture must cross ±180°"
    );
    let s = wrapped_stats(&wrapped).unwrap();
    // Degrees→radians→wrap→back: rounding ~1e-13°.
    assert_relative_eq!(s.mean.to_degrees(), 179.92, epsilon = 1e-10);
    assert_relative_eq!(s.sigma.to_degrees(), 0.047, epsilon = 1e-10);
    assert_relative_eq!(s.sem.to_degrees(), 0.047 / n.sqrt(), epsilon = 1e-10);
}

#[test]
fn wrapped_stats_errors() {
    assert_eq!(
        wrapped_stats(&[0.1]),
        Err(Error::TooFewSamples {
            needed: 2,
            found: 1
        })
    );
}

proptest! {
    #[test]
    fn wrapped_stats_invariant_to_turns(
        c in -PI..PI,
        d in proptest::collection::vec(-0.5..0.5f64, 2..20),
        turns in proptest::collection::vec(-3i32..=3, 20),
    ) {
        let base: Vec<f64> = d.iter().map(|x| c + x).collect();
        let shifted: Vec<f64> = base.iter().zip(&turns).map(|(a, k)| a + f64::from(*k) * TAU).collect();
        let s0 = wrapped_stats(&base).unwrap();
        let s1 = wrapped_stats(&shifted).unwrap();
        // Whole turns only change rounding (|a| ≤ 7π): ~1e-14 rad.
        assert_relative_eq!(wrap_pi(s0.mean - s1.mean), 0.0, epsilon = 1e-12);
        assert_relative_eq!(s0.sigma, s1.sigma, epsilon = 1e-12);
        // Spread of ±0.5 rad about c: the plain statistics of `d` apply.
        let n = d.len() as f64;
        let m = d.iter().sum::<f64>() / n;
        let sd = (d.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt();
        assert_relative_eq!(wrap_pi(s0.mean - (c + m)), 0.0, epsilon = 1e-12);
        assert_relative_eq!(s0.sigma, sd, epsilon = 1e-12);
    }
}
