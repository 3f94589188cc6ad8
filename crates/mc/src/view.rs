//! One observer as seen from one grid point ([`View`]), the one observer form of every grid
//! path: an aimed observer (re-aimed at the point, observed at the principal point, optional
//! pixel noise in normalized coordinates) or a fixed camera with its lens (the true pixel, the
//! lens's Jacobian, the undistortion of a noisy pixel, per draw or per lane).
//!
//! Visibility ([`sight`]): a fixed camera sees a point when it lies in front (z > 0 in the
//! camera frame), projects through its lens inside the image (`0 ≤ u < width`,
//! `0 ≤ v < height`, COLMAP's pixel convention) and the lens maps the pixel back to the same
//! ray (undistortion round trip within 1e-9; this rejects points far outside the field of view
//! that a polynomial distortion folds back into the image).
//!
//! Undistortion in lanes ([`undistort_lanes`]): the linear predictor `n₀ + J⁻¹·δu` (J =
//! ∂pixel/∂normalized at the true pixel) is exact for lenses without distortion. Distorting
//! lenses with a written-out projection ([`FastLens`]: SIMPLE_RADIAL, RADIAL, OPENCV,
//! FULL_OPENCV) take exactly [`REFINE_STEPS`] chord-Newton steps per lane, branch-free; a lane
//! whose last residual is still ≥ [`UNDISTORT_RESIDUAL_PX`] (or not finite) is recomputed by
//! the scalar [`undistort`] — a fix-up that depends only on that draw's pixel offset, so
//! results do not depend on the block, the thread count or the instruction set.

use crate::kernel::normal::{LANES, Lane};
use crate::model::{Aim, FixedCamera, Observer};
use crashrig_camera::{Camera as Lens, ModelId};
#[cfg(test)]
use nalgebra::Vector6;
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector2, Vector3};

/// The undistortion in the draw loop stops when the refined ray reprojects within this many
/// pixels of the observed pixel.
pub const UNDISTORT_RESIDUAL_PX: f64 = 1e-7;

/// Largest number of chord-Newton refinements of the scalar undistortion before the fallback.
const MAX_REFINE: usize = 8;

/// Chord-Newton steps of the undistortion in lanes (every lane takes all of them). The
/// predictor's error is second order in the pixel offset and each step multiplies it by the
/// relative change of the lens Jacobian over the offset (≈ 10⁻⁴–10⁻³ for 0.5–0.8 px at
/// 1000 px focal length near an image corner); the residual checked is the one before the last
/// update, after `REFINE_STEPS − 1` steps: with two steps it was ≈ 10⁻⁷ px near the corners of
/// a strongly distorting lens (k1 = −0.15), where most lanes then took the scalar fix-up; with
/// three it is ≈ 10⁻¹⁰ px (`docs/performance.md`, +13 % on the real-study map).
pub(crate) const REFINE_STEPS: usize = 3;

/// Relative tolerance of the visibility round trip (pixel → ray → same ray).
const ROUND_TRIP_TOL: f64 = 1e-9;

/// One observer as seen from one grid point, ready for the draw loop.
#[derive(Debug, Clone, Copy)]
pub(crate) struct View<'a> {
    /// Nominal projection centre (world, mm).
    pub(crate) c: Vector3<f64>,
    /// Nominal `R_world_from_cam`.
    pub(crate) r: Matrix3<f64>,
    /// ω φ κ of `r` (base of `euler` noise).
    pub(crate) opk: Vector3<f64>,
    /// Lower factor of the pose-noise covariance (mm, rad): `δ = L·ε`.
    pub(crate) l: Matrix6<f64>,
    /// The diagonal of `l` when `l` is diagonal (independent σ): `δ = σ∘ε`.
    #[cfg(test)]
    pub(crate) diag: Option<Vector6<f64>>,
    /// `euler` rotation noise (else tangent).
    pub(crate) euler: bool,
    /// Exact normalized coordinates of the true point.
    pub(crate) n0: Vector2<f64>,
    /// The true pixel (COLMAP convention; unused for aimed views).
    pub(crate) u0: Vector2<f64>,
    /// ∂normalized/∂pixel at the true pixel.
    pub(crate) jinv: Matrix2<f64>,
    /// σ of each image coordinate (px).
    pub(crate) sigma_px: f64,
    /// The lens when it distorts (the predictor needs refining), else `None`.
    pub(crate) lens: Option<&'a Lens>,
    /// Its written-out projection, for the models that have one.
    pub(crate) fast: Option<FastLens>,
    /// The full lens (for the fallback unprojection), `None` for aimed views.
    pub(crate) full_lens: Option<&'a Lens>,
    /// Chain camera whose joint draw this view takes (correlated mode).
    pub(crate) source: Option<usize>,
}

/// The projection of the radial-tangential lenses (SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV)
/// written out for the draw loop: normalized (x, y) ↦ pixel, COLMAP's formulas
/// (`sensor/models.h`), no validation and no `Result` (the lens was validated when read).
/// Tested against `crashrig_camera::Camera::img_from_cam` (`fixed_fast_lens_matches_camera_crate`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FastLens {
    f: [f64; 2],
    c: [f64; 2],
    /// k1 k2 k3 (numerator), k4 k5 k6 (denominator), p1 p2.
    k: [f64; 6],
    p: [f64; 2],
}

impl FastLens {
    /// The fast form of `lens`, if its model has one.
    pub(crate) fn of(lens: &Lens) -> Option<FastLens> {
        use ModelId as M;
        let q = &lens.params;
        let (f, c, k, p) = match lens.model {
            M::SimpleRadial => (
                [q[0], q[0]],
                [q[1], q[2]],
                [q[3], 0.0, 0.0, 0.0, 0.0, 0.0],
                [0.0; 2],
            ),
            M::Radial => (
                [q[0], q[0]],
                [q[1], q[2]],
                [q[3], q[4], 0.0, 0.0, 0.0, 0.0],
                [0.0; 2],
            ),
            M::OpenCv => (
                [q[0], q[1]],
                [q[2], q[3]],
                [q[4], q[5], 0.0, 0.0, 0.0, 0.0],
                [q[6], q[7]],
            ),
            M::FullOpenCv => (
                [q[0], q[1]],
                [q[2], q[3]],
                [q[4], q[5], q[8], q[9], q[10], q[11]],
                [q[6], q[7]],
            ),
            _ => return None,
        };
        Some(FastLens { f, c, k, p })
    }

    /// Pixel (COLMAP convention) of normalized coordinates `n`.
    #[inline(always)]
    pub(crate) fn img_from_normalized(&self, n: Vector2<f64>) -> Vector2<f64> {
        let (u, v) = self.img_from_xy(n.x, n.y);
        Vector2::new(u, v)
    }

    /// [`FastLens::img_from_normalized`] on plain numbers (the lane loop).
    #[inline(always)]
    pub(crate) fn img_from_xy(&self, x: f64, y: f64) -> (f64, f64) {
        self.img_from_xy_k::<true>(x, y)
    }

    /// Whether the radial term has a denominator (FULL_OPENCV's k4 k5 k6).
    pub(crate) fn is_rational(&self) -> bool {
        self.k[3..].iter().any(|k| *k != 0.0)
    }

    /// [`FastLens::img_from_xy`]; without `RATIONAL` the radial term's denominator is left
    /// out, which gives the same bits when k4 = k5 = k6 = 0 (it is then exactly 1 for finite
    /// `r²`): no division per lane and step for the lenses without it.
    #[inline(always)]
    pub(crate) fn img_from_xy_k<const RATIONAL: bool>(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let [k1, k2, k3, k4, k5, k6] = self.k;
        let [p1, p2] = self.p;
        let numerator = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let radial = if RATIONAL {
            numerator / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        } else {
            numerator
        };
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + 2.0 * p2 * x * y + p1 * (r2 + 2.0 * y * y);
        (self.f[0] * xd + self.c[0], self.f[1] * yd + self.c[1])
    }
}

/// True when the lens maps normalized coordinates to pixels linearly (no distortion term).
pub(crate) fn is_linear(lens: &Lens) -> bool {
    use ModelId as M;
    let extra = match lens.model {
        M::SimplePinhole | M::Pinhole => return true,
        M::SimpleRadial | M::Radial => &lens.params[3..],
        M::OpenCv | M::FullOpenCv => &lens.params[4..],
        _ => return false,
    };
    extra.iter().all(|k| *k == 0.0)
}

/// Where a fixed camera at `center` sees world point `x`: the true pixel, the exact
/// normalized coordinates and `∂normalized/∂pixel`; `None` when it does not see it.
pub(crate) fn sight(
    fixed: &FixedCamera,
    center: &Vector3<f64>,
    x: &Vector3<f64>,
) -> Option<(Vector2<f64>, Vector2<f64>, Matrix2<f64>)> {
    let p = fixed.cam_from_world(center, x);
    if p.z.is_nan() || p.z <= 0.0 {
        return None;
    }
    let lens = &fixed.lens;
    let u = lens.img_from_cam(&p).ok()?;
    if !(u.x >= 0.0 && u.x < lens.width as f64 && u.y >= 0.0 && u.y < lens.height as f64) {
        return None;
    }
    let n0 = Vector2::new(p.x / p.z, p.y / p.z);
    let back = lens.cam_from_img(&u).ok()?.normalized;
    if (back - n0).norm() > ROUND_TRIP_TOL * (1.0 + n0.norm()) {
        return None;
    }
    let j = lens
        .dx_img_from_cam_point(&Vector3::new(n0.x, n0.y, 1.0))
        .ok()?;
    let jinv = j.fixed_view::<2, 2>(0, 0).into_owned().try_inverse()?;
    Some((u, n0, jinv))
}

/// Signed margin (px) of world point `x` inside fixed camera's image: `min(u, w − u, v, h − v)`
/// where the camera sees the point, `−(w + h)` where it does not (behind, outside the lens's
/// domain, folded back). Its zero contour on a plane is the camera's field-of-view footprint.
pub fn footprint_margin_px(observer: &Observer, x: &Vector3<f64>) -> Option<f64> {
    let Aim::Fixed(f) = &observer.aim else {
        return None;
    };
    let (w, h) = (f.lens.width as f64, f.lens.height as f64);
    let p = f.cam_from_world(&observer.position_mm, x);
    let outside = -(w + h);
    if p.z.is_nan() || p.z <= 0.0 {
        return Some(outside);
    }
    let Ok(u) = f.lens.img_from_cam(&p) else {
        return Some(outside);
    };
    let n0 = Vector2::new(p.x / p.z, p.y / p.z);
    let folded = match f.lens.cam_from_img(&u) {
        Ok(b) => (b.normalized - n0).norm() > ROUND_TRIP_TOL * (1.0 + n0.norm()),
        Err(_) => true,
    };
    if folded {
        return Some(outside);
    }
    Some(u.x.min(w - u.x).min(u.y).min(h - u.y).max(outside))
}

/// Normalized coordinates of the observed pixel `u0 + du` (undistorted through the lens).
#[inline(always)]
pub(crate) fn undistort(v: &View<'_>, du: Vector2<f64>) -> Vector2<f64> {
    let mut n = v.n0 + v.jinv * du;
    let Some(lens) = v.lens else {
        return n;
    };
    let target = v.u0 + du;
    for _ in 0..MAX_REFINE {
        let p = match v.fast {
            Some(fast) => fast.img_from_normalized(n),
            None => match lens.img_from_cam(&Vector3::new(n.x, n.y, 1.0)) {
                Ok(p) => p,
                Err(_) => break,
            },
        };
        let res = p - target;
        if res.norm_squared() < UNDISTORT_RESIDUAL_PX * UNDISTORT_RESIDUAL_PX {
            return n;
        }
        n -= v.jinv * res;
    }
    // Not refined (never seen for σ of a few pixels): the lens's own unprojection.
    match v.full_lens.map(|l| l.cam_from_img(&target)) {
        Some(Ok(u)) => u.normalized,
        _ => n,
    }
}

/// Normalized coordinates of the observed pixels `u0 + σ_px·(ex, ey)` of view `v` in lanes
/// (see the module docs): the predictor, [`REFINE_STEPS`] chord-Newton steps on the
/// [`FastLens`] projection, and the scalar [`undistort`] for the lanes `< b` that did not
/// converge. Plain loops over lanes with `+ − × ÷` only (vectorised by the caller's
/// instruction-set level, the same bits on every level).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays vectorise
pub(crate) fn undistort_lanes(
    v: &View<'_>,
    ex: &Lane,
    ey: &Lane,
    x: &mut Lane,
    y: &mut Lane,
    b: usize,
) {
    let s = v.sigma_px;
    let j = [
        v.jinv[(0, 0)],
        v.jinv[(0, 1)],
        v.jinv[(1, 0)],
        v.jinv[(1, 1)],
    ];
    let (n0, n1) = (v.n0.x, v.n0.y);
    for l in 0..LANES {
        let (du, dv) = (s * ex[l], s * ey[l]);
        x[l] = n0 + (j[0] * du + j[1] * dv);
        y[l] = n1 + (j[2] * du + j[3] * dv);
    }
    if v.lens.is_none() {
        return;
    }
    let scalar = |l: usize, x: &mut Lane, y: &mut Lane| {
        let n = undistort(v, Vector2::new(s * ex[l], s * ey[l]));
        x[l] = n.x;
        y[l] = n.y;
    };
    let Some(fast) = v.fast else {
        for l in 0..b {
            scalar(l, x, y);
        }
        return;
    };
    let res2 = if fast.is_rational() {
        refine::<true>(v, &fast, j, ex, ey, x, y)
    } else {
        refine::<false>(v, &fast, j, ex, ey, x, y)
    };
    // The last step's residual (before its update) bounds the result's from above. Whether
    // any lane needs the fix-up (r2 ≥ tol² or NaN) is one vectorised reduction, so the usual
    // block, where none does, takes no branch per lane.
    let tol2 = UNDISTORT_RESIDUAL_PX * UNDISTORT_RESIDUAL_PX;
    let far = |r2: f64| r2 >= tol2 || r2.is_nan();
    if res2.iter().fold(0u64, |n, &r2| n | u64::from(far(r2))) == 0 {
        return;
    }
    for l in 0..b {
        if far(res2[l]) {
            scalar(l, x, y);
        }
    }
}

/// The [`REFINE_STEPS`] chord-Newton steps of [`undistort_lanes`] on `fast`'s projection (its
/// denominator only with `RATIONAL`); the squared residual of each lane before the last
/// update.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays vectorise
fn refine<const RATIONAL: bool>(
    v: &View<'_>,
    fast: &FastLens,
    j: [f64; 4],
    ex: &Lane,
    ey: &Lane,
    x: &mut Lane,
    y: &mut Lane,
) -> Lane {
    let (s, t0, t1) = (v.sigma_px, v.u0.x, v.u0.y);
    let mut res2 = [0.0; LANES];
    for _ in 0..REFINE_STEPS {
        for l in 0..LANES {
            let (du, dv) = (s * ex[l], s * ey[l]);
            let (p0, p1) = fast.img_from_xy_k::<RATIONAL>(x[l], y[l]);
            let (r0, r1) = (p0 - (t0 + du), p1 - (t1 + dv));
            x[l] -= j[0] * r0 + j[1] * r1;
            y[l] -= j[2] * r0 + j[3] * r1;
            res2[l] = r0 * r0 + r1 * r1;
        }
    }
    res2
}
