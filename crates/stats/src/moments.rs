//! Streaming mean and covariance of fixed-size vectors (Welford / Chan et al.).

use nalgebra::{SMatrix, SVector};

/// Streaming first and second moments of `N`-vectors.
///
/// Memory is O(N²) regardless of the number of samples. [`Moments::merge`] combines two
/// accumulators exactly (Chan, Golub & LeVeque), so chunked parallel runs reduced in a fixed
/// order are bit-reproducible.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments<const N: usize> {
    n: u64,
    mean: SVector<f64, N>,
    /// Sum of outer products of deviations from the running mean.
    m2: SMatrix<f64, N, N>,
}

impl<const N: usize> Default for Moments<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Moments<N> {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self {
            n: 0,
            mean: SVector::zeros(),
            m2: SMatrix::zeros(),
        }
    }

    /// Adds one sample.
    #[inline]
    pub fn push(&mut self, x: &[f64; N]) {
        self.n += 1;
        let x = SVector::<f64, N>::from_column_slice(x);
        let delta = x - self.mean;
        self.mean += delta / self.n as f64;
        let delta2 = x - self.mean;
        self.m2 += delta * delta2.transpose();
    }

    /// Adds one sample given as a vector.
    #[inline]
    pub fn push_vec(&mut self, x: &SVector<f64, N>) {
        self.n += 1;
        let delta = x - self.mean;
        self.mean += delta / self.n as f64;
        let delta2 = x - self.mean;
        self.m2 += delta * delta2.transpose();
    }

    /// Combines `other` into `self` (exact, order-dependent only in rounding).
    pub fn merge(&mut self, other: &Self) {
        if other.n == 0 {
            return;
        }
        if self.n == 0 {
            *self = *other;
            return;
        }
        let n_a = self.n as f64;
        let n_b = other.n as f64;
        let n = n_a + n_b;
        let delta = other.mean - self.mean;
        self.mean += delta * (n_b / n);
        self.m2 += other.m2 + delta * delta.transpose() * (n_a * n_b / n);
        self.n += other.n;
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// Sample mean (zeros when empty).
    pub fn mean(&self) -> SVector<f64, N> {
        self.mean
    }

    /// The accumulator's state: count, mean and the sum of outer products of deviations
    /// (what [`Moments::from_parts`] takes back, bit for bit; e.g. to store an unfinished
    /// accumulator and continue or finish it elsewhere).
    pub fn parts(&self) -> (u64, SVector<f64, N>, SMatrix<f64, N, N>) {
        (self.n, self.mean, self.m2)
    }

    /// The accumulator whose state is `(n, mean, m2)` ([`Moments::parts`]).
    pub fn from_parts(n: u64, mean: SVector<f64, N>, m2: SMatrix<f64, N, N>) -> Self {
        Self { n, mean, m2 }
    }

    /// Sample covariance with divisor n − 1 (NaN when n < 2).
    pub fn covariance(&self) -> SMatrix<f64, N, N> {
        if self.n < 2 {
            return SMatrix::from_element(f64::NAN);
        }
        self.m2 / (self.n as f64 - 1.0)
    }

    /// Sample standard deviations (divisor n − 1; NaN when n < 2).
    pub fn std_dev(&self) -> SVector<f64, N> {
        let c = self.covariance();
        SVector::from_fn(|i, _| c[(i, i)].sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_round_trip_and_continue() {
        let mut a = Moments::<2>::new();
        for x in [[1.0, 2.0], [0.5, -3.0], [7.25, 0.125]] {
            a.push(&x);
        }
        let (n, mean, m2) = a.parts();
        let mut b = Moments::from_parts(n, mean, m2);
        assert_eq!(a, b);
        a.push(&[2.0, 2.0]);
        b.push(&[2.0, 2.0]);
        assert_eq!(a, b);
    }
    use approx::assert_relative_eq;

    #[test]
    fn moments_nominal_matches_two_pass() {
        let xs = [[1.0, 2.0], [2.0, 1.0], [4.0, 0.5], [7.0, -3.0], [-1.0, 2.5]];
        let mut m = Moments::<2>::new();
        for x in &xs {
            m.push(x);
        }
        let n = xs.len() as f64;
        let mx = xs.iter().map(|x| x[0]).sum::<f64>() / n;
        let my = xs.iter().map(|x| x[1]).sum::<f64>() / n;
        let cxy = xs.iter().map(|x| (x[0] - mx) * (x[1] - my)).sum::<f64>() / (n - 1.0);
        let cxx = xs.iter().map(|x| (x[0] - mx).powi(2)).sum::<f64>() / (n - 1.0);
        // Welford vs two-pass differ only by rounding.
        assert_relative_eq!(m.mean()[0], mx, epsilon = 1e-14);
        assert_relative_eq!(m.mean()[1], my, epsilon = 1e-14);
        assert_relative_eq!(m.covariance()[(0, 1)], cxy, epsilon = 1e-13);
        assert_relative_eq!(m.covariance()[(1, 0)], cxy, epsilon = 1e-13);
        assert_relative_eq!(m.std_dev()[0], cxx.sqrt(), epsilon = 1e-13);
    }

    #[test]
    fn moments_merge_equals_sequential() {
        let xs: Vec<[f64; 3]> = (0..50)
            .map(|i| [i as f64, (i * i % 7) as f64, (i as f64).sin()])
            .collect();
        let mut all = Moments::<3>::new();
        xs.iter().for_each(|x| all.push(x));
        let mut a = Moments::<3>::new();
        let mut b = Moments::<3>::new();
        xs[..17].iter().for_each(|x| a.push(x));
        xs[17..].iter().for_each(|x| b.push(x));
        a.merge(&b);
        assert_eq!(a.count(), 50);
        for i in 0..3 {
            assert_relative_eq!(a.mean()[i], all.mean()[i], epsilon = 1e-12);
            for j in 0..3 {
                assert_relative_eq!(
                    a.covariance()[(i, j)],
                    all.covariance()[(i, j)],
                    epsilon = 1e-11
                );
            }
        }
    }

    #[test]
    fn moments_too_few_is_nan() {
        let mut m = Moments::<1>::new();
        m.push(&[3.0]);
        assert!(m.std_dev()[0].is_nan());
    }
}
