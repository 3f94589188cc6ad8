//! The positions of one replicate: every slot of an epoch intersected from the drawn poses and
//! pixel noise.

use super::prepare::{ATrack, EpochPrep};
use super::streams::{LinkDraw, apply, perturb};
use crashrig_geometry::{Mat3, Vec3, Vec6};
use crashrig_stats::StreamRng;
use nalgebra::Vector2;
use rand::RngExt;
use rand_distr::StandardNormal;

/// Linear least-squares intersection of rays given as (world_from_cam rotation, centre,
/// normalized observation): the DLT rows `(u·c₃ − c₁)·X = (u·c₃ − c₁)·C` with `cᵢ` the columns
/// of `R_world_from_cam` (the rows of `R_cam_from_world`), as [`triangulate::dlt`].
#[inline]
fn intersect<'a>(views: impl Iterator<Item = (&'a Mat3, &'a Vec3, Vector2<f64>)>) -> Option<Vec3> {
    let mut n = Mat3::zeros();
    let mut rhs = Vec3::zeros();
    for (r, c, uv) in views {
        let c1 = r.column(0);
        let c2 = r.column(1);
        let c3 = r.column(2);
        let a1: Vec3 = c3 * uv.x - c1;
        let a2: Vec3 = c3 * uv.y - c2;
        n += a1 * a1.transpose() + a2 * a2.transpose();
        rhs += a1 * a1.dot(c) + a2 * a2.dot(c);
    }
    n.try_inverse().map(|inv| inv * rhs)
}

/// Positions of an epoch's slots for the replicates `links` (the next ones of its stream
/// `rng`): `out[slot·len + r]` (NaN where the slot has no position or a draw is degenerate).
/// `a_joint`: A's joint draws of these replicates (else A is drawn from `rng`).
pub(super) fn epoch_positions(
    ep: &EpochPrep,
    rng: &mut StreamRng,
    links: &[LinkDraw],
    a_joint: Option<&[Vec6]>,
    track: Option<&ATrack>,
    out: &mut Vec<Vec3>,
) {
    let len = links.len();
    out.clear();
    out.resize(ep.slots.len() * len, Vec3::repeat(f64::NAN));
    for (r, link) in links.iter().enumerate() {
        let (r0, c0) = match (track, ep.time_s) {
            (Some(track), Some(t)) if link.sync_s != 0.0 => track.at(t + link.sync_s),
            _ => (ep.r_wa, ep.c_a),
        };
        let (r_wa, c_a) = match a_joint {
            Some(d) => apply(&r0, &c0, &d[r]),
            None => perturb(&r0, &c0, &ep.l_a, rng),
        };
        let r_wb = r_wa * link.r_ab;
        let c_b = c_a + r_wa * link.c_ab;
        let r_wc = r_wb * link.r_bc;
        let c_c = c_b + r_wb * link.c_bc;
        let cams = [(r_wb, c_b), (r_wc, c_c)];
        for (s, slot) in ep.slots.iter().enumerate() {
            if !slot.drawable() {
                continue;
            }
            let mut noisy = [Vector2::zeros(); 2];
            for (k, v) in slot.views.iter().enumerate() {
                let eps = Vector2::new(rng.sample(StandardNormal), rng.sample(StandardNormal));
                noisy[k] = v.n0 + v.m * eps;
            }
            if !slot.drawn {
                continue;
            }
            let x = intersect(
                slot.views
                    .iter()
                    .zip(noisy)
                    .map(|(v, uv)| (&cams[v.cam].0, &cams[v.cam].1, uv)),
            );
            if let Some(x) = x.filter(|x| x.iter().all(|v| v.is_finite())) {
                out[s * len + r] = x;
            }
        }
    }
}

#[inline(always)]
pub(super) fn finite(x: &Vec3) -> bool {
    x.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_geometry::triangulate::{self, View};
    use crashrig_geometry::{Rigid3, quat, so3};
    use nalgebra::Vector3;

    #[test]
    fn intersect_matches_geometry_dlt() {
        // Three cameras around a point, observations slightly off (residuals ≠ 0): the lean
        // solver of the draws must give the geometry crate's DLT solution.
        let cams: Vec<Rigid3> = [(0.1, -0.2, 0.05), (-0.3, 0.4, 0.2), (0.2, 0.1, -0.3)]
            .iter()
            .enumerate()
            .map(|(i, &(a, b, c))| {
                let r = so3::exp(&Vector3::new(a, b, c));
                let centre = Vec3::new(300.0 * i as f64, -100.0, -2000.0 + 50.0 * i as f64);
                quat::rigid_from_rotation(&r, &centre) // world_from_cam
            })
            .collect();
        let x = Vec3::new(120.0, 40.0, 500.0);
        let noise = [(1e-3, -2e-3), (-5e-4, 1e-3), (2e-3, 4e-4)];
        let views: Vec<View> = cams
            .iter()
            .zip(noise)
            .map(|(w, (du, dv))| {
                let p = w.inverse() * nalgebra::Point3::from(x);
                View {
                    cam_from_world: w.inverse(),
                    normalized: Vector2::new(p.x / p.z + du, p.y / p.z + dv),
                }
            })
            .collect();
        let expected = triangulate::dlt(&views).unwrap();
        let mats: Vec<(Mat3, Vec3)> = cams
            .iter()
            .map(|w| {
                (
                    w.rotation.to_rotation_matrix().into_inner(),
                    w.translation.vector,
                )
            })
            .collect();
        let got = intersect(
            mats.iter()
                .zip(&views)
                .map(|((r, c), v)| (r, c, v.normalized)),
        )
        .unwrap();
        assert!(
            (got - expected).norm() < 1e-9 * expected.norm(),
            "{got} vs {expected}"
        );
        assert!((got - x).norm() > 1e-3, "the noise must move the solution");
    }
}
