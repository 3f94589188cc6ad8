//! The crash-test rig study as a library.
//!
//! Each step is a function with typed inputs and a typed result; the `crashrig` binary only
//! turns arguments into a configuration, calls one function and prints the result.
//! - [`contract`]: the JSON documents (`calibrate --json`, `results.json`) as serde structs;
//! - [`study_file`]: the study file (TOML) → a validated [`Study`];
//! - [`calibration`]: COLMAP model → epochs → the rig link `A_from_B` with its covariance;
//! - [`tie`]: database + model → correspondences → bootstrap → the tie link with its covariance;
//! - [`pipeline`]: [`run_study`] — calibration, tie, the chain outward → inward → tie, and one
//!   grid study per layout, with a one-at-a-time sensitivity;
//! - [`grid_run`]: [`run_grid`], the library entry of `crashrig grid`;
//! - [`propagate_run`]: [`run_propagate`], the library entry of `crashrig propagate`;
//! - [`merge`]: [`merge::merge_shards`], the library entry of `crashrig merge`;
//! - [`study_run`]: [`study_run::run_to_dir`], the library entry of `crashrig study` (run +
//!   every output file);
//! - [`grids`]: grid summaries, `grid.csv` and heat maps;
//! - [`fixed_maps`]: layouts with fixed observers (`aim = "fixed"`): coverage and
//!   field-of-view footprints;
//! - [`measure_step`]: `[measure]` — a test sequence measured with the study's own link;
//! - [`length_report`]: `[measure] scale_bars` — the length check's files, verdict box and
//!   report subsection;
//! - [`quality`]: calibration quality — reprojection residuals per camera and the split-half
//!   check of the link;
//! - [`quality_report`]: the calibration's verdict box and the report section "Calibration
//!   quality";
//! - [`report`]: `results.json`, every step's files and the self-contained `report.html`.
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

pub mod calibration;
pub mod contract;
pub mod correspondences;
pub mod epochs;
mod error;
pub mod fixed_maps;
mod fixed_observer;
pub mod grid_run;
pub mod grid_shard;
pub mod grids;
pub mod html;
pub mod kinematics_report;
pub mod length_report;
pub mod measure_step;
pub mod merge;
pub mod paper_study;
pub mod pipeline;
pub mod propagate_run;
pub mod quality;
pub mod quality_report;
pub mod report;
pub mod study_file;
pub mod study_run;
pub mod tie;

pub use error::{BundledError, Error, StepError};
pub use grid_run::{GridConfig, GridRun, run_grid, run_grid_scenario};
pub use pipeline::{Options, StudyResult, run_study};
pub use propagate_run::{PropagateConfig, PropagateRun, run_propagate};
pub use study_file::Study;
