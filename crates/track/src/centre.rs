//! What a fit returns ([`Centre`]), why it may refuse ([`Reject`]), and the options every
//! marker fit shares ([`FitOptions`]).

use crate::image::GreyView;
use crate::lm::Sample;
use nalgebra::SMatrix;

/// A marker centre located in one frame, with the covariance of its fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centre {
    /// Column coordinate, pixels (COLMAP convention: the upper-left pixel's centre is 0.5).
    pub u_px: f64,
    /// Row coordinate, pixels.
    pub v_px: f64,
    /// Standard uncertainty of `u_px` from this fit: `sqrt` of the `(u, u)` element of
    /// `s² (JᵀJ)⁻¹`, with `s²` the fit's residual variance.
    pub sigma_u_px: f64,
    /// Standard uncertainty of `v_px`.
    pub sigma_v_px: f64,
    /// Correlation of the errors of `u_px` and `v_px`.
    pub rho_uv: f64,
    /// Fitted contrast (grey levels, always positive): the step between the two shades.
    pub contrast: f64,
    /// Fitted blur width (pixels; the largest of the edge widths).
    pub blur_px: f64,
    /// Root mean square residual of the fit (grey levels).
    pub residual_rms: f64,
    /// Pixels in the fit window.
    pub pixels: usize,
}

/// Why no centre was returned: the marker is then left out of that frame, never guessed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Reject {
    /// The window (or the search region) leaves the image.
    OutsideImage,
    /// No candidate of the marker's kind in the search region.
    NoCandidate,
    /// The fit did not converge or its normal matrix is singular.
    NotConverged,
    /// The fitted contrast is below [`FitOptions::min_contrast`].
    LowContrast,
    /// The residuals are too large for the model ([`FitOptions::max_residual`]).
    Residual,
    /// The centre left its window, or the shape is implausible (blur wider than the window,
    /// lines nearly parallel, a flattened ellipse).
    Shape,
    /// The centre's σ exceeds [`FitOptions::max_sigma_px`].
    Uncertain,
}

/// Options of one marker fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Quadrant targets: radius of the round fit window around the centre (pixels). It should
    /// stay inside the disc: about 0.6 of the smallest marker radius.
    pub window_px: f64,
    /// Smallest contrast accepted, as a fraction of the image's full scale.
    pub min_contrast: f64,
    /// Largest residual RMS accepted, as a fraction of the fitted contrast.
    pub max_residual: f64,
    /// Largest σ (either axis) accepted, pixels.
    pub max_sigma_px: f64,
    /// Dots: the largest disc radius looked for (pixels).
    pub max_radius_px: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            window_px: 5.0,
            min_contrast: 0.1,
            max_residual: 0.08,
            max_sigma_px: 0.5,
            max_radius_px: 40.0,
        }
    }
}

/// The pixels whose centres lie within `radius` of `(u, v)`, or `None` when that disc is not
/// wholly inside the image.
pub(crate) fn disc_samples(img: &GreyView, u: f64, v: f64, radius: f64) -> Option<Vec<Sample>> {
    let (i0, i1) = ((u - radius).floor(), (u + radius).ceil());
    let (j0, j1) = ((v - radius).floor(), (v + radius).ceil());
    if !(i0 >= 0.0 && j0 >= 0.0 && i1 <= img.width() as f64 && j1 <= img.height() as f64) {
        return None;
    }
    let r2 = radius * radius;
    let mut out = Vec::with_capacity((4.0 * r2) as usize + 8);
    for j in j0 as usize..j1 as usize {
        let y = j as f64 + 0.5;
        for i in i0 as usize..i1 as usize {
            let x = i as f64 + 0.5;
            if (x - u).powi(2) + (y - v).powi(2) <= r2 {
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

/// σ_u, σ_v, ρ from the centre block of a covariance.
pub(crate) fn centre_sigma<const P: usize>(
    cov: &SMatrix<f64, P, P>,
    iu: usize,
    iv: usize,
) -> (f64, f64, f64) {
    let su = cov[(iu, iu)].max(0.0).sqrt();
    let sv = cov[(iv, iv)].max(0.0).sqrt();
    let rho = if su > 0.0 && sv > 0.0 {
        (cov[(iu, iv)] / (su * sv)).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    (su, sv, rho)
}
