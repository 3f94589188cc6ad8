//! Finding 3-D points by where an image sees them: the ids of scale-bar targets, for example;
//! [`points`] is the entry of `crashrig colmap points`.
//!
//! ```
//! # fn main() -> crashrig_colmap::Result<()> {
//! # let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/tie/model");
//! use crashrig_colmap::{Reconstruction, lookup::points_near};
//! let model = Reconstruction::read(&dir)?;
//! let hits = points_near(&model, "in/0001.png", [960.0, 600.0], 200.0).expect("image in the model");
//! assert!(hits.windows(2).all(|w| w[0].distance_px <= w[1].distance_px));
//! # Ok(()) }
//! ```

use std::path::{Path, PathBuf};

use crate::{Error, Reconstruction, Result};

/// A 3-D point observed near a pixel (one object of `crashrig colmap points --near --json`).
///
/// The fields are in alphabetical order: the key order of the command's JSON.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "commands", derive(serde::Serialize))]
pub struct PointNear {
    /// Distance from the query pixel (px).
    pub distance_px: f64,
    /// Its mean reprojection error (px; −1 = not computed).
    pub error_px: f64,
    /// Where the image observes it (px, COLMAP convention).
    pub pixel: [f64; 2],
    /// COLMAP point3D id.
    #[cfg_attr(feature = "commands", serde(rename = "point3D_id"))]
    pub point3d_id: u64,
    /// Number of images observing it.
    pub track_length: usize,
    /// Its position (model units).
    pub xyz: [f64; 3],
}

/// The points image `image_name` observes within `radius_px` of `pixel`, nearest first
/// (ties by id); `None` when the model has no such image.
pub fn points_near(
    model: &Reconstruction,
    image_name: &str,
    pixel: [f64; 2],
    radius_px: f64,
) -> Option<Vec<PointNear>> {
    let image = model.image_by_name(image_name)?;
    let mut out: Vec<PointNear> = image
        .points2d
        .iter()
        .filter_map(|p| {
            let id = p.point3d_id?;
            let pt = model.point3d(id)?;
            let d = (p.xy[0] - pixel[0]).hypot(p.xy[1] - pixel[1]);
            (d <= radius_px).then_some(PointNear {
                point3d_id: id,
                xyz: pt.xyz,
                pixel: p.xy,
                distance_px: d,
                track_length: pt.track.len(),
                error_px: pt.error,
            })
        })
        .collect();
    out.sort_by(|a, b| {
        a.distance_px
            .total_cmp(&b.distance_px)
            .then(a.point3d_id.cmp(&b.point3d_id))
    });
    Some(out)
}

/// What `crashrig colmap points` looks up.
#[derive(Debug, Clone, PartialEq)]
pub enum PointsQuery {
    /// The points image `image` observes within `radius_px` of `pixel`.
    Near {
        /// The image's name in the model.
        image: String,
        /// The pixel (COLMAP convention).
        pixel: [f64; 2],
        /// The search radius (px, positive).
        radius_px: f64,
    },
    /// One point by id, with its track.
    Id(u64),
}

/// One observation of a point's track: the image and the pixel.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "commands", derive(serde::Serialize))]
pub struct TrackPixel {
    /// The image's name.
    pub image: String,
    /// Where it observes the point (px, COLMAP convention).
    pub pixel: [f64; 2],
}

/// A 3-D point with its track (the object of `crashrig colmap points --point ID --json`).
///
/// The fields are in alphabetical order: the key order of the command's JSON.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "commands", derive(serde::Serialize))]
pub struct PointTrack {
    /// Its mean reprojection error (px; −1 = not computed).
    pub error_px: f64,
    /// COLMAP point3D id.
    #[cfg_attr(feature = "commands", serde(rename = "point3D_id"))]
    pub point3d_id: u64,
    /// Its observations, in track order.
    pub track: Vec<TrackPixel>,
    /// Number of images observing it.
    pub track_length: usize,
    /// Its position (model units).
    pub xyz: [f64; 3],
}

/// The answer of `crashrig colmap points`: serialises as the command's JSON array.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "commands", derive(serde::Serialize), serde(untagged))]
pub enum Points {
    /// The points near a pixel, nearest first.
    Near(Vec<PointNear>),
    /// One point and its track.
    Id([PointTrack; 1]),
}

/// Reads the model in `dir` and answers `query`.
///
/// # Errors
/// Any error of [`Reconstruction::read`]; [`Error::NoPoint3D`] or [`Error::NoImage`] when the
/// model has no such point or image.
pub fn points(dir: &Path, query: &PointsQuery) -> Result<Points> {
    let model = Reconstruction::read(dir)?;
    match query {
        PointsQuery::Id(id) => point_track(&model, *id)
            .map(|p| Points::Id([p]))
            .ok_or_else(|| Error::NoPoint3D {
                path: dir.to_path_buf(),
                id: *id,
            }),
        PointsQuery::Near {
            image,
            pixel,
            radius_px,
        } => points_near(&model, image, *pixel, *radius_px)
            .map(Points::Near)
            .ok_or_else(|| Error::NoImage {
                path: PathBuf::from(dir),
                name: image.clone(),
                nearest: model
                    .nearest_image_names(image, 3)
                    .into_iter()
                    .map(|n| format!("{n:?}"))
                    .collect(),
            }),
    }
}

/// The point with this id and its track (observations whose image or point2D is missing are
/// left out); `None` when the model has no such point.
pub fn point_track(model: &Reconstruction, point3d_id: u64) -> Option<PointTrack> {
    let p = model.point3d(point3d_id)?;
    let track = p
        .track
        .iter()
        .filter_map(|t| {
            let img = model.image(t.image_id)?;
            let xy = img.points2d.get(t.point2d_idx as usize)?.xy;
            Some(TrackPixel {
                image: img.name.clone(),
                pixel: xy,
            })
        })
        .collect();
    Some(PointTrack {
        error_px: p.error,
        point3d_id,
        track,
        track_length: p.track.len(),
        xyz: p.xyz,
    })
}

impl Points {
    /// The text of `crashrig colmap points` (stdout): a table of the points near a pixel, or the
    /// point's position, track length and reprojection error, then one line per observation
    /// (a point has no single pixel). Ids and track lengths are not padded (as printed since
    /// the first release).
    pub fn text_report(&self) -> String {
        let mut s = String::new();
        match self {
            Points::Near(rows) => {
                s += &format!(
                    "{:>10} {:>12} {:>12} {:>12} {:>9} {:>9} {:>6}\n",
                    "point3D_id", "x", "y", "z", "u", "v", "track"
                );
                for r in rows {
                    let [x, y, z] = r.xyz;
                    let [u, v] = r.pixel;
                    s += &format!(
                        "{} {x:>12.4} {y:>12.4} {z:>12.4} {u:>9.1} {v:>9.1} {}\n",
                        r.point3d_id, r.track_length
                    );
                }
            }
            Points::Id([p]) => {
                s += &format!(
                    "{:>10} {:>12} {:>12} {:>12} {:>9} {:>6}\n",
                    "point3D_id", "x", "y", "z", "error_px", "track"
                );
                let [x, y, z] = p.xyz;
                s += &format!(
                    "{} {x:>12.4} {y:>12.4} {z:>12.4} {:>9.3} {}\n",
                    p.point3d_id, p.error_px, p.track_length
                );
                if !p.track.is_empty() {
                    s += "track:\n";
                    s += &format!("  {:>9} {:>9}  image\n", "u", "v");
                    for t in &p.track {
                        let [u, v] = t.pixel;
                        s += &format!("  {u:>9.2} {v:>9.2}  {}\n", t.image);
                    }
                }
            }
        }
        s
    }
}
