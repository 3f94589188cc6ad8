//! Fixed observers of a study layout (`aim = "fixed"`): the keys of a scenario's fixed
//! `[[grid.observer]]` (`angles_deg` or `look_at_mm`, `camera = { model, width, height,
//! params }` or `camera_from = "<model dir>:<camera id>"`, `pixel_sigma_px`), read by the
//! Monte Carlo library's own reader ([`crashrig_mc::aim_from_keys`]) into its
//! [`FixedCamera`], so the grid runs them through [`crashrig_mc::GridBuilder::fixed_observer`]
//! exactly as `crashrig grid` does.
//!
//! The rules are those of the scenario (`docs/FIXED_CAMERAS.md`); the errors name the study
//! file, the key (`layout[i].observer[j].camera`) and its line.

use crate::Error;
use crashrig_mc::{Aim, AimKeys, FixedCamera, LensKeys};
use nalgebra::Vector3;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// The fixed-camera keys of a `[[layout.observer]]`, with their spans for error lines.
pub(crate) struct RawFixed<'a> {
    pub aim: &'a Option<Spanned<String>>,
    pub angles_deg: &'a Option<Spanned<[f64; 3]>>,
    pub look_at_mm: &'a Option<Spanned<[f64; 3]>>,
    pub camera: &'a Option<Spanned<LensKeys>>,
    pub camera_from: &'a Option<Spanned<String>>,
    pub pixel_sigma_px: &'a Option<Spanned<f64>>,
}

impl RawFixed<'_> {
    /// The span of key `name` (the observer's own span when it is not given).
    fn span_of(&self, name: &str) -> Option<Range<usize>> {
        match name {
            "aim" => self.aim.as_ref().map(Spanned::span),
            "angles_deg" => self.angles_deg.as_ref().map(Spanned::span),
            "look_at_mm" => self.look_at_mm.as_ref().map(Spanned::span),
            "camera" => self.camera.as_ref().map(Spanned::span),
            "camera_from" => self.camera_from.as_ref().map(Spanned::span),
            "pixel_sigma_px" => self.pixel_sigma_px.as_ref().map(Spanned::span),
            _ => None,
        }
    }
}

/// Where errors point: the study file, its text, the observer's key prefix and span.
pub(crate) struct Site<'a> {
    pub path: &'a Path,
    pub text: &'a str,
    pub dir: &'a Path,
    pub prefix: String,
    pub span: Range<usize>,
}

/// `None` for an aimed observer (`aim` absent or `"point"`; the fixed keys are then errors),
/// the fixed camera for `aim = "fixed"`.
pub(crate) fn fixed_from_raw(
    site: &Site<'_>,
    raw: &RawFixed<'_>,
    position: &Vector3<f64>,
) -> Result<Option<FixedCamera>, Error> {
    let keys = AimKeys {
        aim: raw.aim.as_ref().map(|a| a.get_ref().as_str()),
        angles_deg: raw.angles_deg.as_ref().map(|v| *v.get_ref()),
        look_at_mm: raw.look_at_mm.as_ref().map(|v| *v.get_ref()),
        camera: raw.camera.as_ref().map(Spanned::get_ref),
        camera_from: raw.camera_from.as_ref().map(|v| v.get_ref().as_str()),
        pixel_sigma_px: raw.pixel_sigma_px.as_ref().map(|v| *v.get_ref()),
    };
    match crashrig_mc::aim_from_keys(&keys, &site.prefix, position, site.dir) {
        Ok(Aim::Point) => Ok(None),
        Ok(Aim::Fixed(f)) => Ok(Some(*f)),
        Err(e) => {
            // The library names the key `{prefix}.{name}` and says what is wrong after it.
            let key = e.key().unwrap_or(&site.prefix).to_string();
            let name = key.rsplit('.').next().unwrap_or_default();
            let text = crashrig_input::message::error_line(&e);
            let message = text
                .strip_prefix(&format!("`{key}`: "))
                .unwrap_or(&text)
                .to_string();
            let span = raw.span_of(name).unwrap_or_else(|| site.span.clone());
            Err(Error::Key {
                path: site.path.to_path_buf(),
                line: Some(crashrig_input::location::line_of(site.text, span.start)),
                key,
                message,
            })
        }
    }
}
