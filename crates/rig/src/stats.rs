//! Statistics of the per-epoch links: mean, σ (n − 1), SEM, 6×6 covariance, SO(3) mean.

use crate::{Error, Link};
use crashrig_geometry::{Mat6, Rot3, Vec3, Vec6, angles, mean, opk};

/// Convergence tolerance of the Karcher mean (rad); far below any reported digit.
const KARCHER_TOLERANCE_RAD: f64 = 1e-14;
/// Iteration cap of the Karcher mean (it converges in a handful of steps for small spreads).
const KARCHER_MAX_ITERATIONS: usize = 100;

/// Statistics of a set of links (all epochs, or the epochs that are not outliers).
///
/// Angles are wrap-safe: each angle series is unwrapped to within ±π of its circular mean
/// before the mean, σ and covariance are taken (the contract's rule).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkStatistics {
    /// Number of epochs.
    pub n: usize,
    /// Mean base (mm).
    pub base_mm: Vec3,
    /// Sample σ of the base (mm, divisor n − 1).
    pub base_sigma_mm: Vec3,
    /// Standard error of the mean base, σ/√n (mm).
    pub base_sem_mm: Vec3,
    /// Wrap-safe mean of ω, φ, κ (rad, wrapped to (−π, π]).
    pub angles: Vec3,
    /// Sample σ of ω, φ, κ (rad).
    pub angles_sigma: Vec3,
    /// Standard error of the mean angles (rad).
    pub angles_sem: Vec3,
    /// Sample covariance (n − 1) of (x, y, z mm, ω, φ, κ rad), angles unwrapped as above.
    pub covariance: Mat6,
    /// Karcher (geodesic L2) mean of the rotations `R_A_from_B`.
    pub mean_rotation: Rot3,
    /// ω, φ, κ of [`LinkStatistics::mean_rotation`] (rad).
    pub mean_rotation_angles: Vec3,
}

/// The six parameter series (x, y, z mm; ω, φ, κ rad), angles unwrapped about their
/// circular means.
///
/// # Errors
/// [`Error::Geometry`] when an angle series has no circular mean (e.g. uniformly spread).
pub fn parameter_series(links: &[Link]) -> Result<[Vec<f64>; 6], Error> {
    let mut out: [Vec<f64>; 6] = Default::default();
    for j in 0..3 {
        out[j] = links.iter().map(|l| l.base_mm[j]).collect();
        let a: Vec<f64> = links.iter().map(|l| l.angles[j]).collect();
        let center = angles::circular_mean(&a)?;
        out[3 + j] = angles::unwrap_about(&a, center);
    }
    Ok(out)
}

/// Statistics of `links` (at least two).
///
/// # Errors
/// [`Error::TooFewEpochs`] for fewer than two links; [`Error::Geometry`] when the angles or
/// rotations have no defined mean.
pub fn link_statistics(links: &[Link]) -> Result<LinkStatistics, Error> {
    let n = links.len();
    if n < 2 {
        return Err(Error::TooFewEpochs {
            what: "link statistics",
            needed: 2,
            found: n,
        });
    }
    let series = parameter_series(links)?;
    let nf = n as f64;
    let means = Vec6::from_fn(|j, _| series[j].iter().sum::<f64>() / nf);
    let covariance = Mat6::from_fn(|i, j| {
        series[i]
            .iter()
            .zip(&series[j])
            .map(|(a, b)| (a - means[i]) * (b - means[j]))
            .sum::<f64>()
            / (nf - 1.0)
    });
    let sigma = Vec6::from_fn(|j, _| covariance[(j, j)].sqrt());
    let mut ang = Vec3::zeros();
    let mut ang_sigma = Vec3::zeros();
    let mut ang_sem = Vec3::zeros();
    for j in 0..3 {
        let a: Vec<f64> = links.iter().map(|l| l.angles[j]).collect();
        let s = angles::wrapped_stats(&a)?;
        ang[j] = s.mean;
        ang_sigma[j] = s.sigma;
        ang_sem[j] = s.sem;
    }
    let rotations: Vec<Rot3> = links
        .iter()
        .map(|l| l.a_from_b.rotation.to_rotation_matrix())
        .collect();
    let mean_rotation =
        mean::karcher_mean(&rotations, KARCHER_TOLERANCE_RAD, KARCHER_MAX_ITERATIONS)?;
    let m = opk::opk_from_rotation(&mean_rotation);
    let base_sigma = Vec3::new(sigma[0], sigma[1], sigma[2]);
    Ok(LinkStatistics {
        n,
        base_mm: Vec3::new(means[0], means[1], means[2]),
        base_sigma_mm: base_sigma,
        base_sem_mm: base_sigma / nf.sqrt(),
        angles: ang,
        angles_sigma: ang_sigma,
        angles_sem: ang_sem,
        covariance,
        mean_rotation,
        mean_rotation_angles: Vec3::new(m.omega, m.phi, m.kappa),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::tests_support::link;
    use approx::assert_abs_diff_eq;

    #[test]
    fn link_statistics_nominal_matches_two_pass() {
        let links = vec![
            link([60.0, -1.0, 180.0], [179.9, -0.1, 179.8]),
            link([62.0, -2.0, 179.0], [179.95, -0.05, 179.7]),
            link([64.0, -3.0, 181.0], [-179.98, -0.12, 179.75]),
        ];
        let s = link_statistics(&links).unwrap();
        assert_eq!(s.n, 3);
        // Hand-computed: x = 60, 62, 64 → mean 62, σ = 2, SEM = 2/√3.
        assert_abs_diff_eq!(s.base_mm[0], 62.0, epsilon = 1e-12);
        assert_abs_diff_eq!(s.base_sigma_mm[0], 2.0, epsilon = 1e-12);
        assert_abs_diff_eq!(s.base_sem_mm[0], 2.0 / 3f64.sqrt(), epsilon = 1e-12);
        // ω = 179.9, 179.95, 180.02 after unwrapping → mean 179.956…, σ = 0.060277…
        let w = [179.9, 179.95, 180.02];
        let mw = w.iter().sum::<f64>() / 3.0;
        let sw = (w.iter().map(|v| (v - mw) * (v - mw)).sum::<f64>() / 2.0).sqrt();
        // Angles pass through rotation matrices: ~1e-13 rad of rounding.
        assert_abs_diff_eq!(s.angles[0].to_degrees(), mw, epsilon = 1e-9);
        assert_abs_diff_eq!(s.angles_sigma[0].to_degrees(), sw, epsilon = 1e-9);
        assert_abs_diff_eq!(
            s.covariance[(3, 3)],
            s.angles_sigma[0].powi(2),
            epsilon = 1e-18
        );
        // Covariance of x and ω: Σ (x − x̄)(ω − ω̄) / 2.
        let cxw = [60.0, 62.0, 64.0]
            .iter()
            .zip(&w)
            .map(|(x, a)| (x - 62.0) * (a - mw).to_radians())
            .sum::<f64>()
            / 2.0;
        assert_abs_diff_eq!(s.covariance[(0, 3)], cxw, epsilon = 1e-12);
        assert_abs_diff_eq!(s.covariance[(3, 0)], cxw, epsilon = 1e-12);
        // The Karcher mean agrees with the angle means to second order in the spread (~1e-5°).
        for j in 0..3 {
            assert_abs_diff_eq!(
                angles::wrap_pi(s.mean_rotation_angles[j] - s.angles[j]).to_degrees(),
                0.0,
                epsilon = 1e-3
            );
        }
    }

    #[test]
    fn link_statistics_wrap_gives_small_sigma() {
        // ω alternates 179.95 / −179.95: a 0.05° spread, not ~180°.
        let links: Vec<Link> = (0..10)
            .map(|i| {
                let w = if i % 2 == 0 { 179.95 } else { -179.95 };
                link([0.0, 0.0, 0.0], [w, 0.0, 0.0])
            })
            .collect();
        let s = link_statistics(&links).unwrap();
        // Unwrapped values are 179.95 and 180.05: mean ±180°, σ = 0.05·√(10/9).
        assert_abs_diff_eq!(
            angles::wrap_pi(s.angles[0] - std::f64::consts::PI).to_degrees(),
            0.0,
            epsilon = 1e-9
        );
        assert_abs_diff_eq!(
            s.angles_sigma[0].to_degrees(),
            0.05 * (10.0f64 / 9.0).sqrt(),
            epsilon = 1e-9
        );
    }

    #[test]
    fn link_statistics_one_link_is_error() {
        let links = vec![link([0.0; 3], [0.0; 3])];
        assert!(matches!(
            link_statistics(&links),
            Err(Error::TooFewEpochs { found: 1, .. })
        ));
    }
}
