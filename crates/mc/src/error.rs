//! The error type of `crashrig-mc`: scenario problems name the offending key.

use std::path::PathBuf;

/// Everything that can go wrong while reading a scenario or running a study.
///
/// Scenario errors name the TOML key in dotted form with array indices, e.g.
/// `camera[2].sigma_angles_deg` or `grid.observer[0].position_mm`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The scenario file could not be read.
    #[error("{}: cannot read", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// TOML syntax or type error (line and column are 1-based).
    #[error("{}:{line}:{column}: {message}", path.display())]
    Toml {
        /// The file (`<string>` when parsed from memory).
        path: PathBuf,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// The TOML parser's description.
        message: String,
    },
    /// A value is out of its allowed range (negative σ, NaN, zero count, …).
    #[error("`{key}`: {problem}")]
    Invalid {
        /// Dotted key of the value, e.g. `camera[1].sigma_position_mm`.
        key: String,
        /// What is wrong.
        problem: &'static str,
    },
    /// A value is beyond a documented bound (`crashrig_mc::limits`) or has the wrong number of
    /// elements.
    #[error("`{key}`: {problem}")]
    Bound {
        /// Dotted key of the value.
        key: String,
        /// What is wrong, with the bound.
        problem: String,
    },
    /// The nominal geometry of every grid point is degenerate (rays nearly parallel).
    #[error(
        "`grid.observer`: every grid point is seen under an intersection angle below {min_deg}° (largest: {largest_deg:.3e}°); move the observers apart"
    )]
    AllDegenerate {
        /// The threshold (degrees).
        min_deg: f64,
        /// The largest intersection angle over the grid (degrees).
        largest_deg: f64,
    },
    /// Two cameras share a name.
    #[error("`{key}`: duplicate camera name `{name}`")]
    DuplicateName {
        /// Key of the second occurrence.
        key: String,
        /// The repeated name.
        name: String,
    },
    /// A `parent` or `sigma_from` names no camera.
    #[error("`{key}`: unknown camera `{name}`")]
    UnknownCamera {
        /// Key of the reference, e.g. `camera[1].parent`.
        key: String,
        /// The missing name.
        name: String,
    },
    /// The parent links form a cycle.
    #[error("`camera.parent`: the parent links form a cycle through {cameras:?}")]
    Cycle {
        /// Names of the cameras on the cycle.
        cameras: Vec<String>,
    },
    /// A grid study needs at least two observers.
    #[error("`grid.observer`: at least two observers are needed, found {found}")]
    TooFewObservers {
        /// Number of observers given.
        found: usize,
    },
    /// The command needs a `[grid]` table and the scenario has none.
    #[error("`grid`: the scenario has no [grid] table")]
    NoGrid,
    /// An observer sits on a grid point (it cannot aim at itself).
    #[error("`{key}`: observer is at grid point ({:.3}, {:.3}, {:.3}) mm", point[0], point[1], point[2])]
    ObserverAtGridPoint {
        /// Key of the observer, e.g. `grid.observer[0]`.
        key: String,
        /// The grid point (mm).
        point: [f64; 3],
    },
    /// An observer would look straight up or down at a grid point (roll undefined).
    #[error("`{key}`: observer looks vertically at grid point ({:.3}, {:.3}, {:.3}) mm; the no-roll aim is undefined", point[0], point[1], point[2])]
    VerticalAim {
        /// Key of the observer.
        key: String,
        /// The grid point (mm).
        point: [f64; 3],
    },
    /// The nominal forward intersection at a grid point is degenerate (rays nearly parallel).
    #[error("grid point ({:.3}, {:.3}, {:.3}) mm: the observer rays are (nearly) parallel", point[0], point[1], point[2])]
    DegenerateIntersection {
        /// The grid point (mm).
        point: [f64; 3],
    },
    /// A camera's world orientation is at gimbal lock (φ = ±90°): ω and κ σ are undefined.
    #[error("camera `{name}`: world orientation at gimbal lock (φ = ±90°)")]
    GimbalLock {
        /// The camera.
        name: String,
    },
    /// A `covariance_tangent` (or a propagated covariance) is not a valid covariance.
    #[error("`{key}`: {problem}")]
    Covariance {
        /// Dotted key of the matrix, e.g. `camera[1].covariance_tangent`.
        key: String,
        /// What is wrong with it.
        problem: crashrig_geometry::uncertain::CovarianceProblem,
    },
    /// A JSON result referenced by `from = "…"` (or read by
    /// [`crate::reference::link_from_result_json`]) is missing, unreadable, of the wrong kind
    /// or lacks a field.
    #[error("{}{}: {problem}", key_prefix(key.as_deref()), file.display())]
    Reference {
        /// Dotted scenario key of the reference (`camera[1].from`), when read for a scenario.
        key: Option<String>,
        /// The referenced file.
        file: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A correlated observer does not stand at its chain camera's nominal position.
    #[error(
        "`{key}`: with `correlated = true` the observer takes camera `{camera}`'s draw and must stand at its nominal position ({:.3}, {:.3}, {:.3}) mm; it is {distance_mm:.3} mm away (the chain and the grid share one frame)",
        nominal_mm[0], nominal_mm[1], nominal_mm[2]
    )]
    ObserverOffChain {
        /// Key of the observer's position, e.g. `grid.observer[0].position_mm`.
        key: String,
        /// The chain camera.
        camera: String,
        /// Its nominal world position (mm).
        nominal_mm: [f64; 3],
        /// Distance between the observer and that position (mm).
        distance_mm: f64,
    },
    /// A fixed observer's camera model is invalid (unknown model name, wrong parameter
    /// count, invalid parameter).
    #[error("`{key}`")]
    Camera {
        /// Key of the camera, e.g. `grid.observer[0].camera`.
        key: String,
        /// The camera crate's description.
        #[source]
        source: crashrig_camera::Error,
    },
    /// `camera_from` names a COLMAP model that cannot be read.
    #[cfg(feature = "scenario")]
    #[error("`{key}`")]
    ColmapModel {
        /// Key, e.g. `grid.observer[0].camera_from`.
        key: String,
        /// The COLMAP reader's error.
        #[source]
        source: Box<crashrig_colmap::Error>,
    },
    /// `camera_from` names a camera id the model does not hold.
    #[error("`{key}`: the COLMAP model {} has no camera {camera_id}", dir.display())]
    NoSuchCamera {
        /// Key, e.g. `grid.observer[0].camera_from`.
        key: String,
        /// The model directory.
        dir: PathBuf,
        /// The missing id.
        camera_id: u32,
    },
    /// An error of the geometry layer.
    #[error(transparent)]
    Geometry(#[from] crashrig_geometry::Error),
    /// The run's [`crashrig_stats::progress::Monitor`] cancelled it: nothing was returned.
    #[error(transparent)]
    Cancelled(#[from] crashrig_stats::progress::Cancelled),
    /// A scenario error located in its file: the line of the offending key.
    #[error("{}:{line}", path.display())]
    Located {
        /// The scenario file.
        path: PathBuf,
        /// 1-based line of the key (or of its table header).
        line: usize,
        /// The error.
        #[source]
        source: Box<Error>,
    },
}

impl Error {
    /// The dotted scenario key the error is about, if any.
    pub fn key(&self) -> Option<&str> {
        match self {
            Error::Invalid { key, .. }
            | Error::Bound { key, .. }
            | Error::DuplicateName { key, .. }
            | Error::UnknownCamera { key, .. }
            | Error::ObserverAtGridPoint { key, .. }
            | Error::VerticalAim { key, .. }
            | Error::Covariance { key, .. }
            | Error::ObserverOffChain { key, .. } => Some(key),
            Error::Camera { key, .. } | Error::NoSuchCamera { key, .. } => Some(key),
            #[cfg(feature = "scenario")]
            Error::ColmapModel { key, .. } => Some(key),
            Error::Reference { key, .. } => key.as_deref(),
            Error::Cycle { .. } => Some("camera"),
            Error::TooFewObservers { .. } | Error::AllDegenerate { .. } => Some("grid.observer"),
            Error::NoGrid => Some("grid"),
            _ => None,
        }
    }
}

fn key_prefix(key: Option<&str>) -> String {
    key.map_or_else(String::new, |k| format!("`{k}`: "))
}
