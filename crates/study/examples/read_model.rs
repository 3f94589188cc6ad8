//! Read a COLMAP model and find the 3-D points an image sees near a pixel.
//!
//! `cargo run -p crashrig-study --example read_model [MODEL_DIR IMAGE X Y]`
//! (default: the bundled own-project tie model).

use crashrig_colmap::{Reconstruction, lookup::points_near};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (dir, image, x, y) = match args.as_slice() {
        [d, i, x, y] => (PathBuf::from(d), i.clone(), x.parse()?, y.parse()?),
        _ => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/tie/model"),
            "in/0001.png".to_string(),
            960.0,
            600.0,
        ),
    };
    let model = Reconstruction::read(&dir)?;
    println!(
        "{}: {} cameras, {} images, {} points",
        dir.display(),
        model.cameras().len(),
        model.images().len(),
        model.points3d().len()
    );
    for p in points_near(&model, &image, [x, y], 50.0).ok_or("image not in the model")? {
        println!(
            "point {} at {:?}, seen at {:?} ({:.1} px away), track length {}",
            p.point3d_id, p.xyz, p.pixel, p.distance_px, p.track_length
        );
    }
    Ok(())
}
