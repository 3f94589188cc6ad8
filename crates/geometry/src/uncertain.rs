//! Uncertain poses and links: a nominal `b_from_a` with a 6×6 covariance in the contract's
//! tangent parametrization (`docs/CONVENTIONS.md`; origin: the contract's "Uncertain poses: the tangent covariance").
//!
//! A perturbation `δ = (δx, δy, δz, δθx, δθy, δθz) ~ N(0, Σ)` acts on the nominal pose as
//! - `C = C̄ + (δx, δy, δz)`: the translation of `b_from_a`, i.e. the origin of frame `a`
//!   (the projection centre of camera `a`) in `b`'s axes;
//! - `R = R̄·Exp(δθ)`: a small rotation about `a`'s **own** axes.
//!
//! For a world pose `b = world`, `a = cam`; for a rig link `A_from_B`, `b = A`, `a = B` and the
//! translation is B's centre in A's frame (the paper's base). Inside the library lengths are mm
//! and rotations **radians**; the contract writes the rotation block in degrees:
//! [`UncertainPose::covariance_deg`] and [`UncertainPose::from_covariance_deg`] convert.
//!
//! # Example
//! ```
//! use crashrig_geometry::uncertain::UncertainPose;
//! use crashrig_geometry::{Rigid3, Vec3, Vec6, so3};
//!
//! // A link with 1 mm centre noise and 0.1° of rotation noise about its own z axis,
//! let nominal = Rigid3::from_parts(Vec3::new(60.0, 0.0, 180.0).into(), so3::exp(&Vec3::new(0.0, 3.0, 0.0)).into());
//! let link = UncertainPose::from_sigmas(nominal, Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.0, 0.0, 0.1_f64.to_radians()));
//! // carried by a second, certain link of 1 m along x: the composed centre picks up the
//! // rotation noise as a lever arm.
//! let arm = UncertainPose::certain(Rigid3::translation(1000.0, 0.0, 0.0));
//! let chain = link.compose(&arm);
//! assert!(chain.sigma_position().norm() > 1.0);
//! // Sampling: δ = L·ε with L·Lᵀ = Σ.
//! let eps = Vec6::new(0.0, 0.0, 0.0, 0.0, 0.0, 1.0);
//! let drawn = link.perturbed(&(link.factor() * eps));
//! let back = link.tangent_of(&drawn);
//! assert!((back[5] - 0.1_f64.to_radians()).abs() < 1e-15);
//! ```

use crate::{Error, Mat3, Mat6, Rigid3, Rot3, Vec3, Vec6, mean, so3};
use nalgebra::SymmetricEigen;

/// Relative tolerance for "symmetric" and "positive semi-definite" (beyond rounding): an
/// asymmetry or a negative eigenvalue larger than this times the largest |entry| is an error.
pub const COVARIANCE_RELATIVE_TOLERANCE: f64 = 1e-9;

/// Why a matrix is not a valid covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CovarianceProblem {
    /// An entry is NaN or infinite.
    NonFinite,
    /// `|Σᵢⱼ − Σⱼᵢ|` exceeds the tolerance at (row, column) (0-based).
    NotSymmetric(usize, usize),
    /// The smallest eigenvalue is negative beyond the tolerance.
    NotPositiveSemiDefinite(f64),
}

impl std::fmt::Display for CovarianceProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CovarianceProblem::NonFinite => write!(f, "a covariance entry is not finite"),
            CovarianceProblem::NotSymmetric(i, j) => write!(
                f,
                "the covariance is not symmetric: entry ({}, {}) differs from ({}, {})",
                i + 1,
                j + 1,
                j + 1,
                i + 1
            ),
            CovarianceProblem::NotPositiveSemiDefinite(l) => write!(
                f,
                "the covariance is not positive semi-definite (smallest eigenvalue {l:e})"
            ),
        }
    }
}

/// Checks that `m` is symmetric and positive semi-definite up to
/// [`COVARIANCE_RELATIVE_TOLERANCE`] (relative to its largest |entry|).
pub fn check_covariance(m: &Mat6) -> Result<(), CovarianceProblem> {
    if m.iter().any(|v| !v.is_finite()) {
        return Err(CovarianceProblem::NonFinite);
    }
    let scale = m.amax();
    if scale == 0.0 {
        return Ok(());
    }
    let tol = COVARIANCE_RELATIVE_TOLERANCE * scale;
    for i in 0..6 {
        for j in (i + 1)..6 {
            if (m[(i, j)] - m[(j, i)]).abs() > tol {
                return Err(CovarianceProblem::NotSymmetric(i, j));
            }
        }
    }
    let min = SymmetricEigen::new(symmetrize(m)).eigenvalues.min();
    if min < -tol {
        return Err(CovarianceProblem::NotPositiveSemiDefinite(min));
    }
    Ok(())
}

fn symmetrize(m: &Mat6) -> Mat6 {
    (m + m.transpose()) * 0.5
}

/// Lower-triangular `L` with `L·Lᵀ = Σ` for a symmetric positive **semi**-definite `Σ`.
///
/// Cholesky–Banachiewicz where a pivot at or below `1e-14 × max diagonal` (a direction with no
/// variance, e.g. a camera without rotation noise) gives a zero column instead of a failure.
/// Negative rounding is clamped. For a diagonal `Σ` the result is `diag(√Σᵢᵢ)` exactly.
pub fn psd_factor(cov: &Mat6) -> Mat6 {
    let s = symmetrize(cov);
    let dmax = (0..6).map(|i| s[(i, i)]).fold(0.0_f64, f64::max);
    let floor = 1e-14 * dmax;
    let mut l = Mat6::zeros();
    for j in 0..6 {
        let mut d = s[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d <= floor {
            continue; // zero column: no independent variance left in this direction
        }
        let ljj = d.sqrt();
        l[(j, j)] = ljj;
        for i in (j + 1)..6 {
            let mut v = s[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = v / ljj;
        }
    }
    l
}

/// Scale of the rotation rows/columns between radians (library) and degrees (contract).
fn deg_scaling() -> Vec6 {
    let k = 180.0 / std::f64::consts::PI;
    Vec6::new(1.0, 1.0, 1.0, k, k, k)
}

/// A nominal `b_from_a` with a Gaussian tangent perturbation of covariance `Σ` (mm, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UncertainPose {
    /// The nominal transform `b_from_a` (translation = `a`'s origin in `b`'s axes, mm).
    pub b_from_a: Rigid3,
    /// Covariance of `δ` in the order x, y, z (mm), θx, θy, θz (rad about `a`'s axes).
    pub covariance: Mat6,
}

impl UncertainPose {
    /// A pose with the given covariance (mm, rad).
    ///
    /// # Errors
    /// The [`CovarianceProblem`] of `covariance` (see [`check_covariance`]).
    pub fn new(b_from_a: Rigid3, covariance: Mat6) -> Result<Self, CovarianceProblem> {
        check_covariance(&covariance)?;
        Ok(UncertainPose {
            b_from_a,
            covariance: symmetrize(&covariance),
        })
    }

    /// A pose with the contract's units: the rotation block in degrees (deg², mm·deg).
    ///
    /// # Errors
    /// As [`UncertainPose::new`].
    pub fn from_covariance_deg(
        b_from_a: Rigid3,
        covariance_deg: Mat6,
    ) -> Result<Self, CovarianceProblem> {
        check_covariance(&covariance_deg)?;
        let s = deg_scaling().map(|k| 1.0 / k);
        let c = Mat6::from_fn(|i, j| covariance_deg[(i, j)] * s[i] * s[j]);
        Ok(UncertainPose {
            b_from_a,
            covariance: symmetrize(&c),
        })
    }

    /// A pose without uncertainty.
    pub fn certain(b_from_a: Rigid3) -> Self {
        UncertainPose {
            b_from_a,
            covariance: Mat6::zeros(),
        }
    }

    /// The diagonal case: independent σ of the centre (mm) and of the body-axis rotation (rad).
    pub fn from_sigmas(b_from_a: Rigid3, sigma_position: Vec3, sigma_rotation_rad: Vec3) -> Self {
        let d = Vec6::new(
            sigma_position.x,
            sigma_position.y,
            sigma_position.z,
            sigma_rotation_rad.x,
            sigma_rotation_rad.y,
            sigma_rotation_rad.z,
        );
        UncertainPose {
            b_from_a,
            covariance: Mat6::from_diagonal(&d.component_mul(&d)),
        }
    }

    /// Nominal rotation `R̄_b_from_a`.
    pub fn rotation(&self) -> Rot3 {
        self.b_from_a.rotation.to_rotation_matrix()
    }

    /// Nominal translation: `a`'s origin in `b`'s axes (mm).
    pub fn center(&self) -> Vec3 {
        self.b_from_a.translation.vector
    }

    /// The covariance with the rotation block in degrees (the contract's units).
    pub fn covariance_deg(&self) -> Mat6 {
        let s = deg_scaling();
        Mat6::from_fn(|i, j| self.covariance[(i, j)] * s[i] * s[j])
    }

    /// σ of the centre (mm).
    pub fn sigma_position(&self) -> Vec3 {
        Vec3::new(
            self.covariance[(0, 0)].max(0.0).sqrt(),
            self.covariance[(1, 1)].max(0.0).sqrt(),
            self.covariance[(2, 2)].max(0.0).sqrt(),
        )
    }

    /// σ of the body-axis rotation (rad).
    pub fn sigma_rotation(&self) -> Vec3 {
        Vec3::new(
            self.covariance[(3, 3)].max(0.0).sqrt(),
            self.covariance[(4, 4)].max(0.0).sqrt(),
            self.covariance[(5, 5)].max(0.0).sqrt(),
        )
    }

    /// True when the covariance is diagonal (independent components).
    pub fn is_diagonal(&self) -> bool {
        (0..6).all(|i| (0..6).all(|j| i == j || self.covariance[(i, j)] == 0.0))
    }

    /// Lower-triangular factor `L` (`L·Lᵀ = Σ`) for sampling `δ = L·ε`; see [`psd_factor`].
    pub fn factor(&self) -> Mat6 {
        psd_factor(&self.covariance)
    }

    /// The pose perturbed by `δ` (mm, rad): `C̄ + δ_xyz`, `R̄·Exp(δθ)`.
    pub fn perturbed(&self, delta: &Vec6) -> Rigid3 {
        let c = self.center() + delta.fixed_rows::<3>(0);
        let r = self.rotation() * so3::exp(&delta.fixed_rows::<3>(3).into_owned());
        crate::quat::rigid_from_rotation(&r, &c)
    }

    /// The tangent coordinates of `pose` about the nominal: `(C − C̄, log(R̄ᵀ·R))`.
    pub fn tangent_of(&self, pose: &Rigid3) -> Vec6 {
        let dc = pose.translation.vector - self.center();
        let dr = so3::log(&(self.rotation().inverse() * pose.rotation.to_rotation_matrix()));
        Vec6::new(dc.x, dc.y, dc.z, dr.x, dr.y, dr.z)
    }

    /// Estimates a pose and its covariance from samples: the rotation mean on SO(3) (Karcher),
    /// the arithmetic mean of the translations, and the sample covariance (n − 1) of the
    /// tangent residuals [`UncertainPose::tangent_of`] about that mean.
    ///
    /// # Errors
    /// [`Error::TooFewSamples`] below two samples; [`Error::NonFinite`] for a non-finite
    /// sample; the errors of [`mean::karcher_mean`] (e.g. rotations spread over half a turn).
    pub fn from_samples(samples: &[Rigid3]) -> Result<Self, Error> {
        if samples.len() < 2 {
            return Err(Error::TooFewSamples {
                needed: 2,
                found: samples.len(),
            });
        }
        let finite = |p: &Rigid3| {
            p.translation.vector.iter().all(|v| v.is_finite())
                && p.rotation.coords.iter().all(|v| v.is_finite())
        };
        if !samples.iter().all(finite) {
            return Err(Error::NonFinite {
                what: "pose sample",
            });
        }
        let rs: Vec<Rot3> = samples
            .iter()
            .map(|p| p.rotation.to_rotation_matrix())
            .collect();
        let r_mean = mean::karcher_mean(&rs, 1e-13, 100)?;
        let n = samples.len() as f64;
        let c_mean = samples.iter().map(|p| p.translation.vector).sum::<Vec3>() / n;
        let nominal = crate::quat::rigid_from_rotation(&r_mean, &c_mean);
        let mut pose = UncertainPose::certain(nominal);
        let mut cov = Mat6::zeros();
        let mut sum = Vec6::zeros();
        let residuals: Vec<Vec6> = samples.iter().map(|p| pose.tangent_of(p)).collect();
        for r in &residuals {
            sum += r;
        }
        let m = sum / n;
        for r in &residuals {
            let d = r - m;
            cov += d * d.transpose();
        }
        pose.covariance = symmetrize(&(cov / (n - 1.0)));
        Ok(pose)
    }

    /// First-order composition `b_from_c = self (b_from_a) · other (a_from_c)` of two
    /// independent uncertain transforms.
    ///
    /// With `R = R̄₁Exp(θ₁)·R̄₂Exp(θ₂) = R̄₁R̄₂·Exp(R̄₂ᵀθ₁ + θ₂)` and
    /// `C = C₁ + R₁·C₂ ≈ C̄ + δC₁ − R̄₁[C̄₂]ₓθ₁ + R̄₁δC₂`, `Σ = J₁Σ₁J₁ᵀ + J₂Σ₂J₂ᵀ`.
    pub fn compose(&self, other: &UncertainPose) -> UncertainPose {
        let (j1, j2) = compose_jacobians(self, other);
        UncertainPose {
            b_from_a: self.b_from_a * other.b_from_a,
            covariance: symmetrize(
                &(j1 * self.covariance * j1.transpose() + j2 * other.covariance * j2.transpose()),
            ),
        }
    }

    /// First-order inverse `a_from_b`: `δθ' = −R̄·δθ`, `δC' = −R̄ᵀδC + [C̄']ₓ·δθ`
    /// with `C̄' = −R̄ᵀC̄`.
    pub fn inverse(&self) -> UncertainPose {
        let j = inverse_jacobian(self);
        UncertainPose {
            b_from_a: self.b_from_a.inverse(),
            covariance: symmetrize(&(j * self.covariance * j.transpose())),
        }
    }

    /// Jacobian of (centre, ω φ κ of `R_b_from_a`) with respect to `δ` at `δ = 0`, for display:
    /// `Σ_opk = J·Σ·Jᵀ` gives the Euler-angle covariance (never use it as a tangent σ).
    ///
    /// # Errors
    /// [`Error::GimbalLock`] where ω φ κ are singular (|cos φ| below the tolerance).
    pub fn opk_jacobian(&self) -> Result<Mat6, Error> {
        let d = crate::opk::d_opk_d_tangent_right(&self.rotation())?;
        let mut j = Mat6::identity();
        j.fixed_view_mut::<3, 3>(3, 3).copy_from(&d);
        Ok(j)
    }

    /// Covariance of (centre mm, ω φ κ rad) to first order; see [`UncertainPose::opk_jacobian`].
    ///
    /// # Errors
    /// As [`UncertainPose::opk_jacobian`].
    pub fn opk_covariance(&self) -> Result<Mat6, Error> {
        let j = self.opk_jacobian()?;
        Ok(symmetrize(&(j * self.covariance * j.transpose())))
    }
}

/// Jacobians of `compose` with respect to the two perturbations.
pub fn compose_jacobians(first: &UncertainPose, second: &UncertainPose) -> (Mat6, Mat6) {
    let r1 = first.rotation().into_inner();
    let r2 = second.rotation().into_inner();
    let c2 = second.center();
    let mut j1 = Mat6::identity();
    j1.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-(r1 * so3::hat(&c2))));
    j1.fixed_view_mut::<3, 3>(3, 3).copy_from(&r2.transpose());
    let mut j2 = Mat6::identity();
    j2.fixed_view_mut::<3, 3>(0, 0).copy_from(&r1);
    (j1, j2)
}

fn inverse_jacobian(p: &UncertainPose) -> Mat6 {
    let r: Mat3 = p.rotation().into_inner();
    let c_inv = -(r.transpose() * p.center());
    let mut j = Mat6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-r.transpose()));
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&so3::hat(&c_inv));
    j.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-r));
    j
}
