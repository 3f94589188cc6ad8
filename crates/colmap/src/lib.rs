//! Faithful reader and writer of COLMAP sparse models (3.x three-file and ≥ 3.12 five-file,
//! binary and text) and reader of COLMAP's `database.db`.
//!
//! # Conventions
//! - Record types mirror the files ([`CameraRecord`], [`Rig`], [`Frame`], [`Image`],
//!   [`Point3D`]); poses are stored as read ([`RawPose`]: `qw qx qy qz tx ty tz`, `b_from_a`,
//!   model units) so that a model read and written again is bit-identical. Normalized
//!   [`crashrig_geometry::Rigid3`] poses come from [`RawPose::to_rigid`] and
//!   [`Reconstruction::image_cam_from_world`].
//! - An image pose is `cam_from_world` (`x_cam = R·x_world + t`); with rigs and frames it is
//!   `sensor_from_rig ∘ rig_from_world`, as COLMAP computes it (the pose stored in `images.*`
//!   is then ignored, like COLMAP does).
//! - Pixel coordinates follow COLMAP: the upper-left image corner is (0, 0).
//! - Ids are COLMAP's: `u32` for cameras, images, rigs and frames, `u64` for 3-D points.
//! - Invariants checked after every read: unique ids; images, rigs and frames name existing
//!   cameras, rigs and images; every image is in exactly one frame whose rig holds its camera;
//!   tracks name existing images and valid point2D indices whose `point3D_id` is the track's
//!   point, and every observation is in its point's track. A violation is
//!   [`Error::Invariant`] naming the file and record.
//! - No input makes this crate panic; every failure is an [`Error`] naming the file (and the
//!   line for text, the byte offset or record for binary, the table and row for databases).
//!
//! # Where this reader is stricter or kinder than COLMAP
//! - Binary files with bytes after the last record, text colours outside 0–255, a `HAS_POSE`
//!   flag other than 0/1, unknown sensor types and every broken invariant above are errors
//!   (COLMAP ignores or casts some of them).
//! - A text image name is the rest of its line, so names with spaces survive text (COLMAP
//!   keeps only the first word); an image line that ends the file keeps its image, with no
//!   points (COLMAP silently drops it). Names that text cannot hold (line breaks, leading or
//!   trailing whitespace) are refused when writing text.
//!
//! # Entry points
//! - [`Reconstruction::read`], [`Reconstruction::write`]: a whole model directory.
//! - [`Reconstruction::image_cam_from_world`], [`Reconstruction::image_by_name`]: poses.
//! - [`database::Database::open`]: read-only access to `database.db` (keypoints, matches,
//!   two-view geometries oriented as asked, rigs, frames, pose priors).
//! - Every model file is read through [`crashrig_input::file::read_limited`] (a regular file
//!   within [`crashrig_input::file::MAX_MODEL_FILE_BYTES`]; `/dev/zero`, FIFOs and directories
//!   are refused).
//! - [`fmt::g17`]: `%.17g` number formatting as COLMAP's text writer.
//! - The entries of `crashrig colmap` (feature `commands`, on by default): [`info::model_info`],
//!   [`info::database_info`], [`convert::convert`] and [`lookup::points`], each a typed result
//!   that serialises to the command's JSON and renders its text.
//!
//! # Features
//! - `database` (default): [`database`], the `database.db` reader; it bundles SQLite (`rusqlite`).
//! - `commands` (default, implies `database`): [`info`], [`convert`] and [`lookup::points`], the
//!   entries of `crashrig colmap` (adds `serde` and `crashrig-outdir`).
//!
//! A dependent that only reads models uses `default-features = false`: no SQLite is compiled.
//!
//! # Example
//! Write a one-image legacy model as text, read it back and get the camera centre.
//! ```
//! use crashrig_camera::{Camera, ModelId};
//! use crashrig_colmap::{CameraRecord, Image, ModelFormat, Point2D, RawPose, Reconstruction};
//!
//! let camera = Camera::new(ModelId::Pinhole, 640, 480, vec![500.0, 500.0, 320.0, 240.0])?;
//! let image = Image {
//!     image_id: 1,
//!     // 180° about y, then 2 units along the camera's z axis.
//!     stored_cam_from_world: RawPose { qvec: [0.0, 0.0, 1.0, 0.0], tvec: [0.0, 0.0, 2.0] },
//!     camera_id: 1,
//!     name: "cam a/0001.png".into(),
//!     points2d: vec![Point2D { xy: [320.5, 240.5], point3d_id: None }],
//! };
//! let model = Reconstruction::from_records(
//!     vec![CameraRecord { camera_id: 1, camera }], vec![], vec![], vec![image], vec![],
//! )?;
//! let dir = tempfile::tempdir()?;
//! model.write(dir.path(), ModelFormat::Text)?;
//!
//! let back = Reconstruction::read(dir.path())?;
//! assert!(!back.is_legacy()); // all five files were written
//! let pose = back.image_cam_from_world(1).expect("image 1 has a pose");
//! let centre = crashrig_geometry::projection_center(&pose);
//! assert!((centre - crashrig_geometry::Vec3::new(0.0, 0.0, 2.0)).norm() < 1e-12);
//! assert_eq!(back.image_by_name("cam a/0001.png").map(|i| i.image_id), Some(1));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod binary;
pub mod bounds;
#[cfg(feature = "commands")]
pub mod convert;
#[cfg(feature = "database")]
pub mod database;
mod error;
pub mod fmt;
#[cfg(feature = "commands")]
pub mod info;
pub mod lookup;
mod raw_pose;
mod reconstruction;
mod record;
mod select;
mod text;

pub use error::{Error, Result};
pub use reconstruction::{ModelFormat, Reconstruction};
pub use record::{
    CameraRecord, DataId, Frame, Image, Point2D, Point3D, RawPose, Rig, RigSensor, SensorId,
    SensorType, TrackElement,
};
pub use select::{CameraSelector, epoch_name};

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
