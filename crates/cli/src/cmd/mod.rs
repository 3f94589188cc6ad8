//! One module per subcommand; each owns its clap `Args` and a `run` function.

pub mod bootstrap;
pub mod calibrate;
pub mod colmap;
pub mod covariance;
pub mod export;
pub mod frames;
pub mod grid;
pub mod measure;
pub mod measure_options;
pub mod merge;
pub mod paper;
pub mod place;
pub mod propagate;
pub mod study;
pub mod track;
