//! Batch summaries of a slice: mean, σ (n − 1), SEM, quantiles, the median.

use crate::Error;

/// Mean, sample standard deviation (n − 1) and standard error of the mean of a slice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Number of values.
    pub n: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Sample standard deviation, divisor n − 1.
    pub sigma: f64,
    /// Standard error of the mean, σ/√n.
    pub sem: f64,
}

impl Summary {
    /// Summarises `values` (two-pass, at least two finite values).
    pub fn of(values: &[f64]) -> Result<Self, Error> {
        if values.len() < 2 {
            return Err(Error::TooFewValues {
                needed: 2,
                found: values.len(),
            });
        }
        if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NotFinite { index, value });
        }
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let ss = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>();
        let sigma = (ss / (n as f64 - 1.0)).sqrt();
        Ok(Self {
            n,
            mean,
            sigma,
            sem: sigma / (n as f64).sqrt(),
        })
    }
}

/// Quantile `p` of `values` by linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy).
pub fn quantile(values: &[f64], p: f64) -> Result<f64, Error> {
    if !(0.0..=1.0).contains(&p) {
        return Err(Error::BadProbability(p));
    }
    if values.is_empty() {
        return Err(Error::TooFewValues {
            needed: 1,
            found: 0,
        });
    }
    if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NotFinite { index, value });
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    Ok(quantile_sorted(&v, p))
}

/// Median of the finite values of `values` (NaN and ±∞ are left out): the middle value, or
/// `0.5·(a + b)` of the two middle values for an even count; `None` when no value is finite.
///
/// The one median of the workspace (grid and study summaries, the robust checks of `rig` and
/// `measure`). It equals [`quantile`]`(finite, 0.5)` in exact arithmetic; the midpoint is
/// formed as `0.5·(a + b)`, the correctly rounded mean of the two middle values.
///
/// ```
/// use crashrig_stats::summary::median;
/// assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
/// assert_eq!(median(&[4.0, f64::NAN, 1.0, 3.0, 2.0]), Some(2.5));
/// assert_eq!(median(&[f64::NAN]), None);
/// ```
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Type-7 quantile of an already sorted, finite, non-empty slice.
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn summary_nominal() {
        // Hand computed: mean 5, squared deviations 9+1+1+9 = 20, σ = √(20/3).
        let s = Summary::of(&[2.0, 4.0, 6.0, 8.0]).unwrap();
        assert_relative_eq!(s.mean, 5.0, epsilon = 1e-15);
        assert_relative_eq!(s.sigma, (20.0f64 / 3.0).sqrt(), epsilon = 1e-15);
        assert_relative_eq!(s.sem, (20.0f64 / 3.0).sqrt() / 2.0, epsilon = 1e-15);
    }

    #[test]
    fn summary_rejects_short_and_nan() {
        assert_eq!(
            Summary::of(&[1.0]),
            Err(Error::TooFewValues {
                needed: 2,
                found: 1
            })
        );
        assert!(matches!(
            Summary::of(&[1.0, f64::NAN]),
            Err(Error::NotFinite { index: 1, .. })
        ));
    }

    #[test]
    fn median_known_answers() {
        assert_eq!(median(&[5.0]), Some(5.0));
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
        // Non-finite values are left out, not sorted to one end.
        let v = [f64::INFINITY, 1.0, f64::NAN, 2.0, f64::NEG_INFINITY, 10.0];
        assert_eq!(median(&v), Some(2.0));
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[f64::NAN, f64::INFINITY]), None);
        // The same median as the type-7 quantile at 0.5 (numpy.median([-7, 0.5, 3, 9]) = 1.75).
        let v = [9.0, -7.0, 3.0, 0.5];
        assert_eq!(median(&v), Some(1.75));
        assert_eq!(quantile(&v, 0.5).unwrap(), 1.75);
    }

    #[test]
    fn quantile_type7_known_answers() {
        // numpy.quantile([1, 2, 3, 4], [0, 0.25, 0.5, 1]) = [1, 1.75, 2.5, 4]
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_relative_eq!(quantile(&v, 0.0).unwrap(), 1.0);
        assert_relative_eq!(quantile(&v, 0.25).unwrap(), 1.75, epsilon = 1e-15);
        assert_relative_eq!(quantile(&v, 0.5).unwrap(), 2.5, epsilon = 1e-15);
        assert_relative_eq!(quantile(&v, 1.0).unwrap(), 4.0);
        assert_eq!(quantile(&v, 1.5), Err(Error::BadProbability(1.5)));
    }
}
