//! The integration tests of crashrig-place, one test binary (`cargo test -p crashrig-place --test tests`; a filter such as `place::` runs one file).

mod place;
mod shard;
