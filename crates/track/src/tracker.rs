//! Following markers from frame to frame: seeds, a constant-velocity prediction, a search
//! region that grows while a marker is lost, and the checks that keep identities apart.
//!
//! # Rules
//! - A marker starts at its seed in its start frame (the first frame, or the epoch its seed
//!   names): it must be found within [`TrackerOptions::seed_px`] of the seed there.
//! - Afterwards it is looked for around its **prediction**: the last position found plus the
//!   velocity between the last two positions found (pixels per frame) times the frames since.
//!   With one position only (velocity unknown) the region is [`TrackerOptions::first_step_px`]
//!   wide (motion up to 15 px per frame); otherwise [`TrackerOptions::search_px`], grown by
//!   [`TrackerOptions::grow_px`] for every frame the marker has been lost (an occlusion), up to
//!   [`TrackerOptions::max_search_px`].
//! - **Identities never swap**: a centre is accepted only when it is nearer its own marker's
//!   prediction than any other active marker's; two markers found within
//!   [`TrackerOptions::min_separation_px`] of each other are both left out of that frame.
//! - Markers of one frame are fitted in parallel; each marker's result depends on its own
//!   history and the predictions only, so the output is the same for any number of threads.

use crate::centre::{Centre, FitOptions, Reject};
use crate::dot::find_dot;
use crate::image::GreyView;
use crate::quadrant::find_quadrant;
use rayon::prelude::*;

/// The kind of marker tracked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerKind {
    /// A disc in four quadrants, opposite quadrants of one shade; centre = the saddle point.
    Quadrant,
    /// A disc brighter or darker than its surround; centre = the disc's centre.
    Dot,
}

impl MarkerKind {
    /// `quadrant` or `dot`, as on the command line and in `summary.json`.
    pub fn name(self) -> &'static str {
        match self {
            MarkerKind::Quadrant => "quadrant",
            MarkerKind::Dot => "dot",
        }
    }

    /// Looks for a marker of this kind within `radius` of `at`.
    ///
    /// # Errors
    /// Why none was found.
    pub fn find(
        self,
        img: &GreyView,
        at: (f64, f64),
        radius: f64,
        opts: &FitOptions,
        accept: impl Fn(f64, f64) -> bool,
    ) -> Result<Centre, Reject> {
        match self {
            MarkerKind::Quadrant => find_quadrant(img, at, radius, opts, accept),
            MarkerKind::Dot => find_dot(img, at, radius, opts, accept),
        }
    }
}

/// Options of the tracker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerOptions {
    /// The kind of marker.
    pub kind: MarkerKind,
    /// The fit's options.
    pub fit: FitOptions,
    /// A seed must be within this distance of the marker's centre (pixels).
    pub seed_px: f64,
    /// Search radius in the frame after the first position (velocity unknown), pixels.
    pub first_step_px: f64,
    /// Search radius around the prediction once the velocity is known, pixels.
    pub search_px: f64,
    /// Growth of the search radius per frame lost, pixels.
    pub grow_px: f64,
    /// Largest search radius, pixels.
    pub max_search_px: f64,
    /// Two markers found closer than this are both left out (pixels).
    pub min_separation_px: f64,
}

impl TrackerOptions {
    /// The defaults for `kind`: seeds within 4 px (3 px stated plus a margin), 16 px after
    /// the first frame, 6 px around a prediction, +4 px per lost frame up to 40 px, markers
    /// at least 4 px apart.
    pub fn new(kind: MarkerKind) -> Self {
        Self {
            kind,
            fit: FitOptions::default(),
            seed_px: 4.0,
            first_step_px: 16.0,
            search_px: 6.0,
            grow_px: 4.0,
            max_search_px: 40.0,
            min_separation_px: 4.0,
        }
    }
}

/// Where one marker is to be tracked from.
#[derive(Debug, Clone, PartialEq)]
pub struct Seed {
    /// The marker's name.
    pub name: String,
    /// Rough centre, column (pixels, COLMAP convention).
    pub u_px: f64,
    /// Rough centre, row (pixels).
    pub v_px: f64,
    /// The frame index where the seed lies.
    pub frame: usize,
}

#[derive(Debug, Clone)]
struct MarkerState {
    seed: Seed,
    /// The last two positions found: (frame, u, v), oldest first.
    last: Vec<(usize, f64, f64)>,
}

impl MarkerState {
    /// Prediction and search radius for `frame`, `None` before the marker's start.
    fn search(&self, frame: usize, o: &TrackerOptions) -> Option<((f64, f64), f64)> {
        if frame < self.seed.frame {
            return None;
        }
        if frame == self.seed.frame || self.last.is_empty() {
            // Its start frame (or never found since: keep looking around the seed).
            return Some(((self.seed.u_px, self.seed.v_px), o.seed_px));
        }
        let &(f2, u2, v2) = self.last.last()?;
        let gap = (frame - f2) as f64;
        if self.last.len() < 2 {
            let r = (o.first_step_px + o.grow_px * (gap - 1.0)).min(o.max_search_px);
            return Some(((u2, v2), r));
        }
        let (f1, u1, v1) = self.last[0];
        let df = (f2 - f1) as f64;
        let (vu, vv) = ((u2 - u1) / df, (v2 - v1) / df);
        let r = (o.search_px + o.grow_px * (gap - 1.0)).min(o.max_search_px);
        Some(((u2 + vu * gap, v2 + vv * gap), r))
    }
}

/// A marker that could not be found at its seed.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedMiss {
    /// Index of the marker (seed order).
    pub marker: usize,
    /// Why.
    pub reason: Reject,
}

/// The tracker: feed it frames in order with [`Tracker::step`].
#[derive(Debug, Clone)]
pub struct Tracker {
    options: TrackerOptions,
    markers: Vec<MarkerState>,
}

impl Tracker {
    /// A tracker of `seeds` (their order is the output's order).
    pub fn new(seeds: Vec<Seed>, options: TrackerOptions) -> Self {
        Self {
            options,
            markers: seeds
                .into_iter()
                .map(|seed| MarkerState {
                    seed,
                    last: Vec::new(),
                })
                .collect(),
        }
    }

    /// Number of markers.
    pub fn len(&self) -> usize {
        self.markers.len()
    }

    /// Whether there are no markers.
    pub fn is_empty(&self) -> bool {
        self.markers.is_empty()
    }

    /// Whether marker `i` has started by `frame` (it is then counted as found or lost).
    pub fn started(&self, i: usize, frame: usize) -> bool {
        frame >= self.markers[i].seed.frame
    }

    /// Tracks every marker in frame `frame` (frames must come in increasing order): one entry
    /// per marker, in seed order, `None` where it was not found.
    ///
    /// # Errors
    /// A marker whose seed lies in this frame and is not found there.
    pub fn step(&mut self, frame: usize, img: &GreyView) -> Result<Vec<Option<Centre>>, SeedMiss> {
        let o = self.options;
        let searches: Vec<Option<((f64, f64), f64)>> =
            self.markers.iter().map(|m| m.search(frame, &o)).collect();
        let found: Vec<Result<Centre, Reject>> = (0..self.markers.len())
            .into_par_iter()
            .map(|i| {
                let Some((at, radius)) = searches[i] else {
                    return Err(Reject::NoCandidate);
                };
                // Nearer its own prediction than any other marker's.
                let nearest_is_own = |u: f64, v: f64| {
                    let own = (u - at.0).hypot(v - at.1);
                    own <= radius + 0.5 * o.fit.window_px
                        && searches.iter().enumerate().all(|(j, s)| {
                            j == i || s.is_none_or(|(p, _)| (u - p.0).hypot(v - p.1) > own)
                        })
                };
                o.kind.find(img, at, radius, &o.fit, nearest_is_own)
            })
            .collect();
        // Seeds must be found.
        for (i, m) in self.markers.iter().enumerate() {
            if m.seed.frame == frame
                && let Err(reason) = found[i]
            {
                return Err(SeedMiss { marker: i, reason });
            }
        }
        let mut out: Vec<Option<Centre>> = found.into_iter().map(Result::ok).collect();
        // Two markers on one spot: neither is trusted.
        let mut clash = vec![false; out.len()];
        for i in 0..out.len() {
            for j in i + 1..out.len() {
                if let (Some(a), Some(b)) = (&out[i], &out[j])
                    && (a.u_px - b.u_px).hypot(a.v_px - b.v_px) < o.min_separation_px
                {
                    clash[i] = true;
                    clash[j] = true;
                }
            }
        }
        for (i, c) in clash.into_iter().enumerate() {
            if c {
                out[i] = None;
            }
        }
        for (m, c) in self.markers.iter_mut().zip(&out) {
            if let Some(c) = c {
                m.last.push((frame, c.u_px, c.v_px));
                if m.last.len() > 2 {
                    m.last.remove(0);
                }
            }
        }
        Ok(out)
    }
}
