//! The integration tests of crashrig-grid, one test binary (`cargo test -p crashrig-grid --test tests`; a filter such as `propagate::` runs one file).

mod propagate;
mod run;
mod shard;
