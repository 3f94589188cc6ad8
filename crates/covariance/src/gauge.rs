//! Datum checks before the factorisation: the control points must fix the seven degrees of
//! freedom of a similarity in every connected part of the model.

use crate::Error;
use crate::problem::{PointKind, Problem};
use crashrig_geometry::Vec3;
use nalgebra::Matrix3;
use std::collections::BTreeSet;
use std::path::Path;

/// Control points whose second principal spread is below this fraction of the first are
/// collinear (a line leaves the rotation about it free).
const COLLINEAR_RATIO: f64 = 1e-6;

/// True when the points span at least a plane (three non-collinear points).
pub(crate) fn spans_plane(points: &[Vec3]) -> bool {
    if points.len() < 3 {
        return false;
    }
    let mean = points.iter().sum::<Vec3>() / points.len() as f64;
    let mut c = Matrix3::zeros();
    for p in points {
        let d = p - mean;
        c += d * d.transpose();
    }
    let mut ev: Vec<f64> = c.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    ev[0] > 0.0 && ev[1].max(0.0).sqrt() > COLLINEAR_RATIO * ev[0].sqrt()
}

/// Union–find over frames and free points.
struct Dsu(Vec<usize>);

impl Dsu {
    fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }
    fn union(&mut self, a: usize, b: usize) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b)] = a.min(b);
        }
    }
}

/// Checks the datum: at least three non-collinear control points observed, and in every part
/// of the model connected through free points, three non-collinear control points seen.
///
/// # Errors
/// [`Error::Datum`] naming the control-point file.
pub(crate) fn check(p: &Problem, control_path: &Path) -> Result<(), Error> {
    let err = |problem: String| Error::Datum {
        path: control_path.to_path_buf(),
        problem,
    };
    let all: Vec<Vec3> = p.control.iter().map(|c| c.1).collect();
    if all.len() < 3 {
        return Err(err(format!(
            "{} control point(s) observed by a registered image; the datum needs at least 3 \
             non-collinear ones",
            all.len()
        )));
    }
    if !spans_plane(&all) {
        return Err(err(format!(
            "the {} control points are collinear: the rotation about their line is free",
            all.len()
        )));
    }
    let nf = p.frames.len();
    let mut dsu = Dsu((0..nf + p.points.len()).collect());
    for (j, pt) in p.points.iter().enumerate() {
        if pt.kind != PointKind::Free {
            continue;
        }
        for o in &p.obs[pt.start..pt.end] {
            dsu.union(p.images[o.image].frame, nf + j);
        }
    }
    let mut seen: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); nf];
    for (j, pt) in p.points.iter().enumerate() {
        if pt.kind == PointKind::Free {
            continue;
        }
        for o in &p.obs[pt.start..pt.end] {
            let root = dsu.find(p.images[o.image].frame);
            seen[root].insert(j);
        }
    }
    for (f, seen_f) in seen.iter().enumerate().take(nf) {
        if dsu.find(f) != f {
            continue;
        }
        let pts: Vec<Vec3> = seen_f.iter().map(|&j| p.points[j].xyz).collect();
        if !spans_plane(&pts) {
            return Err(err(format!(
                "the part of the model with image `{}` sees {} control point(s){}; it needs 3 \
                 non-collinear ones (a disconnected image or camera leaves a gauge freedom)",
                p.frames[f].label,
                pts.len(),
                if pts.len() >= 3 {
                    ", all on one line"
                } else {
                    ""
                }
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_test_tells_lines_from_triangles() {
        let line = [
            Vec3::zeros(),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
        ];
        assert!(!spans_plane(&line));
        let tri = [
            Vec3::zeros(),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1e-3, 0.0),
        ];
        assert!(spans_plane(&tri));
        assert!(!spans_plane(&tri[..2]));
    }
}
