//! The integration tests of crashrig-measure, one test binary (`cargo test -p crashrig-measure --test tests`; a filter such as `filter::` runs one file).

mod filter;
mod frame_times;
mod isomme;
mod joint;
mod kinematics;
mod length;
mod observation_sigma;
mod pixel_check;
mod progress;
mod sequence;
mod shard;
