//! The former generator of the legacy engine (compiled into the tests only): a 256-layer ziggurat
//! (Marsaglia & Tsang 2000) over a `rand::Rng`, one draw at a time.
//!
//! Each 64-bit word gives two normals; each 32-bit half supplies 8 bits for the layer and a
//! separate 24-bit signed integer for the abscissa (no bit is used twice, avoiding the
//! layer/value correlation of the original 32-bit ziggurat, Doornik 2005). Within a layer the
//! abscissa is quantized to 2⁻²³ of the layer width, irrelevant for Monte Carlo σ. Wedge and
//! tail cases (≈ 1 % of draws) use further 64-bit words with 53-bit uniforms.

use rand::Rng;
use std::sync::OnceLock;

const LAYERS: usize = 256;
/// Right edge of the base layer (Marsaglia & Tsang 2000, 256 layers).
const R: f64 = 3.654_152_885_361_009;
/// Area of each layer (and of the base layer with its tail).
const V: f64 = 4.92867323399e-3;
/// Scale of the 24-bit signed abscissa: |hz| < 2²³.
const M: f64 = 8_388_608.0;
/// Bits of a 32-bit chunk that pick the layer.
const LAYER_BITS: u32 = 8;
const LAYER_MASK: u32 = (1 << LAYER_BITS) - 1;

#[derive(Debug)]
struct Tables {
    k: [u32; LAYERS],
    w: [f64; LAYERS],
    f: [f64; LAYERS],
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let mut k = [0u32; LAYERS];
        let mut w = [0f64; LAYERS];
        let mut f = [0f64; LAYERS];
        let mut dn = R;
        let mut tn = dn;
        let q = V / (-0.5 * dn * dn).exp();
        k[0] = ((dn / q) * M) as u32;
        k[1] = 0;
        w[0] = q / M;
        w[LAYERS - 1] = dn / M;
        f[0] = 1.0;
        f[LAYERS - 1] = (-0.5 * dn * dn).exp();
        for i in (1..LAYERS - 1).rev() {
            dn = (-2.0 * (V / dn + (-0.5 * dn * dn).exp()).ln()).sqrt();
            k[i + 1] = ((dn / tn) * M) as u32;
            tn = dn;
            f[i] = (-0.5 * dn * dn).exp();
            w[i] = dn / M;
        }
        Tables { k, w, f }
    })
}

/// A source of standard normals over any `rand::Rng`, two per 64-bit word.
#[derive(Debug, Clone, Copy)]
pub struct FastNormal {
    t: &'static Tables,
}

impl Default for FastNormal {
    fn default() -> Self {
        Self::new()
    }
}

#[inline(always)]
fn uniform<Rn: Rng + ?Sized>(rng: &mut Rn) -> f64 {
    // (0, 1]: 53 random bits, never 0 (safe for ln).
    ((rng.next_u64() >> 11) as f64 + 1.0) * (1.0 / 9_007_199_254_740_992.0)
}

impl FastNormal {
    /// The generator (tables are computed once per process).
    pub fn new() -> Self {
        FastNormal { t: tables() }
    }

    /// One normal from a 32-bit chunk `u` (8 bits layer, 24 bits signed abscissa).
    #[inline(always)]
    fn normal_of_bits<Rn: Rng + ?Sized>(&self, u: u32, rng: &mut Rn) -> f64 {
        let t = self.t;
        let iz = (u & LAYER_MASK) as usize;
        // Arithmetic shift of the top 24 bits: a signed integer in [−2²³, 2²³).
        let hz = (u as i32) >> LAYER_BITS;
        if hz.unsigned_abs() < t.k[iz] {
            return hz as f64 * t.w[iz];
        }
        self.slow(hz, iz, rng)
    }

    #[cold]
    fn slow<Rn: Rng + ?Sized>(&self, mut hz: i32, mut iz: usize, rng: &mut Rn) -> f64 {
        let t = self.t;
        loop {
            if iz == 0 {
                // Tail beyond R (Marsaglia 1964).
                loop {
                    let x = -uniform(rng).ln() / R;
                    let y = -uniform(rng).ln();
                    if y + y >= x * x {
                        return if hz > 0 { R + x } else { -R - x };
                    }
                }
            }
            let x = hz as f64 * t.w[iz];
            if t.f[iz] + uniform(rng) * (t.f[iz - 1] - t.f[iz]) < (-0.5 * x * x).exp() {
                return x;
            }
            let u = rng.next_u64() as u32;
            iz = (u & LAYER_MASK) as usize;
            hz = (u as i32) >> LAYER_BITS;
            if hz.unsigned_abs() < t.k[iz] {
                return hz as f64 * t.w[iz];
            }
        }
    }

    /// Two independent standard normals.
    #[inline(always)]
    pub fn pair<Rn: Rng + ?Sized>(&self, rng: &mut Rn) -> (f64, f64) {
        let w = rng.next_u64();
        let a = self.normal_of_bits(w as u32, rng);
        let b = self.normal_of_bits((w >> 32) as u32, rng);
        (a, b)
    }

    /// Fills `out` with standard normals.
    #[inline(always)]
    pub fn fill<Rn: Rng + ?Sized>(&self, rng: &mut Rn, out: &mut [f64]) {
        let mut chunks = out.chunks_exact_mut(2);
        for c in &mut chunks {
            let (a, b) = self.pair(rng);
            c[0] = a;
            c[1] = b;
        }
        if let [last] = chunks.into_remainder() {
            *last = self.pair(rng).0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn fast_normal_nominal_moments_and_cdf() {
        let g = FastNormal::new();
        let mut rng = crashrig_stats::stream(12345, 0);
        let n = 400_000;
        let mut xs = vec![0.0; n];
        g.fill(&mut rng, &mut xs);
        let nf = n as f64;
        let mean = xs.iter().sum::<f64>() / nf;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (nf - 1.0);
        let kurt = xs.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / nf / (var * var);
        // 3 standard errors: mean 1/√n, variance √(2/n), kurtosis √(24/n).
        assert_abs_diff_eq!(mean, 0.0, epsilon = 3.0 / nf.sqrt());
        assert_abs_diff_eq!(var, 1.0, epsilon = 3.0 * (2.0 / nf).sqrt());
        assert_abs_diff_eq!(kurt, 3.0, epsilon = 3.0 * (24.0 / nf).sqrt());
        // Φ at a few points, including the tail beyond R ≈ 3.44 and the wedges
        // (Φ values to 10 digits from standard tables); SE √(p(1−p)/n).
        for (z, phi) in [
            (-3.5, 2.326290790e-4),
            (-2.0, 0.02275013195),
            (-0.5, 0.3085375387),
            (0.0, 0.5),
            (1.0, 0.8413447461),
            (2.5, 0.9937903347),
            (3.6, 0.9998408867),
        ] {
            let p = xs.iter().filter(|x| **x < z).count() as f64 / nf;
            let se = (phi * (1.0 - phi) / nf).sqrt();
            assert_abs_diff_eq!(p, phi, epsilon = 4.0 * se + 1e-6);
        }
    }

    #[test]
    fn fast_normal_tables_are_monotone() {
        let t = tables();
        // Layer edges x_i = w_i·M decrease from the base layer outwards, densities increase.
        for i in 1..LAYERS - 1 {
            assert!(t.w[i] > t.w[i - 1] || i == 1, "w not monotone at {i}");
            assert!(t.f[i] < t.f[i - 1], "f not monotone at {i}");
        }
    }
}
