//! The integration tests of crashrig-mc, one test binary (`cargo test -p crashrig-mc --test tests`; a filter such as `fixed_reference::` runs one file).

mod fixed_reference;
mod uncertain;
