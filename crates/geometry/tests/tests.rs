//! Integration tests of crashrig-geometry (they use crashrig-testkit, hence not in `src`).

mod angles;
mod conventions;
mod goldens;
mod look_at;
mod mean;
mod opk;
mod quat;
mod se3;
mod so3;
mod triangulate;
mod umeyama;
mod uncertain;
