//! Streaming sums of 3-D points about a fixed shift, mergeable and vectorisable.
//!
//! The intersected points of one grid point scatter by millimetres around the grid point, so
//! sums of deviations from the grid point (`Σ(x − s)`, `Σ(x − s)(x − s)ᵀ`) lose nothing to
//! cancellation (the shifted-data algorithm; Chan, Golub & LeVeque 1983) and, unlike Welford's
//! update, need no division per draw and vectorise across draws. Merging adds the sums, so a
//! fixed merge order gives bit-identical results for any thread count.

use nalgebra::{Matrix3, Vector3};

/// Count, first and second sums of deviations from `shift`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Acc3 {
    shift: Vector3<f64>,
    n: u64,
    s1: [f64; 3],
    /// xx, xy, xz, yy, yz, zz.
    s2: [f64; 6],
}

impl Acc3 {
    /// Empty, with deviations taken from `shift`.
    pub(crate) fn new(shift: Vector3<f64>) -> Self {
        Self {
            shift,
            n: 0,
            s1: [0.0; 3],
            s2: [0.0; 6],
        }
    }

    /// The shift.
    #[cfg(test)]
    pub(crate) fn shift(&self) -> Vector3<f64> {
        self.shift
    }

    /// Adds one point.
    #[cfg(test)]
    pub(crate) fn push(&mut self, x: &Vector3<f64>) {
        let d = x - self.shift;
        self.n += 1;
        self.s1[0] += d.x;
        self.s1[1] += d.y;
        self.s1[2] += d.z;
        self.s2[0] += d.x * d.x;
        self.s2[1] += d.x * d.y;
        self.s2[2] += d.x * d.z;
        self.s2[3] += d.y * d.y;
        self.s2[4] += d.y * d.z;
        self.s2[5] += d.z * d.z;
    }

    /// Adds `other`'s sums (both must use the same shift; `other`'s is re-based otherwise).
    pub(crate) fn merge(&mut self, other: &Self) {
        if other.n == 0 {
            return;
        }
        let o = other.rebased(self.shift);
        self.n += o.n;
        for k in 0..3 {
            self.s1[k] += o.s1[k];
        }
        for k in 0..6 {
            self.s2[k] += o.s2[k];
        }
    }

    /// The same sums about another shift (exact algebra: `Σ(x−t) = Σ(x−s) + n(s−t)` etc.).
    fn rebased(&self, shift: Vector3<f64>) -> Self {
        if shift == self.shift {
            return *self;
        }
        let a = self.shift - shift;
        let n = self.n as f64;
        let s1 = [
            self.s1[0] + n * a.x,
            self.s1[1] + n * a.y,
            self.s1[2] + n * a.z,
        ];
        let idx = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
        let mut s2 = self.s2;
        for (k, &(i, j)) in idx.iter().enumerate() {
            s2[k] += a[i] * self.s1[j] + a[j] * self.s1[i] + n * a[i] * a[j];
        }
        Self {
            shift,
            n: self.n,
            s1,
            s2,
        }
    }

    /// Number of points.
    pub(crate) fn count(&self) -> u64 {
        self.n
    }

    /// Mean (zeros-shift when empty).
    pub(crate) fn mean(&self) -> Vector3<f64> {
        if self.n == 0 {
            return self.shift;
        }
        let n = self.n as f64;
        self.shift + Vector3::new(self.s1[0] / n, self.s1[1] / n, self.s1[2] / n)
    }

    /// Sample covariance (n − 1); NaN when n < 2.
    pub(crate) fn covariance(&self) -> Matrix3<f64> {
        if self.n < 2 {
            return Matrix3::from_element(f64::NAN);
        }
        let n = self.n as f64;
        let c =
            |k: usize, i: usize, j: usize| (self.s2[k] - self.s1[i] * self.s1[j] / n) / (n - 1.0);
        let (xx, xy, xz, yy, yz, zz) = (
            c(0, 0, 0),
            c(1, 0, 1),
            c(2, 0, 2),
            c(3, 1, 1),
            c(4, 1, 2),
            c(5, 2, 2),
        );
        Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
    }

    /// Sample standard deviations.
    pub(crate) fn std_dev(&self) -> Vector3<f64> {
        let c = self.covariance();
        Vector3::new(c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt())
    }
}

/// Per-lane partial sums of a block kernel (reduced in lane order at the end of a chunk).
#[derive(Debug, Clone)]
pub(crate) struct LaneSums<const L: usize> {
    n: u64,
    s1: [[f64; L]; 3],
    s2: [[f64; L]; 6],
}

impl<const L: usize> Default for LaneSums<L> {
    fn default() -> Self {
        Self {
            n: 0,
            s1: [[0.0; L]; 3],
            s2: [[0.0; L]; 6],
        }
    }
}

impl<const L: usize> LaneSums<L> {
    /// Adds the first `b` lanes of `xs` (x, y, z rows) as deviations from `shift`.
    #[inline(always)]
    pub(crate) fn add(&mut self, xs: &[[f64; L]; 3], b: usize, shift: &Vector3<f64>) {
        self.n += b as u64;
        #[allow(clippy::needless_range_loop)] // one index over three parallel lane arrays
        for d in 0..b.min(L) {
            self.add_lane(d, [xs[0][d], xs[1][d], xs[2][d]], shift);
        }
    }

    /// Adds point `p` to lane `d` (as a deviation from `shift`) without counting it: callers
    /// that add whole blocks lane by lane count them once with [`Self::count`].
    #[inline(always)]
    pub(crate) fn add_lane(&mut self, d: usize, p: [f64; 3], shift: &Vector3<f64>) {
        let x = p[0] - shift.x;
        let y = p[1] - shift.y;
        let z = p[2] - shift.z;
        self.s1[0][d] += x;
        self.s1[1][d] += y;
        self.s1[2][d] += z;
        self.s2[0][d] += x * x;
        self.s2[1][d] += x * y;
        self.s2[2][d] += x * z;
        self.s2[3][d] += y * y;
        self.s2[4][d] += y * z;
        self.s2[5][d] += z * z;
    }

    /// Counts `b` points added with [`Self::add_lane`].
    #[inline(always)]
    pub(crate) fn count(&mut self, b: usize) {
        self.n += b as u64;
    }

    /// Sums over lanes, in lane order.
    pub(crate) fn reduce(&self, shift: Vector3<f64>) -> Acc3 {
        let mut a = Acc3::new(shift);
        a.n = self.n;
        for k in 0..3 {
            a.s1[k] = self.s1[k].iter().sum();
        }
        for k in 0..6 {
            a.s2[k] = self.s2[k].iter().sum();
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use crashrig_stats::Moments;

    fn points() -> Vec<Vector3<f64>> {
        (0..200)
            .map(|i| {
                let t = i as f64;
                Vector3::new(
                    1000.0 + (t * 0.7).sin(),
                    -300.0 + (t * 1.3).cos() * 2.0,
                    5.0 + (t * 0.37).sin() * (t * 0.11).cos(),
                )
            })
            .collect()
    }

    #[test]
    fn acc3_nominal_matches_welford() {
        let pts = points();
        let mut a = Acc3::new(Vector3::new(1000.0, -300.0, 5.0));
        let mut m = Moments::<3>::new();
        for p in &pts {
            a.push(p);
            m.push_vec(p);
        }
        // Both are accurate to a few ulps of the O(1 mm²) covariance here.
        assert_relative_eq!(a.mean(), m.mean(), epsilon = 1e-12);
        assert_relative_eq!(a.covariance(), m.covariance(), epsilon = 1e-12);
        assert_eq!(a.count(), 200);
    }

    #[test]
    fn acc3_merge_with_other_shift_is_exact() {
        let pts = points();
        let mut all = Acc3::new(Vector3::new(1000.0, -300.0, 5.0));
        pts.iter().for_each(|p| all.push(p));
        let mut a = Acc3::new(Vector3::new(1000.0, -300.0, 5.0));
        let mut b = Acc3::new(Vector3::new(990.0, -310.0, 0.0));
        pts[..70].iter().for_each(|p| a.push(p));
        pts[70..].iter().for_each(|p| b.push(p));
        a.merge(&b);
        assert_relative_eq!(a.mean(), all.mean(), epsilon = 1e-12);
        // Re-basing by ~10 mm costs ~1e-13 relative (sums of ~1e4 mm² terms).
        assert_relative_eq!(a.covariance(), all.covariance(), epsilon = 1e-10);
    }

    #[test]
    fn lane_sums_equal_sequential_pushes() {
        let pts = points();
        let shift = Vector3::new(1000.0, -300.0, 5.0);
        let mut xs = [[0.0; 8]; 3];
        let mut lanes = LaneSums::<8>::default();
        let mut seq = Acc3::new(shift);
        for chunk in pts.chunks(8) {
            for (d, p) in chunk.iter().enumerate() {
                xs[0][d] = p.x;
                xs[1][d] = p.y;
                xs[2][d] = p.z;
                seq.push(p);
            }
            lanes.add(&xs, chunk.len(), &shift);
        }
        let r = lanes.reduce(shift);
        assert_eq!(r.count(), seq.count());
        // Different summation order only.
        assert_relative_eq!(r.covariance(), seq.covariance(), epsilon = 1e-12);
    }
}
