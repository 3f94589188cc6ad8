//! The integration tests of crashrig-tie, one test binary (`cargo test -p crashrig-tie --test tests`; a filter such as `tie::` runs one file).

mod tie;
