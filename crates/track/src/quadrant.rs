//! The quadrant target: a disc in four quadrants, opposite quadrants of one shade; its centre
//! is the saddle point where the four meet.
//!
//! # Model
//! Inside a round window around the centre `(u, v)` the grey value is modelled as
//! `I(x, y) = a + b · erf(d₁ / (√2 s₁)) · erf(d₂ / (√2 s₂))`, where
//! `d_k = −(x − u) sin θ_k + (y − v) cos θ_k` is the signed distance from the line through the
//! centre at angle `θ_k`, and `s_k` the Gaussian blur width across that line. For a sharp
//! saddle blurred by a Gaussian point-spread function and perpendicular lines this is exact;
//! otherwise it is a close, **point-symmetric** approximation: the image of a quadrant target
//! is point-symmetric about its centre (also under motion blur during the exposure, about the
//! mid-exposure centre), the model is too, and the window is centred on the estimate, so what
//! the model misses does not move the centre. The eight parameters `a, b, u, v, θ₁, θ₂, s₁,
//! s₂` are fitted by Levenberg–Marquardt; the centre's covariance is the `(u, v)` block of
//! `s² (JᵀJ)⁻¹` with `s² = RSS / (n − 8)`.
//!
//! # Start
//! [`find_quadrant`] looks for the saddle in a search region: the grey values smoothed by a
//! Gaussian (σ = 1.5 px), the Hessian `H` at every pixel, candidates where `−det H` peaks. At a
//! saddle `H ∝ n₁n₂ᵀ + n₂n₁ᵀ`, whose null directions are the two lines: they start the fit.

use crate::centre::{Centre, FitOptions, Reject, centre_sigma, disc_samples};
use crate::image::GreyView;
use crate::lm::{Model, Sample, adjacent_pairs, erf_and_derivative, solve};

/// The model of the module doc; parameters `[a, b, u, v, θ₁, θ₂, s₁, s₂]`.
pub(crate) struct QuadrantModel;

/// Smallest blur width the fit may reach (pixels): a sharp edge seen through square pixels
/// is about 0.3 px wide; below this the model's derivatives vanish between pixel centres.
const MIN_BLUR_PX: f64 = 0.15;

impl Model<8> for QuadrantModel {
    const CENTRE: [usize; 2] = [2, 3];

    #[inline]
    fn eval(&self, p: &[f64; 8], x: f64, y: f64, g: &mut [f64; 8]) -> f64 {
        let [a, b, u, v, t1, t2, s1, s2] = *p;
        let (dx, dy) = (x - u, y - v);
        let (sn1, cs1) = t1.sin_cos();
        let (sn2, cs2) = t2.sin_cos();
        let d1 = -dx * sn1 + dy * cs1;
        let d2 = -dx * sn2 + dy * cs2;
        let k1 = std::f64::consts::FRAC_1_SQRT_2 / s1;
        let k2 = std::f64::consts::FRAC_1_SQRT_2 / s2;
        let (e1, de1) = erf_and_derivative(d1 * k1);
        let (e2, de2) = erf_and_derivative(d2 * k2);
        // ∂e_k/∂d_k
        let f1 = de1 * k1;
        let f2 = de2 * k2;
        g[0] = 1.0;
        g[1] = e1 * e2;
        // ∂d_k/∂u = sin θ_k, ∂d_k/∂v = −cos θ_k
        g[2] = b * (f1 * sn1 * e2 + e1 * f2 * sn2);
        g[3] = -b * (f1 * cs1 * e2 + e1 * f2 * cs2);
        // ∂d_k/∂θ_k = −dx cos θ_k − dy sin θ_k
        g[4] = b * f1 * (-dx * cs1 - dy * sn1) * e2;
        g[5] = b * e1 * f2 * (-dx * cs2 - dy * sn2);
        // ∂e_k/∂s_k = f_k · (−d_k / s_k)
        g[6] = b * f1 * (-d1 / s1) * e2;
        g[7] = b * e1 * f2 * (-d2 / s2);
        a + b * e1 * e2
    }

    fn constrain(&self, p: &mut [f64; 8]) -> bool {
        p[6] = p[6].max(MIN_BLUR_PX);
        p[7] = p[7].max(MIN_BLUR_PX);
        p[6] < 50.0 && p[7] < 50.0
    }
}

/// A start for [`fit_quadrant`]: a rough centre and the angles of the two lines (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadrantStart {
    /// Rough centre, column (pixels).
    pub u_px: f64,
    /// Rough centre, row (pixels).
    pub v_px: f64,
    /// Angle of the first line from the +u axis towards +v (radians).
    pub theta1: f64,
    /// Angle of the second line.
    pub theta2: f64,
}

/// The linear part `(a, b)` of the model for fixed centre, angles and blur: a 2 × 2 least
/// squares on the window.
fn linear_ab(samples: &[Sample], p: &[f64; 8]) -> (f64, f64) {
    let mut g = [0.0; 8];
    let (mut n, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut q = *p;
    q[0] = 0.0;
    q[1] = 1.0;
    for s in samples {
        let e = QuadrantModel.eval(&q, s.x, s.y, &mut g);
        n += 1.0;
        sx += e;
        sxx += e * e;
        sy += s.z;
        sxy += e * s.z;
    }
    let det = n * sxx - sx * sx;
    if det.abs() < 1e-12 {
        return (sy / n, 0.0);
    }
    let b = (n * sxy - sx * sy) / det;
    ((sy - b * sx) / n, b)
}

/// Fits the quadrant model of the module doc around `start` in a window of
/// [`FitOptions::window_px`], re-centring the window on the estimate until it sits on it.
///
/// # Errors
/// A [`Reject`] saying why no centre is returned.
pub fn fit_quadrant(
    img: &GreyView,
    start: QuadrantStart,
    opts: &FitOptions,
) -> Result<Centre, Reject> {
    let mut p = [
        0.0,
        0.0,
        start.u_px,
        start.v_px,
        start.theta1,
        start.theta2,
        1.5,
        1.5,
    ];
    let mut window = (start.u_px, start.v_px);
    let mut solution = None;
    for _pass in 0..5 {
        let samples =
            disc_samples(img, window.0, window.1, opts.window_px).ok_or(Reject::OutsideImage)?;
        if solution.is_none() {
            let (a, b) = linear_ab(&samples, &p);
            p[0] = a;
            p[1] = b;
        }
        let pairs = adjacent_pairs(&samples);
        let s = solve(&QuadrantModel, &samples, p, Some(&pairs)).ok_or(Reject::NotConverged)?;
        p = s.params;
        let moved = (p[2] - window.0).hypot(p[3] - window.1);
        solution = Some((s, samples.len()));
        if moved > opts.window_px * 0.5 {
            return Err(Reject::Shape);
        }
        if moved < 0.02 {
            break;
        }
        window = (p[2], p[3]);
    }
    let (s, n) = solution.ok_or(Reject::NotConverged)?;
    if (p[2] - window.0).hypot(p[3] - window.1) > 0.1 {
        return Err(Reject::Shape);
    }
    accept(img, &s.params, &s.covariance, s.residual_rms, n, opts)
}

fn accept(
    img: &GreyView,
    p: &[f64; 8],
    cov: &nalgebra::SMatrix<f64, 8, 8>,
    residual_rms: f64,
    pixels: usize,
    opts: &FitOptions,
) -> Result<Centre, Reject> {
    // The step between the two shades: the model spans a − |b| … a + |b|.
    let contrast = 2.0 * p[1].abs();
    if contrast < opts.min_contrast * f64::from(img.full_scale()) {
        return Err(Reject::LowContrast);
    }
    let blur = p[6].max(p[7]);
    if blur > opts.window_px * 0.6 {
        return Err(Reject::Shape);
    }
    // The two lines must cross at a usable angle (20°).
    let cross = (p[4] - p[5]).sin().abs();
    if cross < 20f64.to_radians().sin() {
        return Err(Reject::Shape);
    }
    if residual_rms > opts.max_residual * contrast {
        return Err(Reject::Residual);
    }
    let (su, sv, rho) = centre_sigma(cov, 2, 3);
    if !(su.is_finite() && sv.is_finite()) || su.max(sv) > opts.max_sigma_px {
        return Err(Reject::Uncertain);
    }
    Ok(Centre {
        u_px: p[2],
        v_px: p[3],
        sigma_u_px: su,
        sigma_v_px: sv,
        rho_uv: rho,
        contrast,
        blur_px: blur,
        residual_rms,
        pixels,
    })
}

/// Gaussian σ of the smoothing before the saddle search (pixels).
const SEARCH_SMOOTH_PX: f64 = 1.5;

/// A candidate of the saddle search: the pixel, its response `−det H` and its start.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    response: f64,
    start: QuadrantStart,
}

/// Separable Gaussian smoothing of the patch `[i0, i1) × [j0, j1)` (clamped reads at the image
/// border), returned row-major.
pub(crate) fn smooth_patch(
    img: &GreyView,
    (i0, i1): (usize, usize),
    (j0, j1): (usize, usize),
    sigma: f64,
) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = kernel.iter().sum();
    let (w, h) = (i1 - i0, j1 - j0);
    let (iw, ih) = (img.width() as isize, img.height() as isize);
    // Rows first over the patch's rows widened by r above and below.
    let rows: Vec<Vec<f64>> = (j0 as isize - r..j1 as isize + r)
        .map(|j| {
            let jj = j.clamp(0, ih - 1) as usize;
            (i0..i1)
                .map(|i| {
                    kernel
                        .iter()
                        .enumerate()
                        .map(|(k, wk)| {
                            let ii = (i as isize + k as isize - r).clamp(0, iw - 1) as usize;
                            wk * f64::from(img.at(ii, jj))
                        })
                        .sum::<f64>()
                        / norm
                })
                .collect()
        })
        .collect();
    let mut out = vec![0.0; w * h];
    for j in 0..h {
        for i in 0..w {
            out[j * w + i] = kernel
                .iter()
                .enumerate()
                .map(|(k, wk)| wk * rows[j + k][i])
                .sum::<f64>()
                / norm;
        }
    }
    out
}

/// Saddle candidates within `radius` of `(u, v)`, strongest first, at least 3 px apart.
fn saddle_candidates(img: &GreyView, u: f64, v: f64, radius: f64) -> Vec<Candidate> {
    let clamp = |x: f64, n: usize| x.clamp(0.0, n as f64) as usize;
    let (i0, i1) = (
        clamp((u - radius).floor() - 1.0, img.width()),
        clamp((u + radius).ceil() + 1.0, img.width()),
    );
    let (j0, j1) = (
        clamp((v - radius).floor() - 1.0, img.height()),
        clamp((v + radius).ceil() + 1.0, img.height()),
    );
    if i1 < i0 + 3 || j1 < j0 + 3 {
        return Vec::new();
    }
    let sm = smooth_patch(img, (i0, i1), (j0, j1), SEARCH_SMOOTH_PX);
    let w = i1 - i0;
    let mut cands = Vec::new();
    for j in 1..(j1 - j0 - 1) {
        for i in 1..(w - 1) {
            let x = (i0 + i) as f64 + 0.5;
            let y = (j0 + j) as f64 + 0.5;
            if (x - u).hypot(y - v) > radius {
                continue;
            }
            let at = |di: isize, dj: isize| {
                sm[(j as isize + dj) as usize * w + (i as isize + di) as usize]
            };
            let hxx = at(1, 0) - 2.0 * at(0, 0) + at(-1, 0);
            let hyy = at(0, 1) - 2.0 * at(0, 0) + at(0, -1);
            let hxy = 0.25 * (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1));
            let response = hxy * hxy - hxx * hyy;
            if response <= 0.0 {
                continue;
            }
            // Null directions of H: eigen-decomposition of the symmetric 2 × 2.
            let half_tr = 0.5 * (hxx + hyy);
            let disc = (0.25 * (hxx - hyy).powi(2) + hxy * hxy).sqrt();
            let (l1, l2) = (half_tr + disc, half_tr - disc);
            let phi = 0.5 * (2.0 * hxy).atan2(hxx - hyy); // direction of the l1 eigenvector
            let psi = (l1 / -l2).max(0.0).sqrt().atan();
            cands.push((
                response,
                i,
                j,
                QuadrantStart {
                    u_px: x,
                    v_px: y,
                    theta1: phi + psi,
                    theta2: phi - psi,
                },
            ));
        }
    }
    // Local maxima of the response (3 × 3), strongest first; ties broken by position.
    let resp = |i: usize, j: usize| -> f64 {
        cands
            .iter()
            .find(|c| c.1 == i && c.2 == j)
            .map_or(0.0, |c| c.0)
    };
    let mut peaks: Vec<Candidate> = cands
        .iter()
        .filter(|c| {
            (-1isize..=1).all(|dj| {
                (-1isize..=1).all(|di| {
                    (di == 0 && dj == 0)
                        || resp((c.1 as isize + di) as usize, (c.2 as isize + dj) as usize) <= c.0
                })
            })
        })
        .map(|c| Candidate {
            response: c.0,
            start: c.3,
        })
        .collect();
    peaks.sort_by(|a, b| {
        b.response
            .total_cmp(&a.response)
            .then(a.start.v_px.total_cmp(&b.start.v_px))
            .then(a.start.u_px.total_cmp(&b.start.u_px))
    });
    peaks
}

/// Looks for a quadrant target within `radius` of `(u, v)` and fits it: saddle candidates
/// strongest first (at most four tried); the first whose fit succeeds and whose centre
/// `accept(u, v)` allows is returned.
///
/// # Errors
/// The [`Reject`] of the last candidate tried, [`Reject::NoCandidate`] when there was none.
pub fn find_quadrant(
    img: &GreyView,
    (u, v): (f64, f64),
    radius: f64,
    opts: &FitOptions,
    accept: impl Fn(f64, f64) -> bool,
) -> Result<Centre, Reject> {
    let cands = saddle_candidates(img, u, v, radius);
    let mut last = Reject::NoCandidate;
    for c in cands.iter().take(4) {
        if !accept(c.start.u_px, c.start.v_px) {
            continue;
        }
        match fit_quadrant(img, c.start, opts) {
            Ok(centre) if accept(centre.u_px, centre.v_px) => return Ok(centre),
            Ok(_) => last = Reject::Shape,
            Err(e) => last = e,
        }
    }
    Err(last)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The analytic gradient against central differences at points near and away from the
    /// lines, for tilted, unequal lines and unequal blur.
    #[test]
    fn quadrant_jacobian_matches_finite_differences() {
        let p = [40.0, 90.0, 10.3, 11.7, 0.4, 2.1, 0.9, 1.7];
        let mut g = [0.0; 8];
        let mut gp = [0.0; 8];
        for &(x, y) in &[
            (10.5, 11.5),
            (12.5, 9.5),
            (7.5, 14.5),
            (11.0, 13.0),
            (13.7, 12.2),
        ] {
            QuadrantModel.eval(&p, x, y, &mut g);
            for k in 0..8 {
                let h = 1e-6 * (1.0 + p[k].abs());
                let (mut hi, mut lo) = (p, p);
                hi[k] += h;
                lo[k] -= h;
                let fd = (QuadrantModel.eval(&hi, x, y, &mut gp)
                    - QuadrantModel.eval(&lo, x, y, &mut gp))
                    / (2.0 * h);
                // Central differences with h ~ 1e-6 are good to ~1e-8 absolute here; the erf
                // approximation's derivative differs from the exact Gaussian by < 1e-5
                // relative to the largest gradient (values of order 100).
                assert_relative_eq!(g[k], fd, epsilon = 2e-3, max_relative = 1e-4);
            }
        }
    }
}
