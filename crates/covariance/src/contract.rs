//! The JSON document of `crashrig covariance` (what `measure --a-covariance` reads) as serde
//! structs: [`CovarianceDocument`], built by [`crate::CovarianceResult::document`].
//!
//! Fields are declared in the document's key order (alphabetical, as serde_json writes an
//! object), so serialising a struct directly and serialising
//! [`crate::CovarianceResult::to_json`] give the same bytes; a non-finite number is `null`.

use serde::Serialize;
use std::collections::BTreeMap;

/// `crashrig covariance --json` / `a_covariance.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CovarianceDocument {
    /// Control points observed (used for the datum).
    pub control_points: usize,
    /// Per epoch: centre and σ of A's pose.
    pub epoch_sigmas: Vec<EpochSigmas>,
    /// Per epoch name: A's 6×6 covariance in the contract's units (mm, deg), by rows.
    pub epochs: BTreeMap<String, [[f64; 6]; 6]>,
    /// Frames (pose unknowns) in the system.
    pub frames: usize,
    /// Which intrinsics were marginalised (`all`, `colmap`, `fixed`).
    pub intrinsics: &'static str,
    /// The joint covariance of all epochs.
    pub joint: JointCovariance,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// Observations used.
    pub observations: usize,
    /// Unknowns.
    pub parameters: usize,
    /// The pixel σ used, px.
    pub pixel_sigma_px: f64,
    /// Points left out because they lie on the projection centre of an image observing them;
    /// absent when there is none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub points_at_camera_centre: Vec<PointAtCentre>,
    /// Points of the model left out.
    pub points_left_out: usize,
    /// Redundancy `2·observations − parameters`.
    pub redundancy: i64,
    /// The a-posteriori σ̂₀ of the residuals, px (`null` when undefined).
    pub sigma0_px: Option<f64>,
}

/// One entry of [`CovarianceDocument::epoch_sigmas`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EpochSigmas {
    /// The image of camera A.
    pub image: String,
    /// The epoch name.
    pub name: String,
    /// A's projection centre, mm.
    pub position_mm: [f64; 3],
    /// σ of ω φ κ, degrees.
    pub sigma_angles_deg: [f64; 3],
    /// σ of the centre, mm.
    pub sigma_position_mm: [f64; 3],
}

/// One entry of [`CovarianceDocument::points_at_camera_centre`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointAtCentre {
    /// The images on whose projection centre the point lies.
    pub images: Vec<String>,
    /// The point.
    #[serde(rename = "point3D_id")]
    pub point3d_id: u64,
}

/// [`CovarianceDocument::joint`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointCovariance {
    /// The 6n × 6n covariance (mm, deg), by rows, epochs in [`Self::epochs`] order.
    pub covariance_tangent: Vec<Vec<f64>>,
    /// The epoch names in order.
    pub epochs: Vec<String>,
}
