//! `crashrig colmap info`: the counts of a sparse model or of a `database.db`, as typed
//! results that serialise to the command's JSON and render its text.
//!
//! ```
//! # fn main() -> crashrig_colmap::Result<()> {
//! # let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/tie/model");
//! let info = crashrig_colmap::info::model_info(&dir)?;
//! assert_eq!(info.images, info.frames); // this model has one image per frame
//! assert!(info.text_report().starts_with("COLMAP model "));
//! # Ok(()) }
//! ```

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::database::{Database, DbCounts};
use crate::{ModelFormat, Reconstruction, Result};

/// The counts of a sparse model (`crashrig colmap info MODEL --json`).
///
/// The fields are in alphabetical order: the key order of the command's JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelInfo {
    /// The model directory, as given.
    #[serde(skip)]
    pub dir: PathBuf,
    /// Number of cameras.
    pub cameras: usize,
    /// The files read: binary or text.
    pub format: ModelFormat,
    /// Number of frames (one per image for a legacy model).
    pub frames: usize,
    /// Number of images.
    pub images: usize,
    /// A 3.x three-file model (trivial rigs and frames).
    pub legacy: bool,
    /// Number of image observations of 3-D points.
    pub observations: usize,
    /// Number of 3-D points.
    #[serde(rename = "points3D")]
    pub points3d: usize,
    /// Number of rigs (one per camera for a legacy model).
    pub rigs: usize,
    /// Lines for stderr (each printed after `warning: `).
    #[serde(skip)]
    pub warnings: Vec<String>,
}

/// Reads the model in `dir` and counts its records.
///
/// # Errors
/// Any error of [`Reconstruction::read`].
pub fn model_info(dir: &Path) -> Result<ModelInfo> {
    let model = Reconstruction::read(dir)?;
    Ok(ModelInfo {
        dir: dir.to_path_buf(),
        cameras: model.cameras().len(),
        format: model.format(),
        frames: model.frames().len(),
        images: model.images().len(),
        legacy: model.is_legacy(),
        observations: model.num_observations(),
        points3d: model.points3d().len(),
        rigs: model.rigs().len(),
        warnings: stored_pose_warning(&model).into_iter().collect(),
    })
}

impl ModelInfo {
    /// The text of `crashrig colmap info MODEL` (stdout).
    pub fn text_report(&self) -> String {
        let legacy = if self.legacy {
            " (legacy three-file model: trivial rigs and frames)"
        } else {
            ""
        };
        format!(
            "COLMAP model {}\n  format        {}{legacy}\n  cameras       {}\n  rigs          {}\n  \
             frames        {}\n  images        {}\n  points3D      {}\n  observations  {}\n",
            self.dir.display(),
            self.format.name(),
            self.cameras,
            self.rigs,
            self.frames,
            self.images,
            self.points3d,
            self.observations
        )
    }
}

/// COLMAP uses the rig/frame pose and ignores the one in `images.*`; one line saying so when
/// they disagree (colmap#4752), since other tools may read the `images.*` pose.
pub fn stored_pose_warning(model: &Reconstruction) -> Option<String> {
    let mut worst: Option<(u32, f64, f64)> = None;
    let mut count = 0usize;
    for im in model.images() {
        let Some((angle, dt)) = model.stored_pose_deviation(im.image_id) else {
            continue;
        };
        let scale = model
            .image_cam_from_world(im.image_id)
            .map_or(1.0, |p| p.translation.vector.norm().max(1.0));
        if angle > 1e-6 || dt > 1e-6 * scale {
            count += 1;
            if worst.is_none_or(|(_, a, d)| angle + dt / scale > a + d / scale) {
                worst = Some((im.image_id, angle, dt));
            }
        }
    }
    let (id, angle, dt) = worst?;
    Some(format!(
        "{count} image(s) store a pose in images.* that differs from the rig/frame pose COLMAP uses \
         (worst: image {id}, {:.3e} deg, {dt:.3e} model units); the rig/frame pose is used",
        angle.to_degrees()
    ))
}

/// The counts of a `database.db` (`crashrig colmap info DATABASE --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DatabaseInfo {
    /// The database file, as given.
    #[serde(skip)]
    pub path: PathBuf,
    /// Its row counts (the JSON's keys).
    #[serde(flatten)]
    pub counts: DbCounts,
}

/// Opens the database read-only (it is never modified) and counts its rows.
///
/// # Errors
/// Any error of [`Database::open`] or [`Database::counts`].
pub fn database_info(path: &Path) -> Result<DatabaseInfo> {
    let counts = Database::open(path)?.counts()?;
    Ok(DatabaseInfo {
        path: path.to_path_buf(),
        counts,
    })
}

impl DatabaseInfo {
    /// The text of `crashrig colmap info DATABASE` (stdout).
    pub fn text_report(&self) -> String {
        let c = &self.counts;
        format!(
            "COLMAP database {}\n  user_version    {}\n  cameras         {}\n  images          {}\n  \
             rigs            {}\n  frames          {}\n  keypoints       {} images\n  \
             matched pairs   {}\n  verified pairs  {} (with at least one inlier)\n",
            self.path.display(),
            c.user_version,
            c.cameras,
            c.images,
            c.rigs,
            c.frames,
            c.keypoints,
            c.matched_pairs,
            c.verified_pairs
        )
    }
}
