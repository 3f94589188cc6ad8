//! Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011, "Parallel random numbers: as easy as
//! 1, 2, 3"), the counter-based generator behind the vectorised normals.
//!
//! A counter-based generator is a keyed bijection of a 128-bit counter: output number `c` of
//! stream `k` is `philox(c, k)`, with no state carried from one output to the next. That is
//! what makes it vectorisable (many lanes evaluate different counters at once, with plain
//! 32×32→64-bit multiplies and XORs) and what keeps results independent of the thread count
//! and the SIMD width: a draw's random bits depend only on (seed, task, draw, slot).
//!
//! # Stream layout (fixed; changing it changes every Monte Carlo result)
//! - key = the run's 64-bit seed (low word, high word);
//! - counter word 0 = draw index within the task (low 32 bits);
//! - counter word 1 = slot within the draw (one slot = 128 bits = two normal pairs) in the
//!   low 16 bits, draw index bits 32–47 in the high 16 bits;
//! - counter words 2, 3 = task index (low, high): the grid's `p·2²⁴ + k`, the chain's chunk
//!   `k` — the same task numbering as the former ChaCha8 `stream(seed, task)` — and, for the
//!   chain draws a correlated map shares between its points, task 2⁶⁴ − 1 with draw index =
//!   the replicate (`schedule::CHAIN_TASK`).
//!
//! So every (seed, task, draw, slot) owns a distinct counter, streams never overlap, and a
//! task may hold up to 2⁴⁸ draws of up to 2¹⁶ slots (2¹⁸ normals) each.

/// Multipliers and Weyl increments of Philox4x32 (Random123 `philox.h`).
const M0: u64 = 0xD251_1F53;
const M1: u64 = 0xCD9E_8D57;
const W0: u32 = 0x9E37_79B9;
const W1: u32 = 0xBB67_AE85;

/// Largest number of 128-bit slots per draw (counter word 1 keeps 16 bits for it).
pub(crate) const MAX_SLOTS: usize = 1 << 16;

/// The 64-bit key of a run: its seed.
#[inline(always)]
pub(crate) fn key_of_seed(seed: u64) -> [u32; 2] {
    [seed as u32, (seed >> 32) as u32]
}

/// The counter of (task, draw, slot) (see the module docs).
#[inline(always)]
pub(crate) fn counter(task: u64, draw: u64, slot: u32) -> [u32; 4] {
    [
        draw as u32,
        (slot & 0xFFFF) | (((draw >> 32) as u32) << 16),
        task as u32,
        (task >> 32) as u32,
    ]
}

/// Philox4x32 with 10 rounds: 128 random bits for counter `ctr` under `key`.
///
/// Written with 64-bit products of zero-extended 32-bit words so that, inlined into a loop
/// over lanes, it vectorises to `pmuludq`-style multiplies on every x86 level.
#[inline(always)]
pub(crate) fn philox4x32_10(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let [mut c0, mut c1, mut c2, mut c3] = ctr;
    let [mut k0, mut k1] = key;
    let mut round = |k0: u32, k1: u32| {
        let p0 = M0 * c0 as u64;
        let p1 = M1 * c2 as u64;
        let (hi0, lo0) = ((p0 >> 32) as u32, p0 as u32);
        let (hi1, lo1) = ((p1 >> 32) as u32, p1 as u32);
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
    };
    round(k0, k1);
    for _ in 1..10 {
        k0 = k0.wrapping_add(W0);
        k1 = k1.wrapping_add(W1);
        round(k0, k1);
    }
    [c0, c1, c2, c3]
}

/// Philox4x32-10 of `K` counters at once: the same function as [`philox4x32_10`], evaluated
/// round by round over the lanes. `st[w][d]` holds word `w` of lane `d` in its low 32 bits
/// (the high bits are ignored on input and undefined on output).
///
/// Why this form: one lane's ten rounds are a chain of dependent multiplies (≈ 50 cycles of
/// latency for ≈ 60 instructions), and the lane-by-lane loop left the out-of-order core too
/// few independent chains in flight. With the round loop outside, each round's `K` lanes are
/// independent neighbours in the instruction stream (`K/8` registers per word on AVX-512).
/// Measured: +6–10 % normals per second on one core (`docs/performance.md`).
#[inline(always)]
#[allow(clippy::needless_range_loop)]
pub(crate) fn philox4x32_10_lanes<const K: usize>(st: &mut [[u64; K]; 4], key: [u32; 2]) {
    const LO: u64 = 0xFFFF_FFFF;
    let [mut k0, mut k1] = key.map(u64::from);
    for r in 0..10 {
        if r > 0 {
            k0 = (k0 + W0 as u64) & LO;
            k1 = (k1 + W1 as u64) & LO;
        }
        for d in 0..K {
            let p0 = M0 * (st[0][d] & LO);
            let p1 = M1 * (st[2][d] & LO);
            let c1 = st[1][d];
            let c3 = st[3][d];
            st[0][d] = (p1 >> 32) ^ c1 ^ k0;
            st[1][d] = p1;
            st[2][d] = (p0 >> 32) ^ c3 ^ k1;
            st[3][d] = p0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn philox_nominal_known_answers() {
        // Random123 1.14 `tests/kat_vectors`, the three "philox4x32 10" lines
        // (counter, key → output).
        let cases: [([u32; 4], [u32; 2], [u32; 4]); 3] = [
            (
                [0, 0, 0, 0],
                [0, 0],
                [0x6627_e8d5, 0xe169_c58d, 0xbc57_ac4c, 0x9b00_dbd8],
            ),
            (
                [u32::MAX; 4],
                [u32::MAX; 2],
                [0x408f_276d, 0x41c8_3b0e, 0xa20b_c7c6, 0x6d54_51fd],
            ),
            (
                [0x243f_6a88, 0x85a3_08d3, 0x1319_8a2e, 0x0370_7344],
                [0xa409_3822, 0x299f_31d0],
                [0xd16c_fe09, 0x94fd_cceb, 0x5001_e420, 0x2412_6ea1],
            ),
        ];
        for (ctr, key, want) in cases {
            assert_eq!(philox4x32_10(ctr, key), want);
        }
    }

    #[test]
    fn lanes_nominal_equal_the_scalar_function() {
        // Random123 known-answer inputs and a few more counters, in one 8-lane call (high
        // input bits set, to check they are ignored).
        let key = [0xa409_3822, 0x299f_31d0];
        let ctrs: Vec<[u32; 4]> = (0..8u32)
            .map(|i| [i.wrapping_mul(0x9E37_79B9), i ^ 0xdead, 3 + i, u32::MAX - i])
            .chain([[0x243f_6a88, 0x85a3_08d3, 0x1319_8a2e, 0x0370_7344]])
            .skip(1)
            .collect();
        let mut st = [[0u64; 8]; 4];
        for (d, c) in ctrs.iter().enumerate() {
            for w in 0..4 {
                st[w][d] = c[w] as u64 | 0xABCD_0000_0000_0000;
            }
        }
        philox4x32_10_lanes(&mut st, key);
        for (d, c) in ctrs.iter().enumerate() {
            let got = [0, 1, 2, 3].map(|w| st[w][d] as u32);
            assert_eq!(got, philox4x32_10(*c, key), "lane {d}");
        }
        assert_eq!(
            [0, 1, 2, 3].map(|w| st[w][7] as u32),
            [0xd16c_fe09, 0x94fd_cceb, 0x5001_e420, 0x2412_6ea1]
        );
    }

    #[test]
    fn counter_layout_is_injective_on_its_fields() {
        // Distinct (task, draw, slot) give distinct counters, including draw ≥ 2³².
        let a = counter(5, 7, 1);
        assert_ne!(a, counter(5, 7, 2));
        assert_ne!(a, counter(5, 8, 1));
        assert_ne!(a, counter(6, 7, 1));
        assert_ne!(a, counter(5, 7 + (1 << 32), 1));
        assert_eq!(counter(1 << 33, 3 + (5 << 32), 9), [3, 9 | (5 << 16), 0, 2]);
    }
}
