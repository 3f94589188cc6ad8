//! Units are never guessed: bounds and plausibility checks of a measurement's inputs and
//! outputs (`docs/LIMITS.md`, `docs/MEASURE.md` "Warnings").
//!
//! - [`MAX_SAMPLES`]: the bound on `--samples` (checked before any work).
//! - [`check_measurable`]: at least one row has a position (else an error).
//! - [`check_finite`]: every number of the result is finite, else an error (nothing is
//!   written).
//! - [`warnings`]: a frame rate below [`MIN_FRAME_RATE_HZ`] or a velocity above
//!   [`MAX_VELOCITY_MM_S`] — each names the suspect flag or key and its unit.
//!
//! ```
//! use crashrig_measure::plausible::{MIN_FRAME_RATE_HZ, frame_rate_warning};
//! assert!(frame_rate_warning(1000.0, "--frame-rate-hz").is_none());
//! let w = frame_rate_warning(20.0, "--frame-rate-hz").unwrap();
//! assert!(w.starts_with("--frame-rate-hz = 20 Hz is below 100 Hz"));
//! assert_eq!(MIN_FRAME_RATE_HZ, 100.0);
//! ```

use crate::Error;
use crate::engine::Measurement;

pub use crate::engine::MAX_SAMPLES;
/// A crash-test camera records at 500 Hz or more: a rate below this (Hz) is suspect (a rate
/// typed in kHz).
pub const MIN_FRAME_RATE_HZ: f64 = 100.0;
/// A marker inside a car moves slower than 100 m/s (mm/s): a faster one points at a wrong
/// frame rate or model scale.
pub const MAX_VELOCITY_MM_S: f64 = 100_000.0;

/// The warning for a frame rate below [`MIN_FRAME_RATE_HZ`], naming `key` (the flag or study
/// key) and its unit; `None` for a plausible rate.
pub fn frame_rate_warning(hz: f64, key: &str) -> Option<String> {
    (hz < MIN_FRAME_RATE_HZ).then(|| {
        format!(
            "{key} = {hz} Hz is below {MIN_FRAME_RATE_HZ} Hz: crash-test cameras record at 500 Hz or more; give the rate in Hz (e.g. {} for {hz} kHz)",
            hz * 1000.0
        )
    })
}

/// The plausibility warnings of a measurement (without the `warning: ` prefix): a frame rate
/// below [`MIN_FRAME_RATE_HZ`] and the fastest nominal velocity when it exceeds
/// [`MAX_VELOCITY_MM_S`]. `frame_rate_key` and `scale_key` name the frame rate and the model
/// scale as the user gave them (`--frame-rate-hz` / `--mm-per-unit`, or the study keys).
pub fn warnings(
    m: &Measurement,
    frame_rate_hz: Option<f64>,
    frame_rate_key: &str,
    scale_key: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(w) = frame_rate_hz.and_then(|hz| frame_rate_warning(hz, frame_rate_key)) {
        out.push(w);
    }
    let fastest = m
        .rows
        .iter()
        .filter_map(|r| r.velocity_mm_s.map(|v| (v.norm(), r)))
        .filter(|(v, _)| v.is_finite())
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((v, r)) = fastest
        && v > MAX_VELOCITY_MM_S
    {
        out.push(format!(
            "marker `{}` moves at {:.0} m/s in epoch `{}`, above {} m/s: check {frame_rate_key} (Hz) and {scale_key} (mm per model unit)",
            m.markers[r.marker],
            v / 1000.0,
            m.epochs[r.epoch].name,
            MAX_VELOCITY_MM_S / 1000.0
        ));
    }
    out
}

/// Checks that at least one row has a position: a sequence in which no marker is seen by two
/// cameras (camera B alone, without `--camera-c`) measures nothing, and is not presented as a
/// result.
///
/// # Errors
/// [`Error::Input`] saying so.
pub fn check_measurable(m: &Measurement) -> Result<(), Error> {
    if m.rows.iter().any(|r| r.position_mm.is_some()) {
        return Ok(());
    }
    let single = m.rows.iter().all(|r| r.n_views < 2);
    Err(Error::Input(format!(
        "no marker could be measured in any epoch ({} rows{}): nothing is written",
        m.rows.len(),
        if single {
            ", each seen by one camera only: a marker needs two views, give the tied camera C (--camera-c with --tie)"
        } else {
            ", every intersection degenerate"
        }
    )))
}

/// Checks that every number of the result is finite (positions, σ, displacements,
/// velocities, reprojection residuals, the length check's errors, σ and statistics).
///
/// # Errors
/// [`Error::Input`] naming the first epoch, marker and column that is not finite, and the
/// inputs that scale it (`--mm-per-unit` in mm per model unit, the pixels in px).
pub fn check_finite(m: &Measurement) -> Result<(), Error> {
    for r in &m.rows {
        let vectors = [
            ("x_mm", r.position_mm),
            ("sigma_x_mm", r.sigma_mm),
            ("dx_mm", r.displacement_mm),
            ("sigma_dx_mm", r.displacement_sigma_mm),
            ("vx_mm_s", r.velocity_mm_s),
            ("sigma_vx_mm_s", r.velocity_sigma_mm_s),
        ];
        let bad_vector = vectors.iter().find_map(|(name, v)| {
            v.filter(|v| v.iter().any(|x| !x.is_finite()))
                .map(|v| (*name, v.to_string()))
        });
        let bad = bad_vector.or_else(|| {
            r.reprojection_px
                .filter(|p| !p.is_finite())
                .map(|p| ("reprojection_px", p.to_string()))
        });
        if let Some((column, value)) = bad {
            return Err(Error::Input(format!(
                "the result is not finite ({column} = {} for marker `{}` in epoch `{}`): nothing is written; check --mm-per-unit (mm per model unit) and the marker pixels (px)",
                value.trim(),
                m.markers[r.marker],
                m.epochs[r.epoch].name
            )));
        }
    }
    for bar in m.length_check.iter().flat_map(|lc| &lc.bars) {
        let s = &bar.stats;
        let per_epoch = s.epochs.iter().flat_map(|k| {
            [
                ("measured_mm", Some(k.measured_mm)),
                ("sigma_mm", k.sigma_mm),
                ("z", k.z),
            ]
        });
        let numbers = [
            ("mean_error_mm", s.mean_error_mm),
            ("bias_z", s.bias_z),
            ("scatter_ratio", s.scatter_ratio),
            ("scatter_dof", s.scatter_dof),
            ("scatter_band_99", s.scatter_band.map(|b| b.0 + b.1)),
        ];
        if let Some((name, v)) = per_epoch
            .chain(numbers)
            .find_map(|(name, v)| v.filter(|v| !v.is_finite()).map(|v| (name, v)))
        {
            return Err(Error::Input(format!(
                "the length check is not finite ({name} = {v} for scale bar `{}`): nothing is written; check the marker pixels (px)",
                bar.bar.name
            )));
        }
    }
    Ok(())
}
