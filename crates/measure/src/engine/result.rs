//! The result of a measurement: the rows, the epochs, the trigger offset's share, and the rows
//! assembled from the nominal intersections and the Monte Carlo moments.

use super::Settings;
use super::moments::Acc;
use super::prepare::{EpochPrep, velocity_pair};
use crate::kinematics::{KinRow, Kinematics};
use crate::length::LengthCheck;
use crashrig_geometry::{Mat3, Vec3};
use crashrig_stats::Moments;
use crashrig_stats::summary::median;

/// Modified-z limit of the reprojection check: a residual is an outlier when it exceeds the
/// median of the sequence's residuals by more than this many robust σ (1.4826·MAD).
pub const REPROJECTION_OUTLIER_ROBUST_SIGMAS: f64 = 5.0;

/// The default reprojection limit: `median + 5 · 1.4826 · MAD` of the residuals of all rows
/// with a position. Residuals come from pixel noise *and* from the link, tie and A errors
/// (which make the rays miss each other), so a limit in units of the pixel σ alone would flag
/// good rows; the robust limit flags rows that disagree with the rest of the sequence (a
/// mislabelled or mis-detected marker). `None` for fewer than 3 residuals.
pub fn robust_reprojection_limit(residuals: &[f64]) -> Option<f64> {
    let v: Vec<f64> = residuals
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .collect();
    if v.len() < 3 {
        return None;
    }
    let med = median(&v)?;
    let dev: Vec<f64> = v.iter().map(|r| (r - med).abs()).collect();
    let mad = median(&dev)?;
    Some(med + REPROJECTION_OUTLIER_ROBUST_SIGMAS * 1.4826 * mad)
}

/// Why a row is flagged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Flags {
    /// Fewer than two cameras saw the marker in this epoch (no position).
    pub fewer_than_two_views: bool,
    /// The rays are (nearly) parallel: the intersection failed (no position).
    pub degenerate: bool,
    /// σ_max exceeds the threshold.
    pub sigma_above_threshold: bool,
    /// The largest reprojection residual exceeds the limit.
    pub reprojection_outlier: bool,
}

impl Flags {
    /// The flag names that are set, in a fixed order.
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.fewer_than_two_views {
            v.push("fewer_than_two_views");
        }
        if self.degenerate {
            v.push("degenerate");
        }
        if self.sigma_above_threshold {
            v.push("sigma_above_threshold");
        }
        if self.reprojection_outlier {
            v.push("reprojection_outlier");
        }
        v
    }

    /// True when any flag is set.
    pub fn any(&self) -> bool {
        !self.names().is_empty()
    }
}

/// One (epoch, marker) row of the result. Positions are in the model's world frame (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Index into [`Measurement::epochs`].
    pub epoch: usize,
    /// Index into [`Measurement::markers`].
    pub marker: usize,
    /// Number of cameras that saw the marker in this epoch.
    pub n_views: usize,
    /// Nominal intersection (mm).
    pub position_mm: Option<Vec3>,
    /// Monte Carlo σ of the position (mm, n − 1).
    pub sigma_mm: Option<Vec3>,
    /// Monte Carlo covariance of the position (mm²).
    pub covariance_mm2: Option<Mat3>,
    /// Nominal displacement from the reference epoch (mm).
    pub displacement_mm: Option<Vec3>,
    /// Its Monte Carlo σ (mm).
    pub displacement_sigma_mm: Option<Vec3>,
    /// Nominal velocity by finite differences (mm/s).
    pub velocity_mm_s: Option<Vec3>,
    /// Its Monte Carlo σ (mm/s).
    pub velocity_sigma_mm_s: Option<Vec3>,
    /// Largest reprojection residual of the nominal intersection over its views (px).
    pub reprojection_px: Option<f64>,
    /// Monte Carlo draws that produced a position (= samples unless a draw was degenerate).
    pub draws: u64,
    /// Flags.
    pub flags: Flags,
}

impl Row {
    /// max(σx, σy, σz) (mm).
    pub fn sigma_max_mm(&self) -> Option<f64> {
        self.sigma_mm.map(|s| s.max())
    }
}

/// A measured epoch.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredEpoch {
    /// Epoch key.
    pub key: String,
    /// Epoch name.
    pub name: String,
    /// Frame number (last digits of the name), if any.
    pub frame: Option<u64>,
    /// `frame / frame_rate` (s), with a frame rate.
    pub time_s: Option<f64>,
}

/// Observations of an epoch that the model does not pose (skipped).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedEpoch {
    /// The epoch as the observations spell it.
    pub epoch: String,
    /// How many observations were skipped.
    pub observations: usize,
}

/// The result of [`measure`](crate::engine::measure).
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Measured epochs in sequence order (those with observations and a pose of A).
    pub epochs: Vec<MeasuredEpoch>,
    /// Marker names, sorted.
    pub markers: Vec<String>,
    /// One row per observed (epoch, marker), epoch-major, markers in order.
    pub rows: Vec<Row>,
    /// Index of the reference epoch of the displacements.
    pub reference_epoch: usize,
    /// Epochs of the observations without a pose of camera A.
    pub skipped: Vec<SkippedEpoch>,
    /// Monte Carlo replicates per row.
    pub samples: usize,
    /// The reprojection limit used for the flags (px; given or robust), `None` when no row
    /// has a position or the robust limit had too few residuals.
    pub reprojection_limit_px: Option<f64>,
    /// The filtered kinematics (with [`Settings::cfc`]).
    pub kinematics: Option<Kinematics>,
    /// How much of the variance the trigger offset contributes (with
    /// [`Settings::sync_sigma_ms`] > 0).
    pub sync_share: Option<SyncShare>,
    /// The length check of the scale bars ([`crate::length`]; with scale bars).
    pub length_check: Option<LengthCheck>,
}

/// The share of the variance that camera A's trigger offset contributes: the measurement is
/// repeated without the offset on the same random numbers (the offsets have their own
/// streams), and each row's share is `1 − Σσ₀² / Σσ²` (traces over the three axes; clamped at
/// 0 where Monte Carlo noise makes it negative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncShare {
    /// The offset's σ (ms).
    pub sigma_ms: f64,
    /// Position σ.
    pub position: Option<ShareStats>,
    /// Raw displacement σ.
    pub displacement: Option<ShareStats>,
    /// Raw velocity σ.
    pub velocity: Option<ShareStats>,
    /// Filtered displacement σ (with kinematics).
    pub filtered_displacement: Option<ShareStats>,
    /// Filtered velocity σ (with kinematics).
    pub filtered_velocity: Option<ShareStats>,
    /// Acceleration σ (with kinematics).
    pub acceleration: Option<ShareStats>,
}

/// Median and largest share over the rows (fractions 0…1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShareStats {
    /// Median share.
    pub median: f64,
    /// Largest share.
    pub max: f64,
    /// Rows with the quantity.
    pub rows: usize,
}

impl ShareStats {
    /// The statistics of the per-row shares of `pairs` (σ with, σ without the offset).
    fn of(pairs: impl Iterator<Item = (Option<Vec3>, Option<Vec3>)>) -> Option<ShareStats> {
        let v: Vec<f64> = pairs
            .filter_map(|(with, without)| {
                let (w, o) = (with?.norm_squared(), without?.norm_squared());
                (w > 0.0).then(|| (1.0 - o / w).max(0.0))
            })
            .collect();
        let max = v.iter().copied().fold(0.0, f64::max);
        Some(ShareStats {
            // The shares are finite (≥ 0 and ≤ 1), so `None` only for no share at all.
            median: median(&v)?,
            max,
            rows: v.len(),
        })
    }
}

impl Measurement {
    /// Fraction of rows with σ_max below `threshold_mm` (rows without σ count as not below).
    pub fn fraction_below(&self, threshold_mm: f64) -> f64 {
        let n = self.rows.len().max(1) as f64;
        self.rows
            .iter()
            .filter(|r| r.sigma_max_mm().is_some_and(|s| s < threshold_mm))
            .count() as f64
            / n
    }
}

pub(super) fn sync_share(m: &Measurement, m0: &Measurement, sigma_ms: f64) -> SyncShare {
    let rows = || m.rows.iter().zip(&m0.rows);
    let kin = m.kinematics.as_ref().zip(m0.kinematics.as_ref());
    let kin_share = |f: fn(&KinRow) -> Option<Vec3>| {
        kin.and_then(|(k, k0)| {
            ShareStats::of(k.rows.iter().zip(&k0.rows).map(|(a, b)| (f(a), f(b))))
        })
    };
    SyncShare {
        sigma_ms,
        position: ShareStats::of(rows().map(|(a, b)| (a.sigma_mm, b.sigma_mm))),
        displacement: ShareStats::of(
            rows().map(|(a, b)| (a.displacement_sigma_mm, b.displacement_sigma_mm)),
        ),
        velocity: ShareStats::of(
            rows().map(|(a, b)| (a.velocity_sigma_mm_s, b.velocity_sigma_mm_s)),
        ),
        filtered_displacement: kin_share(|k| k.displacement_sigma_mm),
        filtered_velocity: kin_share(|k| k.velocity_sigma_m_s),
        acceleration: kin_share(|k| k.acceleration_sigma_m_s2),
    }
}

fn sigma_of(m: &Moments<3>) -> Option<Vec3> {
    (m.count() >= 2).then(|| m.std_dev())
}

pub(super) fn assemble(
    preps: &[EpochPrep],
    accs: &[Vec<Acc>],
    settings: &Settings,
    reference: usize,
    reprojection_limit_px: Option<f64>,
) -> Vec<Row> {
    let mut rows = Vec::new();
    for (e, ep) in preps.iter().enumerate() {
        for (s, slot) in ep.slots.iter().enumerate() {
            let acc = &accs[e][s];
            let m = slot.marker;
            let nominal_of = |k: usize| preps[k].slot_of[m].and_then(|s| preps[k].slots[s].nominal);
            let displacement_mm = match (slot.nominal, nominal_of(reference)) {
                (Some(x), Some(xr)) => Some(x - xr),
                _ => None,
            };
            let velocity_mm_s = if settings.frame_rate_hz.is_some() {
                velocity_pair(e, m, preps).and_then(|(p, n)| {
                    let dt = preps[n].time_s? - preps[p].time_s?;
                    Some((nominal_of(n)? - nominal_of(p)?) / dt)
                })
            } else {
                None
            };
            let sigma_mm = if slot.drawable() {
                sigma_of(&acc.pos)
            } else {
                None
            };
            let flags = Flags {
                fewer_than_two_views: slot.n_views < 2,
                degenerate: slot.degenerate,
                sigma_above_threshold: sigma_mm.is_some_and(|s| s.max() > settings.threshold_mm),
                reprojection_outlier: match (slot.reprojection_px, reprojection_limit_px) {
                    (Some(r), Some(l)) => r > l,
                    (Some(r), None) => !r.is_finite(),
                    _ => false,
                },
            };
            rows.push(Row {
                epoch: e,
                marker: m,
                n_views: slot.n_views,
                position_mm: slot.nominal,
                sigma_mm,
                covariance_mm2: sigma_mm.map(|_| acc.pos.covariance()),
                displacement_mm,
                displacement_sigma_mm: displacement_mm.and_then(|_| {
                    if e == reference {
                        Some(Vec3::zeros())
                    } else {
                        sigma_of(&acc.disp)
                    }
                }),
                velocity_mm_s,
                velocity_sigma_mm_s: velocity_mm_s.and_then(|_| sigma_of(&acc.vel)),
                reprojection_px: slot.reprojection_px,
                draws: acc.pos.count(),
                flags,
            });
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_limit_known_answer() {
        // median 3, |dev| = 2 1 0 1 2 → MAD 1: limit 3 + 5·1.4826.
        let l = robust_reprojection_limit(&[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert!((l - (3.0 + 5.0 * 1.4826)).abs() < 1e-12);
        assert_eq!(robust_reprojection_limit(&[1.0, f64::INFINITY]), None);
    }
}
