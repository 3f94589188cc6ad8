//! Accuracy and honesty of σ of the single-frame fits, on frames rendered in the test
//! (support::render): per size and blur class, centre RMS, no error above 1 px, and the errors
//! whitened by each row's own covariance (|z| ≤ 2 for ≥ 90 % of the components, RMS z in
//! [0.7, 1.4]).

use crate::support::{random_marker, render};
use crashrig_track::{FitOptions, GreyView, MarkerKind};
use rand::{RngExt, SeedableRng};

/// Statistics of one class.
#[derive(Debug)]
pub struct Stats {
    pub n: usize,
    pub tried: usize,
    pub rms_px: f64,
    pub max_px: f64,
    pub within_2: f64,
    pub rms_z: f64,
}

/// The error in the principal axes of the row's covariance, each divided by its σ.
pub fn whitened(du: f64, dv: f64, su: f64, sv: f64, rho: f64) -> [f64; 2] {
    let (a, b, c) = (su * su, rho * su * sv, sv * sv);
    let half_tr = 0.5 * (a + c);
    let disc = (0.25 * (a - c).powi(2) + b * b).sqrt();
    let (l1, l2) = (half_tr + disc, (half_tr - disc).max(1e-30));
    let phi = 0.5 * (2.0 * b).atan2(a - c);
    let (s, co) = phi.sin_cos();
    let e1 = co * du + s * dv;
    let e2 = -s * du + co * dv;
    [e1 / l1.sqrt(), e2 / l2.sqrt()]
}

/// Runs `trials` single-marker fits of radius `r`, motion blur `blur` px (random direction),
/// noise σ `noise`.
pub fn class(kind: MarkerKind, r: f64, blur: f64, noise: f64, trials: usize, seed: u64) -> Stats {
    class_tilt(kind, r, blur, noise, 1.0, trials, seed)
}

/// [`class`] with the projective tilt `tilt`.
pub fn class_tilt(
    kind: MarkerKind,
    r: f64,
    blur: f64,
    noise: f64,
    tilt: f64,
    trials: usize,
    seed: u64,
) -> Stats {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
    let size = (2.0 * r + 2.0 * blur + 16.0) as usize;
    let (mut n, mut se, mut max, mut inside, mut sz, mut comps) =
        (0usize, 0.0f64, 0.0f64, 0usize, 0.0f64, 0usize);
    for t in 0..trials {
        let mut m = random_marker(&mut rng, size, r, tilt, kind == MarkerKind::Dot);
        let ang = rng.random_range(0.0..std::f64::consts::TAU);
        m.motion = (blur * ang.cos(), blur * ang.sin());
        // Start the frame's motion half a blur before so the mid-exposure centre stays central.
        m.h[2] -= 0.5 * m.motion.0 * m.h[8];
        m.h[5] -= 0.5 * m.motion.1 * m.h[8];
        let sub = if blur > 0.0 {
            (2.0 * blur).ceil() as usize + 2
        } else {
            1
        };
        let px = render(
            size,
            size,
            128.0,
            &[m],
            if blur > 0.0 { 6 } else { 12 },
            sub,
            noise,
            seed * 1000 + t as u64,
        );
        let img = GreyView::new(size, size, 255.0, &px).unwrap();
        let (tu, tv) = m.truth();
        let seed_at = (
            tu + rng.random_range(-2.0..2.0),
            tv + rng.random_range(-2.0..2.0),
        );
        let opts = FitOptions::default();
        let c = match kind.find(&img, seed_at, 4.0, &opts, |_, _| true) {
            Ok(c) => c,
            Err(e) => {
                if std::env::var("TRACK_DEBUG").is_ok() {
                    eprintln!("reject {e:?}");
                }
                continue;
            }
        };
        let (du, dv) = (c.u_px - tu, c.v_px - tv);
        n += 1;
        if std::env::var("TRACK_DEBUG").is_ok() {
            eprintln!(
                "err {du:.4} {dv:.4} σ {:.4} {:.4} res {:.3} blur {:.2}",
                c.sigma_u_px, c.sigma_v_px, c.residual_rms, c.blur_px
            );
        }
        se += du * du + dv * dv;
        max = max.max(du.hypot(dv));
        for z in whitened(du, dv, c.sigma_u_px, c.sigma_v_px, c.rho_uv) {
            comps += 1;
            sz += z * z;
            if z.abs() <= 2.0 {
                inside += 1;
            }
        }
    }
    Stats {
        n,
        tried: trials,
        rms_px: (se / n.max(1) as f64).sqrt(),
        max_px: max,
        within_2: inside as f64 / comps.max(1) as f64,
        rms_z: (sz / comps.max(1) as f64).sqrt(),
    }
}

/// Sharp quadrant targets, radius 8–25 px, mild perspective, noise σ 2: RMS ≤ 0.05 px, no
/// error above 1 px, σ honest, recall ≥ 99 %.
#[test]
#[ignore = "open: recall 56/60 for radius 8 (LowContrast/Shape refusals), issue 43"]
fn open_quadrant_sharp_per_size() {
    for (r, seed) in [(8.0, 1), (14.0, 2), (25.0, 3)] {
        let s = class(MarkerKind::Quadrant, r, 0.0, 2.0, 60, seed);
        eprintln!("quadrant r {r} sharp: {s:?}");
        assert!(s.n as f64 >= 0.99 * s.tried as f64, "{s:?}");
        assert!(s.rms_px <= 0.05 && s.max_px <= 1.0, "{s:?}");
        assert!(s.within_2 >= 0.9 && (0.7..=1.4).contains(&s.rms_z), "{s:?}");
    }
}

/// Motion blur of 3 and 6 px during the exposure: the mid-exposure centre, RMS ≤ 0.15 px.
#[test]
#[ignore = "open: σ conservative under motion blur (RMS z 0.61 at radius 8, blur 3 px), issue 43"]
fn open_quadrant_blurred_per_size_and_blur() {
    for (r, blur, seed) in [(8.0, 3.0, 4), (12.0, 6.0, 5), (20.0, 6.0, 6)] {
        let s = class(MarkerKind::Quadrant, r, blur, 2.0, 60, seed);
        eprintln!("quadrant r {r} blur {blur}: {s:?}");
        assert!(s.n as f64 >= 0.95 * s.tried as f64, "{s:?}");
        assert!(s.rms_px <= 0.15 && s.max_px <= 1.0, "{s:?}");
        assert!(s.within_2 >= 0.9 && (0.7..=1.4).contains(&s.rms_z), "{s:?}");
    }
}

/// Dots seen square-on (the ellipse's centre is then the disc's): RMS ≤ 0.05 px sharp.
#[test]
#[ignore = "open: dot σ slightly small (RMS z 1.27, 89 % within 2 at radius 8), issue 43"]
fn open_dot_square_on() {
    for (r, blur, seed) in [(8.0, 0.0, 7), (16.0, 0.0, 8), (12.0, 4.0, 9)] {
        let s = class_tilt(MarkerKind::Dot, r, blur, 2.0, 0.0, 60, seed);
        eprintln!("dot r {r} blur {blur}: {s:?}");
        assert!(s.n as f64 >= 0.99 * s.tried as f64, "{s:?}");
        assert!(s.rms_px <= if blur > 0.0 { 0.15 } else { 0.05 }, "{s:?}");
        assert!(s.within_2 >= 0.9 && (0.7..=1.4).contains(&s.rms_z), "{s:?}");
    }
}
