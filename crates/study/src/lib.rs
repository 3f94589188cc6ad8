//! The crash-test rig study as a library: a study file → calibration of the rig link, the
//! tie bootstrap, the chain propagation, one grid per layout (with a sensitivity), an optional
//! measured test sequence → a typed [`StudyResult`], `results.json` and a self-contained
//! `report.html`.
//!
//! Each step is a function with typed inputs and a typed result; the `crashrig` binary and the
//! Python module only turn arguments into a configuration, call one function and print.
//!
//! # Entry points
//! - [`Study::from_path`] / [`Study::from_toml_str`]: the study file (TOML) → a validated
//!   [`Study`] (its sections in [`study_file`]); every error names the file, key and line.
//! - [`run_study`]`(&Study, &`[`Options`]`)` → [`StudyResult`]: calibration, tie, the chain
//!   outward → inward → tie, one grid study per layout ([`LayoutResult`], drawn with
//!   `crashrig_grid`'s summaries and maps) with a one-at-a-time sensitivity, and `[measure]`.
//! - [`write_outputs`]: `results.json`, every step's files and `report.html` below a directory;
//!   [`run_to_dir`] ([`StudyRunConfig`] → [`StudyRun`]) is the library entry of
//!   `crashrig study`: run + every output file, staged and swapped in as a whole.
//! - [`contract`]: the JSON document `results.json` as serde structs.
//! - [`study_toml`] ([`PaperStudy`]): the study file of `crashrig paper`.
//!
//! The steps it orchestrates are the libraries of their commands: `crashrig-calibrate`
//! (`crashrig calibrate`: COLMAP model → epochs → the rig link with its covariance),
//! `crashrig-tie` (`crashrig bootstrap`: database + model → correspondences → bootstrap → the
//! tie link), `crashrig-grid` (grid, propagate), `crashrig-measure` (measure); the study reads
//! their typed results. `crashrig-merge` is the merge command.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```no_run
//! use crashrig_study::{Options, Study, run_study};
//! let study = Study::from_path(std::path::Path::new("my_lab/study.toml"))?;
//! let result = run_study(&study, &Options::default())?;
//! for l in &result.layouts {
//!     println!("{}: {:.0} % below {} mm", l.layout.name,
//!         100.0 * l.summary.fraction_below_threshold, l.summary.threshold_mm);
//! }
//! # Ok::<(), crashrig_study::Error>(())
//! ```
#![deny(missing_docs)]
#![warn(unnameable_types)]

pub mod contract;
mod error;
mod files;
mod first_screen;
mod fixed_observer;
mod html;
mod kinematics_report;
mod length_report;
mod measure_step;
mod paper_study;
mod pipeline;
mod pixel_report;
mod quality_report;
mod report;
pub mod study_file;
mod study_run;
mod verdict;

pub use error::Error;
pub use measure_step::{MeasureResult, MeasureSummary};
pub use paper_study::{Inputs, PaperStudy, study_toml};
pub use pipeline::{ChainPose, LayoutResult, Options, Progress, StudyResult, run_study};
pub use report::{Provenance, write_outputs};
pub use study_file::Study;
pub use study_run::{StepLine, StudyRun, StudyRunConfig, run_to_dir};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
