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

use crate::filter::{Cfc, MIN_SAMPLES, Sample};
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
/// shorter than 3 samples give empty outputs. `T` is a [`Vec3`] (or any [`Sample`]: each
/// component is differentiated as its own record).
pub fn differentiate<T: Sample>(f: &[T], dt: f64, v: &mut Vec<T>, a: &mut Vec<T>) {
    v.clear();
    a.clear();
    if f.len() < 3 {
        return;
    }
    let d = Differences::new(dt);
    v.extend((0..f.len()).map(|i| d.velocity(f, i)));
    a.extend((0..f.len()).map(|i| d.acceleration(f, i)));
}

/// The difference quotients of [`differentiate`] at one sample of a run (`f.len() ≥ 3`): the
/// one place their formulas live.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Differences {
    /// mm → m over `Δt`, over `2Δt`, over `Δt²`.
    one_sided: f64,
    central: f64,
    second: f64,
}

impl Differences {
    pub fn new(dt: f64) -> Differences {
        let to_m = 1e-3;
        Differences {
            one_sided: to_m / dt,
            central: to_m / (2.0 * dt),
            second: to_m / (dt * dt),
        }
    }

    /// Velocity at sample `i` (central inside, one-sided at the ends).
    #[inline(always)]
    pub fn velocity<T: Sample>(&self, f: &[T], i: usize) -> T {
        let n = f.len();
        if i == 0 {
            (f[1] - f[0]) * self.one_sided
        } else if i == n - 1 {
            (f[n - 1] - f[n - 2]) * self.one_sided
        } else {
            (f[i + 1] - f[i - 1]) * self.central
        }
    }

    /// Acceleration at sample `i` (the second difference of the nearest interior sample).
    #[inline(always)]
    pub fn acceleration<T: Sample>(&self, f: &[T], i: usize) -> T {
        let j = i.clamp(1, f.len() - 2);
        (f[j + 1] - f[j] * 2.0 + f[j - 1]) * self.second
    }
}

/// Replicates filtered side by side by the Monte Carlo ([`Lanes`]).
pub(crate) const LANES: usize = 4;

/// The displacements of [`LANES`] replicates at one epoch (`[x₀ y₀ z₀ x₁ y₁ z₁ …]`): a
/// [`Sample`] whose components the filter and the differences treat as independent records,
/// each with exactly the arithmetic of a [`Vec3`] record (the same bits), while the
/// replicates' recurrences run side by side in the CPU's vector lanes instead of one after
/// another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Lanes(pub [f64; 3 * LANES]);

impl Lanes {
    /// Replicate `l`'s displacement.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Vec3 {
        Vec3::new(self.0[3 * l], self.0[3 * l + 1], self.0[3 * l + 2])
    }

    /// Sets replicate `l`'s displacement.
    #[inline(always)]
    pub fn set_lane(&mut self, l: usize, x: &Vec3) {
        self.0[3 * l..3 * l + 3].copy_from_slice(x.as_slice());
    }

    #[inline(always)]
    fn zip(self, o: Lanes, f: impl Fn(f64, f64) -> f64) -> Lanes {
        Lanes(std::array::from_fn(|k| f(self.0[k], o.0[k])))
    }
}

impl std::ops::Add for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn add(self, o: Lanes) -> Lanes {
        self.zip(o, |a, b| a + b)
    }
}

impl std::ops::Sub for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn sub(self, o: Lanes) -> Lanes {
        self.zip(o, |a, b| a - b)
    }
}

impl std::ops::Mul<f64> for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn mul(self, c: f64) -> Lanes {
        Lanes(self.0.map(|a| a * c))
    }
}

impl std::ops::Div<f64> for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn div(self, c: f64) -> Lanes {
        Lanes(self.0.map(|a| a / c))
    }
}

impl Sample for Lanes {}

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
    pub mean: Vec3,
    pub m2: Vec3,
}

impl AxisMoments {
    /// Adds the `n`-th sample, `inv_n = 1/n`.
    #[inline(always)]
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

/// Reusable buffers of one filtering task (`T`: a [`Vec3`] for the nominal series, [`Lanes`]
/// for the Monte Carlo's replicates).
#[derive(Debug)]
pub(crate) struct Scratch<T> {
    work: Vec<T>,
    /// The displacement run to filter (filled by the caller).
    pub d: Vec<T>,
    pub f: Vec<T>,
    pub v: Vec<T>,
    pub a: Vec<T>,
    /// The Monte Carlo's gather: each run epoch's slot.
    pub slots: Vec<usize>,
}

impl<T> Default for Scratch<T> {
    fn default() -> Scratch<T> {
        Scratch {
            work: Vec::new(),
            d: Vec::new(),
            f: Vec::new(),
            v: Vec::new(),
            a: Vec::new(),
            slots: Vec::new(),
        }
    }
}

impl<T: Sample> Scratch<T> {
    /// Filters the displacement run `d` (mm; each component exactly as a scalar record,
    /// [`crate::filter::Sample`]) into `self.f`.
    #[inline(always)]
    pub fn filter(&mut self, filter: &Cfc, d: &[T]) {
        // Every element is overwritten by the filter: only the length matters (unchanged, so
        // nothing is written, when the previous record had the same length).
        if let Some(&x0) = d.first() {
            self.f.resize(d.len(), x0);
        }
        self.f.truncate(d.len());
        filter.filter_into(d, &mut self.f, &mut self.work);
    }

    /// [`Scratch::filter`], then differentiates: the results are in `self.f`, `self.v`,
    /// `self.a`.
    pub fn filter_and_differentiate(&mut self, filter: &Cfc, d: &[T]) {
        self.filter(filter, d);
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
