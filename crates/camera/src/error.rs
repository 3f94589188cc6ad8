//! The error and reject types of crashrig-camera.

use crate::ModelId;

/// Errors of the camera crate: bad model ids or names, invalid parameters, unsupported models.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A COLMAP model id outside 0..=17.
    #[error("unknown COLMAP camera model id {id}")]
    UnknownModelId {
        /// The id found.
        id: i32,
    },
    /// A COLMAP model name that is not one of the 18 known names.
    #[error("unknown COLMAP camera model name {name:?}")]
    UnknownModelName {
        /// The name found.
        name: String,
    },
    /// The parameter vector has the wrong length for the model.
    #[error("camera model {} needs {expected} parameters, got {found}", model.name())]
    WrongParamCount {
        /// The model.
        model: ModelId,
        /// Number of parameters the model needs.
        expected: usize,
        /// Number of parameters given.
        found: usize,
    },
    /// A parameter is NaN, infinite, or outside the model's valid domain.
    #[error("camera model {}: invalid parameter {name} = {value}", model.name())]
    InvalidParam {
        /// The model.
        model: ModelId,
        /// COLMAP name of the parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
    },
    /// An OpenCV-model parameter is NaN, infinite, or outside its valid domain.
    #[error("OpenCV camera: invalid parameter {name} = {value}")]
    InvalidOpenCvParam {
        /// OpenCV name of the parameter (`fx`, `k3`, `tau_x`, ...).
        name: &'static str,
        /// The offending value.
        value: f64,
    },
    /// OpenCV `distCoeffs` must have 0, 4, 5, 8, 12 or 14 entries.
    #[error("OpenCV distCoeffs must have 0, 4, 5, 8, 12 or 14 entries, got {found}")]
    WrongOpenCvCoeffCount {
        /// Number of coefficients given.
        found: usize,
    },
    /// The requested operation is not implemented for this model.
    #[error("camera model {} is not supported by this operation", model.name())]
    UnsupportedModel {
        /// The model.
        model: ModelId,
    },
    /// The COLMAP model has no equivalent in OpenCV's pinhole distortion model.
    #[error("camera model {} has no OpenCV pinhole-model equivalent", model.name())]
    NoOpenCvEquivalent {
        /// The model.
        model: ModelId,
    },
    /// The OpenCV camera uses terms (k3..k6 beyond FULL_OPENCV, s1..s4, tilt) that no COLMAP model has.
    #[error("OpenCV coefficient {name} = {value} has no COLMAP equivalent")]
    NoColmapEquivalent {
        /// OpenCV name of the coefficient.
        name: &'static str,
        /// Its (non-zero) value.
        value: f64,
    },
}

/// Why a 3-D point has no image under a camera model (`img_from_cam`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ProjectionReject {
    /// The point is behind the camera or on the principal plane (z < ε, the cheirality check).
    BehindCamera,
    /// The point is outside the model's domain (division model discriminant < 0, EUCM
    /// denominator < ε, zero vector for the equirectangular model, ...).
    OutsideDomain,
    /// A component of the input point is NaN or infinite.
    NotFinite,
    /// The camera's parameters are invalid (wrong count, NaN, f ≤ 0, ...): a camera built
    /// with a struct literal instead of the validating constructor.
    InvalidParams,
    /// The model is not implemented.
    UnsupportedModel,
}

impl std::fmt::Display for ProjectionReject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self {
            Self::BehindCamera => "point is behind the camera",
            Self::OutsideDomain => "point is outside the model's domain",
            Self::NotFinite => "point is not finite",
            Self::InvalidParams => "camera parameters are invalid",
            Self::UnsupportedModel => "camera model not supported",
        };
        f.write_str(s)
    }
}

impl std::error::Error for ProjectionReject {}

/// Why a pixel could not be unprojected (`cam_from_img`).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UndistortError {
    /// The iterative undistortion did not reach ‖step‖² < 1e-10 within the iteration limit.
    #[error(
        "undistortion did not converge in {iterations} iterations (last step norm {step_norm})"
    )]
    NotConverged {
        /// Iterations run.
        iterations: usize,
        /// Norm of the last Newton step (normalized units).
        step_norm: f64,
    },
    /// The Newton system was singular (the distortion is not invertible here).
    #[error("singular undistortion Jacobian after {iterations} iterations")]
    Singular {
        /// Iterations run before the failure.
        iterations: usize,
    },
    /// The pixel maps outside the model's domain (e.g. beyond the EUCM or fisheye horizon).
    #[error("pixel is outside the model's domain")]
    OutsideDomain,
    /// A pixel coordinate is NaN or infinite.
    #[error("pixel is not finite")]
    NotFinite,
    /// The camera's parameters are invalid (built with a struct literal, not validated).
    #[error("camera parameters are invalid")]
    InvalidParams,
    /// The model is not implemented.
    #[error("camera model not supported")]
    UnsupportedModel,
}
