//! The settings of a measurement and their checks.

use crate::filter::CfcSpec;
use crate::{Error, rules};
use crashrig_input::options::Spelling;

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

/// The largest `--sync-sigma-ms` accepted (ms): [`rules::MAX_SYNC_SIGMA_MS`].
pub const MAX_SYNC_SIGMA_MS: f64 = rules::MAX_SYNC_SIGMA_MS;

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

/// The settings against their [`rules`] (the CLI's spelling in the messages).
pub(super) fn check_settings(s: &Settings) -> Result<(), Error> {
    let flag = |k| Spelling::Flag.name(k).to_string();
    let check = |name, r: Result<f64, String>| {
        r.map(|_| ())
            .map_err(|problem| Error::Setting { name, problem })
    };
    if !(2..=MAX_SAMPLES).contains(&s.samples) {
        return Err(Error::Setting {
            name: "--samples",
            problem: format!("{} (from 2 to {})", s.samples, MAX_SAMPLES),
        });
    }
    check("--pixel-sigma-px", rules::pixel_sigma_px(s.pixel_sigma_px))?;
    check("--threshold-mm", rules::threshold_mm(s.threshold_mm))?;
    if let Some(p) = s.max_reprojection_px {
        check("--max-reprojection-px", rules::max_reprojection_px(p))?;
    }
    if let Some(f) = s.frame_rate_hz {
        check("--frame-rate-hz", rules::frame_rate_hz(f))?;
    }
    check(
        "--sync-sigma-ms",
        rules::sync_sigma_ms(s.sync_sigma_ms, s.frame_rate_hz.is_some(), &flag),
    )?;
    if let Some(ft) = &s.frame_times {
        if s.frame_rate_hz.is_none() {
            return Err(Error::Setting {
                name: "--frame-times",
                problem:
                    "needs the rate of its mean interval as the frame rate (MeasureOptions sets it)"
                        .into(),
            });
        }
        if s.cfc.is_some() {
            ft.uniform_interval()?;
        }
    }
    if let Some(spec) = s.cfc {
        rules::cfc(spec.class.into(), spec.standard, s.frame_rate_hz, &flag).map_err(
            |problem| Error::Setting {
                name: "--cfc",
                problem,
            },
        )?;
    }
    Ok(())
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
