//! A measurement only, used by no engine: a 256-layer ziggurat (Marsaglia & Tsang 2000) in
//! lanes over the engine's Philox bits, to weigh cheaper normals against the Box–Muller
//! transform of [`super::normal::fill_block`] (`docs/performance.md`, issue 39; switching
//! the engine's generator would change every output).
//!
//! Each 32-bit Philox word gives one normal: 8 bits pick the layer, the other 24 a signed
//! abscissa; the fast path (`|hz| < k[layer]`, ≈ 98.8 % of draws) is a table look-up and one
//! product per lane, branch-free. A lane that falls in a wedge or the tail is recomputed after
//! the lane loop by a scalar stand-in (the Box–Muller pair of its slot word), so the cost of
//! the rare slow path is counted but its output is **not** the ziggurat's: the normals of
//! this function are for timing, not for statistics.

#![allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays vectorise

use super::normal::{LANES, Lane, box_muller};
use super::philox::{counter, philox4x32_10, philox4x32_10_lanes};
use super::simd::Width;
use std::sync::OnceLock;

const LAYERS: usize = 256;
/// Right edge of the base layer (Marsaglia & Tsang 2000, 256 layers).
const R: f64 = 3.654_152_885_361_009;
/// Area of each layer.
const V: f64 = 4.92867323399e-3;
/// Scale of the 24-bit signed abscissa.
const M: f64 = 8_388_608.0;

/// The layer tables: the abscissa bound `k` (as a float, compared with |hz|) and the scale `w`.
struct Tables {
    k: [f64; LAYERS],
    w: [f64; LAYERS],
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let (mut k, mut w) = ([0.0; LAYERS], [0.0; LAYERS]);
        let mut dn = R;
        let mut tn = dn;
        let q = V / (-0.5 * dn * dn).exp();
        k[0] = ((dn / q) * M).floor();
        w[0] = q / M;
        w[LAYERS - 1] = dn / M;
        for i in (1..LAYERS - 1).rev() {
            dn = (-2.0 * (V / dn + (-0.5 * dn * dn).exp()).ln()).sqrt();
            k[i + 1] = ((dn / tn) * M).floor();
            tn = dn;
            w[i] = dn / M;
        }
        Tables { k, w }
    })
}

/// Normals for the draws `draw0 .. draw0 + LANES` of `task` into `rows` (4 per Philox slot,
/// as [`super::normal::fill_block`] lays them out), by the ziggurat's fast path (see the
/// module docs). Inline into a dispatched kernel.
#[inline(always)]
pub(crate) fn fill_block_ziggurat(
    key: [u32; 2],
    task: u64,
    draw0: u64,
    rows: &mut [Lane],
    width: Width,
) {
    const K: usize = 32;
    let t = tables();
    let mut words = [[0u64; LANES]; 4];
    for (slot, group) in rows.chunks_mut(4).enumerate() {
        // The Philox words of the slot, in the loop shape of `fill_block`.
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
                    for w in 0..4 {
                        for d in 0..K {
                            words[w][h * K + d] = st[w][d] & 0xFFFF_FFFF;
                        }
                    }
                }
            }
            Width::Narrow => {
                for d in 0..LANES {
                    let w = philox4x32_10(counter(task, draw0 + d as u64, slot as u32), key);
                    for q in 0..4 {
                        words[q][d] = u64::from(w[q]);
                    }
                }
            }
        }
        for (q, row) in group.iter_mut().enumerate() {
            let mut slow = [0u64; LANES];
            for d in 0..LANES {
                let u = words[q][d];
                let layer = (u & 0xFF) as usize;
                // The top 24 bits of the word as a signed integer.
                let hz = (((u << 32) as i64) >> 40) as f64;
                row[d] = hz * t.w[layer];
                slow[d] = u64::from(hz.abs() >= t.k[layer]) << d;
            }
            // The lanes off the fast path, as a bit mask (one vectorised reduction).
            let mut mask = slow.iter().fold(0, |m, &b| m | b);
            while mask != 0 {
                let d = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                row[d] = box_muller(words[q ^ 1][d] << 32 | words[q][d]).0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::philox::key_of_seed;
    use crate::kernel::ziggurat::FastNormal;

    /// A "generator" that hands out a given word first (the ziggurat's fast path takes one),
    /// then further words of a Weyl sequence (for the slow path of the other half, whose
    /// value is not compared).
    struct Word(u64);
    impl rand::TryRng for Word {
        type Error = std::convert::Infallible;
        fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
            self.try_next_u64().map(|w| w as u32)
        }
        fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
            let w = self.0;
            self.0 = w.wrapping_add(0x9E37_79B9_7F4A_7C15);
            Ok(w)
        }
        fn try_fill_bytes(&mut self, _: &mut [u8]) -> Result<(), Self::Error> {
            unreachable!("the ziggurat takes words")
        }
    }

    #[test]
    fn ziggurat_lanes_fast_path_is_the_trees_ziggurat() {
        // Every lane on the fast path gives, bit for bit, the test-only scalar ziggurat of the
        // tree (`kernel::ziggurat`) on the same 32-bit word; about 98.8 % of lanes are on it.
        let (zig, key) = (FastNormal::new(), key_of_seed(3));
        let mut rows = vec![[0.0; LANES]; 4];
        let (mut fast, mut all) = (0, 0);
        for b in 0..64u64 {
            let draw0 = b * LANES as u64;
            fill_block_ziggurat(key, 1, draw0, &mut rows, Width::Narrow);
            for d in 0..LANES {
                let w = philox4x32_10(counter(1, draw0 + d as u64, 0), key);
                for q in [0, 2] {
                    let word = u64::from(w[q]) | u64::from(w[q + 1]) << 32;
                    let (a, c) = zig.pair(&mut Word(word));
                    let t = tables();
                    for (r, (u, z)) in [(q, (w[q], a)), (q + 1, (w[q + 1], c))] {
                        let hz = f64::from((u as i32) >> 8);
                        all += 1;
                        if hz.abs() < t.k[(u & 0xFF) as usize] {
                            fast += 1;
                            assert_eq!(rows[r][d].to_bits(), z.to_bits(), "row {r} lane {d}");
                        }
                    }
                }
            }
        }
        let share = fast as f64 / all as f64;
        assert!((share - 0.988).abs() < 0.005, "fast path share {share}");
    }
}
