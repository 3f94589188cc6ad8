//! Integration tests of crashrig-pose: exact recovery on noise-free synthetic data, robustness,
//! Jacobians against finite differences, first-order covariance against the empirical spread,
//! and goldens from pycolmap's estimators.

#[path = "pose/absolute.rs"]
mod absolute;
#[path = "pose/golden.rs"]
mod golden;
#[path = "pose/relative.rs"]
mod relative;
#[path = "pose/scene.rs"]
mod scene;
