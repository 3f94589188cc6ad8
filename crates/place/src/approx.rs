//! The first-order approximation the search runs on: per grid point and observer, the additive
//! [`LinearTerm`] of the forward intersection (`crashrig_mc::GridStudy::linear_terms`, the same
//! model as `grid`'s first-order map), so a layout's covariance at a point is
//! `A⁻¹ N A⁻¹` of the sums of its observers' terms — no Jacobian is recomputed per layout.

use crashrig_mc::degenerate::is_degenerate;
use crashrig_mc::{GridStudy, LinearTerm};
use crashrig_stats::progress::{Counter, Progress};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::sync::atomic::{AtomicU64, Ordering as AtomicOrdering};

/// One candidate's share at one grid point.
#[derive(Debug, Clone, Copy)]
struct Seen {
    term: LinearTerm,
    /// Unit line of sight from the candidate to the point (for the intersection angle).
    dir: Vector3<f64>,
}

/// The base layout's (the scenario's own observers) share at one grid point.
#[derive(Debug, Clone)]
struct Base {
    term: LinearTerm,
    dirs: Vec<Vector3<f64>>,
}

/// The terms of every grid point for the base layout and every candidate:
/// `points × candidates` entries (bounded by [`crate::MAX_TERMS`] before it is built).
#[derive(Debug)]
pub struct Table {
    base: Vec<Base>,
    /// Layouts scored so far ([`Table::score`] calls).
    scored: AtomicU64,
    cand: Vec<Option<Seen>>,
    candidates: usize,
    threshold_mm: f64,
}

/// The approximate objective of a layout: points at or below the threshold, then the mean
/// σ_max of the measurable, non-degenerate points (lower is better).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Score {
    /// Points with σ_max ≤ threshold.
    pub below: usize,
    /// Grid points.
    pub points: usize,
    /// Σ σ_max over the points with a σ (mm).
    pub sum_sigma_max_mm: f64,
    /// Points with a σ (seen twice, not degenerate).
    pub with_sigma: usize,
}

impl Score {
    /// Share of the grid with σ_max ≤ threshold.
    pub fn share(&self) -> f64 {
        self.below as f64 / self.points.max(1) as f64
    }

    /// Mean σ_max (mm) of the points with a σ; NaN when there is none.
    pub fn mean_sigma_max_mm(&self) -> f64 {
        if self.with_sigma == 0 {
            f64::NAN
        } else {
            self.sum_sigma_max_mm / self.with_sigma as f64
        }
    }

    /// `Greater` when `self` is the better layout: more points below, then the lower mean
    /// (no σ at all ranks last).
    pub fn compare(&self, other: &Score) -> Ordering {
        let mean = |s: &Score| {
            let m = s.mean_sigma_max_mm();
            if m.is_nan() { f64::INFINITY } else { m }
        };
        self.below
            .cmp(&other.below)
            .then_with(|| mean(other).total_cmp(&mean(self)))
    }

    /// The score of per-point σ_max values (`None`: no σ).
    pub fn of(sigmas: impl Iterator<Item = Option<f64>>, threshold_mm: f64) -> Score {
        let mut s = Score {
            below: 0,
            points: 0,
            sum_sigma_max_mm: 0.0,
            with_sigma: 0,
        };
        for v in sigmas {
            s.points += 1;
            if let Some(v) = v.filter(|v| v.is_finite()) {
                s.with_sigma += 1;
                s.sum_sigma_max_mm += v;
                if v <= threshold_mm {
                    s.below += 1;
                }
            }
        }
        s
    }
}

impl Table {
    /// Bytes of one (grid point, candidate) entry of the table, the unit of
    /// [`crate::MAX_TERMS`] (a candidate's two 3 × 3 matrices and its line of sight).
    pub const BYTES_PER_TERM: usize = std::mem::size_of::<Option<Seen>>();

    /// The terms of `study` (its first `base` observers are the scenario's own, the rest the
    /// candidates) at every grid point, in parallel; `progress` counts points.
    ///
    /// # Errors
    /// As [`GridStudy::linear_terms`].
    pub fn build(
        study: &GridStudy,
        base: usize,
        progress: Option<Progress<'_>>,
    ) -> Result<Table, crashrig_mc::Error> {
        let grid = study.grid();
        let points = grid.points();
        let counter = Counter::new(progress, points.len());
        let rows: Vec<(Base, Vec<Option<Seen>>)> = points
            .par_iter()
            .map(|p| {
                let terms = study.linear_terms(p)?;
                counter.add(1);
                let dir = |k: usize| (p - grid.observers[k].position_mm).normalize();
                let mut b = Base {
                    term: LinearTerm::zero(),
                    dirs: Vec::new(),
                };
                for (k, t) in terms[..base].iter().enumerate() {
                    if let Some(t) = t {
                        b.term.add(t);
                        b.dirs.push(dir(k));
                    }
                }
                let c = terms[base..]
                    .iter()
                    .enumerate()
                    .map(|(j, t)| {
                        t.map(|term| Seen {
                            term,
                            dir: dir(base + j),
                        })
                    })
                    .collect();
                Ok((b, c))
            })
            .collect::<Result<_, crashrig_mc::Error>>()?;
        counter.finish();
        let candidates = grid.observers.len() - base;
        let mut table = Table {
            scored: AtomicU64::new(0),
            base: Vec::with_capacity(rows.len()),
            cand: Vec::with_capacity(rows.len() * candidates),
            candidates,
            threshold_mm: grid.threshold_mm,
        };
        for (b, c) in rows {
            table.base.push(b);
            table.cand.extend(c);
        }
        Ok(table)
    }

    /// Layouts scored so far.
    pub fn scored(&self) -> u64 {
        self.scored.load(AtomicOrdering::Relaxed)
    }

    /// Number of candidates.
    pub fn candidates(&self) -> usize {
        self.candidates
    }

    /// First-order σ_max (mm) of `layout` (candidate indices) at point `p`; `None` where fewer
    /// than two observers see it or its intersection angle is degenerate (as `grid` blanks
    /// it). `dirs` is scratch space.
    pub fn sigma_max(
        &self,
        p: usize,
        layout: &[usize],
        dirs: &mut Vec<Vector3<f64>>,
    ) -> Option<f64> {
        let b = &self.base[p];
        let row = &self.cand[p * self.candidates..(p + 1) * self.candidates];
        let mut term = b.term;
        dirs.clear();
        dirs.extend_from_slice(&b.dirs);
        for &c in layout {
            if let Some(s) = &row[c] {
                term.add(&s.term);
                dirs.push(s.dir);
            }
        }
        if dirs.len() < 2 || !wide_enough(dirs) {
            return None;
        }
        let cov = term.covariance();
        let v = cov[(0, 0)].max(cov[(1, 1)]).max(cov[(2, 2)]);
        Some(v.sqrt())
    }

    /// The approximate [`Score`] of `layout`.
    pub fn score(&self, layout: &[usize], dirs: &mut Vec<Vector3<f64>>) -> Score {
        self.scored.fetch_add(1, AtomicOrdering::Relaxed);
        Score::of(
            (0..self.base.len()).map(|p| self.sigma_max(p, layout, dirs)),
            self.threshold_mm,
        )
    }
}

/// Whether some two lines of sight meet at an angle that is not degenerate (the rule of
/// `crashrig_mc::degenerate`, with an early exit).
fn wide_enough(dirs: &[Vector3<f64>]) -> bool {
    for (i, a) in dirs.iter().enumerate() {
        for b in &dirs[i + 1..] {
            let angle = a.cross(b).norm().atan2(a.dot(b).abs()).to_degrees();
            if !is_degenerate(angle) {
                return true;
            }
        }
    }
    false
}
