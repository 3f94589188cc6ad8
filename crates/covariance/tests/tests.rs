//! The integration tests of crashrig-covariance, one test binary (`cargo test -p crashrig-covariance --test tests`; a filter such as `bundled_models::` runs one file).

mod bundled_models;
mod common;
mod degenerate;
mod ill_conditioned;
mod mc;
mod progress;
mod rule;
mod selectors;
mod synthetic;
