//! Runtime dispatch of the kinematics' hot loop (gather, filter, differences and moments of
//! [`LANES`](crate::kinematics) replicates at a time) to the widest vector level the CPU has,
//! with `pulp` (safe API): the loop is compiled inside a `#[target_feature]` function, so the
//! twelve side-by-side recurrences of a [`Lanes`](crate::kinematics) group take three 256-bit
//! registers on x86-64-v3 instead of six 128-bit ones on the SSE2 baseline.
//!
//! # The same bits on every level
//! The loop uses only `+ − × ÷` and comparisons, which IEEE 754 rounds alike at every vector
//! width, and Rust never fuses `a·b + c` on its own: every level computes every value with the
//! same operations in the same order (`tests::every_level_gives_the_same_kinematics` compares the bits of a group's filtered
//! values and moments against the scalar level).

/// Runs `job` compiled for the CPU's widest vector level. Its `with_simd` and what it calls in
/// its loops must be `#[inline(always)]`, so that they are compiled inside that level's
/// function (a closure would be compiled on its own, for the baseline).
#[inline(always)]
pub(crate) fn vectorized<W: pulp::WithSimd>(job: W) -> W::Output {
    pulp::Arch::new().dispatch(job)
}

#[cfg(test)]
mod tests {
    use crate::filter::{Cfc, Standard};
    use crate::kinematics::{AxisMoments, Differences, LANES, Lanes, Scratch};

    /// The kinematics' arithmetic of one group of replicates (filter, differences, moments)
    /// as the Monte Carlo runs it.
    struct Group<'a> {
        filter: &'a Cfc,
        d: &'a [Lanes],
    }

    impl pulp::WithSimd for Group<'_> {
        type Output = Vec<u64>;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _simd: S) -> Vec<u64> {
            let mut scratch = Scratch::<Lanes>::default();
            scratch.filter(self.filter, self.d);
            let diff = Differences::new(1.0 / self.filter.frame_rate_hz());
            let f = &scratch.f;
            let mut m = vec![[AxisMoments::default(); 3]; f.len()];
            let mut bits = Vec::new();
            for l in 0..LANES {
                let inv_n = 1.0 / (l + 1) as f64;
                for (i, q) in m.iter_mut().enumerate() {
                    let (v, a) = (diff.velocity(f, i), diff.acceleration(f, i));
                    q[0].push(&f[i].lane(l), inv_n);
                    q[1].push(&v.lane(l), inv_n);
                    q[2].push(&a.lane(l), inv_n);
                }
            }
            for q in &m {
                for a in q {
                    let s = a.std_dev(LANES as u64).unwrap();
                    bits.extend(s.iter().map(|x| x.to_bits()));
                }
            }
            bits.extend(f.iter().flat_map(|x| x.0.map(f64::to_bits)));
            bits
        }
    }

    /// The CPU's widest level computes every filtered value and moment of a group with the
    /// same bits as the scalar level (no target features).
    #[test]
    fn every_level_gives_the_same_kinematics() {
        let d: Vec<Lanes> = (0..700)
            .map(|i| {
                let t = i as f64 * 5e-5;
                Lanes(std::array::from_fn(|k| {
                    (37.0 * t * (k + 1) as f64).sin() * 5.0 + t * t * 1e4 * k as f64 - 0.3
                }))
            })
            .collect();
        for standard in [Standard::J211, Standard::Iso6487] {
            let filter = Cfc::new(180, standard, 20_000.0).unwrap();
            let wide = super::vectorized(Group {
                filter: &filter,
                d: &d,
            });
            let scalar = pulp::Simd::vectorize(
                pulp::Scalar::new(),
                Group {
                    filter: &filter,
                    d: &d,
                },
            );
            assert_eq!(wide.len(), scalar.len());
            let differ = wide.iter().zip(&scalar).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{standard:?}: {differ} values differ");
        }
    }
}
