//! The kernel layer: everything the draw loops are made of, importing nothing above it (only
//! `crashrig-geometry`'s DLT rows, nalgebra, pulp and std).
//!
//! - [`simd`]: the instruction-set levels ([`Isa`]) and the dispatch that compiles a kernel per
//!   level; the level is an explicit argument, never read from the environment.
//! - [`philox`], [`normal`]: counter-based bits (Philox4x32-10) into standard normals
//!   (Box–Muller), 64 draws per block ([`LANES`]).
//! - [`lanes`]: the lane forms — the pose-noise factor `δ = L·ε`, the perturbed rotations and
//!   rays by their series, the per-lane DLT normal equations.
//! - [`scalar`]: the same formulas per draw (exact `sin`/`cos`), the fallback of a lane beyond
//!   the series and the reference of the tests; the scalar DLT normal equations.
//! - [`accumulate`]: streaming sums of the intersected points; [`ordered`]: the thread-count
//!   independent map-and-merge of the runs.

pub(crate) mod accumulate;
pub(crate) mod lanes;
pub(crate) mod normal;
pub(crate) mod ordered;
pub(crate) mod philox;
pub(crate) mod scalar;
pub(crate) mod simd;
pub(crate) mod zig_lanes;
#[cfg(test)]
pub(crate) mod ziggurat;

pub(crate) use scalar::*;
pub use simd::Isa;
