//! Camera models for crashrig: all COLMAP models (ids 0–17) and the full OpenCV model.
//!
//! # Conventions
//! - COLMAP pixel convention: the upper-left image corner is (0, 0) and the centre of the
//!   upper-left pixel is (0.5, 0.5).
//!
//! # Entry points
//! - [`ModelId`], [`Camera`].
//!
//! # Example
//! ```
//! use crashrig_camera::{Camera, ModelId};
//! let cam = Camera::new(ModelId::from_name("PINHOLE")?, 640, 480, vec![500.0, 500.0, 320.0, 240.0])?;
//! assert_eq!(cam.model.id(), 1);
//! # Ok::<(), crashrig_camera::Error>(())
//! ```
#![deny(missing_docs)]

mod dual;
mod error;
mod model;
mod opencv;
mod project;

pub use error::{Error, ProjectionReject, UndistortError};
pub use model::{Camera, ModelId};
pub use opencv::{
    COLMAP_MINUS_OPENCV_PIXEL, OPENCV_UNDISTORT_MAX_ITERATIONS, OPENCV_UNDISTORT_STEP_SQ_TOL,
    OpenCvCamera, colmap_from_opencv_pixel, opencv_from_colmap_pixel,
};
pub use project::{COLMAP_UNDISTORT_MAX_ITERATIONS, COLMAP_UNDISTORT_STEP_SQ_TOL, Undistorted};
