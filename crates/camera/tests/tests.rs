//! The integration tests of crashrig-camera, one test binary (`cargo test -p crashrig-camera --test tests`; a filter such as `conformance::` runs one file).

mod conformance;
mod goldens;
