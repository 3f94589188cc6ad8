//! Helpers shared by the covariance crate's integration tests.

use crashrig_colmap::{Frame, Image, Point3D, RawPose, Reconstruction};
use crashrig_geometry::{Rigid3, Vec3};
use nalgebra::Point3;

/// The model moved as a whole: `world' = t · world`.
pub fn moved(model: &Reconstruction, t: &Rigid3) -> Reconstruction {
    let inv = t.inverse();
    let pose = |p: &RawPose| p.to_rigid().map_or(*p, |r| RawPose::from_rigid(&(r * inv)));
    let images: Vec<Image> = model
        .images()
        .iter()
        .map(|im| {
            let mut im = im.clone();
            im.stored_cam_from_world = pose(&im.stored_cam_from_world);
            im
        })
        .collect();
    let frames: Vec<Frame> = model
        .frames()
        .iter()
        .map(|f| {
            let mut f = f.clone();
            f.rig_from_world = pose(&f.rig_from_world);
            f
        })
        .collect();
    let points: Vec<Point3D> = model
        .points3d()
        .iter()
        .map(|p| {
            let mut p = p.clone();
            let x = t * Point3::from(Vec3::from(p.xyz));
            p.xyz = [x.x, x.y, x.z];
            p
        })
        .collect();
    Reconstruction::from_records(
        model.cameras().to_vec(),
        model.rigs().to_vec(),
        frames,
        images,
        points,
    )
    .unwrap()
}
