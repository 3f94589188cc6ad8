//! The dot: a disc brighter or darker than its surround; its centre is the centre of the
//! imaged disc.
//!
//! # Model
//! Over a window covering the disc and a ring of its surround the grey value is modelled as a
//! blurred ellipse edge, `I(x, y) = a + b · (1 + erf(d / (√2 s))) / 2`, with
//! `d = (1 − ρ) · √(r₁ r₂)` and `ρ = √((p₁/r₁)² + (p₂/r₂)²)`, `(p₁, p₂)` the pixel's position
//! relative to the centre `(u, v)` in axes turned by `φ`: `a` is the surround, `a + b` the
//! disc, `r₁, r₂` the semi-axes, `s` the blur. Eight parameters `a, b, u, v, r₁, r₂, φ, s`
//! fitted by Levenberg–Marquardt; the centre's covariance is the `(u, v)` block of
//! `s² (JᵀJ)⁻¹`, `s² = RSS / (n − 8)`.
//!
//! The fitted centre is the centre of the imaged ellipse. The image of the disc's own centre
//! differs from it by a perspective term of order `r² / f` times the tilt of the disc (for a
//! 10 px disc seen at 30° through a lens of 1 000 px focal length: ≈ 0.03 px); without the
//! camera's intrinsics and the disc's plane it cannot be removed here (docs/TRACK.md).
//!
//! # Start
//! [`find_dot`] casts 24 rays from the predicted position, takes on each the position of the
//! largest grey-value step, fits a circle to those edge points (dropping outliers) and starts
//! the fit from it.

use crate::centre::{Centre, FitOptions, Reject, centre_sigma};
use crate::image::GreyView;
use crate::lm::{Model, Sample, adjacent_pairs, erf_and_derivative, solve};

/// The model of the module doc; parameters `[a, b, u, v, r₁, r₂, φ, s]`.
pub(crate) struct DotModel;

impl Model<8> for DotModel {
    const CENTRE: [usize; 2] = [2, 3];

    #[inline]
    fn eval(&self, p: &[f64; 8], x: f64, y: f64, g: &mut [f64; 8]) -> f64 {
        let [a, b, u, v, r1, r2, phi, s] = *p;
        let (dx, dy) = (x - u, y - v);
        let (sn, cs) = phi.sin_cos();
        let p1 = cs * dx + sn * dy;
        let p2 = -sn * dx + cs * dy;
        let q = (p1 / r1).powi(2) + (p2 / r2).powi(2);
        let rho = q.sqrt().max(1e-9);
        let rbar = (r1 * r2).sqrt();
        let d = (1.0 - rho) * rbar;
        let k = std::f64::consts::FRAC_1_SQRT_2 / s;
        let (e, de) = erf_and_derivative(d * k);
        let step = 0.5 * (1.0 + e);
        // ∂I/∂d
        let fd = 0.5 * b * de * k;
        // ∂ρ/∂p1, ∂ρ/∂p2
        let rp1 = p1 / (r1 * r1 * rho);
        let rp2 = p2 / (r2 * r2 * rho);
        // ∂ρ/∂u = rp1 ∂p1/∂u + rp2 ∂p2/∂u with ∂p1/∂u = −cos φ, ∂p2/∂u = sin φ
        let rho_u = -rp1 * cs + rp2 * sn;
        let rho_v = -rp1 * sn - rp2 * cs;
        // ∂p1/∂φ = p2, ∂p2/∂φ = −p1
        let rho_phi = rp1 * p2 - rp2 * p1;
        let rho_r1 = -p1 * p1 / (r1 * r1 * r1 * rho);
        let rho_r2 = -p2 * p2 / (r2 * r2 * r2 * rho);
        g[0] = 1.0;
        g[1] = step;
        g[2] = fd * (-rbar * rho_u);
        g[3] = fd * (-rbar * rho_v);
        g[4] = fd * (-rbar * rho_r1 + (1.0 - rho) * rbar / (2.0 * r1));
        g[5] = fd * (-rbar * rho_r2 + (1.0 - rho) * rbar / (2.0 * r2));
        g[6] = fd * (-rbar * rho_phi);
        g[7] = fd * (-d / s);
        a + b * step
    }

    fn constrain(&self, p: &mut [f64; 8]) -> bool {
        p[7] = p[7].max(0.15);
        p[4] > 1.0 && p[5] > 1.0 && p[7] < 30.0
    }
}

/// Bilinear value at `(x, y)` in pixel-centre coordinates (`None` outside).
fn bilinear(img: &GreyView, x: f64, y: f64) -> Option<f64> {
    let (fx, fy) = (x - 0.5, y - 0.5);
    if fx < 0.0 || fy < 0.0 {
        return None;
    }
    let (i, j) = (fx.floor() as usize, fy.floor() as usize);
    if i + 1 >= img.width() || j + 1 >= img.height() {
        return None;
    }
    let (tx, ty) = (fx - i as f64, fy - j as f64);
    let at = |i, j| f64::from(img.at(i, j));
    Some(
        (1.0 - ty) * ((1.0 - tx) * at(i, j) + tx * at(i + 1, j))
            + ty * ((1.0 - tx) * at(i, j + 1) + tx * at(i + 1, j + 1)),
    )
}

/// Kåsa's algebraic circle fit: centre and radius.
fn circle_fit(pts: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut suu, mut svv, mut suv, mut suuu, mut svvv, mut suvv, mut svuu) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y) in pts {
        let (u, v) = (x - mx, y - my);
        suu += u * u;
        svv += v * v;
        suv += u * v;
        suuu += u * u * u;
        svvv += v * v * v;
        suvv += u * v * v;
        svuu += v * u * u;
    }
    let det = suu * svv - suv * suv;
    if det.abs() < 1e-9 {
        return None;
    }
    let (b1, b2) = (0.5 * (suuu + suvv), 0.5 * (svvv + svuu));
    let uc = (b1 * svv - b2 * suv) / det;
    let vc = (suu * b2 - suv * b1) / det;
    let r = (uc * uc + vc * vc + (suu + svv) / n).sqrt();
    Some((uc + mx, vc + my, r))
}

/// Rays cast by the start.
const RAYS: usize = 24;

/// The circle the rays from `(u, v)` see: centre, radius.
fn ray_circle(img: &GreyView, u: f64, v: f64, max_r: f64) -> Option<(f64, f64, f64)> {
    let mut pts = Vec::with_capacity(RAYS);
    let inside = bilinear(img, u, v)?;
    for k in 0..RAYS {
        let ang = k as f64 * std::f64::consts::TAU / RAYS as f64;
        let (c, s) = (ang.cos(), ang.sin());
        let step = 0.5;
        let mut prev = inside;
        let mut best = (0.0, 0.0);
        let mut t = step;
        while t <= max_r {
            let Some(val) = bilinear(img, u + c * t, v + s * t) else {
                break;
            };
            // The step out of the disc: the value leaves the inside's level.
            let diff = (prev - val) * (inside - val).signum();
            if diff > best.0 {
                best = (diff, t - 0.5 * step);
            }
            prev = val;
            t += step;
        }
        if best.0 > 0.0 {
            pts.push((u + c * best.1, v + s * best.1));
        }
    }
    if pts.len() < RAYS / 2 {
        return None;
    }
    let (mut cu, mut cv, mut r) = circle_fit(&pts)?;
    for _ in 0..2 {
        let kept: Vec<_> = pts
            .iter()
            .copied()
            .filter(|p| ((p.0 - cu).hypot(p.1 - cv) - r).abs() < 0.25 * r + 1.0)
            .collect();
        if kept.len() < RAYS / 2 {
            return None;
        }
        (cu, cv, r) = circle_fit(&kept)?;
    }
    Some((cu, cv, r))
}

/// The pixels within `reach` of the ellipse's centre, scaled: `ρ ≤ 1 + margin / r`.
fn ellipse_samples(img: &GreyView, p: &[f64; 8], margin: f64) -> Option<Vec<Sample>> {
    let rmax = p[4].max(p[5]) + margin;
    let (u, v) = (p[2], p[3]);
    let (i0, i1) = ((u - rmax).floor(), (u + rmax).ceil());
    let (j0, j1) = ((v - rmax).floor(), (v + rmax).ceil());
    if !(i0 >= 0.0 && j0 >= 0.0 && i1 <= img.width() as f64 && j1 <= img.height() as f64) {
        return None;
    }
    let (sn, cs) = p[6].sin_cos();
    let mut out = Vec::new();
    for j in j0 as usize..j1 as usize {
        let y = j as f64 + 0.5;
        for i in i0 as usize..i1 as usize {
            let x = i as f64 + 0.5;
            let (dx, dy) = (x - u, y - v);
            let p1 = (cs * dx + sn * dy) / (p[4] + margin);
            let p2 = (-sn * dx + cs * dy) / (p[5] + margin);
            if p1 * p1 + p2 * p2 <= 1.0 {
                out.push(Sample {
                    x,
                    y,
                    z: f64::from(img.at(i, j)),
                });
            }
        }
    }
    Some(out)
}

/// Looks for a dot containing `(u, v)` (or, when `radius > 0`, containing a point of a grid
/// of 4 px spacing within `radius` of it, nearest first) and fits it; the first centre that
/// `accept` allows is returned.
///
/// # Errors
/// The [`Reject`] of the last start tried.
pub fn find_dot(
    img: &GreyView,
    (u, v): (f64, f64),
    radius: f64,
    opts: &FitOptions,
    accept: impl Fn(f64, f64) -> bool,
) -> Result<Centre, Reject> {
    let mut starts = vec![(u, v)];
    let n = (radius / 4.0).floor() as i64;
    let mut grid: Vec<(f64, f64)> = (-n..=n)
        .flat_map(|j| (-n..=n).map(move |i| (i as f64 * 4.0, j as f64 * 4.0)))
        .filter(|&(di, dj)| (di != 0.0 || dj != 0.0) && di.hypot(dj) <= radius)
        .collect();
    grid.sort_by(|a, b| {
        a.0.hypot(a.1)
            .total_cmp(&b.0.hypot(b.1))
            .then(a.1.total_cmp(&b.1))
            .then(a.0.total_cmp(&b.0))
    });
    starts.extend(grid.into_iter().map(|(di, dj)| (u + di, v + dj)));
    let mut last = Reject::NoCandidate;
    let mut tried: Vec<(f64, f64)> = Vec::new();
    for (su, sv) in starts {
        let Some((cu, cv, r)) = ray_circle(img, su, sv, opts.max_radius_px) else {
            continue;
        };
        if tried.iter().any(|t| (t.0 - cu).hypot(t.1 - cv) < 1.0) || !accept(cu, cv) {
            continue;
        }
        tried.push((cu, cv));
        match fit_dot(img, (cu, cv, r), opts) {
            Ok(c) if accept(c.u_px, c.v_px) => return Ok(c),
            Ok(_) => last = Reject::Shape,
            Err(e) => last = e,
        }
        if tried.len() >= 4 {
            break;
        }
    }
    Err(last)
}

/// Fits the dot model of the module doc from a circle `(u, v, r)`.
///
/// # Errors
/// A [`Reject`] saying why no centre is returned.
pub fn fit_dot(
    img: &GreyView,
    (u, v, r): (f64, f64, f64),
    opts: &FitOptions,
) -> Result<Centre, Reject> {
    if !(r >= 2.0 && r <= opts.max_radius_px) {
        return Err(Reject::Shape);
    }
    // Start: inside and surround levels from the means over the disc and a ring.
    let mut p = [0.0, 0.0, u, v, r, r, 0.0, 1.0];
    let (mut si, mut ni, mut so, mut no) = (0.0, 0.0, 0.0, 0.0);
    let margin = |s: f64| 3.0 * s + 3.0;
    let samples = ellipse_samples(img, &p, margin(1.0)).ok_or(Reject::OutsideImage)?;
    for s in &samples {
        let d = (s.x - u).hypot(s.y - v);
        if d < r - 1.5 {
            si += s.z;
            ni += 1.0;
        } else if d > r + 1.5 {
            so += s.z;
            no += 1.0;
        }
    }
    if ni < 4.0 || no < 4.0 {
        return Err(Reject::Shape);
    }
    p[0] = so / no;
    p[1] = si / ni - p[0];
    let mut solution = None;
    for _pass in 0..4 {
        let m = margin(p[7]);
        let samples = ellipse_samples(img, &p, m).ok_or(Reject::OutsideImage)?;
        let pairs = adjacent_pairs(&samples);
        let s = solve(&DotModel, &samples, p, Some(&pairs)).ok_or(Reject::NotConverged)?;
        let before = p;
        p = s.params;
        solution = Some((s, samples.len()));
        let moved = (p[2] - before[2]).hypot(p[3] - before[3]);
        let grew = (p[4] - before[4])
            .abs()
            .max((p[5] - before[5]).abs())
            .max(3.0 * (p[7] - before[7]).abs());
        if moved < 0.05 && grew < 0.3 {
            break;
        }
    }
    let (s, n) = solution.ok_or(Reject::NotConverged)?;
    let contrast = p[1].abs();
    if contrast < opts.min_contrast * f64::from(img.full_scale()) {
        return Err(Reject::LowContrast);
    }
    let (r1, r2) = (p[4].min(p[5]), p[4].max(p[5]));
    if r1 < 0.3 * r2
        || r2 > opts.max_radius_px
        || p[7] > 0.5 * r1
        || (p[2] - u).hypot(p[3] - v) > 0.5 * r
    {
        return Err(Reject::Shape);
    }
    if s.residual_rms > opts.max_residual * contrast {
        return Err(Reject::Residual);
    }
    let (su, sv, rho) = centre_sigma(&s.covariance, 2, 3);
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
        blur_px: p[7],
        residual_rms: s.residual_rms,
        pixels: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn dot_jacobian_matches_finite_differences() {
        let p = [30.0, 120.0, 20.2, 19.6, 9.0, 7.0, 0.6, 1.3];
        let mut g = [0.0; 8];
        let mut gp = [0.0; 8];
        for &(x, y) in &[
            (28.5, 19.5),
            (20.5, 26.5),
            (14.5, 14.5),
            (25.0, 24.0),
            (20.5, 18.5),
        ] {
            DotModel.eval(&p, x, y, &mut g);
            for k in 0..8 {
                let h = 1e-6 * (1.0 + p[k].abs());
                let (mut hi, mut lo) = (p, p);
                hi[k] += h;
                lo[k] -= h;
                let fd = (DotModel.eval(&hi, x, y, &mut gp) - DotModel.eval(&lo, x, y, &mut gp))
                    / (2.0 * h);
                // As for the quadrant model: central differences ~1e-8, the erf
                // approximation's derivative within 1e-5 of the exact one (relative).
                assert_relative_eq!(g[k], fd, epsilon = 2e-3, max_relative = 1e-4);
            }
        }
    }
}
