//! ω-φ-κ: known matrices, the paper's angles, round trips, gimbal lock, derivatives.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::angles::wrap_pi;
use crashrig_geometry::tolerance::GIMBAL_LOCK_COS_PHI;
use crashrig_geometry::{Error, Mat3, Rot3, Vec3, opk, so3};
use crashrig_testkit::strategies::{opk_away_from_gimbal, rot3};
use std::f64::consts::FRAC_PI_2;

/// Central-difference step and tolerance (truncation h² ≈ 1e-12, rounding ε/h ≈ 2e-11;
/// d_opk grows like 1/cos φ, and the strategies keep cos φ ≥ 0.01, hence 1e-6).
const H: f64 = 1e-5;

#[test]
fn rotation_from_opk_nominal_single_axes() {
    // Hand-written Rx(90°), Ry(90°), Rz(90°); cos(π/2) ≈ 6e-17.
    let rx = Mat3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
    let ry = Mat3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
    let rz = Mat3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    assert_abs_diff_eq!(
        *opk::rotation_from_opk(FRAC_PI_2, 0.0, 0.0).matrix(),
        rx,
        epsilon = 1e-15
    );
    assert_abs_diff_eq!(
        *opk::rotation_from_opk(0.0, FRAC_PI_2, 0.0).matrix(),
        ry,
        epsilon = 1e-15
    );
    assert_abs_diff_eq!(
        *opk::rotation_from_opk(0.0, 0.0, FRAC_PI_2).matrix(),
        rz,
        epsilon = 1e-15
    );
}

#[test]
fn rotation_from_opk_order_is_rx_ry_rz() {
    // The product Rx(ω)·Ry(φ)·Rz(κ) written out by hand, entry by entry.
    let (o, p, k): (f64, f64, f64) = (0.3, -0.4, 1.1);
    let (so, co, sp, cp, sk, ck) = (o.sin(), o.cos(), p.sin(), p.cos(), k.sin(), k.cos());
    let expected = Mat3::new(
        cp * ck,
        -cp * sk,
        sp,
        co * sk + so * sp * ck,
        co * ck - so * sp * sk,
        -so * cp,
        so * sk - co * sp * ck,
        so * ck + co * sp * sk,
        co * cp,
    );
    assert_relative_eq!(
        *opk::rotation_from_opk(o, p, k).matrix(),
        expected,
        epsilon = 1e-15
    );
}

#[test]
fn opk_paper_angles_round_trip() {
    // The paper's rig link angles (179.92, −0.09, 179.76)°.
    let (o, p, k) = (
        179.92f64.to_radians(),
        (-0.09f64).to_radians(),
        179.76f64.to_radians(),
    );
    let a = opk::opk_from_rotation(&opk::rotation_from_opk(o, p, k));
    assert!(!a.gimbal_lock);
    // Far from gimbal lock, atan2 of exact-to-ulps entries: ~1e-15 rad.
    assert_relative_eq!(a.omega, o, epsilon = 1e-14);
    assert_relative_eq!(a.phi, p, epsilon = 1e-14);
    assert_relative_eq!(a.kappa, k, epsilon = 1e-14);
}

#[test]
fn opk_gimbal_lock_nominal() {
    for phi in [FRAC_PI_2, -FRAC_PI_2] {
        for (o, k) in [(0.3, 0.0), (0.3, -1.2), (-2.5, 2.9), (0.0, 0.7)] {
            let r = opk::rotation_from_opk(o, phi, k);
            let a = opk::opk_from_rotation(&r);
            assert!(a.gimbal_lock, "φ = {phi}, ω = {o}, κ = {k}");
            assert_eq!(a.kappa, 0.0);
            assert_relative_eq!(a.phi, phi, epsilon = 1e-15);
            // R reproduced: entries exact to a few ulps.
            let back = opk::rotation_from_opk(a.omega, a.phi, a.kappa);
            assert_abs_diff_eq!(*back.matrix(), *r.matrix(), epsilon = 1e-15);
            // Only ω ± κ is defined: ω = ω₀ + sign(φ)·κ₀.
            assert_relative_eq!(
                wrap_pi(a.omega - (o + phi.signum() * k)),
                0.0,
                epsilon = 1e-15
            );
        }
    }
}

#[test]
fn d_opk_d_tangent_gimbal_lock_is_err() {
    let r = opk::rotation_from_opk(0.2, FRAC_PI_2, 0.1);
    assert!(matches!(
        opk::d_opk_d_tangent_right(&r),
        Err(Error::GimbalLock { .. })
    ));
    assert!(matches!(
        opk::d_opk_d_tangent_left(&r),
        Err(Error::GimbalLock { .. })
    ));
}

fn opk_vec(r: &Rot3) -> Vec3 {
    let a = opk::opk_from_rotation(r);
    Vec3::new(a.omega, a.phi, a.kappa)
}

/// Central difference of ω-φ-κ under a perturbation, wrap-safe (ω, κ may sit near ±π).
fn fd_opk(perturbed: impl Fn(&Vec3) -> Rot3) -> Mat3 {
    let mut m = Mat3::zeros();
    for i in 0..3 {
        let mut e = Vec3::zeros();
        e[i] = H;
        let d = opk_vec(&perturbed(&e)) - opk_vec(&perturbed(&-e));
        m.set_column(i, &(d.map(wrap_pi) / (2.0 * H)));
    }
    m
}

#[test]
fn d_opk_d_tangent_paper_angles_finite_difference() {
    let r = opk::rotation_from_opk(
        179.92f64.to_radians(),
        (-0.09f64).to_radians(),
        179.76f64.to_radians(),
    );
    let right = fd_opk(|d| r * so3::exp(d));
    let left = fd_opk(|d| so3::exp(d) * r);
    assert_abs_diff_eq!(
        opk::d_opk_d_tangent_right(&r).unwrap(),
        right,
        epsilon = 1e-8
    );
    assert_abs_diff_eq!(opk::d_opk_d_tangent_left(&r).unwrap(), left, epsilon = 1e-8);
}

proptest::proptest! {
    #[test]
    fn opk_round_trip_away_from_gimbal((o, p, k) in opk_away_from_gimbal()) {
        let a = opk::opk_from_rotation(&opk::rotation_from_opk(o, p, k));
        proptest::prop_assert!(!a.gimbal_lock);
        // cos φ ≥ 0.01: the atan2 arguments keep ≥ 1e-2 magnitude, error ≲ 1e-13 rad.
        assert_abs_diff_eq!(wrap_pi(a.omega - o), 0.0, epsilon = 1e-12);
        assert_abs_diff_eq!(a.phi, p, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap_pi(a.kappa - k), 0.0, epsilon = 1e-12);
    }

    #[test]
    fn rotation_round_trip_any(r in rot3()) {
        let a = opk::opk_from_rotation(&r);
        let back = opk::rotation_from_opk(a.omega, a.phi, a.kappa);
        // Any rotation (gimbal lock included) is reproduced; near lock the fold costs ≲ 1e-9.
        assert_abs_diff_eq!(*back.matrix(), *r.matrix(), epsilon = 1e-12);
        proptest::prop_assert!(a.phi.abs() <= FRAC_PI_2);
    }

    #[test]
    fn d_rotation_d_opk_finite_difference((o, p, k) in opk_away_from_gimbal()) {
        let [dw, dp, dk] = opk::d_rotation_d_opk(o, p, k);
        let fd = |f: &dyn Fn(f64) -> Mat3, x: f64| (f(x + H) - f(x - H)) / (2.0 * H);
        let nw = fd(&|x| opk::rotation_from_opk(x, p, k).into_inner(), o);
        let np = fd(&|x| opk::rotation_from_opk(o, x, k).into_inner(), p);
        let nk = fd(&|x| opk::rotation_from_opk(o, p, x).into_inner(), k);
        // Entries are products of sines/cosines: truncation h²/6 ≈ 2e-11.
        assert_abs_diff_eq!(dw, nw, epsilon = 1e-9);
        assert_abs_diff_eq!(dp, np, epsilon = 1e-9);
        assert_abs_diff_eq!(dk, nk, epsilon = 1e-9);
    }

    #[test]
    fn d_opk_d_tangent_finite_difference((o, p, k) in opk_away_from_gimbal()) {
        let r = opk::rotation_from_opk(o, p, k);
        let right = fd_opk(|d| r * so3::exp(d));
        let left = fd_opk(|d| so3::exp(d) * r);
        // Third derivatives of ω-φ-κ grow like 1/cos³φ: truncation ≈ h²/6·1/cos³φ, plus rounding
        // ε·π/h/cos φ; 1e-9/cos³φ covers both (1e-9 at φ = 0, 1e-3 at cos φ = 0.01).
        let tol = 1e-9 / p.cos().powi(3);
        assert_abs_diff_eq!(opk::d_opk_d_tangent_right(&r).unwrap(), right, epsilon = tol);
        assert_abs_diff_eq!(opk::d_opk_d_tangent_left(&r).unwrap(), left, epsilon = tol);
    }
}

#[test]
fn opk_near_gimbal_lock_reproduces_rotation() {
    // Just outside the lock threshold the normal branch still reproduces R to rounding (the
    // errors of ω and κ are correlated); inside it, folding κ into ω costs ≈ cos φ·|κ|.
    for e in [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
        for sign in [1.0, -1.0] {
            for (o, k) in [(0.3, 1.0), (-2.0, 2.5), (1.0, -0.7)] {
                let r = opk::rotation_from_opk(o, sign * (FRAC_PI_2 - e), k);
                let a = opk::opk_from_rotation(&r);
                assert_eq!(a.gimbal_lock, e < GIMBAL_LOCK_COS_PHI);
                let back = opk::rotation_from_opk(a.omega, a.phi, a.kappa);
                let tol = if a.gimbal_lock {
                    2.0 * e * f64::abs(k)
                } else {
                    1e-15
                };
                assert_abs_diff_eq!(*back.matrix(), *r.matrix(), epsilon = tol);
            }
        }
    }
}
