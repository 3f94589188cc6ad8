//! Finding 3-D points by where an image sees them: the ids of scale-bar targets, for example.
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

use crate::Reconstruction;

/// A 3-D point observed near a pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct PointNear {
    /// COLMAP point3D id.
    pub point3d_id: u64,
    /// Its position (model units).
    pub xyz: [f64; 3],
    /// Where the image observes it (px, COLMAP convention).
    pub pixel: [f64; 2],
    /// Distance from the query pixel (px).
    pub distance_px: f64,
    /// Number of images observing it.
    pub track_length: usize,
    /// Its mean reprojection error (px; −1 = not computed).
    pub error_px: f64,
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
