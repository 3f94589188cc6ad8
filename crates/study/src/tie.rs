//! The tie link of a third camera: correspondences from a COLMAP database and model, bootstrapped.
//!
//! INTERIM (H11): a minimal absolute-orientation bootstrap with the STUDY_API interface so the
//! pipeline builds and runs before H12b's module lands; at the merge this file is replaced.

use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
use serde_json::{Value, json};
use std::path::PathBuf;

/// Method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Resection.
    Absolute,
    /// Relative orientation.
    Relative,
}

/// What is resampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resample {
    /// Inliers.
    Inliers,
    /// All matches.
    AllMatches,
}

/// Configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct TieConfig {
    /// Database.
    pub database: PathBuf,
    /// Model.
    pub model: PathBuf,
    /// Image A.
    pub image_a: String,
    /// Image B.
    pub image_b: String,
    /// Method.
    pub method: Method,
    /// Replicates.
    pub iterations: usize,
    /// Seed.
    pub seed: u64,
    /// Scale.
    pub mm_per_unit: f64,
    /// RANSAC threshold.
    pub max_error_px: f64,
    /// Base.
    pub base_mm: Option<f64>,
    /// Resample.
    pub resample: Resample,
}

impl Default for TieConfig {
    fn default() -> Self {
        TieConfig {
            database: PathBuf::new(),
            model: PathBuf::new(),
            image_a: String::new(),
            image_b: String::new(),
            method: Method::Absolute,
            iterations: 500,
            seed: 1,
            mm_per_unit: 1.0,
            max_error_px: 4.0,
            base_mm: None,
            resample: Resample::Inliers,
        }
    }
}

/// Why the tie failed.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TieError(String);

/// Result.
#[derive(Debug, Clone)]
pub struct TieResult {
    /// A_from_B with the replicates' covariance.
    pub link: UncertainPose,
    /// Replicates.
    pub replicates: Vec<Rigid3>,
    iterations: usize,
    n: usize,
}

impl TieResult {
    /// JSON.
    pub fn to_json(&self) -> Value {
        json!({
            "method": "absolute",
            "iterations": self.iterations,
            "n_correspondences": self.n,
            "base_mm": <[f64; 3]>::from(self.link.b_from_a.translation.vector),
            "covariance_tangent": crate::pipeline::covariance_deg_rows(&self.link.covariance),
        })
    }
}

/// Bootstraps.
///
/// # Errors
/// Any failure, naming the file.
pub fn bootstrap(c: &TieConfig) -> Result<TieResult, TieError> {
    use rand::RngExt;
    let m = |x: &dyn std::fmt::Display| TieError(format!("{}: {x}", c.model.display()));
    let model =
        crashrig_colmap::Reconstruction::read(&c.model).map_err(|x| TieError(x.to_string()))?;
    let get = |name: &str| -> Result<_, TieError> {
        let img = model
            .image_by_name(name)
            .ok_or_else(|| m(&format!("image {name:?} is not in the model")))?;
        let pose = model
            .image_cam_from_world(img.image_id)
            .ok_or_else(|| m(&format!("image {name:?} has no pose")))?;
        let cam = model
            .camera(img.camera_id)
            .ok_or_else(|| m(&"camera missing"))?
            .camera
            .clone();
        Ok((
            img,
            cam,
            Rigid3::from_parts(
                (pose.translation.vector * c.mm_per_unit).into(),
                pose.rotation,
            ),
        ))
    };
    let (_, _, a_from_world) = get(&c.image_a)?;
    let (img_b, cam_b, _) = get(&c.image_b)?;
    let mut px = Vec::new();
    let mut pts = Vec::new();
    for p in &img_b.points2d {
        if let Some(q) = p.point3d_id.and_then(|id| model.point3d(id)) {
            px.push(nalgebra::Vector2::new(p.xy[0], p.xy[1]));
            pts.push(Vec3::new(q.xyz[0], q.xyz[1], q.xyz[2]) * c.mm_per_unit);
        }
    }
    let mut opts = crashrig_pose::RansacOptions::new(c.seed);
    opts.max_error_px = c.max_error_px;
    let full =
        crashrig_pose::estimate_absolute_pose(&cam_b, &px, &pts, &opts).map_err(|x| m(&x))?;
    let link_of = |b_from_world: &Rigid3| a_from_world * b_from_world.inverse();
    let nominal = link_of(&full.refinement.cam_from_world);
    let inl = full.inliers.clone();
    let mut reps = Vec::new();
    for k in 0..c.iterations {
        let mut rng = crashrig_stats::stream(c.seed, k as u64);
        let idx: Vec<usize> = (0..inl.len())
            .map(|_| inl[rng.random_range(0..inl.len())])
            .collect();
        if let Ok(r) = crashrig_pose::refine_absolute_pose(
            &cam_b,
            &px,
            &pts,
            &idx,
            &full.refinement.cam_from_world,
        ) {
            reps.push(link_of(&r.cam_from_world));
        }
    }
    let spread = UncertainPose::from_samples(&reps).map_err(|x| m(&x))?;
    let link = UncertainPose {
        b_from_a: nominal,
        covariance: spread.covariance,
    };
    Ok(TieResult {
        link,
        replicates: reps,
        iterations: c.iterations,
        n: inl.len(),
    })
}
