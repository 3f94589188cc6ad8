//! Correspondences of a tie from a COLMAP model and database: B's observations of the model's
//! 3-D points (for resection) or the A–B matches (for relative orientation).
//!
//! - Absolute: every 2-D point of image B that has a 3-D point in the model (the model's
//!   tracks), with the point in mm; A's pose is the model's.
//! - Relative: the keypoints of the A–B matches, either the verified ones
//!   (`two_view_geometries` inliers) or every raw candidate of the `matches` table.
//!
//! Lengths are converted to mm with `mm_per_unit` here; nothing downstream sees model units.

use crate::error::Error;
use crashrig_camera::Camera;
use crashrig_colmap::Reconstruction;
use crashrig_colmap::database::Database;
use crashrig_geometry::{Rigid3, Vec3};
use nalgebra::Vector2;
use std::path::{Path, PathBuf};

/// One image of the model with its camera and pose (`cam_from_world`, mm).
#[derive(Debug, Clone)]
pub struct ModelImage {
    /// The image's name.
    pub name: String,
    /// Its camera (validated).
    pub camera: Camera,
    /// `cam_from_world`, translation in mm.
    pub cam_from_world: Rigid3,
}

/// Resection input: B's observations of 3-D points (mm) and A's fixed pose.
#[derive(Debug, Clone)]
pub struct AbsoluteCorrespondences {
    /// Image A (the reference; its pose is held fixed).
    pub a: ModelImage,
    /// Image B (resected).
    pub b: ModelImage,
    /// B's pixels (COLMAP convention) of the observed 3-D points.
    pub pixels_b: Vec<Vector2<f64>>,
    /// The observed points, world frame, mm.
    pub points_mm: Vec<Vec3>,
}

/// Relative-orientation input: matched pixels of A and B.
#[derive(Debug, Clone)]
pub struct MatchedPixels {
    /// Image A.
    pub a: ModelImage,
    /// Image B.
    pub b: ModelImage,
    /// A's pixels of the matches.
    pub pixels_a: Vec<Vector2<f64>>,
    /// B's pixels of the matches (same order).
    pub pixels_b: Vec<Vector2<f64>>,
    /// Distance of the two projection centres in the model, mm.
    pub model_base_mm: f64,
}

/// Which A–B matches of the database to take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatchSet {
    /// The verified matches (`two_view_geometries` inliers).
    Verified,
    /// Every candidate of the `matches` table.
    Raw,
}

/// The model and database of a tie, opened, with both images checked.
pub struct TieSource {
    model_dir: PathBuf,
    database_path: PathBuf,
    model: Reconstruction,
    db: Database,
    a: ModelImage,
    b: ModelImage,
    ids: (u32, u32, u32, u32),
}

fn model_error(dir: &Path, message: String) -> Error {
    Error::Model {
        path: dir.to_path_buf(),
        message,
    }
}

fn db_error(path: &Path, message: String) -> Error {
    Error::Database {
        path: path.to_path_buf(),
        message,
    }
}

fn scale_pose(p: &Rigid3, k: f64) -> Rigid3 {
    Rigid3::from_parts((p.translation.vector * k).into(), p.rotation)
}

fn model_image(
    model: &Reconstruction,
    dir: &Path,
    name: &str,
    mm_per_unit: f64,
) -> Result<(u32, ModelImage), Error> {
    let image = model.image_by_name(name).ok_or_else(|| {
        let nearest: Vec<String> = model
            .nearest_image_names(name, 3)
            .iter()
            .map(|n| format!("{n:?}"))
            .collect();
        model_error(
            dir,
            format!(
                "image {name:?} is not in the model{}",
                if nearest.is_empty() {
                    String::new()
                } else {
                    format!("; nearest: {}", nearest.join(", "))
                }
            ),
        )
    })?;
    let camera = model
        .camera(image.camera_id)
        .ok_or_else(|| {
            model_error(
                dir,
                format!(
                    "camera {} of image {name:?} is not in the model",
                    image.camera_id
                ),
            )
        })?
        .camera
        .clone();
    camera.validate().map_err(|e| {
        model_error(
            dir,
            format!(
                "camera {} of image {name:?} is invalid: {e}",
                image.camera_id
            ),
        )
    })?;
    let pose = model
        .image_cam_from_world(image.image_id)
        .ok_or_else(|| model_error(dir, format!("image {name:?} has no pose")))?;
    Ok((
        image.image_id,
        ModelImage {
            // The model's own spelling (a name typed in another Unicode normal form finds it).
            name: image.name.clone(),
            camera,
            cam_from_world: scale_pose(&pose, mm_per_unit),
        },
    ))
}

impl TieSource {
    /// Opens the model and the database and finds images A and B in both.
    ///
    /// Errors name the file: an unreadable model or database, an image missing from either,
    /// A and B naming the same image.
    pub fn open(
        model_dir: &Path,
        database: &Path,
        image_a: &str,
        image_b: &str,
        mm_per_unit: f64,
    ) -> Result<Self, Error> {
        let model = Reconstruction::read(model_dir)
            .map_err(|e| model_error(model_dir, format!("cannot read the COLMAP model: {e}")))?;
        let db = Database::open(database)
            .map_err(|e| db_error(database, format!("cannot open the COLMAP database: {e}")))?;
        let (ma, a) = model_image(&model, model_dir, image_a, mm_per_unit)?;
        let (mb, b) = model_image(&model, model_dir, image_b, mm_per_unit)?;
        if ma == mb {
            return Err(Error::Option {
                option: "--image-a/--image-b",
                message: format!("--image-a and --image-b name the same image {image_a:?}"),
            });
        }
        let db_id = |name: &str| -> Result<u32, Error> {
            db.image_id_by_name(name)
                .map_err(|e| db_error(database, format!("reading the images table: {e}")))?
                .ok_or_else(|| db_error(database, format!("image {name:?} is not in the database")))
        };
        let (da, dbb) = (db_id(&a.name)?, db_id(&b.name)?);
        Ok(TieSource {
            model_dir: model_dir.to_path_buf(),
            database_path: database.to_path_buf(),
            model,
            db,
            a,
            b,
            ids: (ma, mb, da, dbb),
        })
    }

    /// B's observations of the model's 3-D points (mm), with A's pose.
    pub fn absolute(&self, mm_per_unit: f64) -> Result<AbsoluteCorrespondences, Error> {
        let image_b = self.model.image(self.ids.1).ok_or_else(|| {
            model_error(&self.model_dir, format!("image {:?} vanished", self.b.name))
        })?;
        let mut pixels_b = Vec::new();
        let mut points_mm = Vec::new();
        for p in &image_b.points2d {
            if let Some(pt) = p.point3d_id.and_then(|id| self.model.point3d(id)) {
                pixels_b.push(Vector2::new(p.xy[0], p.xy[1]));
                points_mm.push(Vec3::new(pt.xyz[0], pt.xyz[1], pt.xyz[2]) * mm_per_unit);
            }
        }
        Ok(AbsoluteCorrespondences {
            a: self.a.clone(),
            b: self.b.clone(),
            pixels_b,
            points_mm,
        })
    }

    /// The A–B matches of the database (`set`), as pixel pairs.
    pub fn matches(&self, set: MatchSet) -> Result<MatchedPixels, Error> {
        let path = &self.database_path;
        let (da, dbb) = (self.ids.2, self.ids.3);
        let (ia, ib) = (&self.a.name, &self.b.name);
        let pairs: Vec<[u32; 2]> = match set {
            MatchSet::Verified => {
                self.db
                    .two_view_geometry(da, dbb)
                    .map_err(|e| db_error(path, format!("reading two_view_geometries: {e}")))?
                    .ok_or_else(|| {
                        db_error(
                            path,
                            format!("no verified matches between {ia:?} and {ib:?}"),
                        )
                    })?
                    .inliers
            }
            MatchSet::Raw => {
                let m = self
                    .db
                    .matches(da, dbb)
                    .map_err(|e| db_error(path, format!("reading matches: {e}")))?;
                if m.is_empty() {
                    return Err(db_error(
                        path,
                        format!("no matches between {ia:?} and {ib:?}"),
                    ));
                }
                m
            }
        };
        let kp = |id: u32, name: &str| -> Result<Vec<Vector2<f64>>, Error> {
            Ok(self
                .db
                .keypoints(id)
                .map_err(|e| db_error(path, format!("keypoints of {name:?}: {e}")))?
                .iter()
                .map(|k| Vector2::new(f64::from(k.xy[0]), f64::from(k.xy[1])))
                .collect())
        };
        let (kp_a, kp_b) = (kp(da, ia)?, kp(dbb, ib)?);
        let mut pixels_a = Vec::with_capacity(pairs.len());
        let mut pixels_b = Vec::with_capacity(pairs.len());
        for m in &pairs {
            let (Some(xa), Some(xb)) = (kp_a.get(m[0] as usize), kp_b.get(m[1] as usize)) else {
                return Err(db_error(
                    path,
                    format!("a match of {ia:?}-{ib:?} names keypoint {m:?} beyond the keypoints"),
                ));
            };
            pixels_a.push(*xa);
            pixels_b.push(*xb);
        }
        let ca = crashrig_geometry::projection_center(&self.a.cam_from_world);
        let cb = crashrig_geometry::projection_center(&self.b.cam_from_world);
        Ok(MatchedPixels {
            a: self.a.clone(),
            b: self.b.clone(),
            pixels_a,
            pixels_b,
            model_base_mm: (cb - ca).norm(),
        })
    }
}
