//! The study file (TOML): what `crashrig study` runs.
//!
//! Paths are relative to the study file. Frames (see `docs/REFERENCE.md`, "Study file"):
//! - the **world frame** is the lab frame in which the outward camera A's pose
//!   `world_from_A` is given (`[outward]`); the chain outward → inward (the calibrated link
//!   `A_from_B`) → tie (the bootstrapped link `B_from_C`) is composed in it;
//! - the **vehicle frame** of a `[[layout]]` (x forwards from the trunk opening, y left, z up)
//!   holds the grid and the observers' positions. An observer with `from = "inward"` takes the
//!   propagated world covariance of that chain camera unchanged: the vehicle axes are taken as
//!   parallel to the world axes (the covariance is not rotated).

use crate::Error;
use layout::layout_sections;
use measure::measure_section;
use raw::{Raw, parse_raw};
use rig::{calibration_section, outward_section, tie_section};
use std::path::{Path, PathBuf};
use toml::Spanned;
use validate::Ctx;

mod layout;
mod locate;
mod measure;
mod raw;
mod rig;
mod sections;
pub mod units;
mod validate;

pub use layout::MIN_OBSERVER_DISTANCE_MM;
pub(crate) use layout::check_layout_size;
pub(crate) use locate::{key_line, key_line_top, line_of};
pub use sections::{
    ABundle, AxisSpec, CalibrationSection, ChainCamera, Layout, MeasureANoise, MeasureSection,
    Observer, ObserverNoise, Study, StudyScale, TieMethod, TieResample, TieSection,
};

/// The top-level keys `samples`, `chain_samples` (with their defaults) and `reference`.
fn top_level_keys(cx: &Ctx<'_>, raw: &Raw) -> Result<(usize, usize), Error> {
    let samples = raw.samples.as_ref().map_or(Ok(2000), |v| {
        cx.count(v, "samples", 2, crashrig_mc::limits::MAX_SAMPLES)
    })?;
    let chain_samples = raw.chain_samples.as_ref().map_or(Ok(200_000), |v| {
        cx.count(v, "chain_samples", 2, crashrig_mc::limits::MAX_SAMPLES)
    })?;
    if let Some(r) = &raw.reference
        && r.get_ref() != "kaminski2023"
    {
        return cx.err(
            Some(r.span()),
            "reference",
            format!(
                "unknown reference {:?} (known: \"kaminski2023\")",
                r.get_ref()
            ),
        );
    }
    Ok((samples, chain_samples))
}

impl Study {
    /// Reads and validates a study file: every path it names must exist.
    ///
    /// # Errors
    /// [`Error::Read`], [`Error::Toml`] or [`Error::Key`] naming the file, key and line.
    pub fn from_path(path: &Path) -> Result<Study, Error> {
        let text =
            crashrig_input::file::read_text_limited(path, crashrig_input::file::MAX_TOML_BYTES)
                .map_err(|source| Error::Read {
                    path: path.to_path_buf(),
                    source,
                })?;
        Study::from_toml_str(&text, path)
    }

    /// Parses and validates study text; relative paths are resolved against `path`'s folder.
    ///
    /// # Errors
    /// As [`Study::from_path`].
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Study, Error> {
        let raw = parse_raw(text, path)?;
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        let cx = Ctx { path, text, dir };
        let (samples, chain_samples) = top_level_keys(&cx, &raw)?;
        let calibration = calibration_section(&cx, raw.calibration.as_ref())?;
        let tie = raw.tie.as_ref().map(|t| tie_section(&cx, t)).transpose()?;
        let outward = outward_section(&cx, raw.outward.as_ref())?;
        let layouts = layout_sections(&cx, &raw.layout, tie.is_some(), samples)?;
        let measure = match &raw.measure {
            None => None,
            Some(m) => Some(measure_section(&cx, m, tie.is_some())?),
        };
        let warnings = units::read_warnings(
            &cx,
            &raw,
            &units::Read {
                outward: &outward,
                layouts: &layouts,
                tie: tie.as_ref(),
                measure: measure.as_ref(),
            },
        );
        Ok(Study {
            path: path.to_path_buf(),
            text: text.to_string(),
            seed: raw.seed.unwrap_or(1),
            samples,
            chain_samples,
            calibration,
            tie,
            outward,
            layouts,
            reference: raw.reference.map(Spanned::into_inner),
            measure,
            warnings,
        })
    }
}

#[cfg(test)]
mod tests;
