//! The rule by which a user (and the tests) picks camera A and control points on a model
//! that has no lab survey (shared by `bundled_models.rs` and `examples/survey.rs`; the rule is
//! stated in `bundled_models.rs`'s module doc and in `docs/COVARIANCE.md`).

// Each includer uses a part of it.
#![allow(dead_code)]

use crashrig_colmap::Reconstruction;
use crashrig_geometry::Vec3;
use std::collections::BTreeMap;

/// Camera A of the rule: the camera id with the most registered images.
pub fn camera_a(model: &Reconstruction) -> Option<u32> {
    let mut count: BTreeMap<u32, usize> = BTreeMap::new();
    for im in model.images() {
        *count.entry(im.camera_id).or_default() += 1;
    }
    // max_by_key keeps the last maximum; iterate in reverse for the lowest id on a tie.
    count
        .into_iter()
        .rev()
        .max_by_key(|&(_, n)| n)
        .map(|(id, _)| id)
}

/// The control points of the rule (module docs), or `None` when there are no three
/// non-collinear well-observed points.
pub fn control_points(model: &Reconstruction) -> Option<Vec<u64>> {
    control_points_excluding(model, &[])
}

/// [`control_points`] among the points not in `excluded` (a user replacing a control point
/// that the command refused).
pub fn control_points_excluding(model: &Reconstruction, excluded: &[u64]) -> Option<Vec<u64>> {
    let candidates = || {
        model
            .points3d()
            .iter()
            .filter(|p| !excluded.contains(&p.point3d_id))
    };
    let long = candidates().filter(|p| p.track.len() >= 3).count();
    let min_track = if long >= 4 { 3 } else { 2 };
    let pts: Vec<(u64, Vec3, usize)> = candidates()
        .filter(|p| p.track.len() >= min_track)
        .map(|p| (p.point3d_id, Vec3::from(p.xyz), p.track.len()))
        .collect();
    let first = pts
        .iter()
        .max_by(|a, b| a.2.cmp(&b.2).then(b.0.cmp(&a.0)))?;
    let farthest = |f: &dyn Fn(&Vec3) -> f64| {
        pts.iter()
            .max_by(|a, b| f(&a.1).total_cmp(&f(&b.1)).then(b.0.cmp(&a.0)))
            .copied()
    };
    let second = farthest(&|x| (x - first.1).norm())?;
    let base = second.1 - first.1;
    let span = base.norm();
    if span == 0.0 {
        return None;
    }
    let third = farthest(&|x| (x - first.1).cross(&base).norm() / span)?;
    if (third.1 - first.1).cross(&base).norm() / span <= 1e-6 * span {
        return None;
    }
    let normal = base.cross(&(third.1 - first.1)).normalize();
    let fourth = farthest(&|x| (x - first.1).dot(&normal).abs())?;
    let mut ids = vec![first.0, second.0, third.0];
    if (fourth.1 - first.1).dot(&normal).abs() > 0.01 * span {
        ids.push(fourth.0);
    }
    Some(ids)
}
