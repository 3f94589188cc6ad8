//! The integration tests of crashrig-rig, one test binary (`cargo test -p crashrig-rig --test tests`; a filter such as `simulated::` runs one file).

mod sem_coverage;
mod sem_pooled;
mod simulated;
