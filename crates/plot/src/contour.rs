//! Iso-lines of a gridded field by marching squares.

/// Line segments of the iso-line `value == level` of a field sampled at grid nodes.
///
/// `values[iy * xs.len() + ix]` is the field at `(xs[ix], ys[iy])`. Each grid cell whose four
/// corners are finite and straddle `level` contributes one or two segments, with end points
/// linearly interpolated along the cell edges (saddle cells are split using the mean of the
/// four corners). Returns an empty list when the level is never crossed or the lengths do
/// not match.
pub fn contour_segments(
    xs: &[f64],
    ys: &[f64],
    values: &[f64],
    level: f64,
) -> Vec<((f64, f64), (f64, f64))> {
    let nx = xs.len();
    let ny = ys.len();
    let mut out = Vec::new();
    if nx < 2 || ny < 2 || values.len() != nx * ny || !level.is_finite() {
        return out;
    }
    let v = |ix: usize, iy: usize| values[iy * nx + ix];
    // Interpolated crossing between two nodes (value a at p, value b at q).
    let cross = |p: (f64, f64), a: f64, q: (f64, f64), b: f64| {
        let t = if b != a { (level - a) / (b - a) } else { 0.5 };
        (p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1))
    };
    for iy in 0..ny - 1 {
        for ix in 0..nx - 1 {
            // Corners counter-clockwise: 0 (x0,y0), 1 (x1,y0), 2 (x1,y1), 3 (x0,y1).
            let p = [
                (xs[ix], ys[iy]),
                (xs[ix + 1], ys[iy]),
                (xs[ix + 1], ys[iy + 1]),
                (xs[ix], ys[iy + 1]),
            ];
            let c = [v(ix, iy), v(ix + 1, iy), v(ix + 1, iy + 1), v(ix, iy + 1)];
            if c.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let above: Vec<bool> = c.iter().map(|&x| x >= level).collect();
            // Edge k joins corner k and k+1.
            let mut pts = Vec::with_capacity(4);
            for k in 0..4 {
                let j = (k + 1) % 4;
                if above[k] != above[j] {
                    pts.push((k, cross(p[k], c[k], p[j], c[j])));
                }
            }
            match pts.len() {
                2 => out.push((pts[0].1, pts[1].1)),
                4 => {
                    // Saddle: decide the pairing by the centre value.
                    let centre = c.iter().sum::<f64>() / 4.0;
                    if (centre >= level) == above[0] {
                        out.push((pts[0].1, pts[3].1));
                        out.push((pts[1].1, pts[2].1));
                    } else {
                        out.push((pts[0].1, pts[1].1));
                        out.push((pts[2].1, pts[3].1));
                    }
                }
                _ => {}
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn contour_segments_nominal_linear_ramp() {
        // f = x on a 3×2 grid, level 0.5: one vertical segment at x = 0.5 in the first column.
        let xs = [0.0, 1.0, 2.0];
        let ys = [0.0, 1.0];
        let values = [0.0, 1.0, 2.0, 0.0, 1.0, 2.0];
        let segs = contour_segments(&xs, &ys, &values, 0.5);
        assert_eq!(segs.len(), 1);
        let ((ax, ay), (bx, by)) = segs[0];
        // Linear interpolation of a linear field is exact up to rounding.
        assert_abs_diff_eq!(ax, 0.5, epsilon = 1e-15);
        assert_abs_diff_eq!(bx, 0.5, epsilon = 1e-15);
        assert_abs_diff_eq!((ay - by).abs(), 1.0, epsilon = 1e-15);
    }

    #[test]
    fn contour_segments_no_crossing_is_empty() {
        let values = [1.0, 2.0, 3.0, 4.0];
        assert!(contour_segments(&[0.0, 1.0], &[0.0, 1.0], &values, 10.0).is_empty());
        assert!(contour_segments(&[0.0, 1.0], &[0.0, 1.0], &values[..3], 2.5).is_empty());
    }

    #[test]
    fn contour_segments_saddle_gives_two() {
        // Row-major: (0,0)=1, (1,0)=0, (0,1)=0, (1,1)=1 — diagonal corners agree.
        let values = [1.0, 0.0, 0.0, 1.0];
        let segs = contour_segments(&[0.0, 1.0], &[0.0, 1.0], &values, 0.5);
        assert_eq!(segs.len(), 2);
    }
}
