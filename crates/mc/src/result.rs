//! The grid study's result: statistics per grid point ([`PointStats`]) and for the grid
//! ([`GridResult`]).

use crate::model::PoseSigma;
use nalgebra::{Matrix3, Matrix6, SymmetricEigen, Vector3};

/// Statistics of the intersected points at one grid point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointStats {
    /// The grid point (mm).
    pub point: Vector3<f64>,
    /// Draws used.
    pub count: u64,
    /// Mean intersected point (mm).
    pub mean_mm: Vector3<f64>,
    /// Sample covariance (mm², n − 1).
    pub covariance: Matrix3<f64>,
    /// σx, σy, σz (mm).
    pub sigma_mm: Vector3<f64>,
    /// max(σx, σy, σz) (mm).
    pub sigma_max_mm: f64,
    /// First-order covariance (mm²) of the same inputs (observers drawn jointly from the chain
    /// through the chain's Jacobians, the others independent).
    pub linear_covariance: Matrix3<f64>,
    /// Observers that see the point (all of them when every observer is aimed); fewer than
    /// two: not measurable, σ and covariances NaN, `count` 0 (fixed observers, `fixed.rs`).
    pub observers_seen: usize,
    /// Adaptive runs (`[grid.adaptive]`): whether the tolerance was met before
    /// `max_samples`; `None` for a fixed number of draws.
    pub converged: Option<bool>,
}

impl PointStats {
    /// Semi-axes (mm) of the 1σ error ellipsoid, largest first (√ of the covariance
    /// eigenvalues).
    pub fn ellipsoid_semi_axes_mm(&self) -> Vector3<f64> {
        let e = SymmetricEigen::new(self.covariance);
        let mut v: Vec<f64> = e.eigenvalues.iter().map(|l| l.max(0.0).sqrt()).collect();
        v.sort_by(|a, b| b.total_cmp(a));
        Vector3::new(v[0], v[1], v[2])
    }

    /// Worst-direction σ (mm): √ of the largest eigenvalue of [`PointStats::covariance`], the
    /// σ along the direction in which the point is least certain (never below
    /// [`PointStats::sigma_max_mm`]: a 5 mm promise holds in every direction only when this is
    /// below 5 mm). NaN when σ_max is NaN (not measurable, or blanked as degenerate).
    pub fn sigma_worst_mm(&self) -> f64 {
        if self.sigma_max_mm.is_finite() && self.covariance.iter().all(|v| v.is_finite()) {
            self.ellipsoid_semi_axes_mm()[0]
        } else {
            f64::NAN
        }
    }
    /// First-order σx, σy, σz (mm).
    pub fn linear_sigma_mm(&self) -> Vector3<f64> {
        Vector3::from_fn(|i, _| self.linear_covariance[(i, i)].sqrt())
    }

    /// First-order σ_max (mm).
    pub fn linear_sigma_max_mm(&self) -> f64 {
        self.linear_sigma_mm().max()
    }
}

/// The result of a grid study.
#[derive(Debug, Clone, PartialEq)]
pub struct GridResult {
    /// One entry per grid point, in [`Grid::points`](crate::Grid::points) order.
    pub points: Vec<PointStats>,
    /// The noise each observer was given (σ of `sigma_from` cameras resolved from the chain's
    /// Monte Carlo propagation; rotation σ in the observer's [`RotationNoise`](crate::RotationNoise) meaning): the
    /// square roots of the diagonal of [`GridResult::observer_covariance`].
    pub observer_sigma: Vec<PoseSigma>,
    /// The full covariance of each observer's noise (mm, rad; tangent about the observer's
    /// own axes, or ω φ κ for Euler noise).
    pub observer_covariance: Vec<Matrix6<f64>>,
    /// Whether observers from the same chain were drawn jointly.
    pub correlated: bool,
}

impl GridResult {
    /// Fraction of points with σ_max below `threshold_mm`.
    pub fn fraction_below(&self, threshold_mm: f64) -> f64 {
        let n = self.points.len().max(1) as f64;
        self.points
            .iter()
            .filter(|p| p.sigma_max_mm < threshold_mm)
            .count() as f64
            / n
    }
}

impl PointStats {
    /// Whether at least two observers see the point (else its σ are NaN: not measurable).
    pub fn is_measurable(&self) -> bool {
        self.observers_seen >= 2
    }
}

impl GridResult {
    /// Fraction of points seen by at least two observers.
    pub fn fraction_measurable(&self) -> f64 {
        let n = self.points.len().max(1) as f64;
        self.points.iter().filter(|p| p.is_measurable()).count() as f64 / n
    }
}
