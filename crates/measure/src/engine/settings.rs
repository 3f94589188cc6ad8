//! The settings of a measurement and their checks.

use crate::filter::{Cfc, CfcSpec};
use crate::{Error, MeasureOptions};

/// Settings of a measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Monte Carlo replicates per row (≥ 2).
    pub samples: usize,
    /// Master seed.
    pub seed: u64,
    /// σ of each pixel coordinate (px, ≥ 0).
    pub pixel_sigma_px: f64,
    /// Reference epoch of the displacements (key or name); `None`: the first measured epoch.
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz) for velocities; `None`: no velocities.
    pub frame_rate_hz: Option<f64>,
    /// Each frame's time from the camera's clock (`--frame-times`): the epochs' times and
    /// frame numbers (the index in the file) instead of `frame / frame_rate_hz`; needs
    /// [`Settings::frame_rate_hz`] (the rate of the mean interval).
    pub frame_times: Option<crate::input::FrameTimes>,
    /// Rows with σ_max above this (mm) are flagged.
    pub threshold_mm: f64,
    /// Rows whose largest reprojection residual exceeds this (px) are flagged; `None`: the
    /// robust limit of the sequence, [`robust_reprojection_limit`](crate::engine::robust_reprojection_limit).
    pub max_reprojection_px: Option<f64>,
    /// CFC filter of the kinematics ([`crate::kinematics`]; needs a frame rate); `None`: no
    /// kinematics.
    pub cfc: Option<CfcSpec>,
    /// σ of camera A's trigger offset against the inward cameras (ms, ≥ 0; needs a frame
    /// rate): drawn once per replicate, A's pose interpolated to the shifted time. 0: none.
    pub sync_sigma_ms: f64,
}

/// The largest `--sync-sigma-ms` accepted (ms): an offset of a second is not a trigger offset.
pub const MAX_SYNC_SIGMA_MS: f64 = 1000.0;

/// Largest number of Monte Carlo replicates per row (`--samples`, `[measure] samples`).
pub const MAX_SAMPLES: usize = 10_000_000;

/// Largest number of row draws of one measure run: observation rows × replicates (the same
/// bound as a grid's points × samples), checked before the replicates start.
pub const MAX_DRAWS: u64 = 10_000_000_000;

/// Refuses a run whose `rows × samples` exceeds [`MAX_DRAWS`] (it would run for hours).
pub(super) fn check_draws(rows: usize, samples: usize) -> Result<(), Error> {
    let draws = rows as u64 * samples as u64;
    if draws > MAX_DRAWS {
        return Err(Error::Setting {
            name: "--samples",
            problem: format!(
                "{samples} replicates × {rows} observation rows = {draws} draws exceeds the limit of {MAX_DRAWS}; use fewer --samples"
            ),
        });
    }
    Ok(())
}

pub(super) fn check_settings(s: &Settings) -> Result<(), Error> {
    let bad = |name, problem: String| Err(Error::Setting { name, problem });
    if !(2..=MAX_SAMPLES).contains(&s.samples) {
        return bad(
            "--samples",
            format!("{} (from 2 to {})", s.samples, MAX_SAMPLES),
        );
    }
    if !MeasureOptions::pixel_sigma_px_is_valid(s.pixel_sigma_px) {
        return bad(
            "--pixel-sigma-px",
            format!("{} (a number ≥ 0)", s.pixel_sigma_px),
        );
    }
    if !(s.threshold_mm.is_finite() && s.threshold_mm > 0.0) {
        return bad(
            "--threshold-mm",
            format!("{} (a number > 0)", s.threshold_mm),
        );
    }
    if let Some(p) = s.max_reprojection_px
        && !(p.is_finite() && p > 0.0)
    {
        return bad("--max-reprojection-px", format!("{p} (a number > 0)"));
    }
    if let Some(f) = s.frame_rate_hz
        && !(f.is_finite() && f > 0.0)
    {
        return bad("--frame-rate-hz", format!("{f} (a number > 0)"));
    }
    if !(s.sync_sigma_ms.is_finite() && (0.0..=MAX_SYNC_SIGMA_MS).contains(&s.sync_sigma_ms)) {
        return bad(
            "--sync-sigma-ms",
            format!(
                "{} (a number from 0 to {MAX_SYNC_SIGMA_MS} ms)",
                s.sync_sigma_ms
            ),
        );
    }
    if s.sync_sigma_ms > 0.0 && s.frame_rate_hz.is_none() {
        return bad(
            "--sync-sigma-ms",
            "needs --frame-rate-hz (the offset shifts A's pose in time)".into(),
        );
    }
    if let Some(ft) = &s.frame_times {
        if s.frame_rate_hz.is_none() {
            return bad(
                "--frame-times",
                "needs the rate of its mean interval as the frame rate (MeasureOptions sets it)"
                    .into(),
            );
        }
        if s.cfc.is_some() {
            ft.uniform_interval()?;
        }
    }
    match (s.cfc, s.frame_rate_hz) {
        (Some(spec), None) => bad(
            "--cfc",
            format!(
                "CFC {} needs --frame-rate-hz (the filter's sampling rate)",
                spec.class
            ),
        ),
        (Some(spec), Some(hz)) => Cfc::new(spec.class, spec.standard, hz).map(|_| ()),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_bound_is_rows_times_samples() {
        // 1000 rows × 10⁷ replicates = 10¹⁰ draws: at the limit, accepted; one row more is not.
        assert!(check_draws(1000, 10_000_000).is_ok());
        let err = check_draws(1001, 10_000_000).unwrap_err().to_string();
        assert!(
            err.contains("--samples") && err.contains("10010000000 draws"),
            "{err}"
        );
    }
}
