//! The channel frequency class (CFC) filter of crash testing: the phaseless 4-pole Butterworth
//! low-pass of SAE J211-1 (Appendix C) and ISO 6487 (Annex A), as two passes — forward, then
//! backward — of one 2-pole Butterworth section.
//!
//! # The difference equation (both standards)
//! With `T` the sampling interval (s), the 2-pole section is
//! ```text
//! ω_d = 2π · CFC · k            (design corner, rad/s; k below)
//! ω_a = tan(ω_d · T / 2)        (bilinear pre-warping)
//! a₀ = ω_a² / (1 + √2·ω_a + ω_a²),   a₁ = 2·a₀,   a₂ = a₀
//! b₁ = −2·(ω_a² − 1) / (1 + √2·ω_a + ω_a²)
//! b₂ = (−1 + √2·ω_a − ω_a²) / (1 + √2·ω_a + ω_a²)
//! Y[t] = a₀·X[t] + a₁·X[t−1] + a₂·X[t−2] + b₁·Y[t−1] + b₂·Y[t−2]
//! ```
//! run forward over the data and then backward over the forward output (the phase shifts of
//! the two passes cancel; the magnitude response is the square of one pass's).
//!
//! # What differs between the two standards
//! - **The constant `k`.** The −3 dB frequency of a channel class is `F_H = 5/3 · CFC`; two
//!   passes of a 2-pole Butterworth with corner `f_c` are 3 dB down where
//!   `(1 + (f/f_c)⁴)² = 2`, i.e. at `f = (√2 − 1)^{1/4} · f_c = 0.80225 · f_c`. SAE J211-1
//!   (Appendix C, from its 2003 revision) writes the exact factor `k = 5/3 / 0.80225 = 2.0775`;
//!   ISO 6487 (Annex A) rounds `1/0.80225` to 1.25 and writes `k = 1.25 · 5/3 = 2.0833` (as
//!   pyisomme's `Channel.cfc` computes it: `2π · CFC / 0.6 · 1.25`). The ISO corner is 0.28 %
//!   higher.
//! - **The ends.** ISO 6487 ([`Standard::Iso6487`]) extends the record at both ends by point
//!   reflection about its end values (`2·x₀ − x_i`, `2·x_{n−1} − x_{n−1−i}`) over
//!   `max(10 ms, 100 samples)` (at most `n − 1` samples, truncated to whole samples as
//!   `⌊min(max(0.01/T, 100), n − 1)⌋`), starts each pass with its first two outputs equal to the
//!   mean of the first ten values the pass reads, and cuts the extension off afterwards — a
//!   record that moves at a constant rate at its end keeps that rate through the filter.
//!   SAE J211-1 ([`Standard::J211`]) prescribes the difference equation and the two passes but
//!   no extension: it asks for data before time zero so that the start-up transient has died
//!   out before the event. crashrig starts each J211 pass **at rest on the end value** it
//!   starts from (`X[−1] = X[−2] = Y[−1] = Y[−2] = X[0]`, the steady state of the section for a
//!   constant input): a record that is at rest at its ends (a displacement before the impact,
//!   a vehicle at standstill after it) passes without a transient, one that still moves at an
//!   end gets a transient over a few `1/F_H` there. The reference implementation pyisomme
//!   (1.1.0) starts its `SAE-J211-1` passes from zero instead (and uses ISO's `k`), which puts
//!   a step of the full end value into the record; that is not reproduced.
//!
//! # Which classes a frame rate carries
//! A class is refused unless the design corner is well below the Nyquist frequency:
//! `k · CFC ≤ 0.8 · f_s / 2` ([`NYQUIST_FRACTION`]). Beyond it the bilinear pre-warping
//! stretches the digital response by more than a factor `tan(0.4π)/(0.4π) = 2.45` and the
//! section's poles approach `z = −1`: the filter no longer is the class's analogue response.
//! At 1000 frames/s this admits CFC 60 and 180 (`2.0833 · 180 = 375 Hz ≤ 400 Hz`), CFC 600
//! needs ≥ 3125 frames/s and CFC 1000 ≥ 5208 frames/s. A record needs at least
//! [`MIN_SAMPLES`] samples.
//!
//! # Worked example (J211-1 Appendix C's recipe, numbers from this module)
//! CFC 60 sampled at 10 kHz (`T = 10⁻⁴ s`): `ω_d = 2π·60·2.0775 = 783.19 rad/s`,
//! `ω_a = tan(0.039160) = 0.039180`, `a₀ = 0.0014524`, `b₁ = 1.8893`, `b₂ = −0.89515`.
//! ```
//! use crashrig_measure::filter::{Cfc, Standard};
//!
//! let f = Cfc::new(60, Standard::J211, 10_000.0)?;
//! let c = f.coefficients();
//! assert!((c.a0 - 0.0014524).abs() < 1e-7);
//! assert!((c.b1 - 1.8893).abs() < 1e-4 && (c.b2 + 0.89515).abs() < 1e-5);
//! // Unit gain at DC: a record at rest stays where it is.
//! let still = f.filter(&[3.0; 50]);
//! assert!(still.iter().all(|y| (y - 3.0).abs() < 1e-12));
//! // CFC 1000 is refused at 1000 frames/s (its corner lies above the Nyquist frequency).
//! assert!(Cfc::new(1000, Standard::J211, 1000.0).is_err());
//! # Ok::<(), crashrig_measure::Error>(())
//! ```

use crate::Error;

/// The channel frequency classes of SAE J211-1 / ISO 6487 that `--cfc` accepts.
pub const CLASSES: [u32; 4] = [60, 180, 600, 1000];

/// The design corner `k · CFC` may be at most this fraction of the Nyquist frequency.
pub const NYQUIST_FRACTION: f64 = 0.8;

/// The shortest record the filter takes (ISO 6487's end handling needs four samples to form
/// its ten-value start means).
pub const MIN_SAMPLES: usize = 4;

/// Which standard's constant and end handling (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Standard {
    /// SAE J211-1 Appendix C: `k = 2.0775`, each pass started at rest on its first value.
    J211,
    /// ISO 6487 Annex A: `k = 1.25 · 5/3`, point-reflected extension, ten-value start means.
    Iso6487,
}

impl Standard {
    /// The name `--cfc-standard` takes and `summary.json` writes (`j211`, `iso6487`).
    pub fn name(self) -> &'static str {
        match self {
            Standard::J211 => "j211",
            Standard::Iso6487 => "iso6487",
        }
    }

    /// The standard of a name ([`Standard::name`]).
    ///
    /// # Errors
    /// [`Error::Setting`] naming `--cfc-standard` for any other text.
    pub fn parse(s: &str) -> Result<Standard, Error> {
        match s {
            "j211" => Ok(Standard::J211),
            "iso6487" => Ok(Standard::Iso6487),
            other => Err(Error::Setting {
                name: "--cfc-standard",
                problem: format!("`{other}` is not a filter standard (j211 or iso6487)"),
            }),
        }
    }

    /// The factor `k` of the design corner `ω_d = 2π · CFC · k`, as the standard writes it
    /// (ISO's as pyisomme evaluates it, so that both round alike).
    fn corner_rad_s(self, class: u32) -> f64 {
        let two_pi_cfc = 2.0 * std::f64::consts::PI * f64::from(class);
        match self {
            Standard::J211 => two_pi_cfc * 2.0775,
            Standard::Iso6487 => two_pi_cfc / 0.6 * 1.25,
        }
    }

    /// The factor `k` (module docs).
    pub fn k(self) -> f64 {
        match self {
            Standard::J211 => 2.0775,
            Standard::Iso6487 => 1.25 / 0.6,
        }
    }
}

/// A filter as the user names it (`--cfc CLASS --cfc-standard S`), before the frame rate is
/// known; [`Cfc::new`] checks it against the rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CfcSpec {
    /// The channel frequency class ([`CLASSES`]).
    pub class: u32,
    /// The standard.
    pub standard: Standard,
}

/// The 2-pole section `Y[t] = a₀X[t] + a₁X[t−1] + a₂X[t−2] + b₁Y[t−1] + b₂Y[t−2]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients {
    /// `a₀ = ω_a² / (1 + √2·ω_a + ω_a²)`.
    pub a0: f64,
    /// `a₁ = 2·a₀`.
    pub a1: f64,
    /// `a₂ = a₀`.
    pub a2: f64,
    /// `b₁ = −2·(ω_a² − 1) / (1 + √2·ω_a + ω_a²)`.
    pub b1: f64,
    /// `b₂ = (−1 + √2·ω_a − ω_a²) / (1 + √2·ω_a + ω_a²)`.
    pub b2: f64,
}

impl Coefficients {
    /// One step of the section: input `x0` with the two previous inputs and outputs (the same
    /// products and sums in the same order for every [`Sample`], so a 3-vector's components are
    /// filtered bit for bit as three scalar records).
    #[inline(always)]
    fn step<T: Sample>(&self, x0: T, x1: T, x2: T, y1: T, y2: T) -> T {
        x0 * self.a0 + x1 * self.a1 + x2 * self.a2 + y1 * self.b1 + y2 * self.b2
    }
}

/// A value the filter takes: a scalar (`f64`) or a 3-vector ([`crashrig_geometry::Vec3`]),
/// whose three components are filtered as three independent records — with the same
/// arithmetic, bit for bit, but in one pass, so that the three recurrences overlap.
pub trait Sample:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<f64, Output = Self>
    + std::ops::Div<f64, Output = Self>
{
}

impl Sample for f64 {}
impl Sample for crashrig_geometry::Vec3 {}

/// A CFC filter for one class, standard and sampling rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cfc {
    class: u32,
    standard: Standard,
    frame_rate_hz: f64,
    c: Coefficients,
}

impl Cfc {
    /// The filter of `class` ([`CLASSES`]) under `standard` for data sampled at
    /// `frame_rate_hz`.
    ///
    /// # Errors
    /// [`Error::Setting`] naming `--cfc` for a class not in [`CLASSES`] or one whose design
    /// corner exceeds [`NYQUIST_FRACTION`] of the Nyquist frequency (the message names the
    /// class, the frame rate and the lowest frame rate that carries the class), or naming
    /// `--frame-rate-hz` for a rate that is not a positive number.
    pub fn new(class: u32, standard: Standard, frame_rate_hz: f64) -> Result<Cfc, Error> {
        if !CLASSES.contains(&class) {
            return Err(Error::Setting {
                name: "--cfc",
                problem: format!("{class} is not a channel frequency class (60, 180, 600, 1000)"),
            });
        }
        if !(frame_rate_hz.is_finite() && frame_rate_hz > 0.0) {
            return Err(Error::Setting {
                name: "--frame-rate-hz",
                problem: format!("{frame_rate_hz} is not a positive number"),
            });
        }
        let corner_hz = standard.k() * f64::from(class);
        let limit_hz = NYQUIST_FRACTION * frame_rate_hz / 2.0;
        if corner_hz > limit_hz {
            return Err(Error::Setting {
                name: "--cfc",
                problem: format!(
                    "CFC {class} is too high for {frame_rate_hz} frames/s: its design corner {corner_hz:.0} Hz ({} × CFC) must be at most {NYQUIST_FRACTION} × the Nyquist frequency ({limit_hz:.0} Hz); it needs at least {:.0} frames/s",
                    standard.k(),
                    (corner_hz / NYQUIST_FRACTION * 2.0).ceil()
                ),
            });
        }
        let t = 1.0 / frame_rate_hz;
        let wa = (standard.corner_rad_s(class) * t / 2.0).tan();
        let sqrt2 = std::f64::consts::SQRT_2;
        let den = 1.0 + sqrt2 * wa + wa * wa;
        let a0 = wa * wa / den;
        let c = Coefficients {
            a0,
            a1: 2.0 * a0,
            a2: a0,
            b1: -2.0 * (wa * wa - 1.0) / den,
            b2: (-1.0 + sqrt2 * wa - wa * wa) / den,
        };
        Ok(Cfc {
            class,
            standard,
            frame_rate_hz,
            c,
        })
    }

    /// The channel frequency class.
    pub fn class(&self) -> u32 {
        self.class
    }

    /// The standard.
    pub fn standard(&self) -> Standard {
        self.standard
    }

    /// The sampling rate (Hz).
    pub fn frame_rate_hz(&self) -> f64 {
        self.frame_rate_hz
    }

    /// The 2-pole section's coefficients.
    pub fn coefficients(&self) -> Coefficients {
        self.c
    }

    /// The samples ISO 6487 adds at each end of a record of `n` samples.
    fn iso_extension(&self, n: usize) -> usize {
        let t = 1.0 / self.frame_rate_hz;
        // pyisomme: int(min(max(0.01 / T, 100), n − 1)).
        (0.01 / t).max(100.0).min((n - 1) as f64) as usize
    }

    /// The filtered record (a new vector); see [`Cfc::filter_into`].
    pub fn filter(&self, x: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; x.len()];
        self.filter_into(x, &mut out, &mut Vec::new());
        out
    }

    /// Filters `x` into `out` (same length) with `scratch` as working memory (reused across
    /// calls, so filtering many records allocates once). Records shorter than
    /// [`MIN_SAMPLES`] are copied unchanged — callers check the length first (the kinematics
    /// give such records no filtered values). `T` = [`crashrig_geometry::Vec3`] filters the
    /// three axes of a series at once, each exactly as `f64` records would be.
    ///
    /// # Panics
    /// When `out.len() != x.len()` (a programming error).
    #[inline(always)]
    pub fn filter_into<T: Sample>(&self, x: &[T], out: &mut [T], scratch: &mut Vec<T>) {
        assert_eq!(x.len(), out.len(), "filter_into: output length");
        let n = x.len();
        if n < MIN_SAMPLES {
            out.copy_from_slice(x);
            return;
        }
        match self.standard {
            Standard::J211 => {
                // Forward from `x` into `out`, then backward over `out` in place (each step
                // reads its input before it writes its output).
                self.pass_at_rest(x.iter().copied(), out.iter_mut());
                j211_backward_in_place(&self.c, out);
            }
            Standard::Iso6487 => {
                let k = self.iso_extension(n);
                scratch.clear();
                scratch.reserve(n + 2 * k);
                scratch.extend((0..k).map(|j| x[0] * 2.0 - x[k - j]));
                scratch.extend_from_slice(x);
                scratch.extend((0..k).map(|i| x[n - 1] * 2.0 - x[n - 2 - i]));
                iso_pass(&self.c, scratch, false);
                iso_pass(&self.c, scratch, true);
                out.copy_from_slice(&scratch[k..k + n]);
            }
        }
    }

    /// One J211 pass over `input` into `output`, started at rest on the first input.
    #[inline(always)]
    fn pass_at_rest<'a, T: Sample + 'a>(
        &self,
        input: impl Iterator<Item = T>,
        output: impl Iterator<Item = &'a mut T>,
    ) {
        let mut input = input.peekable();
        let Some(&x0) = input.peek() else { return };
        let (mut x1, mut x2, mut y1, mut y2) = (x0, x0, x0, x0);
        for (x, y) in input.zip(output) {
            let v = self.c.step(x, x1, x2, y1, y2);
            *y = v;
            (x2, x1, y2, y1) = (x1, x, y1, v);
        }
    }
}

/// The backward J211 pass in place over `v` (the forward pass's output), started at rest on
/// its last value: the arithmetic of [`Cfc::pass_at_rest`] over `v` reversed.
#[inline(always)]
fn j211_backward_in_place<T: Sample>(c: &Coefficients, v: &mut [T]) {
    let Some(&x0) = v.last() else { return };
    let (mut x1, mut x2, mut y1, mut y2) = (x0, x0, x0, x0);
    for y in v.iter_mut().rev() {
        let x = *y;
        let out = c.step(x, x1, x2, y1, y2);
        *y = out;
        (x2, x1, y2, y1) = (x1, x, y1, out);
    }
}

/// One ISO 6487 pass in place (forward, or backward when `reverse`): the first two outputs are
/// the mean of the first ten values the pass reads; from the third on, the section.
#[inline(always)]
fn iso_pass<T: Sample>(c: &Coefficients, v: &mut [T], reverse: bool) {
    let n = v.len();
    let at = |i: usize| if reverse { n - 1 - i } else { i };
    // Summed from the first value, as `f64`'s `Sum` (from −0.0) sums: the same bits.
    let mean = (1..10).fold(v[at(0)], |s, i| s + v[at(i)]) / 10.0;
    let (mut x2, mut x1) = (v[at(0)], v[at(1)]);
    v[at(0)] = mean;
    v[at(1)] = mean;
    let (mut y2, mut y1) = (mean, mean);
    for i in 2..n {
        let x0 = v[at(i)];
        let y = c.step(x0, x1, x2, y1, y2);
        v[at(i)] = y;
        (x2, x1, y2, y1) = (x1, x0, y1, y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_and_rates_are_checked() {
        assert!(Cfc::new(100, Standard::J211, 1000.0).is_err());
        assert!(Cfc::new(60, Standard::J211, 0.0).is_err());
        assert!(Cfc::new(60, Standard::J211, f64::NAN).is_err());
        // 1000 frames/s: 60 and 180 pass, 600 and 1000 do not.
        for (class, ok) in [(60, true), (180, true), (600, false), (1000, false)] {
            for s in [Standard::J211, Standard::Iso6487] {
                assert_eq!(Cfc::new(class, s, 1000.0).is_ok(), ok, "{class} {s:?}");
            }
        }
        // The limit itself: 2.0775·600 = 1246.5 Hz ≤ 0.4·f_s ⇔ f_s ≥ 3116.25.
        assert!(Cfc::new(600, Standard::J211, 3116.25).is_ok());
        assert!(Cfc::new(600, Standard::J211, 3116.0).is_err());
        let msg = Cfc::new(600, Standard::J211, 1000.0)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("--cfc") && msg.contains("600") && msg.contains("1000"),
            "{msg}"
        );
        assert_eq!(Standard::parse("iso6487").unwrap(), Standard::Iso6487);
        assert!(
            Standard::parse("iso")
                .unwrap_err()
                .to_string()
                .contains("--cfc-standard")
        );
    }

    /// A 3-vector record is filtered component by component exactly (bit for bit) as three
    /// scalar records, in both standards (the kinematics filter the three axes at once).
    #[test]
    fn vec3_records_filter_as_three_scalar_records() {
        use crashrig_geometry::Vec3;
        let x: Vec<Vec3> = (0..300)
            .map(|i| {
                let t = i as f64 * 1e-3;
                Vec3::new(
                    (37.0 * t).sin() * 5.0,
                    t * t * 1e3 - 0.3,
                    (i % 7) as f64 - 3.0,
                )
            })
            .collect();
        for s in [Standard::J211, Standard::Iso6487] {
            let f = Cfc::new(180, s, 1000.0).unwrap();
            let mut out = vec![Vec3::zeros(); x.len()];
            f.filter_into(&x, &mut out, &mut Vec::new());
            for c in 0..3 {
                let axis: Vec<f64> = x.iter().map(|v| v[c]).collect();
                let want = f.filter(&axis);
                for (o, w) in out.iter().zip(&want) {
                    assert_eq!(o[c].to_bits(), w.to_bits(), "{s:?} axis {c}");
                }
            }
        }
    }

    #[test]
    fn dc_gain_is_one_and_short_records_pass_unchanged() {
        for s in [Standard::J211, Standard::Iso6487] {
            let f = Cfc::new(180, s, 1000.0).unwrap();
            let c = f.coefficients();
            // (a₀ + a₁ + a₂) / (1 − b₁ − b₂) = 1.
            assert!(((c.a0 + c.a1 + c.a2) / (1.0 - c.b1 - c.b2) - 1.0).abs() < 1e-12);
            assert_eq!(f.filter(&[1.0, 2.0, 4.0]), vec![1.0, 2.0, 4.0]);
            // A ramp passes the ISO extension unchanged (point reflection keeps it a ramp).
            if s == Standard::Iso6487 {
                let ramp: Vec<f64> = (0..200).map(|i| 0.5 * i as f64).collect();
                let y = f.filter(&ramp);
                for (a, b) in ramp.iter().zip(&y) {
                    assert!((a - b).abs() < 1e-9, "{a} {b}");
                }
            }
        }
    }
}
