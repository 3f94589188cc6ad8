//! Kinematics a crash lab uses: each marker's displacement CFC-filtered ([`crate::filter`]),
//! velocity and acceleration as central differences of the filtered displacement — in the
//! nominal series and **inside every Monte Carlo replicate**, so their σ is the spread of the
//! filtered quantities over the replicates (a filtered σ is not the raw σ: the filter averages
//! the epoch-to-epoch noise and keeps the noise that is common to neighbouring epochs).
//!
//! # Runs
//! A marker's series is filtered per **unbroken run**: measured epochs with consecutive frame
//! numbers in which the marker has a position. A frame without the marker (not seen by two
//! cameras, a degenerate intersection, a frame missing from the sequence) ends the run; the
//! next one starts a new run, filtered on its own (the filter never bridges a gap). A run
//! shorter than [`crate::filter::MIN_SAMPLES`] epochs, or a marker absent from the reference
//! epoch (no displacement), gets no kinematics (blank fields). A replicate in which one of the
//! run's intersections failed is left out of that run's σ.
//!
//! # Differences
//! With `f` the filtered displacement (mm) and `Δt = 1/frame rate` (s), inside a run of `n ≥ 4`:
//! - velocity `v_i = (f_{i+1} − f_{i−1}) / (2Δt)`, at the run's ends the one-sided
//!   `(f_1 − f_0)/Δt` and `(f_{n−1} − f_{n−2})/Δt`;
//! - acceleration `a_i = (f_{i+1} − 2f_i + f_{i−1}) / Δt²`, at the ends the second difference
//!   of the nearest interior epoch;
//! - reported in m/s and m/s² (mm / 1000).
//!
//! # Example
//! ```
//! use crashrig_geometry::Vec3;
//! use crashrig_measure::kinematics::differentiate;
//! // x = 500·t² mm sampled at 1 kHz: v = 1000·t mm/s = t m/s, a = 1000 mm/s² = 1 m/s².
//! let dt = 1e-3;
//! let f: Vec<Vec3> = (0..6).map(|i| Vec3::repeat(500.0 * (i as f64 * dt).powi(2))).collect();
//! let (mut v, mut a) = (Vec::new(), Vec::new());
//! differentiate(&f, dt, &mut v, &mut a);
//! assert!((v[2].x - 2.0 * dt).abs() < 1e-12);
//! assert!(a.iter().all(|a| (a.x - 1.0).abs() < 1e-6));
//! ```

use crate::filter::{Cfc, MIN_SAMPLES};
use crashrig_geometry::Vec3;

/// The filtered kinematics of one (epoch, marker) row; every field is `None` where the row is
/// not in a run that carries kinematics (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KinRow {
    /// Filtered nominal displacement from the reference epoch (mm, world axes).
    pub displacement_mm: Option<Vec3>,
    /// Its σ over the replicates (mm).
    pub displacement_sigma_mm: Option<Vec3>,
    /// Velocity (m/s).
    pub velocity_m_s: Option<Vec3>,
    /// Its σ (m/s).
    pub velocity_sigma_m_s: Option<Vec3>,
    /// Acceleration (m/s²).
    pub acceleration_m_s2: Option<Vec3>,
    /// Its σ (m/s²).
    pub acceleration_sigma_m_s2: Option<Vec3>,
}

/// The kinematics of a measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Kinematics {
    /// The filter (class, standard, frame rate).
    pub filter: Cfc,
    /// One entry per [`crate::Measurement::rows`] row, in the same order.
    pub rows: Vec<KinRow>,
    /// Rows that got kinematics.
    pub rows_with_kinematics: usize,
    /// Number of unbroken runs filtered (all markers).
    pub runs: usize,
}

/// Velocity (m/s) and acceleration (m/s²) of a filtered displacement run `f` (mm) sampled at
/// `dt` (s), by the central differences of the module docs; `v` and `a` are overwritten. Runs
/// shorter than 3 samples give empty outputs.
pub fn differentiate(f: &[Vec3], dt: f64, v: &mut Vec<Vec3>, a: &mut Vec<Vec3>) {
    v.clear();
    a.clear();
    let n = f.len();
    if n < 3 {
        return;
    }
    let to_m = 1e-3;
    v.push((f[1] - f[0]) * (to_m / dt));
    for i in 1..n - 1 {
        v.push((f[i + 1] - f[i - 1]) * (to_m / (2.0 * dt)));
    }
    v.push((f[n - 1] - f[n - 2]) * (to_m / dt));
    let second = |i: usize| (f[i + 1] - f[i] * 2.0 + f[i - 1]) * (to_m / (dt * dt));
    a.push(second(1));
    for i in 1..n - 1 {
        a.push(second(i));
    }
    a.push(second(n - 2));
}

/// One unbroken run of a marker: measured epochs `start..start + len`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Run {
    pub marker: usize,
    pub start: usize,
    pub len: usize,
}

/// The runs of every marker (module docs). `has(e, m)`: marker `m` has a position in measured
/// epoch `e`; `frames[e]`: its frame number.
pub(crate) fn runs(
    n_markers: usize,
    frames: &[u64],
    has: impl Fn(usize, usize) -> bool,
) -> Vec<Vec<Run>> {
    (0..n_markers)
        .map(|m| {
            let mut out = Vec::new();
            let mut e = 0;
            while e < frames.len() {
                if !has(e, m) {
                    e += 1;
                    continue;
                }
                let start = e;
                while e + 1 < frames.len() && has(e + 1, m) && frames[e + 1] == frames[e] + 1 {
                    e += 1;
                }
                let len = e + 1 - start;
                if len >= MIN_SAMPLES {
                    out.push(Run {
                        marker: m,
                        start,
                        len,
                    });
                }
                e += 1;
            }
            out
        })
        .collect()
}

/// Streaming per-axis mean and variance (Welford, as [`crashrig_stats::Moments`] per diagonal
/// element, without the off-diagonal work that σ per axis does not need). The count lives in
/// [`RunAcc`]: every epoch of a run takes the same replicates.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct AxisMoments {
    mean: Vec3,
    m2: Vec3,
}

impl AxisMoments {
    /// Adds the `n`-th sample, `inv_n = 1/n`.
    #[inline]
    pub fn push(&mut self, x: &Vec3, inv_n: f64) {
        let delta = x - self.mean;
        self.mean += delta * inv_n;
        self.m2 += delta.component_mul(&(x - self.mean));
    }

    /// σ per axis (n − 1) after `n` samples, `None` below two.
    pub fn std_dev(&self, n: u64) -> Option<Vec3> {
        (n >= 2).then(|| (self.m2 / (n as f64 - 1.0)).map(f64::sqrt))
    }
}

/// Streaming moments of one run's filtered displacement, velocity and acceleration: per
/// epoch of the run `[d, v, a]`, and the number of replicates taken.
#[derive(Debug, Clone, Default)]
pub(crate) struct RunAcc {
    pub n: u64,
    pub m: Vec<[AxisMoments; 3]>,
}

impl RunAcc {
    pub fn new(len: usize) -> RunAcc {
        RunAcc {
            n: 0,
            m: vec![[AxisMoments::default(); 3]; len],
        }
    }
}

/// Reusable buffers of one filtering task.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    work: Vec<Vec3>,
    /// The displacement runs of a chunk's replicates, replicate-major (filled by the caller).
    pub d: Vec<Vec3>,
    pub f: Vec<Vec3>,
    pub v: Vec<Vec3>,
    pub a: Vec<Vec3>,
}

impl Scratch {
    /// Filters the displacement run `d` (mm; the three axes at once, each exactly as a scalar
    /// record, [`crate::filter::Sample`]) and differentiates it: the results are in `self.f`,
    /// `self.v`, `self.a`.
    pub fn filter_and_differentiate(&mut self, filter: &Cfc, d: &[Vec3]) {
        self.f.clear();
        self.f.resize(d.len(), Vec3::zeros());
        filter.filter_into(d, &mut self.f, &mut self.work);
        differentiate(
            &self.f,
            1.0 / filter.frame_rate_hz(),
            &mut self.v,
            &mut self.a,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_split_at_gaps_and_missing_frames() {
        // Frames 1..=12 with frame 8 missing from the sequence; marker 0 absent at index 3.
        let frames: Vec<u64> = (1..=12).filter(|&f| f != 8).collect();
        let r = runs(2, &frames, |e, m| !(m == 0 && e == 3));
        // Marker 0: [0,1,2] too short, [4,5,6] (frames 5,6,7) too short, [7..11) frames 9..12.
        assert_eq!(
            r[0],
            vec![Run {
                marker: 0,
                start: 7,
                len: 4
            }]
        );
        // Marker 1: frames 1..=7 (indices 0..7), then 9..=12.
        assert_eq!(r[1].len(), 2);
        assert_eq!((r[1][0].start, r[1][0].len), (0, 7));
        assert_eq!((r[1][1].start, r[1][1].len), (7, 4));
    }

    #[test]
    fn axis_moments_are_the_diagonal_of_moments() {
        let xs = [
            Vec3::new(1.0, -2.0, 0.5),
            Vec3::new(3.0, 0.0, 0.25),
            Vec3::new(-1.0, 5.0, 2.0),
        ];
        let mut a = AxisMoments::default();
        let mut full = crashrig_stats::Moments::<3>::new();
        for (k, x) in xs.iter().enumerate() {
            a.push(x, 1.0 / (k + 1) as f64);
            full.push_vec(x);
        }
        let (got, want) = (a.std_dev(3).unwrap(), full.std_dev());
        assert!((got - want).norm() < 1e-15 * want.norm(), "{got} {want}");
        // Known answer: x values 1, 3, −1 → mean 1, variance (0 + 4 + 4)/2 = 4.
        assert!((got.x - 2.0).abs() < 1e-15);
        assert_eq!(a.std_dev(1), None);
    }

    #[test]
    fn differences_are_exact_on_a_cubic_interior() {
        // x = t³ (mm): v = 3t² exactly up to the O(Δt²) term t-independent Δt²; a = 6t.
        let dt = 0.01;
        let f: Vec<Vec3> = (0..8)
            .map(|i| Vec3::repeat((i as f64 * dt).powi(3)))
            .collect();
        let (mut v, mut a) = (Vec::new(), Vec::new());
        differentiate(&f, dt, &mut v, &mut a);
        for i in 1..7 {
            let t = i as f64 * dt;
            // Central difference of t³: 3t² + Δt² (exact), second difference: 6t (exact).
            assert!((v[i].x - 1e-3 * (3.0 * t * t + dt * dt)).abs() < 1e-15);
            assert!((a[i].x - 1e-3 * 6.0 * t).abs() < 1e-9);
        }
        assert_eq!(a[0], a[1]);
        assert_eq!(a[7], a[6]);
    }
}
