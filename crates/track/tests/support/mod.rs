//! A renderer with known truth for the tests: planar quadrant targets and dots under a
//! homography, anti-aliased by supersampling, motion-blurred by sub-exposures, with Gaussian
//! noise and 8-bit quantisation (seeded).

#![allow(dead_code)]

use rand::{Rng, RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// One planar marker: a target-plane → image homography (target coordinates in units of the
/// disc radius), moving by a pure image translation during the exposure.
#[derive(Debug, Clone, Copy)]
pub struct Marker {
    /// Row-major 3 × 3, target (X, Y, 1) → image (x, y, w).
    pub h: [f64; 9],
    /// Image translation during the exposure (start → end, pixels).
    pub motion: (f64, f64),
    /// Dot (disc) instead of a quadrant target.
    pub dot: bool,
    /// Grey levels: background, shade 1 (quadrants 1 and 3 or the dot), shade 2.
    pub levels: (f64, f64, f64),
}

impl Marker {
    /// A marker centred at `(u, v)` with radius `r` px, turned by `angle`, tilted by the
    /// projective terms `(p1, p2)` (per pixel of target-plane offset; ~1 / focal length).
    pub fn new(u: f64, v: f64, r: f64, angle: f64, skew: f64, p: (f64, f64), dot: bool) -> Self {
        let (s, c) = angle.sin_cos();
        // Affine part: rotation · diag(r, r·(1 − skew)) then the projective row; the
        // translation is put back so that the centre maps exactly to (u, v).
        let a = [r * c, -r * (1.0 - skew) * s, r * s, r * (1.0 - skew) * c];
        let h = [
            a[0] + u * p.0 * r,
            a[1] + u * p.1 * r,
            u,
            a[2] + v * p.0 * r,
            a[3] + v * p.1 * r,
            v,
            p.0 * r,
            p.1 * r,
            1.0,
        ];
        Self {
            h,
            motion: (0.0, 0.0),
            dot,
            levels: (200.0, 40.0, 200.0),
        }
    }

    /// The image of the target's centre at mid-exposure.
    pub fn truth(&self) -> (f64, f64) {
        (
            self.h[2] / self.h[8] + 0.5 * self.motion.0,
            self.h[5] / self.h[8] + 0.5 * self.motion.1,
        )
    }

    fn value(&self, x: f64, y: f64) -> Option<f64> {
        // Inverse homography by solving H (X, Y, 1)ᵀ ∝ (x, y, 1)ᵀ.
        let h = &self.h;
        let (a, b, c) = (h[0] - x * h[6], h[1] - x * h[7], x * h[8] - h[2]);
        let (d, e, f) = (h[3] - y * h[6], h[4] - y * h[7], y * h[8] - h[5]);
        let det = a * e - b * d;
        let (tx, ty) = ((c * e - b * f) / det, (a * f - c * d) / det);
        if tx * tx + ty * ty > 1.0 {
            return None;
        }
        Some(if self.dot || tx * ty > 0.0 {
            self.levels.1
        } else {
            self.levels.2
        })
    }
}

/// Renders `markers` into a `w × h` 8-bit-valued frame (as f32) with `ss × ss` samples per
/// pixel, `sub` sub-exposures, noise σ `noise` (grey levels), then rounded to integers.
// A test renderer's knobs, each named at the call sites.
#[allow(clippy::too_many_arguments)]
pub fn render(
    w: usize,
    h: usize,
    background: f64,
    markers: &[Marker],
    ss: usize,
    sub: usize,
    noise: f64,
    seed: u64,
) -> Vec<f32> {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise.max(1e-12)).unwrap();
    let mut out = vec![0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            let mut acc = 0.0;
            for k in 0..sub {
                let t = if sub == 1 {
                    0.5
                } else {
                    (k as f64 + 0.5) / sub as f64
                };
                for sj in 0..ss {
                    for si in 0..ss {
                        let x = i as f64 + (si as f64 + 0.5) / ss as f64;
                        let y = j as f64 + (sj as f64 + 0.5) / ss as f64;
                        let mut val = background;
                        for m in markers {
                            if let Some(v) = m.value(x - m.motion.0 * t, y - m.motion.1 * t) {
                                val = v;
                            }
                        }
                        acc += val;
                    }
                }
            }
            let mean = acc / (ss * ss * sub) as f64;
            let noisy = if noise > 0.0 {
                mean + normal.sample(&mut rng)
            } else {
                mean
            };
            out[j * w + i] = noisy.round().clamp(0.0, 255.0) as f32;
        }
    }
    out
}

/// A random marker for the statistics tests: centre near the middle of a `size` frame,
/// radius `r`, random angle, skew up to 0.2, projective terms up to `tilt / r`.
pub fn random_marker(rng: &mut impl Rng, size: usize, r: f64, tilt: f64, dot: bool) -> Marker {
    let c = size as f64 / 2.0;
    let u = c + rng.random_range(-1.0..1.0);
    let v = c + rng.random_range(-1.0..1.0);
    let angle = rng.random_range(0.0..std::f64::consts::PI);
    let skew = rng.random_range(0.0..0.2);
    let p = (
        tilt * rng.random_range(-1.0..1.0) / (r * 20.0),
        tilt * rng.random_range(-1.0..1.0) / (r * 20.0),
    );
    let mut m = Marker::new(u, v, r, angle, skew, p, dot);
    let lo = rng.random_range(20.0..60.0);
    let hi = lo + rng.random_range(120.0..180.0);
    m.levels = if dot { (lo, hi, hi) } else { (hi, lo, hi) };
    m
}
