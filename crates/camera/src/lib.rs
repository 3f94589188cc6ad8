//! Camera models for crashrig: every COLMAP model (ids 0–17) and OpenCV's full pinhole model,
//! with projection, exact Jacobians and convergence-checked unprojection.
//!
//! # Conventions
//! - **Camera frame**: x right, y down, z forward (optical axis), as in COLMAP and OpenCV. A
//!   point in the camera frame is `p_cam` (any length unit: projection is scale invariant).
//! - **Normalized coordinates** are (x/z, y/z) of the undistorted ray; a **bearing** is the
//!   unit ray (`cam_ray_from_img`).
//! - **Pixel conventions**:
//!   - COLMAP ([`Camera`]): the upper-left image corner is (0, 0), the centre of the upper-left
//!     pixel is **(0.5, 0.5)**, the lower-right corner is (width, height).
//!   - OpenCV ([`OpenCvCamera`]): the centre of the upper-left pixel is **(0, 0)**.
//!   - Hence `x_colmap = x_opencv + 0.5` for pixels *and* principal points
//!     ([`colmap_from_opencv_pixel`], [`opencv_from_colmap_pixel`]); focal lengths and
//!     distortion coefficients are the same in both.
//! - **Cheirality** (as COLMAP 4.2): pinhole- and fisheye-class models, EUCM and
//!   [`OpenCvCamera`] reject points with z < ε = `f64::EPSILON`
//!   ([`ProjectionReject::BehindCamera`]); the division models and EQUIRECTANGULAR have no
//!   such check (the latter covers the whole sphere and rejects only the zero vector).
//! - **Unprojection** ([`Camera::cam_from_img`]) is closed form where COLMAP has one and
//!   otherwise COLMAP's Newton iteration (trust region, ‖step‖² < 1e-10, ≤ 100 iterations);
//!   not converging is an [`UndistortError`], never a silent value. The result carries the
//!   iteration count and last step norm ([`Undistorted`]).
//! - **Jacobians** follow the `dx_<output>_<wrt>` grammar and are exact: each model is
//!   written once over a private scalar trait and differentiated by forward-mode dual
//!   numbers (the chain rule applied operation by operation, as COLMAP does with Ceres jets),
//!   and checked against central differences in `tests/conformance.rs`.
//! - Parameters are in COLMAP's order ([`ModelId::param_names`]), focal lengths and principal
//!   point in pixels; angles (FOV ω, OpenCV tilt τ) in radians.
//!
//! # Entry points
//! - [`ModelId`]: the COLMAP model table (ids, names, parameter counts and names).
//! - [`Camera`]: a validated COLMAP camera; [`Camera::img_from_cam`],
//!   [`Camera::dx_img_from_cam_point`], [`Camera::dx_img_from_params`],
//!   [`Camera::cam_from_img`], [`Camera::cam_ray_from_img`].
//! - [`OpenCvCamera`]: k1–k6, p1 p2, s1–s4, τx τy in OpenCV's pixel convention, with
//!   [`OpenCvCamera::from_colmap`] / [`OpenCvCamera::to_colmap`].
//! - [`Error`] (construction), [`ProjectionReject`] and [`UndistortError`] (partial maps).
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_camera::{Camera, ModelId, OpenCvCamera, ProjectionReject, colmap_from_opencv_pixel};
//! use nalgebra::{Vector2, Vector3};
//!
//! // COLMAP's OPENCV model: fx, fy, cx, cy, k1, k2, p1, p2 (COLMAP pixel convention).
//! let cam = Camera::new(
//!     ModelId::from_name("OPENCV")?,
//!     1024,
//!     768,
//!     vec![1000.0, 1000.0, 512.0, 384.0, -0.1, 0.01, 1e-3, -5e-4],
//! )?;
//! let p_cam = Vector3::new(0.2, -0.1, 2.0); // 2 units in front of the camera
//! let px = cam.img_from_cam(&p_cam).expect("in front of the camera");
//!
//! // Back to normalized coordinates by COLMAP's Newton iteration, with a convergence report.
//! let und = cam.cam_from_img(&px).expect("converges");
//! assert!((und.normalized - Vector2::new(0.1, -0.05)).norm() < 1e-9);
//! assert!(und.iterations >= 1);
//!
//! // Exact Jacobians: 2×3 with respect to the point, 2×8 with respect to the parameters.
//! let j_point = cam.dx_img_from_cam_point(&p_cam).expect("in front");
//! let j_params = cam.dx_img_from_params(&p_cam).expect("in front");
//! assert_eq!((j_params.nrows(), j_params.ncols()), (2, 8));
//! assert!(j_point[(0, 0)] > 0.0);
//!
//! // Behind the camera is a typed reject, not a panic or a garbage pixel.
//! assert_eq!(cam.img_from_cam(&Vector3::new(0.0, 0.0, -1.0)), Err(ProjectionReject::BehindCamera));
//!
//! // The same camera in OpenCV's convention: the principal point moves by −0.5 px.
//! let cv = OpenCvCamera::from_colmap(&cam)?;
//! assert_eq!((cv.cx, cv.cy), (511.5, 383.5));
//! let px_cv = cv.img_from_cam(&p_cam).expect("in front");
//! assert!((colmap_from_opencv_pixel(&px_cv) - px).norm() < 1e-9);
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

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
