//! The raw TOML document: the serde mirror of the study file, with the errors of its syntax,
//! its unknown sections and its vectors of the wrong length.

use super::line_of;
use crate::Error;
use serde::Deserialize;
use std::path::Path;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Raw {
    pub(super) seed: Option<u64>,
    pub(super) samples: Option<Spanned<i64>>,
    pub(super) chain_samples: Option<Spanned<i64>>,
    pub(super) reference: Option<Spanned<String>>,
    pub(super) calibration: Option<Spanned<RawCalibration>>,
    pub(super) tie: Option<Spanned<RawTie>>,
    pub(super) outward: Option<Spanned<RawPose>>,
    #[serde(default)]
    pub(super) layout: Vec<Spanned<RawLayout>>,
    pub(super) measure: Option<Spanned<RawMeasure>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMeasure {
    pub(super) model: Option<Spanned<String>>,
    pub(super) camera_a: Option<Spanned<String>>,
    pub(super) camera_b: Option<Spanned<String>>,
    pub(super) camera_c: Option<Spanned<String>>,
    pub(super) observations: Option<Spanned<String>>,
    pub(super) mm_per_unit: Option<Spanned<f64>>,
    pub(super) sigma_a_position_mm: Option<Spanned<[f64; 3]>>,
    pub(super) sigma_a_angles_deg: Option<Spanned<[f64; 3]>>,
    pub(super) a_covariance: Option<Spanned<String>>,
    pub(super) a_model: Option<Spanned<String>>,
    pub(super) a_control_points: Option<Spanned<String>>,
    pub(super) a_pixel_sigma_px: Option<Spanned<f64>>,
    pub(super) a_intrinsics: Option<Spanned<String>>,
    /// A number (px) or `"estimate"`.
    pub(super) pixel_sigma_px: Option<Spanned<toml::Value>>,
    pub(super) samples: Option<Spanned<i64>>,
    pub(super) reference_epoch: Option<String>,
    pub(super) frame_rate_hz: Option<Spanned<f64>>,
    pub(super) frame_times: Option<Spanned<String>>,
    pub(super) threshold_mm: Option<Spanned<f64>>,
    pub(super) max_reprojection_px: Option<Spanned<f64>>,
    pub(super) cfc: Option<Spanned<i64>>,
    pub(super) cfc_standard: Option<Spanned<String>>,
    pub(super) sync_sigma_ms: Option<Spanned<f64>>,
    pub(super) scale_bars: Option<Spanned<String>>,
    pub(super) mpe_mm: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCalibration {
    pub(super) model: Option<Spanned<String>>,
    pub(super) camera_a: Option<Spanned<String>>,
    pub(super) camera_b: Option<Spanned<String>>,
    pub(super) scale_points: Option<Spanned<Vec<u64>>>,
    pub(super) scale_length_mm: Option<Spanned<f64>>,
    pub(super) mm_per_unit: Option<Spanned<f64>>,
    pub(super) max_lag: Option<Spanned<i64>>,
    pub(super) refine: Option<bool>,
    pub(super) accept_rig_constrained: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTie {
    pub(super) database: Option<Spanned<String>>,
    pub(super) model: Option<Spanned<String>>,
    pub(super) image_a: Option<Spanned<String>>,
    pub(super) image_b: Option<Spanned<String>>,
    pub(super) method: Option<Spanned<String>>,
    pub(super) iterations: Option<Spanned<i64>>,
    pub(super) mm_per_unit: Option<Spanned<f64>>,
    pub(super) max_error_px: Option<Spanned<f64>>,
    pub(super) base_mm: Option<Spanned<f64>>,
    pub(super) resample: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPose {
    pub(super) position_mm: Option<Spanned<[f64; 3]>>,
    pub(super) angles_deg: Option<Spanned<[f64; 3]>>,
    pub(super) sigma_position_mm: Option<Spanned<[f64; 3]>>,
    pub(super) sigma_angles_deg: Option<Spanned<[f64; 3]>>,
    pub(super) covariance_tangent: Option<Spanned<Vec<Vec<f64>>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLayout {
    pub(super) name: Option<Spanned<String>>,
    pub(super) description: Option<String>,
    pub(super) x_mm: Option<Spanned<[f64; 3]>>,
    pub(super) y_mm: Option<Spanned<[f64; 3]>>,
    pub(super) z_mm: Option<Spanned<[f64; 3]>>,
    pub(super) threshold_mm: Option<Spanned<f64>>,
    pub(super) pixel_sigma_px: Option<Spanned<f64>>,
    pub(super) focal_px: Option<Spanned<f64>>,
    pub(super) correlated: Option<bool>,
    #[serde(default)]
    pub(super) observer: Vec<Spanned<RawObserver>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawObserver {
    pub(super) name: Option<String>,
    pub(super) position_mm: Option<Spanned<[f64; 3]>>,
    pub(super) from: Option<Spanned<String>>,
    pub(super) sigma_position_mm: Option<Spanned<[f64; 3]>>,
    pub(super) sigma_angles_deg: Option<Spanned<[f64; 3]>>,
    pub(super) covariance_tangent: Option<Spanned<Vec<Vec<f64>>>>,
    pub(super) aim: Option<Spanned<String>>,
    pub(super) angles_deg: Option<Spanned<[f64; 3]>>,
    pub(super) look_at_mm: Option<Spanned<[f64; 3]>>,
    pub(super) camera: Option<Spanned<crashrig_mc::LensKeys>>,
    pub(super) camera_from: Option<Spanned<String>>,
    pub(super) pixel_sigma_px: Option<Spanned<f64>>,
}

/// Keys of a study whose value is exactly three numbers (serde would silently drop a fourth).
const STUDY_THREE_VECTORS: &[&str] = &[
    "position_mm",
    "angles_deg",
    "sigma_position_mm",
    "sigma_angles_deg",
    "look_at_mm",
    "sigma_a_position_mm",
    "sigma_a_angles_deg",
    "x_mm",
    "y_mm",
    "z_mm",
];

/// The first 3-vector key of `text` whose array does not hold exactly three values:
/// (dotted key, 1-based line, length).
fn wrong_length_vector(text: &str) -> Option<(String, usize, usize)> {
    use toml::de::{DeTable, DeValue};
    fn walk(t: &DeTable<'_>, prefix: &str, text: &str) -> Option<(String, usize, usize)> {
        for (k, v) in t.iter() {
            let leaf = k.get_ref().as_ref();
            let key = if prefix.is_empty() {
                leaf.to_string()
            } else {
                format!("{prefix}.{leaf}")
            };
            match v.get_ref() {
                DeValue::Table(t) => {
                    if let Some(found) = walk(t, &key, text) {
                        return Some(found);
                    }
                }
                DeValue::Array(a) => {
                    for (i, e) in a.iter().enumerate() {
                        if let DeValue::Table(t) = e.get_ref()
                            && let Some(found) = walk(t, &format!("{key}[{i}]"), text)
                        {
                            return Some(found);
                        }
                    }
                    if STUDY_THREE_VECTORS.contains(&leaf) && a.len() != 3 {
                        return Some((key, line_of(text, v.span().start), a.len()));
                    }
                }
                _ => {}
            }
        }
        None
    }
    let doc = DeTable::parse(text).ok()?;
    walk(doc.get_ref(), "", text)
}

/// The sections a study file may have (`[name]`, `[[layout]]`).
const SECTIONS: [&str; 5] = ["calibration", "tie", "outward", "layout", "measure"];

/// A top-level table or array of tables that is not a known section (a misspelled
/// `[calibraton]`): an error naming it as an unknown section at its header's line, with the
/// nearest known section (serde alone would call it an "unknown field").
fn unknown_section(text: &str, path: &Path) -> Option<Error> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(text).ok()?;
    doc.get_ref().iter().find_map(|(k, v)| {
        let name = k.get_ref().as_ref();
        let is_section = match v.get_ref() {
            DeValue::Table(_) => true,
            DeValue::Array(a) => {
                !a.is_empty() && a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_)))
            }
            _ => false,
        };
        if !is_section || SECTIONS.contains(&name) {
            return None;
        }
        let nearest = SECTIONS
            .iter()
            .min_by_key(|s| strsim::levenshtein(s, name))
            .copied()
            .unwrap_or("calibration");
        let bracket = |n: &str| {
            if n == "layout" {
                "[[layout]]".to_string()
            } else {
                format!("[{n}]")
            }
        };
        Some(Error::Key {
            path: path.to_path_buf(),
            line: Some(line_of(text, k.span().start)),
            key: name.to_string(),
            message: format!(
                "unknown section; did you mean {}? (sections: {})",
                bracket(nearest),
                SECTIONS.map(bracket).join(", ")
            ),
        })
    })
}

/// The study text as the raw TOML document: a syntax or type error names its line, column and
/// (for a value) its key; a vector of the wrong length names its key.
pub(super) fn parse_raw(text: &str, path: &Path) -> Result<Raw, Error> {
    if let Some(e) = unknown_section(text, path) {
        return Err(e);
    }
    let raw: Raw = toml::from_str(text).map_err(|e| {
        let offset = e.span().map_or(0, |s| s.start);
        let line = line_of(text, offset);
        let col = text[..offset.min(text.len())]
            .rfind('\n')
            .map_or(offset, |p| offset - p - 1)
            + 1;
        // A type error is located at the value: name its key as every other error does.
        let message = e.message().trim();
        let message = match crashrig_input::location::toml_value_key(text, offset) {
            Some(key) => format!("`{key}`: {message}"),
            None => message.to_string(),
        };
        Error::Toml {
            path: path.to_path_buf(),
            line,
            column: col,
            message,
        }
    })?;
    if let Some((key, line, n)) = wrong_length_vector(text) {
        return Err(Error::Key {
            path: path.to_path_buf(),
            line: Some(line),
            key,
            message: format!("must have exactly 3 values, found {n}"),
        });
    }
    Ok(raw)
}
