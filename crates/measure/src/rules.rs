//! The rules of `measure`'s settings, one function per key, and their defaults: what every
//! front end applies — the CLI's flags and Python's keywords ([`crate::MeasureOptions`]), the
//! settings a library caller builds ([`crate::Settings`], checked again by [`crate::measure`]) and
//! a study file's `[measure]` section, which attaches the key's line. A rule and a default exist
//! once, here.
//!
//! Each rule takes the value and what it depends on, and returns the value to use or the problem
//! in words. The problem does not name its own key (the caller does, as its front end spells it:
//! `--sync-sigma-ms`, `sync_sigma_ms`, `measure.sync_sigma_ms` and its line); other settings it
//! names through `name`, a keyword → spelling function.
//!
//! ```
//! use crashrig_measure::rules;
//! let flag = |k: &'static str| format!("--{}", k.replace('_', "-"));
//! assert_eq!(rules::sync_sigma_ms(0.2, true, &flag), Ok(0.2));
//! assert_eq!(
//!     rules::sync_sigma_ms(0.2, false, &flag).unwrap_err(),
//!     "needs --frame-rate-hz (the offset shifts A's pose in time)"
//! );
//! assert_eq!(rules::threshold_mm(0.0).unwrap_err(), "0 is not a number > 0 (mm)");
//! ```

use crate::Error;
use crate::filter::{Cfc, CfcSpec, Standard};

/// How a front end spells a setting named in a problem (snake_case keyword → its spelling).
pub type Name<'a> = &'a dyn Fn(&'static str) -> String;

/// σ of each pixel coordinate when none is given (px).
pub const DEFAULT_PIXEL_SIGMA_PX: f64 = 0.5;

/// σ_max above which rows are flagged when no threshold is given (mm).
pub const DEFAULT_THRESHOLD_MM: f64 = 5.0;

/// The CFC filter's standard when none is given.
pub const DEFAULT_CFC_STANDARD: Standard = Standard::J211;

/// The largest `sync_sigma_ms` accepted (ms): an offset of a second is not a trigger offset.
pub const MAX_SYNC_SIGMA_MS: f64 = 1000.0;

/// The problem text of an [`Error::Setting`] (other errors whole).
fn problem(e: Error) -> String {
    match e {
        Error::Setting { problem, .. } => problem,
        other => other.to_string(),
    }
}

/// A finite number > 0, in `unit`.
fn positive(x: f64, unit: &str) -> Result<f64, String> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("{x} is not a number > 0 ({unit})"))
    }
}

/// `pixel_sigma_px`: finite and not negative (px).
pub fn pixel_sigma_px(x: f64) -> Result<f64, String> {
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("{x} is not a number ≥ 0 (px)"))
    }
}

/// `threshold_mm`: a number > 0 (mm).
pub fn threshold_mm(x: f64) -> Result<f64, String> {
    positive(x, "mm")
}

/// `max_reprojection_px`: a number > 0 (px).
pub fn max_reprojection_px(x: f64) -> Result<f64, String> {
    positive(x, "px")
}

/// `frame_rate_hz`: a number > 0 (frames per second).
pub fn frame_rate_hz(x: f64) -> Result<f64, String> {
    positive(x, "Hz")
}

/// `mpe_mm`, the lab's maximum permissible error of a length: needs `scale_bars`
/// (`scale_bars` given or not), a number > 0 (mm).
pub fn mpe_mm(x: f64, scale_bars: bool, name: Name<'_>) -> Result<f64, String> {
    if !scale_bars {
        return Err(format!(
            "needs {} (the maximum permissible error of the bars' lengths)",
            name("scale_bars")
        ));
    }
    positive(x, "mm")
}

/// `sync_sigma_ms`, σ of camera A's trigger offset: from 0 to [`MAX_SYNC_SIGMA_MS`] (ms), and
/// above 0 it needs a frame rate (`frame_rate` given or not: A's pose is shifted in time).
pub fn sync_sigma_ms(x: f64, frame_rate: bool, name: Name<'_>) -> Result<f64, String> {
    if !(x.is_finite() && (0.0..=MAX_SYNC_SIGMA_MS).contains(&x)) {
        return Err(format!(
            "{x} is not a number from 0 to {MAX_SYNC_SIGMA_MS} (ms)"
        ));
    }
    if x > 0.0 && !frame_rate {
        return Err(format!(
            "needs {} (the offset shifts A's pose in time)",
            name("frame_rate_hz")
        ));
    }
    Ok(x)
}

/// `cfc_standard`: `j211` or `iso6487`, only with `cfc` (`cfc` given or not); absent,
/// [`DEFAULT_CFC_STANDARD`].
pub fn cfc_standard(s: Option<&str>, cfc: bool, name: Name<'_>) -> Result<Standard, String> {
    match s {
        None => Ok(DEFAULT_CFC_STANDARD),
        Some(_) if !cfc => Err(format!(
            "needs {} (it names the standard of a CFC filter)",
            name("cfc")
        )),
        Some(s) => Standard::parse(s).map_err(problem),
    }
}

/// `cfc`, the channel frequency class of the kinematics' filter: one of
/// [`crate::filter::CLASSES`], with a frame rate whose Nyquist frequency it stays well below
/// ([`Cfc::new`]).
pub fn cfc(
    class: i64,
    standard: Standard,
    frame_rate_hz: Option<f64>,
    name: Name<'_>,
) -> Result<CfcSpec, String> {
    let Ok(class) = u32::try_from(class) else {
        return Err(format!(
            "{class} is not a channel frequency class (60, 180, 600, 1000)"
        ));
    };
    let Some(hz) = frame_rate_hz else {
        return Err(format!(
            "CFC {class} needs {} (the filter's sampling rate)",
            name("frame_rate_hz")
        ));
    };
    Cfc::new(class, standard, hz).map_err(problem)?;
    Ok(CfcSpec { class, standard })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(k: &'static str) -> String {
        format!("measure.{k}")
    }

    #[test]
    fn each_rule_accepts_its_range_and_names_what_it_needs() {
        assert_eq!(pixel_sigma_px(0.0), Ok(0.0));
        assert!(pixel_sigma_px(-0.1).is_err() && pixel_sigma_px(f64::NAN).is_err());
        assert_eq!(threshold_mm(5.0), Ok(5.0));
        assert!(threshold_mm(f64::INFINITY).is_err());
        assert_eq!(
            max_reprojection_px(-1.0).unwrap_err(),
            "-1 is not a number > 0 (px)"
        );
        assert_eq!(
            frame_rate_hz(0.0).unwrap_err(),
            "0 is not a number > 0 (Hz)"
        );
        assert_eq!(
            mpe_mm(1.0, false, &key).unwrap_err(),
            "needs measure.scale_bars (the maximum permissible error of the bars' lengths)"
        );
        assert_eq!(
            mpe_mm(-1.0, true, &key).unwrap_err(),
            "-1 is not a number > 0 (mm)"
        );
        assert_eq!(sync_sigma_ms(0.0, false, &key), Ok(0.0));
        assert_eq!(sync_sigma_ms(MAX_SYNC_SIGMA_MS, true, &key), Ok(1000.0));
        assert_eq!(
            sync_sigma_ms(1000.5, true, &key).unwrap_err(),
            "1000.5 is not a number from 0 to 1000 (ms)"
        );
        assert_eq!(cfc_standard(None, false, &key), Ok(Standard::J211));
        assert_eq!(
            cfc_standard(Some("iso6487"), true, &key),
            Ok(Standard::Iso6487)
        );
        assert_eq!(
            cfc_standard(Some("j211"), false, &key).unwrap_err(),
            "needs measure.cfc (it names the standard of a CFC filter)"
        );
        assert!(
            cfc_standard(Some("sae"), true, &key)
                .unwrap_err()
                .contains("`sae`")
        );
        assert_eq!(
            cfc(180, Standard::J211, Some(1000.0), &key),
            Ok(CfcSpec {
                class: 180,
                standard: Standard::J211
            })
        );
        assert_eq!(
            cfc(-5, Standard::J211, Some(1000.0), &key).unwrap_err(),
            "-5 is not a channel frequency class (60, 180, 600, 1000)"
        );
        assert!(
            cfc(180, Standard::J211, None, &key)
                .unwrap_err()
                .contains("measure.frame_rate_hz")
        );
        // 180 × 2.0775 = 374 Hz corner needs far more than 500 frames/s.
        assert!(
            cfc(180, Standard::J211, Some(500.0), &key)
                .unwrap_err()
                .contains("too high")
        );
    }
}
