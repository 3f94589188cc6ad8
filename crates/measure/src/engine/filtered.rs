//! The filtered kinematics of the Monte Carlo: every replicate's runs filtered and
//! differentiated, and the kinematic rows assembled.

use super::positions::finite;
use super::prepare::EpochPrep;
use crate::filter::Cfc;
use crate::kinematics::{Differences, KinRow, Kinematics, LANES, Lanes, Run, RunAcc, Scratch};
use crashrig_geometry::Vec3;

/// The kinematic rows: the nominal runs filtered and differentiated, σ from the replicates.
pub(super) fn assemble_kinematics(
    preps: &[EpochPrep],
    kin: &KinWork<'_>,
    accs: &[Vec<RunAcc>],
    reference: usize,
    n_rows: usize,
) -> Kinematics {
    // Row index of (epoch, slot): rows are epoch-major in slot order.
    let mut offsets = Vec::with_capacity(preps.len());
    let mut n = 0;
    for p in preps {
        offsets.push(n);
        n += p.slots.len();
    }
    let mut rows = vec![KinRow::default(); n_rows];
    let mut scratch = Scratch::<Vec3>::default();
    let mut with = 0;
    for (runs, racc) in kin.runs.iter().zip(accs) {
        for (run, acc) in runs.iter().zip(racc) {
            let mk = run.marker;
            let nominal = |e: usize| {
                preps[e].slot_of[mk]
                    .and_then(|s| preps[e].slots[s].nominal)
                    .unwrap_or_else(|| Vec3::repeat(f64::NAN))
            };
            let xr = nominal(reference);
            let d: Vec<Vec3> = (run.start..run.start + run.len)
                .map(|e| nominal(e) - xr)
                .collect();
            scratch.filter_and_differentiate(kin.filter, &d);
            for i in 0..run.len {
                let e = run.start + i;
                let Some(s) = preps[e].slot_of[mk] else {
                    continue;
                };
                let [d, v, a] = &acc.m[i];
                rows[offsets[e] + s] = KinRow {
                    displacement_mm: Some(scratch.f[i]),
                    displacement_sigma_mm: d.std_dev(acc.n),
                    velocity_m_s: Some(scratch.v[i]),
                    velocity_sigma_m_s: v.std_dev(acc.n),
                    acceleration_m_s2: Some(scratch.a[i]),
                    acceleration_sigma_m_s2: a.std_dev(acc.n),
                };
                with += 1;
            }
        }
    }
    Kinematics {
        filter: *kin.filter,
        rows,
        rows_with_kinematics: with,
        runs: kin.runs.iter().map(Vec::len).sum(),
    }
}

/// The kinematics work of the Monte Carlo: the filter and every marker's runs.
pub(super) struct KinWork<'a> {
    pub(super) filter: &'a Cfc,
    pub(super) runs: &'a [Vec<Run>],
}

/// Filters one run of one marker in each of the `m` replicates of a chunk and feeds its
/// moments (a replicate with a failed intersection in the run, or at the reference epoch, is
/// left out). [`LANES`] replicates at a time: their displacement series are gathered side by
/// side ([`Lanes`]; `bufs[e]` holds the chunk's replicates of a slot contiguously), filtered
/// together — each replicate with exactly the arithmetic of its own record — and their
/// velocity and acceleration taken at each epoch as the moments are fed. Every accumulator
/// still takes the replicates in replicate order, so the moments have the bits of a
/// replicate-by-replicate loop.
/// The job the vector level runs (`crate::simd`; a struct rather than a closure: its
/// `with_simd` is `#[inline(always)]`, so the whole body is compiled for the level).
pub(super) struct FeedRun<'a> {
    pub(super) filter: &'a Cfc,
    pub(super) run: &'a Run,
    pub(super) acc: &'a mut RunAcc,
    pub(super) preps: &'a [EpochPrep],
    pub(super) bufs: &'a [Vec<Vec3>],
    pub(super) reference: usize,
    pub(super) m: usize,
    pub(super) scratch: &'a mut Scratch<Lanes>,
}

impl pulp::WithSimd for FeedRun<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let FeedRun {
            filter,
            run,
            acc,
            preps,
            bufs,
            reference,
            m,
            scratch,
        } = self;
        let slot = |e: usize| preps[e].slot_of[run.marker].expect("a run's epochs see its marker");
        let rs = slot(reference);
        let diff = Differences::new(1.0 / filter.frame_rate_hz());
        let (len, groups) = (run.len, m.div_ceil(LANES));
        let xr = &bufs[reference][rs * m..rs * m + m];
        // The epochs' slots first, in a loop of independent lookups (the CPU overlaps their cache
        // misses), then the gather reads each epoch's replicates at a known address.
        let mut slots = std::mem::take(&mut scratch.slots);
        slots.clear();
        slots.extend((run.start..run.start + len).map(slot));
        // Group by group: group `g` of replicates `g·LANES…` at run epoch `i` goes to `d[i]`,
        // which is filtered and fed at once (one group's series stays in the core's cache,
        // where all groups' series side by side did not). A lane past `m` in the last group
        // keeps whatever it held (it is filtered alongside but never fed), so `d` is only
        // resized.
        let mut d = std::mem::take(&mut scratch.d);
        d.resize(len, Lanes([0.0; 3 * LANES]));
        for g in 0..groups {
            let (r0, lanes) = (g * LANES, LANES.min(m - g * LANES));
            let xr = &xr[r0..r0 + lanes];
            let mut taken = [true; LANES];
            for ((&s, e), di) in slots.iter().zip(run.start..).zip(d.iter_mut()) {
                let b = s * m + r0;
                for (l, (x, xr)) in bufs[e][b..b + lanes].iter().zip(xr).enumerate() {
                    let dx = x - xr;
                    taken[l] &= finite(&dx);
                    di.set_lane(l, &dx);
                }
            }
            scratch.filter(filter, &d);
            let mut inv_n = [0.0; LANES];
            for l in 0..lanes {
                if taken[l] {
                    acc.n += 1;
                    inv_n[l] = 1.0 / acc.n as f64;
                }
            }
            let f = &scratch.f;
            for (i, q) in acc.m.iter_mut().enumerate() {
                let (v, a) = (diff.velocity(f, i), diff.acceleration(f, i));
                for l in (0..lanes).filter(|&l| taken[l]) {
                    q[0].push(&f[i].lane(l), inv_n[l]);
                    q[1].push(&v.lane(l), inv_n[l]);
                    q[2].push(&a.lane(l), inv_n[l]);
                }
            }
        }
        scratch.d = d;
        scratch.slots = slots;
    }
}
