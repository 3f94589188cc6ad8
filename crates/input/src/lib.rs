//! What users give crashrig, read at the edge: the one bounded reader of every input file, the
//! options the front ends share (how a message spells them, the scale of a model), where in a
//! text a problem is, and the reader of the link a `calibrate` / `bootstrap` result reports.
//!
//! The engines (`crashrig-mc` without its `scenario` feature, `crashrig-bootstrap`,
//! `crashrig-rig`, …) do not need this crate; the readers of user files (COLMAP models,
//! scenarios, studies, measure's inputs) and the front ends (CLI, Python) do.
//!
//! # Modules
//! - [`mod@file`]: [`file::read_limited`] / [`file::read_text_limited`], a regular file within a
//!   size limit (`/dev/zero`, FIFOs and directories are refused before they are opened), and
//!   the limits of each kind of file (`docs/LIMITS.md`); text that is not UTF-8 is a
//!   [`file::NotUtf8`] naming the line and column of its first bad byte.
//! - [`options`]: [`options::Spelling`] (`--mm-per-unit` for the CLI, `mm_per_unit` for
//!   Python), the model-scale range and [`options::ScaleOptions`] (a factor or a scale bar).
//! - [`location`]: [`location::line_of`], [`location::line_col_of`] and
//!   [`location::toml_value_key`], the line, column and key an error names.
//! - [`message`]: [`message::error_line`], the one line a front end prints for an error and
//!   its sources.
//! - `result_json` (feature `json`): `link_from_result_value`, the uncertain link `A_from_B`
//!   of a `calibrate --json` / `bootstrap --json` result, the one reader of those documents.
//!
//! # Features
//! - `json` (off by default): the `result_json` module (serde_json, and `crashrig-geometry` for
//!   the link's `UncertainPose`). Without it the crate depends on `thiserror` alone.
//!
//! # Example
//! A scenario file read within its size limit, an option checked as the CLI spells it, and a
//! parser's error located by line and key.
//! ```
//! use crashrig_input::{file, location, options::{ScaleOptions, Spelling}};
//!
//! let dir = std::env::temp_dir().join(format!("crashrig-input-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let path = dir.join("scenario.toml");
//! std::fs::write(&path, "[grid]\nthreshold_mm = \"5\"\n")?;
//! let text = file::read_text_limited(&path, file::MAX_TOML_BYTES)?;
//! // A TOML parser reports the string at its offset; the message names line 2 and the key.
//! let at = text.find('"').unwrap();
//! assert_eq!(location::line_of(&text, at), 2);
//! assert_eq!(location::toml_value_key(&text, at), Some("threshold_mm"));
//!
//! let scale = ScaleOptions { mm_per_unit: Some(0.0), ..ScaleOptions::default() };
//! let e = scale.given(Spelling::Flag).unwrap_err();
//! assert_eq!(e.to_string(), "--mm-per-unit: must be a number from 1e-9 to 1e9 mm per model unit");
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), std::io::Error>(())
//! ```
#![deny(missing_docs)]

mod error;
pub mod file;
pub mod location;
pub mod message;
pub mod options;
#[cfg(feature = "json")]
pub mod result_json;

pub use error::Error;

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
