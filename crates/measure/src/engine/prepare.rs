//! The preparation of a measurement: the observations grouped by epoch and marker, the views
//! undistorted, the nominal intersections, the link, camera A's track and the scale bars.

use super::{Epoch, MeasuredEpoch, Rig, Settings};
use crate::Error;
use crate::input::{Inward, Observation};
use crate::length::{self, BarEpochPrep, BarPrep};
use crate::sequence::frame_number;
use crashrig_camera::Camera;
use crashrig_geometry::triangulate::{self, View};
use crashrig_geometry::{Mat3, Mat6, Vec3, so3};
use nalgebra::{Matrix2, Vector2, Vector3};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// One view of a marker prepared for the draws.
#[derive(Debug, Clone, Copy)]
pub(super) struct ViewPrep {
    pub(super) cam: usize,
    pub(super) n0: Vector2<f64>,
    /// `J⁻¹·L` (`L·Lᵀ` the observation's Σ; `σ_px·J⁻¹` with one σ): normalized perturbation
    /// per unit normal.
    pub(super) m: Matrix2<f64>,
}

#[derive(Debug, Clone)]
pub(super) struct Slot {
    pub(super) marker: usize,
    pub(super) n_views: usize,
    pub(super) views: Vec<ViewPrep>,
    pub(super) nominal: Option<Vec3>,
    pub(super) reprojection_px: Option<f64>,
    pub(super) degenerate: bool,
    /// Intersected in the draws (false: a marker of another shard, whose pixel noise is drawn
    /// and dropped so that the epoch's stream stays aligned).
    pub(super) drawn: bool,
}

impl Slot {
    pub(super) fn drawable(&self) -> bool {
        self.nominal.is_some()
    }
}

#[derive(Debug, Clone)]
pub(super) struct EpochPrep {
    pub(super) r_wa: Mat3,
    pub(super) c_a: Vec3,
    pub(super) l_a: Mat6,
    pub(super) slots: Vec<Slot>,
    /// marker index → slot index.
    pub(super) slot_of: Vec<Option<usize>>,
    pub(super) time_s: Option<f64>,
}

/// Camera A's nominal poses along the sequence, for the poses between frames (trigger offset):
/// the centre is interpolated linearly, the rotation by slerp `R_k·Exp(s·Log(R_kᵀR_{k+1}))`;
/// before the first and after the last pose the end interval is extended.
#[derive(Debug, Clone)]
pub(super) struct ATrack {
    pub(super) times: Vec<f64>,
    pub(super) r: Vec<Mat3>,
    pub(super) c: Vec<Vec3>,
    /// `Log(R_kᵀ·R_{k+1})`.
    pub(super) w: Vec<Vec3>,
}

impl ATrack {
    /// The track of the epochs with a frame number (times `frame / hz`, increasing), or with
    /// `times` the epochs that have a frame time.
    pub(super) fn new(
        epochs: &[Epoch],
        hz: f64,
        times: Option<&crate::input::FrameTimes>,
    ) -> Option<ATrack> {
        let mut t = ATrack {
            times: Vec::new(),
            r: Vec::new(),
            c: Vec::new(),
            w: Vec::new(),
        };
        for e in epochs {
            let time = match times {
                Some(ft) => match ft.lookup(&[&e.name, &e.key]) {
                    Some((_, t)) => t,
                    None => continue,
                },
                None => match frame_number(&e.name) {
                    Some(f) => f as f64 / hz,
                    None => continue,
                },
            };
            if t.times.last().is_some_and(|&last| last >= time) {
                continue;
            }
            t.times.push(time);
            t.r.push(e.world_from_a.rotation().into_inner());
            t.c.push(e.world_from_a.center());
        }
        if t.times.len() < 2 {
            return None;
        }
        t.w =
            t.r.windows(2)
                .map(|p| {
                    so3::log(&crashrig_geometry::Rot3::from_matrix_unchecked(
                        p[0].transpose() * p[1],
                    ))
                })
                .collect();
        Some(t)
    }

    /// `world_from_A` (rotation, centre) at time `t` (s).
    pub(super) fn at(&self, t: f64) -> (Mat3, Vec3) {
        let n = self.times.len();
        let k = self
            .times
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(n - 2);
        let s = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
        let r = self.r[k] * so3::exp(&(self.w[k] * s)).into_inner();
        (r, self.c[k] + (self.c[k + 1] - self.c[k]) * s)
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct LinkPrep {
    pub(super) r_ab: Mat3,
    pub(super) c_ab: Vec3,
    pub(super) l_ab: Mat6,
    pub(super) c: Option<(Mat3, Vec3, Mat6)>,
}

impl LinkPrep {
    /// The link's and the tie's nominal rotation, centre and covariance factor.
    pub(super) fn new(rig: &Rig) -> LinkPrep {
        LinkPrep {
            r_ab: rig.a_from_b.rotation().into_inner(),
            c_ab: rig.a_from_b.center(),
            l_ab: rig.a_from_b.factor(),
            c: rig
                .c
                .as_ref()
                .map(|(p, _)| (p.rotation().into_inner(), p.center(), p.factor())),
        }
    }
}

/// How epoch `e` differentiates in time: `(previous epoch, next epoch)` whose difference gives
/// the velocity of a marker (central where both neighbours measured it, one-sided otherwise).
pub(super) fn velocity_pair(
    e: usize,
    marker: usize,
    preps: &[EpochPrep],
) -> Option<(usize, usize)> {
    let has = |k: usize| preps[k].slot_of[marker].is_some_and(|s| preps[k].slots[s].drawable());
    let prev = (e > 0 && has(e - 1)).then(|| e - 1);
    let next = (e + 1 < preps.len() && has(e + 1)).then_some(e + 1);
    match (prev, next) {
        (Some(p), Some(n)) => Some((p, n)),
        (Some(p), None) if has(e) => Some((p, e)),
        (None, Some(n)) if has(e) => Some((e, n)),
        _ => None,
    }
}

/// Prepares a view: the undistorted normalized observation and `J⁻¹·L` (`L·Lᵀ` = the
/// observation's own Σ, else `σ·I`).
fn prep_view(
    camera: &Camera,
    cam: usize,
    obs: &Observation,
    sigma: f64,
) -> Result<ViewPrep, Error> {
    let fail = |what: String| {
        Error::Input(format!(
            "observation on line {} (epoch `{}`, camera {}, marker `{}`): {what}",
            obs.line,
            obs.epoch,
            obs.camera.letter(),
            obs.marker
        ))
    };
    let und = camera
        .cam_from_img(&obs.pixel)
        .map_err(|e| fail(format!("the pixel cannot be undistorted: {e}")))?;
    let n0 = und.normalized;
    let j = camera
        .dx_img_from_cam_point(&Vector3::new(n0.x, n0.y, 1.0))
        .map_err(|e| fail(format!("the lens Jacobian is undefined: {e:?}")))?;
    let j2 = Matrix2::new(j[(0, 0)], j[(0, 1)], j[(1, 0)], j[(1, 1)]);
    let inv = j2
        .try_inverse()
        .ok_or_else(|| fail("the lens Jacobian is singular".into()))?;
    // The observation's own Σ = L·Lᵀ (draw L·ε), else σ on each axis as ever (same bits).
    let m = match &obs.sigma {
        Some(s) => inv * s.factor(),
        None => inv * sigma,
    };
    Ok(ViewPrep { cam, n0, m })
}

/// Every scale bar prepared for the draws: its markers' indices (`None`: a marker seen only
/// in epochs without a pose of A) and the measured epochs in which both have a position.
pub(super) fn bar_preps(
    bars: &[length::ScaleBar],
    marker_idx: &HashMap<&str, usize>,
    preps: &[EpochPrep],
) -> Vec<BarPrep> {
    bars.iter()
        .map(|bar| {
            let markers = [
                marker_idx.get(bar.marker_1.as_str()).copied(),
                marker_idx.get(bar.marker_2.as_str()).copied(),
            ];
            let mut epochs = Vec::new();
            if let [Some(m1), Some(m2)] = markers {
                for (e, p) in preps.iter().enumerate() {
                    let at = |m: usize| {
                        let s = p.slot_of[m]?;
                        p.slots[s].nominal.map(|x| (s, x))
                    };
                    if let (Some((s1, x1)), Some((s2, x2))) = (at(m1), at(m2)) {
                        epochs.push(BarEpochPrep {
                            e,
                            s1,
                            s2,
                            nominal_mm: (x1 - x2).norm(),
                        });
                    }
                }
            }
            BarPrep::new(markers, epochs)
        })
        .collect()
}

/// One epoch's observations: marker → camera → observation.
pub(super) type ByMarker<'a> = BTreeMap<&'a str, BTreeMap<Inward, &'a Observation>>;

/// The observations grouped by posed epoch (index into the epochs), the skipped epochs with
/// their observation counts, and the markers in order.
pub(super) struct Groups<'a> {
    pub(super) by_epoch: BTreeMap<usize, ByMarker<'a>>,
    pub(super) skipped: BTreeMap<&'a str, usize>,
    pub(super) markers: Vec<String>,
}

/// Groups the observations by epoch, marker and camera.
pub(super) fn group_observations<'a>(
    epochs: &[Epoch],
    rig: &Rig,
    observations: &'a [Observation],
) -> Result<Groups<'a>, Error> {
    let mut lookup: HashMap<&str, usize> = HashMap::new();
    for (i, e) in epochs.iter().enumerate() {
        lookup.insert(e.key.as_str(), i);
        lookup.insert(e.name.as_str(), i);
    }
    let mut by_epoch: BTreeMap<usize, ByMarker<'a>> = BTreeMap::new();
    let mut skipped: BTreeMap<&str, usize> = BTreeMap::new();
    let mut markers: BTreeSet<&str> = BTreeSet::new();
    for obs in observations {
        if obs.camera == Inward::C && rig.c.is_none() {
            return Err(Error::Input(format!(
                "observation on line {} is from camera C, but no camera C is configured",
                obs.line
            )));
        }
        match lookup.get(obs.epoch.as_str()) {
            Some(&e) => {
                markers.insert(obs.marker.as_str());
                by_epoch
                    .entry(e)
                    .or_default()
                    .entry(obs.marker.as_str())
                    .or_default()
                    .insert(obs.camera, obs);
            }
            None => *skipped.entry(obs.epoch.as_str()).or_default() += 1,
        }
    }
    if by_epoch.is_empty() {
        return Err(Error::Input(format!(
            "no observation belongs to an epoch with a pose of camera A ({} epochs skipped)",
            skipped.len()
        )));
    }
    Ok(Groups {
        by_epoch,
        skipped,
        markers: markers.into_iter().map(String::from).collect(),
    })
}

/// The measured epochs in sequence order with their times (with a frame rate), and the index
/// of the reference epoch.
pub(super) fn measured_epochs(
    epochs: &[Epoch],
    groups: &Groups<'_>,
    settings: &Settings,
) -> Result<(Vec<MeasuredEpoch>, usize), Error> {
    let mut measured: Vec<MeasuredEpoch> = Vec::new();
    for &e in groups.by_epoch.keys() {
        let ep = &epochs[e];
        let mut frame = frame_number(&ep.name);
        let time_s = match (&settings.frame_times, settings.frame_rate_hz) {
            // The camera's own clock: the time from the file, the frame number its line's
            // index (runs of the CFC filter break where a frame of the file is not measured).
            (Some(ft), _) => {
                let (f, t) = ft.lookup(&[&ep.name, &ep.key]).ok_or_else(|| {
                    Error::Sequence(format!(
                        "epoch `{}` has no time in {} (--frame-times): every measured epoch needs its frame time",
                        ep.name,
                        ft.path.display()
                    ))
                })?;
                frame = Some(f);
                Some(t)
            }
            (None, Some(hz)) => {
                let f = frame.ok_or_else(|| {
                    Error::Sequence(format!(
                        "epoch `{}` has no frame number (digits in its name), needed for velocities",
                        ep.name
                    ))
                })?;
                Some(f as f64 / hz)
            }
            (None, None) => None,
        };
        if let (Some(t), Some(last)) = (time_s, measured.last())
            && last.time_s.is_some_and(|lt| lt >= t)
        {
            return Err(Error::Sequence(match &settings.frame_times {
                Some(ft) => format!(
                    "frame times do not increase along the sequence: epoch `{}` ({t} s in {}) follows `{}` ({} s)",
                    ep.name,
                    ft.path.display(),
                    last.name,
                    last.time_s.unwrap_or(f64::NAN)
                ),
                None => format!(
                    "frame numbers do not increase along the sequence: epoch `{}` follows `{}` (zero-pad the image names)",
                    ep.name, last.name
                ),
            }));
        }
        measured.push(MeasuredEpoch {
            key: ep.key.clone(),
            name: ep.name.clone(),
            frame,
            time_s,
        });
    }
    let reference_epoch = match &settings.reference_epoch {
        None => 0,
        Some(r) => measured
            .iter()
            .position(|m| &m.key == r || &m.name == r)
            .ok_or_else(|| Error::Setting {
                name: "--reference-epoch",
                problem: format!("`{r}` is not a measured epoch"),
            })?,
    };
    Ok((measured, reference_epoch))
}

/// One epoch prepared for the draws: its views, the nominal intersections and their
/// reprojection residuals (`time_s` is left to the caller).
pub(super) fn prep_epoch(
    ep: &Epoch,
    rig: &Rig,
    by_marker: &ByMarker<'_>,
    marker_idx: &HashMap<&str, usize>,
    settings: &Settings,
) -> Result<EpochPrep, Error> {
    let cameras: Vec<&Camera> = std::iter::once(&rig.camera_b)
        .chain(rig.c.as_ref().map(|(_, c)| c))
        .collect();
    let world_from_b = ep.world_from_a.b_from_a * rig.a_from_b.b_from_a;
    let world_from_c = rig.c.as_ref().map(|(p, _)| world_from_b * p.b_from_a);
    let cam_from_world = [
        Some(world_from_b.inverse()),
        world_from_c.map(|w| w.inverse()),
    ];
    let mut slots = Vec::with_capacity(by_marker.len());
    let mut slot_of = vec![None; marker_idx.len()];
    for (&marker, by_cam) in by_marker {
        let mut views = Vec::with_capacity(by_cam.len());
        for (&cam, &obs) in by_cam {
            let ci = usize::from(cam == Inward::C);
            views.push(prep_view(cameras[ci], ci, obs, settings.pixel_sigma_px)?);
        }
        let n_views = views.len();
        let mut nominal = None;
        let mut degenerate = false;
        let mut reprojection_px = None;
        if n_views >= 2 {
            let dlt_views: Vec<View> = views
                .iter()
                .map(|v| View {
                    cam_from_world: cam_from_world[v.cam].expect("camera present"),
                    normalized: v.n0,
                })
                .collect();
            match triangulate::dlt(&dlt_views) {
                Ok(x) => {
                    nominal = Some(x);
                    let mut worst = 0.0_f64;
                    for (&cam, &obs) in by_cam {
                        let ci = usize::from(cam == Inward::C);
                        let p =
                            cam_from_world[ci].expect("camera present") * nalgebra::Point3::from(x);
                        let res = match cameras[ci].img_from_cam(&p.coords) {
                            Ok(px) => (px - obs.pixel).norm(),
                            Err(_) => f64::INFINITY,
                        };
                        worst = worst.max(res);
                    }
                    reprojection_px = Some(worst);
                }
                Err(_) => degenerate = true,
            }
        }
        slot_of[marker_idx[marker]] = Some(slots.len());
        slots.push(Slot {
            marker: marker_idx[marker],
            n_views,
            views,
            nominal,
            reprojection_px,
            degenerate,
            drawn: true,
        });
    }
    Ok(EpochPrep {
        r_wa: ep.world_from_a.rotation().into_inner(),
        c_a: ep.world_from_a.center(),
        l_a: ep.world_from_a.factor(),
        slots,
        slot_of,
        time_s: None,
    })
}
