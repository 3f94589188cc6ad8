//! The pixel σ checked on the test itself (`summary.json` → `pixel_sigma_check`): every
//! marker-epoch seen by B and C has 4 image coordinates for 3 unknowns, so the sequence's own
//! residuals show how large the image errors really were.
//!
//! # The statistic
//! For marker-epoch `i` with pixels `y = (u_B, v_B, u_C, v_C)`, stated image covariance
//! `Σ_i = blockdiag(Σ_B, Σ_C)` (each observation's own, or `σ²·I` from `pixel_sigma_px`) and
//! `L_i` its block Cholesky factor, the nominal intersection `X̂` (the engine's DLT; in B's
//! frame — camera A's pose and the link move B and C rigidly together and change no
//! residual) reprojects to `f(X̂)`. With `J̃ = L⁻¹·∂f/∂X` (4 × 3, through the lens) and `n` the
//! unit vector orthogonal to its columns, the **whitened redundant residual**
//! `w_i = nᵀ·L⁻¹·(y − f(X̂))` is to first order `w_i = e_i + g_iᵀ·δ`, whatever estimator gave
//! `X̂`: `e_i = nᵀL⁻¹ε ~ N(0, k²)` when the true image covariance is `k²·Σ_i`, and `δ` the
//! error of the tie `B_from_C` (the one random effect shared by the whole sequence; `g_i =
//! (L⁻¹·∂f/∂δ)ᵀ·n`, by central differences of the tie's tangent perturbation).
//!
//! The tie is not compared against its stated covariance: its effect `G·δ` (`G` the N × 6
//! matrix of the `g_i`) is **projected out**. With `U` an orthonormal basis of `G`'s columns
//! (rank `r` ≤ 6; 5 for a two-camera tie, whose baseline length does not move the epipolar
//! lines), `Q = |w|² − |Uᵀw|²` is `k²·χ²_ν` with `ν = N − r` (the `redundancy`) whatever the
//! tie's error — a stated tie σ that is too small or too large changes nothing here (the
//! length check's `bias_z` is the test of the tie). Then:
//! - `sigma_ratio = √(Q/ν)` (1 on honest σ);
//! - `sigma_ratio_band_99 = [√(χ²_ν(0.005)/ν), √(χ²_ν(0.995)/ν)]`;
//! - `estimate_px = sigma_ratio · σ_stated` and its 95 % interval
//!   `σ_stated·[√(Q/χ²_ν(0.975)), √(Q/χ²_ν(0.025))]`, where `σ_stated` is the typed
//!   `pixel_sigma_px`, or with per-observation σ the RMS of the stated σ (both axes of every
//!   observation in the check);
//! - `verdict`: `consistent` inside the band, `sigma_too_small` above it, `sigma_too_large`
//!   below it.
//!
//! # Per camera
//! B's share of a residual is `a_i = |n_B|²` (the B half of `n`); `E[w_i²] = k_B²·a_i +
//! k_C²·(1 − a_i)`. The two projected quadratic forms `q_B = Σ a_i·p_i²` and `q_C = Σ (1 −
//! a_i)·p_i²` (`p = w − U·Uᵀw`) have exact expectations linear in `(k_B², k_C²)`, and solving
//! the 2 × 2 system gives an unbiased estimate of each. Where the shares `a_i` hardly vary
//! (two similar cameras at similar distances) the system is nearly singular: the geometry does
//! not separate the cameras, and `per_camera` is `None` with the reason. The per-camera band
//! and interval use Satterthwaite's `k̂²·ν_c/k² ≈ χ²_{ν_c}`, `ν_c = 2·k⁴/Var(k̂²)` (the variance
//! of each quadratic form from its Gaussian moments, the projection's `r/N` neglected there).
//! A camera's band is that of its null hypothesis `k_c = 1` with the other camera at its
//! estimate (a nuisance parameter): a C stated at half its σ widens B's spread as well, and a
//! band computed as if both were honest flagged an honest B in 4 of 30 opposed sequences
//! (`tests/pixel_check.rs::opposed_cameras_are_checked_apart`; now 0 of 30).

use crate::engine::{Epoch, Rig};
use crate::input::{Inward, Observation, PixelSigma};
use crashrig_camera::Camera;
use crashrig_geometry::triangulate::{self, View};
use crashrig_geometry::{Rigid3, Vec3, Vec6};
use nalgebra::{DMatrix, Matrix2, Matrix2x3, Matrix4x3, Vector2, Vector4};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::collections::{BTreeMap, HashMap};

/// The level of the band of [`SigmaRatio::sigma_ratio_band_99`].
pub const BAND_LEVEL: f64 = 0.99;
/// The level of the estimate's interval ([`SigmaRatio::estimate_95_px`]).
pub const INTERVAL_LEVEL: f64 = 0.95;
/// The per-camera estimates are reported only where the geometry separates the cameras: the
/// standard error of each camera's variance ratio `k̂²` (on honest σ) at most this.
pub const MAX_PER_CAMERA_RELATIVE_SE: f64 = 0.25;
/// Relative size below which a singular value of the (column-scaled) tie matrix `G` counts as
/// zero (a direction of the tie that moves no residual).
const RANK_TOLERANCE: f64 = 1e-9;
/// Central-difference steps of the tie's tangent: mm and rad.
const STEP_MM: f64 = 1e-3;
const STEP_RAD: f64 = 1e-6;

/// The verdict of the check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The ratio lies inside its 99 % band.
    Consistent,
    /// Above the band: the image errors are larger than stated.
    SigmaTooSmall,
    /// Below the band: the image errors are smaller than stated.
    SigmaTooLarge,
}

impl Verdict {
    /// `consistent`, `sigma_too_small` or `sigma_too_large`.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::SigmaTooSmall => "sigma_too_small",
            Verdict::SigmaTooLarge => "sigma_too_large",
        }
    }

    fn of(ratio: f64, band: (f64, f64)) -> Verdict {
        if ratio > band.1 {
            Verdict::SigmaTooSmall
        } else if ratio < band.0 {
            Verdict::SigmaTooLarge
        } else {
            Verdict::Consistent
        }
    }
}

/// One camera's (or the common) numbers of the check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmaRatio {
    /// Degrees of freedom of the statistic: `N − r` for the common check, Satterthwaite's
    /// effective `ν_c` per camera.
    pub redundancy: f64,
    /// The residuals' size over the predicted (1 on honest σ).
    pub sigma_ratio: f64,
    /// Its two-sided 99 % band for this redundancy.
    pub sigma_ratio_band_99: (f64, f64),
    /// The true pixel σ: `sigma_ratio · σ_stated` (px).
    pub estimate_px: f64,
    /// Its 95 % interval (px).
    pub estimate_95_px: (f64, f64),
    /// The σ the observations stated (px; the RMS of per-observation σ).
    pub stated_px: f64,
    /// The verdict.
    pub verdict: Verdict,
}

/// The check of a sequence ([`check`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PixelSigmaCheck {
    /// Marker-epochs seen by both B and C (each one redundant coordinate).
    pub marker_epochs: usize,
    /// Directions of the tie's effect projected out (`r`).
    pub tie_directions: usize,
    /// The common check over both cameras.
    pub common: SigmaRatio,
    /// B and C apart, where the geometry separates them.
    pub per_camera: Option<[SigmaRatio; 2]>,
    /// Why there are no per-camera numbers (when [`PixelSigmaCheck::per_camera`] is `None`).
    pub per_camera_note: Option<String>,
}

impl PixelSigmaCheck {
    /// The `warning:` sentence when the common verdict is not `consistent`.
    pub fn warning(&self) -> Option<String> {
        let c = &self.common;
        let (lo, hi) = c.sigma_ratio_band_99;
        let what = match c.verdict {
            Verdict::Consistent => return None,
            Verdict::SigmaTooSmall => "larger",
            Verdict::SigmaTooLarge => "smaller",
        };
        Some(format!(
            "pixel_sigma_check: {}: the image errors of B and C were {:.2}× the stated pixel σ ({:.3} px; 99 % band {lo:.2} … {hi:.2} for redundancy {}): estimated {:.3} px (95 %: {:.3} … {:.3}), {what} than stated; every σ of this run comes partly from the stated pixel σ (--pixel-sigma-px estimate uses the estimate)",
            c.verdict.name(),
            c.sigma_ratio,
            c.stated_px,
            c.redundancy,
            c.estimate_px,
            c.estimate_95_px.0,
            c.estimate_95_px.1
        ))
    }
}

/// One marker-epoch's whitened redundant residual ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    /// `w = nᵀ·L⁻¹·(y − f(X̂))` (whitened: N(0, 1) on honest σ, tie apart).
    pub w: f64,
    /// `g = (L⁻¹·∂f/∂δ)ᵀ·n`: how the tie's tangent error `δ` (mm, rad) moves `w`.
    pub g: Vec6,
    /// B's share `a = |n_B|²` of the residual (C's is `1 − a`).
    pub share_b: f64,
    /// The stated σ² of the observations (B u, B v, C u, C v; px²), for σ_stated.
    pub stated_px2: [f64; 4],
}

/// The stated Σ factor of an observation.
fn factor(o: &Observation, pixel_sigma_px: f64) -> Matrix2<f64> {
    o.sigma
        .unwrap_or(PixelSigma::isotropic(pixel_sigma_px))
        .factor()
}

/// The pixel of `x` (B's frame, mm) in C under the tie `b_from_c`.
fn project_c(camera: &Camera, b_from_c: &Rigid3, x: &Vec3) -> Option<Vector2<f64>> {
    let p = b_from_c.inverse_transform_point(&nalgebra::Point3::from(*x));
    camera.img_from_cam(&p.coords).ok()
}

/// The residual of one marker-epoch (`None` where the rays are degenerate or a pixel does not
/// undistort or project).
fn residual(rig: &Rig, obs: [&Observation; 2], pixel_sigma_px: f64) -> Option<Residual> {
    let (tie, camera_c) = rig.c.as_ref()?;
    let cams = [&rig.camera_b, camera_c];
    let b_from_c = tie.b_from_a;
    let c_from_b = b_from_c.inverse();
    let views: Vec<View> = [Rigid3::identity(), c_from_b]
        .into_iter()
        .zip(obs)
        .zip(cams)
        .map(|((cam_from_world, o), cam)| {
            cam.cam_from_img(&o.pixel).ok().map(|u| View {
                cam_from_world,
                normalized: u.normalized,
            })
        })
        .collect::<Option<_>>()?;
    let x = triangulate::dlt(&views).ok()?;
    let x_c = c_from_b.transform_point(&nalgebra::Point3::from(x)).coords;
    let f_b = cams[0].img_from_cam(&x).ok()?;
    let f_c = cams[1].img_from_cam(&x_c).ok()?;
    let j_b: Matrix2x3<f64> = cams[0].dx_img_from_cam_point(&x).ok()?;
    let j_c: Matrix2x3<f64> =
        cams[1].dx_img_from_cam_point(&x_c).ok()? * c_from_b.rotation.to_rotation_matrix().matrix();
    let l = [
        factor(obs[0], pixel_sigma_px),
        factor(obs[1], pixel_sigma_px),
    ];
    let l_inv = [l[0].try_inverse()?, l[1].try_inverse()?];
    let r_b = l_inv[0] * (obs[0].pixel - f_b);
    let r_c = l_inv[1] * (obs[1].pixel - f_c);
    let jw_b = l_inv[0] * j_b;
    let jw_c = l_inv[1] * j_c;
    let mut j = Matrix4x3::zeros();
    j.fixed_view_mut::<2, 3>(0, 0).copy_from(&jw_b);
    j.fixed_view_mut::<2, 3>(2, 0).copy_from(&jw_c);
    let n = normal(&j)?;
    let r = Vector4::new(r_b.x, r_b.y, r_c.x, r_c.y);
    let w = n.dot(&r);
    // ∂f_C/∂δ by central differences of the tie's tangent perturbation.
    let n_c = Vector2::new(n[2], n[3]);
    let mut g = Vec6::zeros();
    for k in 0..6 {
        let h = if k < 3 { STEP_MM } else { STEP_RAD };
        let mut d = Vec6::zeros();
        d[k] = h;
        let plus = project_c(cams[1], &tie.perturbed(&d), &x)?;
        let minus = project_c(cams[1], &tie.perturbed(&(-d)), &x)?;
        let df = l_inv[1] * (plus - minus) / (2.0 * h);
        g[k] = n_c.dot(&df);
    }
    let s = |m: &Matrix2<f64>| {
        let c = m * m.transpose();
        [c[(0, 0)], c[(1, 1)]]
    };
    let (sb, sc) = (s(&l[0]), s(&l[1]));
    Some(Residual {
        w,
        g,
        share_b: n[0] * n[0] + n[1] * n[1],
        stated_px2: [sb[0], sb[1], sc[0], sc[1]],
    })
}

/// The unit vector orthogonal to the three columns of `j` (their generalized cross product),
/// `None` when they are (nearly) dependent.
fn normal(j: &Matrix4x3<f64>) -> Option<Vector4<f64>> {
    let minor = |skip: usize| {
        let rows: Vec<usize> = (0..4).filter(|&r| r != skip).collect();
        nalgebra::Matrix3::from_fn(|a, b| j[(rows[a], b)]).determinant()
    };
    let n = Vector4::new(minor(0), -minor(1), minor(2), -minor(3));
    let norm = n.norm();
    let scale = j.column(0).norm() * j.column(1).norm() * j.column(2).norm();
    (norm.is_finite() && norm > 1e-12 * scale).then(|| n / norm)
}

/// The residuals of every marker-epoch that B and C both saw, in epoch order and marker name
/// order (observations of epochs not in `epochs` are left out, as the measurement skips them).
/// Empty without camera C.
pub fn residuals(
    epochs: &[Epoch],
    rig: &Rig,
    observations: &[Observation],
    pixel_sigma_px: f64,
) -> Vec<Residual> {
    if rig.c.is_none() {
        return Vec::new();
    }
    let mut lookup: HashMap<&str, usize> = HashMap::new();
    for (i, e) in epochs.iter().enumerate() {
        lookup.insert(e.key.as_str(), i);
        lookup.insert(e.name.as_str(), i);
    }
    let mut pairs: BTreeMap<(usize, &str), [Option<&Observation>; 2]> = BTreeMap::new();
    for o in observations {
        if let Some(&e) = lookup.get(o.epoch.as_str()) {
            let k = usize::from(o.camera == Inward::C);
            pairs.entry((e, o.marker.as_str())).or_default()[k] = Some(o);
        }
    }
    pairs
        .values()
        .filter_map(|[b, c]| residual(rig, [(*b)?, (*c)?], pixel_sigma_px))
        .collect()
}

/// The two-sided [`BAND_LEVEL`] band of `√(χ²_ν/ν)`.
pub fn band(dof: f64) -> (f64, f64) {
    let (lo, hi) = quantiles(dof, 0.5 * (1.0 - BAND_LEVEL));
    ((lo / dof).sqrt(), (hi / dof).sqrt())
}

/// `(χ²_ν(p), χ²_ν(1 − p))`.
fn quantiles(dof: f64, p: f64) -> (f64, f64) {
    match ChiSquared::new(dof) {
        Ok(chi) => (chi.inverse_cdf(p), chi.inverse_cdf(1.0 - p)),
        Err(_) => (f64::NAN, f64::NAN),
    }
}

/// The numbers of a ratio² estimate `k2` with `dof` degrees of freedom, the band at `band_dof`.
fn sigma_ratio(k2: f64, dof: f64, band_dof: f64, stated_px: f64) -> SigmaRatio {
    let k2 = k2.max(0.0);
    let ratio = k2.sqrt();
    let band = band(band_dof);
    let (lo, hi) = quantiles(dof, 0.5 * (1.0 - INTERVAL_LEVEL));
    SigmaRatio {
        redundancy: band_dof,
        sigma_ratio: ratio,
        sigma_ratio_band_99: band,
        estimate_px: ratio * stated_px,
        estimate_95_px: (
            (k2 * dof / hi).sqrt() * stated_px,
            (k2 * dof / lo).sqrt() * stated_px,
        ),
        stated_px,
        verdict: Verdict::of(ratio, band),
    }
}

/// The check of `residuals` ([module docs](self)); `None` when there are fewer redundant
/// coordinates than tie directions + 1.
pub fn check(residuals: &[Residual]) -> Option<PixelSigmaCheck> {
    let n = residuals.len();
    if n == 0 {
        return None;
    }
    // The tie's directions: an orthonormal basis of G's columns (scaled to unit length first:
    // mm and rad columns differ by orders of magnitude).
    let mut g = DMatrix::from_fn(n, 6, |i, k| residuals[i].g[k]);
    for mut col in g.column_iter_mut() {
        let norm = col.norm();
        if norm > 0.0 {
            col /= norm;
        }
    }
    let svd = g.svd(true, false);
    let smax = svd.singular_values.max();
    let u_all = svd.u?;
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| smax > 0.0 && svd.singular_values[k] > RANK_TOLERANCE * smax)
        .collect();
    let r = keep.len();
    if n <= r {
        return None;
    }
    let u = DMatrix::from_fn(n, r, |i, k| u_all[(i, keep[k])]);
    let w = nalgebra::DVector::from_iterator(n, residuals.iter().map(|x| x.w));
    let p = &w - &u * (u.transpose() * &w);
    let q = p.norm_squared();
    let dof = (n - r) as f64;
    let stated = |idx: &[usize]| {
        let s: f64 = residuals
            .iter()
            .map(|x| idx.iter().map(|&k| x.stated_px2[k]).sum::<f64>())
            .sum();
        (s / (idx.len() * n) as f64).sqrt()
    };
    let common = sigma_ratio(q / dof, dof, dof, stated(&[0, 1, 2, 3]));
    let (per_camera, per_camera_note) =
        match per_camera(residuals, &u, &p, [stated(&[0, 1]), stated(&[2, 3])]) {
            Ok(c) => (Some(c), None),
            Err(note) => (None, Some(note)),
        };
    Some(PixelSigmaCheck {
        marker_epochs: n,
        tie_directions: r,
        common,
        per_camera,
        per_camera_note,
    })
}

/// The per-camera estimates ([module docs](self)), or why the geometry does not separate them.
fn per_camera(
    residuals: &[Residual],
    u: &DMatrix<f64>,
    p: &nalgebra::DVector<f64>,
    stated: [f64; 2],
) -> Result<[SigmaRatio; 2], String> {
    let n = residuals.len();
    let a: Vec<f64> = residuals.iter().map(|x| x.share_b).collect();
    // The two weightings M = diag(a) and diag(1 − a).
    let m = |which: usize, i: usize| if which == 0 { a[i] } else { 1.0 - a[i] };
    // c_i(M) = m_i·(1 − 2h_i) + u_iᵀ·(Uᵀ·M·U)·u_i: the diagonal of P·M·P.
    let h: Vec<f64> = (0..n).map(|i| u.row(i).norm_squared()).collect();
    let mut design = Matrix2::<f64>::zeros();
    let mut q = Vector2::<f64>::zeros();
    for which in 0..2 {
        // K_M = Uᵀ·M·U, summed row by row (never an N × N matrix).
        let mut k = DMatrix::zeros(u.ncols(), u.ncols());
        for i in 0..n {
            let ui = u.row(i);
            k += ui.transpose() * ui * m(which, i);
        }
        for i in 0..n {
            let ui = u.row(i).transpose();
            let c = m(which, i) * (1.0 - 2.0 * h[i]) + (ui.transpose() * &k * &ui)[(0, 0)];
            design[(which, 0)] += c * a[i];
            design[(which, 1)] += c * (1.0 - a[i]);
            q[which] += m(which, i) * p[i] * p[i];
        }
    }
    let spread = {
        let mean = a.iter().sum::<f64>() / n as f64;
        let sd = (a.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        let (lo, hi) = a
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        format!("B's share of the residuals {lo:.2} … {hi:.2}, mean {mean:.2}, SD {sd:.3}")
    };
    let inv = design.try_inverse().ok_or_else(|| {
        format!("the two cameras' errors enter every residual in the same proportion ({spread}): the residuals cannot tell them apart")
    })?;
    let k2 = inv * q;
    // Cov(q_M, q_M') ≈ 2·Σ m_i·m'_i·d_i² (Gaussian quadratic forms; the projection neglected).
    let cov_q = |d: &dyn Fn(usize) -> f64| -> Matrix2<f64> {
        let mut c = Matrix2::<f64>::zeros();
        for i in 0..n {
            for x in 0..2 {
                for y in 0..2 {
                    c[(x, y)] += 2.0 * m(x, i) * m(y, i) * d(i).powi(2);
                }
            }
        }
        inv * c * inv.transpose()
    };
    let honest = cov_q(&|_| 1.0);
    let rel_se = [honest[(0, 0)].sqrt(), honest[(1, 1)].sqrt()];
    if rel_se
        .iter()
        .any(|s| !(s.is_finite() && *s <= MAX_PER_CAMERA_RELATIVE_SE))
    {
        return Err(format!(
            "the geometry does not separate B's and C's image errors: each camera's σ² would be known to ± {:.0} % and {:.0} % (1 SE; at most {:.0} % is reported) — {spread}",
            100.0 * rel_se[0],
            100.0 * rel_se[1],
            100.0 * MAX_PER_CAMERA_RELATIVE_SE
        ));
    }
    let kb = k2[0].max(0.0);
    let kc = k2[1].max(0.0);
    let at = cov_q(&|i| kb * a[i] + kc * (1.0 - a[i]));
    let out = [0, 1].map(|c| {
        // The band tests this camera's σ with the other camera's at its estimate (a nuisance):
        // under k_c = 1, k_other = k̂_other. A badly stated C widens B's spread too; a band
        // from both honest would then cry wolf on an honest B.
        let null = cov_q(&|i| {
            let (kb0, kc0) = if c == 0 { (1.0, kc) } else { (kb, 1.0) };
            kb0 * a[i] + kc0 * (1.0 - a[i])
        });
        let band_dof = 2.0 / null[(c, c)];
        let k = k2[c].max(0.0);
        let dof = if at[(c, c)] > 0.0 {
            2.0 * k * k / at[(c, c)]
        } else {
            band_dof
        };
        sigma_ratio(k, dof.max(1.0), band_dof, stated[c])
    });
    Ok(out)
}

/// The check of a measurement's inputs: [`residuals`] then [`check`]; `None` without camera C
/// or with a stated σ of 0 (nothing to whiten by: rays that must meet exactly).
pub fn pixel_sigma_check(
    epochs: &[Epoch],
    rig: &Rig,
    observations: &[Observation],
    pixel_sigma_px: f64,
) -> Option<PixelSigmaCheck> {
    rig.c.as_ref()?;
    let typed_used = observations.iter().any(|o| o.sigma.is_none());
    if typed_used && pixel_sigma_px <= 0.0 {
        return None;
    }
    check(&residuals(epochs, rig, observations, pixel_sigma_px))
}

/// Where the Monte Carlo's pixel σ comes from ([`crate::MeasureConfig::pixel_sigma_from`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelSigmaFrom {
    /// The stated σ: each observation's own, else `pixel_sigma_px` (the default).
    #[default]
    Stated,
    /// The check's estimate (`--pixel-sigma-px estimate`): every observation's stated σ scaled
    /// by its camera's `sigma_ratio` ([`apply_estimate`]).
    Estimate,
}

/// Below this redundancy the estimate used by [`PixelSigmaFrom::Estimate`] earns a warning: its
/// 95 % interval is then wider than −20 % … +34 % of the σ (`√(ν/χ²_ν)` at ν = 30).
pub const MIN_ESTIMATE_REDUNDANCY: f64 = 30.0;

/// What [`PixelSigmaFrom::Estimate`] used, per camera (B, C).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateUsed {
    /// `true`: each camera's own estimate; `false`: the common one for both.
    pub per_camera: bool,
    /// The factor each camera's stated σ was multiplied by (its `sigma_ratio`).
    pub scale: [f64; 2],
    /// The estimated pixel σ of each camera (px; its `estimate_px`).
    pub estimate_px: [f64; 2],
    /// Its 95 % interval (px).
    pub estimate_95_px: [(f64, f64); 2],
    /// The redundancy behind each estimate.
    pub redundancy: [f64; 2],
}

/// The observations with the check's estimate as their σ: each observation's stated Σ (its own,
/// else `pixel_sigma_px` on each axis) scaled by its camera's ratio — the per-camera one where
/// `check` separates the cameras and both are above 0, else the common one. `None` when the
/// ratio to use is not above 0 (residuals of exactly 0: nothing to estimate from).
pub fn apply_estimate(
    check: &PixelSigmaCheck,
    observations: &[Observation],
    pixel_sigma_px: f64,
) -> Option<(Vec<Observation>, EstimateUsed)> {
    let per = check
        .per_camera
        .filter(|[b, c]| b.sigma_ratio > 0.0 && c.sigma_ratio > 0.0);
    let [b, c] = per.unwrap_or([check.common; 2]);
    if !(b.sigma_ratio > 0.0 && c.sigma_ratio > 0.0) {
        return None;
    }
    let used = EstimateUsed {
        per_camera: per.is_some(),
        scale: [b.sigma_ratio, c.sigma_ratio],
        estimate_px: [b.estimate_px, c.estimate_px],
        estimate_95_px: [b.estimate_95_px, c.estimate_95_px],
        redundancy: [b.redundancy, c.redundancy],
    };
    let scaled = observations
        .iter()
        .map(|o| {
            let k = used.scale[usize::from(o.camera == Inward::C)];
            let s = o.sigma.unwrap_or(PixelSigma::isotropic(pixel_sigma_px));
            Observation {
                sigma: Some(PixelSigma {
                    sigma_u_px: k * s.sigma_u_px,
                    sigma_v_px: k * s.sigma_v_px,
                    rho_uv: s.rho_uv,
                }),
                ..o.clone()
            }
        })
        .collect();
    Some((scaled, used))
}

impl EstimateUsed {
    /// The `warning:` sentence when an estimate rests on fewer than
    /// [`MIN_ESTIMATE_REDUNDANCY`] redundant coordinates.
    pub fn warning(&self) -> Option<String> {
        let i = usize::from(self.redundancy[1] < self.redundancy[0]);
        let least = self.redundancy[i];
        (least < MIN_ESTIMATE_REDUNDANCY).then(|| {
            let (lo, hi) = self.estimate_95_px[i];
            format!(
                "pixel σ estimate: it rests on a redundancy of only {least:.0} (fewer than {MIN_ESTIMATE_REDUNDANCY:.0}): {:.3} px with a 95 % interval of {lo:.3} … {hi:.3} px, and every σ of this run is as uncertain; measure more markers or epochs seen by both B and C",
                self.estimate_px[i]
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ratio `k` with redundancy `dof` against a stated 0.5 px.
    fn ratio(k: f64, dof: f64) -> SigmaRatio {
        sigma_ratio(k * k, dof, dof, 0.5)
    }

    fn obs(camera: Inward, sigma: Option<PixelSigma>) -> Observation {
        Observation {
            epoch: "e".into(),
            camera,
            marker: "m".into(),
            pixel: Vector2::new(1.0, 2.0),
            sigma,
            line: 2,
        }
    }

    /// Each camera's σ scaled by its own ratio where the check separates them, by the common
    /// one where it does not or where a camera's ratio is 0; ρ kept.
    #[test]
    fn the_estimate_scales_each_camera_by_its_ratio() {
        let own = PixelSigma {
            sigma_u_px: 0.2,
            sigma_v_px: 0.4,
            rho_uv: 0.3,
        };
        let observations = [obs(Inward::B, None), obs(Inward::C, Some(own))];
        let mut check = PixelSigmaCheck {
            marker_epochs: 40,
            tie_directions: 5,
            common: ratio(1.5, 35.0),
            per_camera: Some([ratio(2.0, 20.0), ratio(0.5, 18.0)]),
            per_camera_note: None,
        };
        let (o, used) = apply_estimate(&check, &observations, 0.5).unwrap();
        assert!(used.per_camera);
        assert_eq!(used.scale, [2.0, 0.5]);
        assert_eq!(o[0].sigma, Some(PixelSigma::isotropic(1.0)));
        assert_eq!(
            o[1].sigma,
            Some(PixelSigma {
                sigma_u_px: 0.1,
                sigma_v_px: 0.2,
                rho_uv: 0.3
            })
        );
        assert!(used.warning().unwrap().contains("redundancy of only 18"));
        check.per_camera = Some([ratio(2.0, 20.0), ratio(0.0, 18.0)]);
        let (o, used) = apply_estimate(&check, &observations, 0.5).unwrap();
        assert!(!used.per_camera);
        assert_eq!(o[0].sigma, Some(PixelSigma::isotropic(0.75)));
        assert_eq!(used.warning(), None);
        check.per_camera = None;
        check.common = ratio(0.0, 35.0);
        assert!(apply_estimate(&check, &observations, 0.5).is_none());
    }
}
