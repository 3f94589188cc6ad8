//! Standard-normal draws.
//!
//! - [`fill_block`]: the engine's generator. Philox4x32-10 ([`crate::kernel::philox`]) bits, 64 per pair
//!   of normals, into a branch-free Box–Muller transform, over blocks of [`LANES`] draws; written
//!   as plain loops over lane arrays so that, inlined into a dispatched kernel
//!   ([`crate::kernel::simd`]), it vectorises with the CPU's widest units. Only correctly rounded
//!   operations (`+ − × ÷ √`, explicit `mul_add`, integer and bit operations; no other libm
//!   function) are used, so every instruction-set path gives the same bits.
//!
//! # The Box–Muller transform of a 64-bit word `v`
//! - radius: the top 42 bits `k` give `u = 1 − k·2⁻⁴² ∈ [2⁻⁴², 1]` (exact), and
//!   `r = √(−2 ln u)`; so |z| ≤ r_max = √(84 ln 2) ≈ 7.63 (P(|N(0,1)| > 7.63) ≈ 2·10⁻¹⁴,
//!   i.e. one draw in 5·10¹³ is clipped to the last radius).
//! - angle: the low 22 bits pick one of 2²² equally spaced angles `φ_j = 2π(j + ½)/2²²`
//!   (2 bits the quadrant, 20 bits the angle inside it). A uniform angle on such a lattice
//!   reproduces every trigonometric moment `E[cosᵃφ sinᵇφ]` with `a + b < 2²²` exactly, so the
//!   moments of (z₀, z₁) = r(cos φ, sin φ) are those of the continuous transform.
//! - `ln u` = e·ln 2 + 2 atanh(s), s = (m − 1)/(m + 1), m ∈ [√½, √2), with fdlibm's
//!   `e_log.c` minimax polynomial `2 atanh s = 2s + s·(Lg1 z + … + Lg7 z⁷)`, z = s² (error
//!   < 2⁻⁵⁸·⁴⁵); `sin`, `cos` on [−π/4, π/4] with the Cephes minimax polynomials (≈ 1 ulp).
//!   Both are tested against `std` to a few ulps.
//! - Philox runs either lane by lane or round by round over 32 lanes, as the level's
//!   registers allow ([`Width`]); the bits are the same.

use crate::kernel::philox::{counter, philox4x32_10, philox4x32_10_lanes};
use crate::kernel::simd::Width;

/// Draws per block of the vectorised kernels.
pub(crate) const LANES: usize = 64;

/// One row of a block: a value per draw.
pub(crate) type Lane = [f64; LANES];

const ONE_BITS: u64 = 0x3FF0_0000_0000_0000;
const MANT_MASK: u64 = 0x000F_FFFF_FFFF_FFFF;
/// 2⁵² as f64: `from_bits(MAGIC_BITS | k) − MAGIC = k` exactly for k < 2⁵².
const MAGIC_BITS: u64 = 0x4330_0000_0000_0000;
const MAGIC: f64 = 4_503_599_627_370_496.0;
const SQRT2: f64 = std::f64::consts::SQRT_2;
/// ln 2 split so that e·LN2_HI is exact for |e| < 2¹¹ (fdlibm).
#[allow(clippy::excessive_precision)] // the published digits (fdlibm, Cephes)
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
#[allow(clippy::excessive_precision)] // the published digits (fdlibm, Cephes)
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
/// Cephes `sin` (|x| ≤ π/4): sin x = x + x·z·P(z), z = x².
#[allow(clippy::excessive_precision)] // the published digits (fdlibm, Cephes)
const SIN: [f64; 6] = [
    1.589_623_015_765_465_680_60e-10,
    -2.505_074_776_285_780_728_66e-8,
    2.755_731_362_138_572_452_13e-6,
    -1.984_126_982_958_953_859_96e-4,
    8.333_333_333_322_118_588_78e-3,
    -1.666_666_666_666_663_072_95e-1,
];
/// Cephes `cos` (|x| ≤ π/4): cos x = 1 − z/2 + z²·Q(z).
#[allow(clippy::excessive_precision)] // the published digits (fdlibm, Cephes)
const COS: [f64; 6] = [
    -1.135_853_652_138_768_173_00e-11,
    2.087_570_084_197_473_167_78e-9,
    -2.755_731_417_929_673_881_12e-7,
    2.480_158_728_885_170_453_48e-5,
    -1.388_888_888_887_305_641_16e-3,
    4.166_666_666_666_659_292_18e-2,
];
/// Angle step inside a quadrant: (π/2)/2²⁰.
const ANGLE_STEP: f64 = std::f64::consts::FRAC_PI_2 / 1_048_576.0;

#[inline(always)]
fn horner(x: f64, c: &[f64]) -> f64 {
    let mut p = c[0];
    for &k in &c[1..] {
        p = p.mul_add(x, k);
    }
    p
}

/// `ln u` for `u ∈ [2⁻¹⁰²², 1]` with correctly rounded operations only, branch-free.
#[inline(always)]
pub(crate) fn ln_unit(u: f64) -> f64 {
    let b = u.to_bits();
    let mant = (b & MANT_MASK) | ONE_BITS;
    // m ∈ [1, 2); halve it (exponent − 1) when above √2, and count that in e.
    let big = (f64::from_bits(mant) > SQRT2) as u64;
    let m = f64::from_bits(mant - (big << 52));
    // The exponent (plus `big`) as a float: exact integer arithmetic.
    let e = f64::from_bits(MAGIC_BITS | ((b >> 52) + big)) - (MAGIC + 1023.0);
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    // fdlibm e_log.c (Lg7 … Lg1): 2 atanh s = 2s + s·R(z), R(z) = Lg1 z + … + Lg7 z⁷.
    #[allow(clippy::excessive_precision)] // the published digits (fdlibm)
    const LG: [f64; 7] = [
        1.479_819_860_511_658_591e-01,
        1.531_383_769_920_937_332e-01,
        1.818_357_216_161_805_012e-01,
        2.222_219_843_214_978_396e-01,
        2.857_142_874_366_239_149e-01,
        3.999_999_999_940_941_908e-01,
        6.666_666_666_666_735_130e-01,
    ];
    let lnm = s.mul_add(z * horner(z, &LG), s + s);
    e.mul_add(LN2_HI, e.mul_add(LN2_LO, lnm))
}

/// `(cos x, sin x)` for |x| ≤ π/4 (Cephes polynomials).
#[inline(always)]
pub(crate) fn cos_sin_small(x: f64) -> (f64, f64) {
    let z = x * x;
    let s = (x * z).mul_add(horner(z, &SIN), x);
    let c = (z * z).mul_add(horner(z, &COS), (-0.5f64).mul_add(z, 1.0));
    (c, s)
}

/// Two standard normals from 64 random bits (see the module docs).
#[inline(always)]
pub(crate) fn box_muller(v: u64) -> (f64, f64) {
    // Radius.
    let k = v >> 22;
    let u = 2.0 - f64::from_bits(ONE_BITS | (k << 10));
    let l = ln_unit(u);
    let r = (-(l + l)).sqrt();
    // Angle: quadrant q, lattice point j inside it.
    let q = (v >> 20) & 3;
    let j = v & 0xF_FFFF;
    let a =
        ((f64::from_bits(MAGIC_BITS | j) - MAGIC) + 0.5) * ANGLE_STEP - std::f64::consts::FRAC_PI_4;
    let (c, s) = cos_sin_small(a);
    // Rotate (c, s) by q quarter turns: (c, s), (−s, c), (−c, −s), (s, −c).
    let swap = 0u64.wrapping_sub(q & 1);
    let (cb, sb) = (c.to_bits(), s.to_bits());
    let x = (sb & swap) | (cb & !swap);
    let y = (cb & swap) | (sb & !swap);
    let negx = ((q ^ (q >> 1)) & 1) << 63;
    let negy = (q >> 1) << 63;
    (r * f64::from_bits(x ^ negx), r * f64::from_bits(y ^ negy))
}

/// Fills `rows` with standard normals for the draws `draw0 .. draw0 + LANES` of `task`:
/// `rows[i][d]` is normal `i` of draw `draw0 + d`. Normals `4s .. 4s + 4` of a draw come from
/// its slot `s` (one Philox block: pairs `(w₀, w₁)` and `(w₂, w₃)`), so a draw's normals do
/// not depend on the block it is in, on `rows.len()` beyond the slots it needs, on the
/// instruction set or on `width` (which only chooses the loop shape, see [`Width`]). Inline
/// into a dispatched kernel (see [`crate::simd`]).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays vectorise
pub(crate) fn fill_block(key: [u32; 2], task: u64, draw0: u64, rows: &mut [Lane], width: Width) {
    debug_assert!(rows.len().is_multiple_of(2), "normals come in pairs");
    // Wide registers: Philox on K lanes at a time, round by round (`philox4x32_10_lanes`).
    const K: usize = 32;
    let mut bits = [[0u64; LANES]; 2];
    for (slot, group) in rows.chunks_mut(4).enumerate() {
        match width {
            Width::Wide => {
                for h in 0..LANES / K {
                    let mut st = [[0u64; K]; 4];
                    for d in 0..K {
                        let c = counter(task, draw0 + (h * K + d) as u64, slot as u32);
                        for w in 0..4 {
                            st[w][d] = c[w] as u64;
                        }
                    }
                    philox4x32_10_lanes(&mut st, key);
                    for d in 0..K {
                        bits[0][h * K + d] = (st[0][d] & 0xFFFF_FFFF) | st[1][d] << 32;
                        bits[1][h * K + d] = (st[2][d] & 0xFFFF_FFFF) | st[3][d] << 32;
                    }
                }
            }
            Width::Narrow => {
                for d in 0..LANES {
                    let w = philox4x32_10(counter(task, draw0 + d as u64, slot as u32), key);
                    bits[0][d] = w[0] as u64 | (w[1] as u64) << 32;
                    bits[1][d] = w[2] as u64 | (w[3] as u64) << 32;
                }
            }
        }
        // Both pairs of the slot in one loop: two independent chains per iteration.
        if let [r0, r1, r2, r3] = group {
            for d in 0..LANES {
                let (z0, z1) = box_muller(bits[0][d]);
                let (z2, z3) = box_muller(bits[1][d]);
                r0[d] = z0;
                r1[d] = z1;
                r2[d] = z2;
                r3[d] = z3;
            }
        } else if let [r0, r1] = group {
            for d in 0..LANES {
                let (z0, z1) = box_muller(bits[0][d]);
                r0[d] = z0;
                r1[d] = z1;
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lane-indexed, like the code under test
mod block_tests {
    use super::*;
    use crate::kernel::philox::key_of_seed;
    use crate::kernel::simd::{Isa, dispatch};

    #[test]
    fn ln_unit_nominal_matches_std() {
        // Exact-operation log against libm over the whole radius range, including the
        // endpoints and both sides of the √2 switch.
        let mut worst = 0.0f64;
        for i in 0..200_000u64 {
            let k = (i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 22) | (i == 0) as u64;
            for u in [2.0 - f64::from_bits(ONE_BITS | (k << 10)), 2f64.powi(-42)] {
                let (got, want) = (ln_unit(u), u.ln());
                let err = (got - want).abs() / want.abs().max(1e-300);
                worst = worst.max(if want == 0.0 { got.abs() } else { err });
            }
        }
        for u in [1.0, 0.5, 1.0 / SQRT2, 1.0 / SQRT2 * (1.0 + 1e-15), 0.75] {
            assert!(
                (ln_unit(u) - u.ln()).abs() <= 4e-16 * u.ln().abs(),
                "u = {u}"
            );
        }
        // A few ulps (the polynomial and the split ln 2 round at ~1e-16).
        assert!(worst < 4e-16, "worst relative error {worst:e}");
    }

    #[test]
    fn cos_sin_small_nominal_matches_std() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = (i as f64 / 50_000.0 - 1.0) * std::f64::consts::FRAC_PI_4;
            let (c, s) = cos_sin_small(x);
            worst = worst.max((c - x.cos()).abs()).max((s - x.sin()).abs());
        }
        // ≈ 1 ulp of values ≤ 1.
        assert!(worst < 3e-16, "worst absolute error {worst:e}");
    }

    #[test]
    fn box_muller_nominal_quadrants_and_radius() {
        // v = 0: u = 1 → r = 0. Top radius bits all ones: u = 2⁻⁴² → r = √(84 ln 2).
        assert_eq!(box_muller(0), (0.0, 0.0));
        let rmax = (84.0 * std::f64::consts::LN_2).sqrt();
        for q in 0..4u64 {
            let v = (u64::MAX << 22) | (q << 20) | 0x7_FFFF;
            let (x, y) = box_muller(v);
            assert!((x.hypot(y) - rmax).abs() < 1e-14);
            // Lattice point j = 2¹⁹ − 1 sits just below the middle of quadrant q: angle
            // q·π/2 − step/2 (the lattice is φ_j = qπ/2 − π/4 + (j + ½)·step).
            let phi = q as f64 * std::f64::consts::FRAC_PI_2 - 0.5 * ANGLE_STEP;
            assert!((x - rmax * phi.cos()).abs() < 1e-14, "q = {q}");
            assert!((y - rmax * phi.sin()).abs() < 1e-14, "q = {q}");
        }
    }

    #[test]
    fn fill_block_nominal_equals_the_scalar_generator() {
        // The block form (Philox round by round over 32 lanes, then Box–Muller) gives, lane
        // by lane, the scalar definition: slot s of draw d is philox(counter(task, d, s)).
        let key = key_of_seed(0xDEAD_BEEF_0123);
        let (task, draw0) = (77, (5u64 << 32) + 640);
        let mut rows = vec![[0.0; LANES]; 12];
        dispatch(
            Isa::Auto,
            #[inline(always)]
            |width| fill_block(key, task, draw0, &mut rows, width),
        );
        for d in 0..LANES {
            for slot in 0..3 {
                let w = philox4x32_10(counter(task, draw0 + d as u64, slot as u32), key);
                let (a, b) = box_muller(w[0] as u64 | (w[1] as u64) << 32);
                let (c, e) = box_muller(w[2] as u64 | (w[3] as u64) << 32);
                let got: Vec<f64> = (0..4).map(|k| rows[4 * slot + k][d]).collect();
                assert_eq!(got, [a, b, c, e], "draw {d}, slot {slot}");
            }
        }
    }

    #[test]
    fn fill_block_is_identical_for_both_widths() {
        // The two loop shapes of `simd::Width` (called outside any level, so on every CPU),
        // with 12 rows (3 slots) and 6 rows (a half-used slot).
        let key = key_of_seed(99);
        for rows in [12, 6] {
            let (mut wide, mut narrow) = (vec![[0.0; LANES]; rows], vec![[0.0; LANES]; rows]);
            for block in [0u64, 1, (1 << 32) + 3] {
                fill_block(key, 5, block * LANES as u64, &mut wide, Width::Wide);
                fill_block(key, 5, block * LANES as u64, &mut narrow, Width::Narrow);
                assert_eq!(wide, narrow, "rows {rows}, block {block}");
            }
        }
    }

    /// Normals `0..rows` of draws `0..draws` of one task, with the given level.
    fn normals(isa: Isa, seed: u64, task: u64, draws: u64, rows: usize) -> Vec<f64> {
        let key = key_of_seed(seed);
        let mut out = Vec::with_capacity(draws as usize * rows);
        let mut block = vec![[0.0; LANES]; rows];
        for b in 0..draws.div_ceil(LANES as u64) {
            dispatch(
                isa,
                #[inline(always)]
                |width| fill_block(key, task, b * LANES as u64, &mut block, width),
            );
            out.extend(block.iter().flatten());
        }
        out
    }

    #[test]
    fn fill_block_is_identical_on_every_isa_and_row_count() {
        let base = normals(Isa::Baseline, 7, 3, 256, 12);
        for isa in Isa::LEVELS {
            if !isa.is_available() {
                eprintln!("{} not available on this CPU: not compared", isa.name());
                continue;
            }
            let got = normals(isa, 7, 3, 256, 12);
            assert!(
                got.iter()
                    .zip(&base)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{} differs from baseline",
                isa.name()
            );
        }
        // Asking for fewer rows gives the same first rows (a draw's normals depend only on
        // (seed, task, draw, slot)).
        let six = normals(Isa::Auto, 7, 3, 64, 6);
        let twelve = normals(Isa::Auto, 7, 3, 64, 12);
        assert_eq!(&six[..6 * 64], &twelve[..6 * 64]);
    }

    /// Sums of z, z², z³, z⁴, tail counts and the lag-1 products of a sample.
    #[derive(Default)]
    struct Tally {
        n: f64,
        s: [f64; 4],
        tails: [f64; 6],
        pair: f64,
        lag: f64,
        max: f64,
    }
    const TAIL_AT: [f64; 6] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    /// P(|Z| > k) = erfc(k/√2), k = 1…6 (standard tables).
    const TAIL_P: [f64; 6] = [
        0.317_310_507_862_914_1,
        0.045_500_263_896_358_42,
        0.002_699_796_063_260_207,
        6.334_248_366_623_996e-5,
        5.733_031_437_583_878e-7,
        1.973_175_290_075_72e-9,
    ];

    fn tally(isa: Isa, seed: u64, task: u64, draws: u64) -> Tally {
        // 12 normals per draw (the grid's two-observer layout): rows are checked for
        // moments, tails, the pair correlation (rows 0, 1: the two outputs of one
        // Box–Muller pair) and the lag-1 correlation along draws (row 2).
        let key = key_of_seed(seed);
        let mut t = Tally::default();
        let mut block = vec![[0.0; LANES]; 12];
        let mut prev = f64::NAN;
        for b in 0..draws / LANES as u64 {
            dispatch(
                isa,
                #[inline(always)]
                |width| fill_block(key, task, b * LANES as u64, &mut block, width),
            );
            for row in &block {
                for &z in row {
                    let z2 = z * z;
                    t.s[0] += z;
                    t.s[1] += z2;
                    t.s[2] += z2 * z;
                    t.s[3] += z2 * z2;
                    for (c, k) in t.tails.iter_mut().zip(TAIL_AT) {
                        *c += (z.abs() > k) as u8 as f64;
                    }
                    t.max = t.max.max(z.abs());
                }
            }
            for d in 0..LANES {
                t.pair += block[0][d] * block[1][d];
                if !prev.is_nan() {
                    t.lag += prev * block[2][d];
                }
                prev = block[2][d];
            }
        }
        t.n = (draws / LANES as u64 * LANES as u64 * 12) as f64;
        t
    }

    /// Checks a tally against N(0, 1) within `k` standard errors.
    fn check(t: &Tally, k: f64, draws: f64) {
        let n = t.n;
        let m = |i: usize| t.s[i] / n;
        // SE of the sample raw moments: √(Var(zʲ)/n) with Var z = 1, Var z² = 2, Var z³ = 15,
        // Var z⁴ = 105 − 9 = 96.
        assert!(m(0).abs() < k * (1.0 / n).sqrt(), "mean {}", m(0));
        assert!((m(1) - 1.0).abs() < k * (2.0 / n).sqrt(), "E z² {}", m(1));
        assert!(m(2).abs() < k * (15.0 / n).sqrt(), "E z³ {}", m(2));
        assert!((m(3) - 3.0).abs() < k * (96.0 / n).sqrt(), "E z⁴ {}", m(3));
        for (i, p) in TAIL_P.iter().enumerate() {
            let se = (p * (1.0 - p) / n).sqrt();
            // Only tails with ≥ 20 expected counts are checked within k SE (Poisson counts
            // below that are too skewed for a normal-approximation bound).
            if p * n >= 20.0 {
                let got = t.tails[i] / n;
                assert!(
                    (got - p).abs() < k * se,
                    "P(|z|>{}) = {got:e}, want {p:e}",
                    i + 1
                );
            }
        }
        // Correlations of unit-variance variables: SE 1/√(pairs).
        assert!(t.pair.abs() / draws < k / draws.sqrt(), "pair corr");
        assert!(t.lag.abs() / draws < k / draws.sqrt(), "lag corr");
        assert!(t.max <= (84.0 * std::f64::consts::LN_2).sqrt());
    }

    #[test]
    fn philox_normals_nominal_moments_and_tails() {
        // 2¹⁶ draws × 12 = 786 432 normals; bounds at 4 standard errors (a false alarm
        // ≈ 6·10⁻⁵ per statistic).
        let draws = 1u64 << 16;
        let t = tally(Isa::Auto, 12345, 0, draws);
        check(&t, 4.0, draws as f64);
    }

    #[test]
    #[ignore = "slow: 1.26·10⁹ normals (about 16 s in release on 2 cores)"]
    fn slow_philox_normals_moments_and_tails_1e9() {
        use rayon::prelude::*;
        // 10⁸ draws × 12 normals over 100 tasks; tails out to 6σ (P(|z| > 5) ≈ 688 expected
        // counts), 5 standard errors.
        let tasks = 100u64;
        let per = 1u64 << 20;
        let parts: Vec<Tally> = (0..tasks)
            .into_par_iter()
            .map(|task| tally(Isa::Auto, 2026, task, per))
            .collect();
        let mut t = Tally::default();
        for p in &parts {
            t.n += p.n;
            for i in 0..4 {
                t.s[i] += p.s[i];
            }
            for i in 0..6 {
                t.tails[i] += p.tails[i];
            }
            t.pair += p.pair;
            t.lag += p.lag;
            t.max = t.max.max(p.max);
        }
        assert!(t.n >= 1.2e9);
        check(&t, 5.0, (tasks * per) as f64);
        // Beyond 6σ: 2.4 expected; the count must be a plausible Poisson(2.4) value.
        assert!(t.tails[5] <= 12.0, "{} draws beyond 6σ", t.tails[5]);
    }
}
