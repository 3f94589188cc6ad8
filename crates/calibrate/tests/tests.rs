//! The integration tests of crashrig-calibrate, one test binary (`cargo test -p crashrig-calibrate --test tests`; a filter such as `calibration_api::` runs one file).

mod calibration_api;
mod calibration_fixtures;
