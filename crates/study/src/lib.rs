//! The crash-test rig study as a library (work in progress: modules are being filled in).
//!
//! Each step is a function with typed inputs and a typed result; the `crashrig` binary only
//! turns arguments into a configuration, calls one function and prints the result.
//! - [`calibration`]: COLMAP model → epochs → the rig link `A_from_B` with its covariance.
//! - [`tie`]: database + model → correspondences → bootstrap → the tie link with its covariance.
#![deny(missing_docs)]

pub mod calibration;
pub mod correspondences;
pub mod tie;
