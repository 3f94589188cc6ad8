//! The integration tests of crashrig-frames, one test binary (`cargo test -p crashrig-frames --test tests`; a filter such as `dir::` runs one file).

mod dir;
mod goldens;
mod robust;
