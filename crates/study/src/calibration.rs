//! Rig calibration from a COLMAP model: epochs → link `A_from_B` with its tangent covariance.
