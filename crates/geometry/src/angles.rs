//! Wrap-safe statistics of angles (rad): a spread of values around ±π is the small spread it is.

use crate::Error;
use crate::tolerance::MIN_MEAN_RESULTANT;
use std::f64::consts::{PI, TAU};

/// Wrap an angle to (−π, π]. NaN and infinities give NaN.
pub fn wrap_pi(a: f64) -> f64 {
    let r = a.rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// Circular mean `atan2(Σ sin a, Σ cos a)`, in (−π, π].
///
/// # Errors
/// [`Error::TooFewSamples`] on an empty slice, [`Error::NonFinite`] on NaN/∞ input,
/// [`Error::UndefinedCircularMean`] when the mean resultant length is below
/// [`MIN_MEAN_RESULTANT`] (e.g. two opposite angles).
pub fn circular_mean(a: &[f64]) -> Result<f64, Error> {
    if a.is_empty() {
        return Err(Error::TooFewSamples {
            needed: 1,
            found: 0,
        });
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what: "angle" });
    }
    let (s, c) = a
        .iter()
        .fold((0.0, 0.0), |(s, c), v| (s + v.sin(), c + v.cos()));
    let resultant = s.hypot(c) / a.len() as f64;
    if resultant < MIN_MEAN_RESULTANT {
        return Err(Error::UndefinedCircularMean { resultant });
    }
    Ok(wrap_pi(s.atan2(c)))
}

/// Each value shifted by a multiple of 2π to lie within ±π of `center` (in (center − π, center + π]).
pub fn unwrap_about(a: &[f64], center: f64) -> Vec<f64> {
    a.iter().map(|v| center + wrap_pi(v - center)).collect()
}

/// Mean, sample σ (n − 1), SEM = σ/√n and count of a set of angles (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleStats {
    /// Mean, wrapped to (−π, π].
    pub mean: f64,
    /// Sample standard deviation (divisor n − 1) of the unwrapped values.
    pub sigma: f64,
    /// Standard error of the mean, σ/√n.
    pub sem: f64,
    /// Number of values.
    pub n: usize,
}

/// Wrap-safe mean/σ/SEM: values are unwrapped about their circular mean, then the ordinary
/// mean and sample σ are taken; the mean is re-wrapped to (−π, π].
///
/// # Errors
/// [`Error::TooFewSamples`] for fewer than 2 values, plus the errors of [`circular_mean`].
pub fn wrapped_stats(a: &[f64]) -> Result<AngleStats, Error> {
    if a.len() < 2 {
        return Err(Error::TooFewSamples {
            needed: 2,
            found: a.len(),
        });
    }
    let center = circular_mean(a)?;
    let u = unwrap_about(a, center);
    let n = u.len() as f64;
    let mean = u.iter().sum::<f64>() / n;
    let var = u.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    let sigma = var.sqrt();
    Ok(AngleStats {
        mean: wrap_pi(mean),
        sigma,
        sem: sigma / n.sqrt(),
        n: a.len(),
    })
}
