//! The integration tests of crashrig-cli, one test binary (`cargo test -p crashrig-cli --test tests`; a filter such as `browser::` runs one file).

mod browser;
mod contract;
mod mc_golden;
mod measure;
mod robustness;
mod sigint_race;
mod swap;
