//! The Monte Carlo's moments by row, kinematic run and scale bar: drawn here for a shard's
//! markers, or given as the union of a shard set's.

use super::filtered::KinWork;
use super::prepare::{EpochPrep, Slot};
use crate::Error;
use crate::kinematics::{Run, RunAcc};
use crate::length::{BarAcc, BarPrep};
use crashrig_stats::Moments;
use std::collections::BTreeMap;

/// A row's streaming moments of position, displacement and velocity.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Acc {
    pub pos: Moments<3>,
    pub disp: Moments<3>,
    pub vel: Moments<3>,
}

/// The Monte Carlo's accumulators of some markers ([`crate::shard`]): the rows' moments by
/// (measured epoch, marker) and the kinematic runs' moments by (marker, first epoch).
#[derive(Debug, Clone, Default)]
pub(crate) struct Accs {
    pub rows: BTreeMap<(usize, usize), Acc>,
    pub runs: BTreeMap<(usize, usize), RunAcc>,
    /// The scale bars' moments by bar index ([`crate::length`]).
    pub bars: BTreeMap<usize, BarAcc>,
}

/// Where the Monte Carlo's moments come from.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Draws<'a> {
    /// Drawn here, for the markers of this shard (`Shard::whole()`: every marker).
    Shard(crashrig_outdir::shard::Shard),
    /// Given, per pass (the measurement, then the one without the trigger offset): the union
    /// of a shard set's accumulators.
    Given(&'a [Accs]),
}

/// The Monte Carlo's moments of every row, kinematic run and scale bar.
pub(super) struct AllMoments {
    pub(super) rows: Vec<Vec<Acc>>,
    pub(super) runs: Vec<Vec<RunAcc>>,
    pub(super) bars: Vec<BarAcc>,
}

/// The accumulators of the rows and kinematic runs of the markers `mine` and of the scale
/// bars `my_bars` (a shard's).
pub(super) fn shard_part(
    preps: &[EpochPrep],
    kin_runs: Option<&[Vec<Run>]>,
    moments: &AllMoments,
    mine: &std::ops::Range<usize>,
    my_bars: std::ops::Range<usize>,
) -> Accs {
    let mut part = Accs::default();
    for (e, p) in preps.iter().enumerate() {
        for (s, slot) in p.slots.iter().enumerate() {
            if mine.contains(&slot.marker) {
                part.rows.insert((e, slot.marker), moments.rows[e][s]);
            }
        }
    }
    for (runs, racc) in kin_runs.into_iter().flatten().zip(&moments.runs) {
        for (run, acc) in runs.iter().zip(racc) {
            part.runs.insert((run.marker, run.start), acc.clone());
        }
    }
    for b in my_bars {
        part.bars.insert(b, moments.bars[b].clone());
    }
    part
}

/// The accumulators of every row and run, from the union of a shard set's ([`Draws::Given`]).
///
/// # Errors
/// [`Error::Input`] naming the first row or run that no shard holds, or a run whose length
/// differs (the shards come from other inputs).
pub(super) fn given_moments(
    preps: &[EpochPrep],
    kin: Option<&KinWork<'_>>,
    bars: &[BarPrep],
    given: &Accs,
) -> Result<AllMoments, Error> {
    let mut accs = Vec::with_capacity(preps.len());
    for (e, p) in preps.iter().enumerate() {
        let row = |slot: &Slot| {
            given.rows.get(&(e, slot.marker)).copied().ok_or_else(|| {
                Error::Input(format!(
                    "no shard holds the moments of measured epoch {e}, marker {}",
                    slot.marker
                ))
            })
        };
        accs.push(p.slots.iter().map(row).collect::<Result<Vec<_>, _>>()?);
    }
    let runs = kin.map_or(&[][..], |k| k.runs);
    let (n_rows, n_runs) = (
        accs.iter().map(Vec::len).sum(),
        runs.iter().map(Vec::len).sum(),
    );
    if (given.rows.len(), given.runs.len()) != (n_rows, n_runs) {
        return Err(Error::Input(format!(
            "the shards hold the moments of {} rows and {} kinematic runs, the run has {n_rows} and {n_runs}",
            given.rows.len(),
            given.runs.len()
        )));
    }
    let mut kin_accs = Vec::new();
    for runs in runs {
        let mut racc = Vec::with_capacity(runs.len());
        for run in runs {
            match given.runs.get(&(run.marker, run.start)) {
                Some(acc) if acc.m.len() == run.len => racc.push(acc.clone()),
                _ => {
                    return Err(Error::Input(format!(
                        "no shard holds the moments of marker {}'s kinematic run of {} epochs from measured epoch {}",
                        run.marker, run.len, run.start
                    )));
                }
            }
        }
        kin_accs.push(racc);
    }
    let mut bar_accs = Vec::with_capacity(bars.len());
    for (b, bar) in bars.iter().enumerate() {
        match given.bars.get(&b) {
            Some(acc) if acc.dist.len() == bar.epochs.len() => bar_accs.push(acc.clone()),
            _ => {
                return Err(Error::Input(format!(
                    "no shard holds the moments of scale bar {b} over {} epochs",
                    bar.epochs.len()
                )));
            }
        }
    }
    if given.bars.len() != bars.len() {
        return Err(Error::Input(format!(
            "the shards hold the moments of {} scale bars, the run has {}",
            given.bars.len(),
            bars.len()
        )));
    }
    Ok(AllMoments {
        rows: accs,
        runs: kin_accs,
        bars: bar_accs,
    })
}
