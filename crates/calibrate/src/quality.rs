//! Calibration quality: what lets a lab judge its calibration, as typed values computed with
//! the calibration ([`crate::CalibrationResult::reprojection`] and
//! [`crate::CalibrationResult::split_half`]).
//!
//! - [`reprojection`]: the reprojection residuals of camera A's and camera B's observations in
//!   the calibration model (COLMAP's camera models, the model's own poses and points): the
//!   pixel noise the bundle actually left, per camera.
//! - [`split_half`]: mrcal's cross-validation idea applied to the link: the mean link of the
//!   first half of the sequence and of the second half, each with its own σ of the mean; the
//!   halves agree when their difference is within 2 σ of the difference on every axis (a drift,
//!   a bumped rig or an underestimated σ shows up here).
//!
//! A study's report renders them (`crashrig_study`'s calibration-quality section).
//!
//! # Example
//! ```
//! use crashrig_calibrate::SplitHalf;
//! // A difference of 0.3 mm with σ 0.2 mm on each half: σ of the difference √0.08 ≈ 0.28 mm.
//! let s = SplitHalf::from_difference(10, 10, [0.3, 0.0, 0.0, 0.0, 0.0, 0.0], [0.04; 6], [0.04; 6]);
//! assert!((s.z[0] - 0.3 / 0.08f64.sqrt()).abs() < 1e-12);
//! assert!(s.agree);
//! ```

use crashrig_colmap::{CameraSelector, Reconstruction};
use crashrig_rig::{CalibrateOptions, Epoch};
use crashrig_stats::summary::median;
use nalgebra::{Point3, Vector3};

/// Agreement bound of [`SplitHalf`]: |difference| ≤ `SPLIT_HALF_Z` × its σ on every axis.
pub const SPLIT_HALF_Z: f64 = 2.0;

/// The reprojection residuals of one camera of the calibration model.
#[derive(Debug, Clone, PartialEq)]
pub struct Reprojection {
    /// `A` or `B`.
    pub role: char,
    /// The camera selector of the study file (`camera_a` / `camera_b`).
    pub selector: String,
    /// Images of the camera with a pose.
    pub images: usize,
    /// The length of every residual (px), one per observation of a 3-D point.
    pub residuals_px: Vec<f64>,
    /// σ per image axis (px): `√(Σ (Δu² + Δv²) / (2 n))`, the pixel noise the bundle left.
    pub sigma_px: f64,
    /// Median residual length (px).
    pub median_px: f64,
    /// Largest residual length (px).
    pub max_px: f64,
}

/// The residuals of every observation of a 3-D point in the images of `selector`: observed
/// pixel minus the projection of the point through the image's pose and camera model.
/// Observations that do not project (behind the camera, a bad camera) are skipped.
pub fn reprojection(model: &Reconstruction, selector: &str, role: char) -> Reprojection {
    let sel = CameraSelector::parse(selector);
    let (mut images, mut sq, mut residuals) = (0usize, 0.0f64, Vec::new());
    for img in model.images().iter().filter(|i| sel.matches(i)) {
        let (Some(pose), Some(cam)) = (
            model.image_cam_from_world(img.image_id),
            model.camera(img.camera_id),
        ) else {
            continue;
        };
        images += 1;
        for p in &img.points2d {
            let Some(x) = p.point3d_id.and_then(|id| model.point3d(id)) else {
                continue;
            };
            let p_cam = pose * Point3::new(x.xyz[0], x.xyz[1], x.xyz[2]);
            let Ok(uv) = cam.camera.img_from_cam(&p_cam.coords) else {
                continue;
            };
            let d = Vector3::new(p.xy[0] - uv.x, p.xy[1] - uv.y, 0.0);
            sq += d.norm_squared();
            residuals.push(d.norm());
        }
    }
    let n = residuals.len();
    Reprojection {
        role,
        selector: selector.to_string(),
        images,
        sigma_px: if n > 0 {
            (sq / (2.0 * n as f64)).sqrt()
        } else {
            f64::NAN
        },
        median_px: median(&residuals).unwrap_or(f64::NAN),
        max_px: residuals.iter().copied().fold(f64::NAN, f64::max),
        residuals_px: residuals,
    }
}

/// The split-half check of the link.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitHalf {
    /// Epochs of the first half (in sequence order).
    pub n_first: usize,
    /// Epochs of the second half.
    pub n_second: usize,
    /// Second half's mean link minus the first's, tangent coordinates about the first
    /// (x y z in mm, θx θy θz in rad).
    pub difference: [f64; 6],
    /// σ of that difference: √(σ₁² + σ₂²) from each half's σ of the mean.
    pub sigma: [f64; 6],
    /// |difference| / σ per axis.
    pub z: [f64; 6],
    /// Every |z| ≤ 2 (`SPLIT_HALF_Z`).
    pub agree: bool,
}

impl SplitHalf {
    /// The check from the difference and each half's variances of the mean (diagonals).
    pub fn from_difference(
        n_first: usize,
        n_second: usize,
        difference: [f64; 6],
        var_first: [f64; 6],
        var_second: [f64; 6],
    ) -> SplitHalf {
        let sigma: [f64; 6] = std::array::from_fn(|k| (var_first[k] + var_second[k]).sqrt());
        let z: [f64; 6] = std::array::from_fn(|k| {
            if sigma[k] > 0.0 {
                difference[k].abs() / sigma[k]
            } else if difference[k] == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        });
        SplitHalf {
            n_first,
            n_second,
            difference,
            sigma,
            z,
            agree: z.iter().all(|v| *v <= SPLIT_HALF_Z),
        }
    }
}

/// Calibrates the two halves of `epochs` separately (same options, no refinement) and
/// compares their mean links; `None` below 4 epochs or when a half cannot be calibrated.
pub fn split_half(
    epochs: &[Epoch],
    mm_per_unit: f64,
    options: &CalibrateOptions,
) -> Option<SplitHalf> {
    if epochs.len() < 4 {
        return None;
    }
    let h = epochs.len() / 2;
    let o = CalibrateOptions {
        refine: None,
        ..options.clone()
    };
    let a = crashrig_rig::calibrate(&epochs[..h], mm_per_unit, &o, None).ok()?;
    let b = crashrig_rig::calibrate(&epochs[h..], mm_per_unit, &o, None).ok()?;
    let d = a.link.tangent_of(&b.link.b_from_a);
    let diag = |c: &crashrig_geometry::Mat6| -> [f64; 6] { std::array::from_fn(|k| c[(k, k)]) };
    Some(SplitHalf::from_difference(
        h,
        epochs.len() - h,
        std::array::from_fn(|k| d[k]),
        diag(&a.link.covariance),
        diag(&b.link.covariance),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_half_agreement_bound() {
        let v = [1.0; 6];
        // σ of the difference √2: 2.8 / √2 = 1.98 agrees, 2.9 / √2 = 2.05 does not.
        let ok = SplitHalf::from_difference(5, 5, [2.8, 0.0, 0.0, 0.0, 0.0, -2.8], v, v);
        assert!(ok.agree, "{:?}", ok.z);
        let bad = SplitHalf::from_difference(5, 5, [0.0, 0.0, -2.9, 0.0, 0.0, 0.0], v, v);
        assert!(!bad.agree);
        assert!((bad.z[2] - 2.9 / 2f64.sqrt()).abs() < 1e-12);
        // A zero σ (rig-constrained model) with a zero difference agrees; with one, it does not.
        assert!(SplitHalf::from_difference(2, 2, [0.0; 6], [0.0; 6], [0.0; 6]).agree);
        assert!(
            !SplitHalf::from_difference(2, 2, [1e-9, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6], [0.0; 6])
                .agree
        );
    }
}
