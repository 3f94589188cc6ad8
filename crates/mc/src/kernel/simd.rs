//! Runtime instruction-set dispatch of the Monte Carlo kernels, with `pulp` (safe API, no
//! `unsafe` here).
//!
//! The kernels are plain loops over lane arrays ([`super::normal::LANES`] draws per block),
//! marked `#[inline(always)]` down to the arithmetic. [`dispatch`] runs such a kernel inside
//! a function compiled for the chosen level (pulp's `Simd::vectorize`, a
//! `#[target_feature]` function), so the compiler vectorises the inlined loops with that
//! level's registers: 512-bit on x86-64-v4 (AVX-512), 256-bit on x86-64-v3 (AVX2+FMA),
//! 128-bit SSE2 on the x86-64 baseline, NEON on aarch64.
//!
//! # Bit-identical on every level
//! The kernels use only operations that IEEE 754 rounds exactly the same way at any vector
//! width — `+ − × ÷ √`, comparisons, integer and bit operations — and, where they help
//! (polynomials, dot products, the cofactor solve), fused multiply-adds written explicitly as
//! `f64::mul_add` (one rounding, by definition). Rust never contracts `a*b + c` on its own,
//! so an expression is either always fused or never. `mul_add` is an FMA instruction on
//! x86-64-v3/v4 and NEON and the correctly rounded libm `fma` on the SSE2 baseline (glibc's
//! uses the FMA instruction when the CPU has one, exact software otherwise): the same bits,
//! only slower (≈ 10× on the baseline; `docs/performance.md` weighs the alternatives). No other libm function is called in the vectorised loops. Sums are kept per
//! lane of the 64-draw block and reduced in lane order, whatever the register width. So
//! every level gives the same bits; `grid::tests::every_isa_gives_identical_grids`,
//! `fixed::tests::fixed_every_isa_gives_identical_grids`,
//! `chain::tests::chain_every_isa_gives_identical_results` and
//! `normal::block_tests::fill_block_is_identical_on_every_isa_and_row_count` force each
//! available level and compare the results exactly.
//!
//! # Choosing the level
//! The level is an explicit, typed argument: [`Isa::Auto`] (what the library's entry points
//! use) takes the best level the CPU has; an explicit level the CPU lacks falls back to the
//! best available one. No environment variable is read — the results are the same bits on
//! every level, so the choice only changes the speed. Tests and benchmarks pass an explicit
//! [`Isa`].

use std::sync::OnceLock;

/// Instruction-set level of the Monte Carlo kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Isa {
    /// The best level of this CPU.
    Auto,
    /// The target's baseline (SSE2 on x86-64; NEON on aarch64, where it is the baseline).
    Baseline,
    /// x86-64-v3: AVX2 + FMA, 256-bit.
    X86V3,
    /// x86-64-v4: AVX-512 (F, BW, CD, DQ, VL), 512-bit.
    X86V4,
}

impl Isa {
    /// The explicit levels, slowest first.
    pub const LEVELS: [Isa; 3] = [Isa::Baseline, Isa::X86V3, Isa::X86V4];

    /// Whether this CPU can run the level.
    pub fn is_available(self) -> bool {
        match self {
            Isa::Auto | Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::X86V3 => pulp::x86::V3::try_new().is_some(),
            #[cfg(target_arch = "x86_64")]
            Isa::X86V4 => pulp::x86::V4::try_new().is_some(),
            #[cfg(not(target_arch = "x86_64"))]
            Isa::X86V3 | Isa::X86V4 => false,
        }
    }

    /// The level `dispatch` will run for this request (resolving `Auto` and unavailable
    /// levels).
    pub fn resolve(self) -> Isa {
        match self {
            Isa::Auto => *AUTO.get_or_init(best),
            l if l.is_available() => l,
            _ => best(),
        }
    }

    /// A short name (`baseline`, `v3`, `v4`, or `auto`).
    pub fn name(self) -> &'static str {
        match self {
            Isa::Auto => "auto",
            Isa::Baseline => "baseline",
            Isa::X86V3 => "v3",
            Isa::X86V4 => "v4",
        }
    }
}

static AUTO: OnceLock<Isa> = OnceLock::new();

fn best() -> Isa {
    Isa::LEVELS
        .into_iter()
        .rev()
        .find(|l| l.is_available())
        .unwrap_or(Isa::Baseline)
}

/// How much the level's vector registers hold, fixed per level at compile time: the block
/// kernels choose their loop shapes from it. Both shapes compute the same operations in the
/// same order, so the results are the same bits; only the speed differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Width {
    /// At least 256 f64 lanes of registers (AVX-512: 32 registers × 8 lanes): Philox round
    /// by round over 32 lanes, and each aimed observer's stages fused into one pass. On
    /// x86-64-v4 this is 1.10–1.2× faster than the narrow shape (`docs/performance.md`).
    Wide,
    /// Fewer (AVX2: 16 × 4, NEON: 32 × 2, SSE2: 16 × 2): the wide shape's live values would
    /// spill (measured 1.3× slower on x86-64-v3), so Philox lane by lane and one pass per stage.
    Narrow,
}

/// A closure run under a SIMD level.
struct Job<F>(F);

impl<R, F: FnOnce(Width) -> R> pulp::WithSimd for Job<F> {
    type Output = R;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> R {
        let lanes = S::REGISTER_COUNT * (size_of::<S::f64s>() / size_of::<f64>());
        let wide = lanes >= 256;
        #[cfg(test)]
        let wide = wide && !FORCE_NARROW.load(std::sync::atomic::Ordering::Relaxed);
        (self.0)(if wide { Width::Wide } else { Width::Narrow })
    }
}

/// Tests: run the wide levels with the narrow loop shapes (both must give the same bits).
#[cfg(test)]
pub(crate) static FORCE_NARROW: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Runs `f` compiled for `isa` (see the module docs), passing it the level's [`Width`] (a
/// constant inside each level's function). `f` and everything it calls in the hot loop must
/// be `#[inline(always)]` so that it is compiled inside the level's function.
#[inline(always)]
pub(crate) fn dispatch<R>(isa: Isa, f: impl FnOnce(Width) -> R) -> R {
    let job = Job(f);
    match isa.resolve() {
        #[cfg(target_arch = "x86_64")]
        Isa::X86V4 => match pulp::x86::V4::try_new() {
            Some(s) => pulp::Simd::vectorize(s, job),
            None => pulp::Arch::new().dispatch(job),
        },
        #[cfg(target_arch = "x86_64")]
        Isa::X86V3 => match pulp::x86::V3::try_new() {
            Some(s) => pulp::Simd::vectorize(s, job),
            None => pulp::Arch::new().dispatch(job),
        },
        #[cfg(target_arch = "x86_64")]
        _ => pulp::Simd::vectorize(pulp::Scalar::new(), job),
        #[cfg(not(target_arch = "x86_64"))]
        _ => pulp::Arch::new().dispatch(job),
    }
}
