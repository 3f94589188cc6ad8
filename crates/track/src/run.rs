//! The library entry of `crashrig track`: a typed [`TrackConfig`] → [`run`] → a typed
//! [`TrackRun`], with `observations.csv`, `frames.csv` and `summary.json` written as one unit
//! into a staged output directory (an error or an interruption leaves no output).
//!
//! Frames are streamed: one frame is decoded while the previous one is tracked (two buffers),
//! so memory does not grow with the number of frames.

use crate::seeds::{SeedLine, read_seeds};
use crate::tracker::{MarkerKind, Seed, Tracker, TrackerOptions};
use crate::{Centre, Error, GreyView};
use crashrig_frames::{GreyFrame, Sequence, SourceKind};
use crashrig_stats::progress::{Monitor, check};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What `crashrig track` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackConfig {
    /// The frames: a directory of PNG/TIFF images, a `.cine`, or a `.cih`/`.cihx`.
    pub frames: PathBuf,
    /// The seeds file (`marker,u_px,v_px[,epoch]`).
    pub seeds: PathBuf,
    /// The camera's name written in `observations.csv` (`B` or `C`).
    pub camera: String,
    /// The output directory (absent, empty or a previous `track` output; replaced whole).
    pub out: PathBuf,
    /// The kind of marker.
    pub kind: MarkerKind,
    /// The first epoch tracked (default: the first frame).
    pub first: Option<String>,
    /// The last epoch tracked (default: the last frame).
    pub last: Option<String>,
}

/// One observation: a marker found in a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Index of the frame in the tracked range (from 0).
    pub frame: usize,
    /// Index of the marker (seed order).
    pub marker: usize,
    /// The centre and its σ.
    pub centre: Centre,
}

/// `summary.json` → `markers[]`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerSummary {
    /// The marker's name.
    pub name: String,
    /// Frames it was found in.
    pub found: usize,
    /// Frames from its start on in which it was not found.
    pub lost: usize,
    /// The runs of consecutive frames it was lost in: `[first, last]` epoch names.
    pub lost_epochs: Vec<[String; 2]>,
    /// Median over its rows of the larger principal σ of the centre (pixels); `null` when
    /// never found.
    pub median_sigma_px: Option<f64>,
    /// Largest of them (pixels).
    pub max_sigma_px: Option<f64>,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackSummary {
    /// Frames tracked.
    pub frames: usize,
    /// `quadrant` or `dot`.
    pub marker_kind: &'static str,
    /// `directory`, `cine` or `mraw`.
    pub source: &'static str,
    /// The camera (`B` or `C`).
    pub camera: String,
    /// First and last epoch tracked.
    pub first_epoch: String,
    /// Last epoch tracked.
    pub last_epoch: String,
    /// Rows of `observations.csv`.
    pub observations: usize,
    /// Per marker, in seed order.
    pub markers: Vec<MarkerSummary>,
    /// `.cine`/`.mraw`: the frame rate the camera states (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_rate_hz: Option<f64>,
    /// `.cine`: the trigger's time as the camera states it (UTC, ISO 8601).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trigger_utc: Option<String>,
    /// `.mraw`: the trigger's frame number in the camera's numbering.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trigger_frame: Option<i64>,
    /// Wall-clock time of the run (s).
    pub elapsed_s: f64,
    /// Marker-observations per second (rows / elapsed).
    pub observations_per_second: f64,
}

/// The result of [`run`].
#[derive(Debug, Clone)]
pub struct TrackRun {
    /// `summary.json`.
    pub summary: TrackSummary,
    /// Every row of `observations.csv`, in file order (frame, then seed order).
    pub observations: Vec<Observation>,
    /// The marker names (seed order).
    pub markers: Vec<String>,
    /// Files written.
    pub files: usize,
}

/// The names `track` writes: an old output made only of these may be replaced.
pub fn is_track_output(name: &str) -> bool {
    matches!(name, "observations.csv" | "summary.json" | "frames.csv")
}

/// The larger principal σ of a centre's covariance (pixels).
pub fn worst_sigma_px(c: &Centre) -> f64 {
    let (a, b, d) = (
        c.sigma_u_px * c.sigma_u_px,
        c.rho_uv * c.sigma_u_px * c.sigma_v_px,
        c.sigma_v_px * c.sigma_v_px,
    );
    (0.5 * (a + d) + (0.25 * (a - d).powi(2) + b * b).sqrt()).sqrt()
}

fn frames_error(config: &TrackConfig, reason: String) -> Error {
    Error::Frames {
        path: config.frames.clone(),
        reason,
    }
}

/// Converts a frame to the tracker's grey view (values unscaled).
fn to_f32(frame: &GreyFrame, buf: &mut Vec<f32>) {
    buf.clear();
    buf.extend(frame.pixels.iter().map(|&p| f32::from(p)));
}

/// Tracks the markers of `config.seeds` through `config.frames` and writes the output.
///
/// # Errors
/// Bad input (frames that do not open or decode, a frame range without frames, a malformed
/// seeds file, a seed outside the image or with no marker in reach), the output directory,
/// or a cancellation through `monitor` (nothing is written then).
pub fn run(config: &TrackConfig, monitor: Option<&dyn Monitor>) -> Result<TrackRun, Error> {
    let started = std::time::Instant::now();
    let seq = Sequence::open(&config.frames)?;
    if seq.is_empty() {
        return Err(frames_error(config, "no frame".into()));
    }
    let index = |e: &Option<String>, flag: &str, default: usize| -> Result<usize, Error> {
        match e {
            None => Ok(default),
            Some(name) => seq.index_of(name).ok_or_else(|| {
                frames_error(config, format!("{flag} {name}: no frame of that epoch"))
            }),
        }
    };
    let i0 = index(&config.first, "--first", 0)?;
    let i1 = index(&config.last, "--last", seq.len() - 1)?;
    if i1 < i0 {
        return Err(frames_error(
            config,
            format!(
                "no frame in the range {} .. {}",
                seq.epoch(i0),
                seq.epoch(i1)
            ),
        ));
    }
    let lines = read_seeds(&config.seeds)?;
    let (w, h) = (seq.width() as usize, seq.height() as usize);
    let seeds = seeds_in_range(config, &seq, &lines, (i0, i1))?;
    let full_scale = ((1u32 << seq.bits()) - 1) as f32;
    let mut tracker = Tracker::new(seeds, TrackerOptions::new(config.kind));
    let staged_names = is_track_output;
    let mut staged = crashrig_outdir::Staged::new(&config.out, staged_names)?;

    let n = i1 - i0 + 1;
    let mut observations = Vec::new();
    let (mut cur, mut next) = (GreyFrame::default(), GreyFrame::default());
    let (mut cur_f, mut next_f) = (Vec::new(), Vec::new());
    seq.read(i0, &mut cur)?;
    to_f32(&cur, &mut cur_f);
    for k in 0..n {
        check(monitor)?;
        let img = GreyView::new(w, h, full_scale, &cur_f).ok_or_else(|| {
            frames_error(
                config,
                format!("frame {} has the wrong size", seq.epoch(i0 + k)),
            )
        })?;
        // Decode the next frame while this one is tracked.
        let (step, read) = rayon::join(
            || tracker.step(k, &img),
            || {
                if k + 1 < n {
                    seq.read(i0 + k + 1, &mut next)
                        .map(|()| to_f32(&next, &mut next_f))
                } else {
                    Ok(())
                }
            },
        );
        let found = step.map_err(|miss| {
            let s = &lines[miss.marker];
            Error::SeedNotFound {
                path: config.seeds.clone(),
                line: s.line,
                marker: s.marker.clone(),
                kind: config.kind.name(),
                radius_px: TrackerOptions::new(config.kind).seed_px,
                u_px: s.u_px,
                v_px: s.v_px,
                epoch: seq.epoch(i0 + k).to_string(),
            }
        })?;
        read?;
        for (marker, c) in found.into_iter().enumerate() {
            if let Some(centre) = c {
                observations.push(Observation {
                    frame: k,
                    marker,
                    centre,
                });
            }
        }
        std::mem::swap(&mut cur_f, &mut next_f);
        if let Some(m) = monitor {
            m.report(k + 1, n);
        }
    }
    check(monitor)?;

    let names: Vec<String> = lines.iter().map(|s| s.marker.clone()).collect();
    let epoch = |k: usize| seq.epoch(i0 + k);
    let csv = observations_csv(config, &names, &observations, &epoch);
    let times = frames_csv(&seq, i0, n);
    let markers = names
        .iter()
        .enumerate()
        .map(|(m, name)| marker_summary(m, name, &tracker, &observations, n, &epoch))
        .collect();
    let info = seq.info();
    let elapsed_s = started.elapsed().as_secs_f64();
    let summary = TrackSummary {
        frames: n,
        marker_kind: config.kind.name(),
        source: seq.kind().name(),
        camera: config.camera.clone(),
        first_epoch: epoch(0).to_string(),
        last_epoch: epoch(n - 1).to_string(),
        observations: observations.len(),
        markers,
        frame_rate_hz: (seq.kind() != SourceKind::Directory)
            .then_some(info.frame_rate_hz)
            .flatten(),
        trigger_utc: info.trigger_utc.clone(),
        trigger_frame: info.trigger_frame,
        elapsed_s,
        observations_per_second: observations.len() as f64 / elapsed_s.max(1e-9),
    };
    let json = serde_json::to_string_pretty(&summary).map_err(Error::Summary)?;
    staged.write("observations.csv", csv.as_bytes())?;
    staged.write("frames.csv", times.as_bytes())?;
    staged.write("summary.json", format!("{json}\n").as_bytes())?;
    staged.commit()?;
    Ok(TrackRun {
        summary,
        observations,
        markers: names,
        files: 3,
    })
}

/// `observations.csv`: one row per marker and frame in which it was found.
fn observations_csv<'a>(
    config: &TrackConfig,
    names: &[String],
    observations: &[Observation],
    epoch: &dyn Fn(usize) -> &'a str,
) -> String {
    let mut csv = String::from("epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,rho_uv\n");
    for o in observations {
        let c = &o.centre;
        let _ = writeln!(
            csv,
            "{},{},{},{:.6},{:.6},{:.7},{:.7},{:.4}",
            epoch(o.frame),
            config.camera,
            csv_field(&names[o.marker]),
            c.u_px,
            c.v_px,
            c.sigma_u_px,
            c.sigma_v_px,
            c.rho_uv
        );
    }
    csv
}

/// `frames.csv`: each tracked frame's epoch and its time (empty for a directory).
fn frames_csv(seq: &Sequence, i0: usize, n: usize) -> String {
    let mut times = String::from("epoch,time_s\n");
    for k in 0..n {
        match seq.time_s(i0 + k) {
            Some(t) => {
                let _ = writeln!(times, "{},{t}", seq.epoch(i0 + k));
            }
            None => {
                let _ = writeln!(times, "{},", seq.epoch(i0 + k));
            }
        }
    }
    times
}

/// A marker name as one CSV field (quoted when it holds a comma, quote or line break).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn marker_summary<'a>(
    m: usize,
    name: &str,
    tracker: &Tracker,
    obs: &[Observation],
    n: usize,
    epoch: &impl Fn(usize) -> &'a str,
) -> MarkerSummary {
    let mut found = vec![false; n];
    let mut sigmas = Vec::new();
    for o in obs.iter().filter(|o| o.marker == m) {
        found[o.frame] = true;
        sigmas.push(worst_sigma_px(&o.centre));
    }
    let mut lost_epochs = Vec::new();
    let mut lost = 0;
    let mut run: Option<usize> = None;
    for k in 0..=n {
        let is_lost = found.get(k).is_some_and(|&f| !f) && tracker.started(m, k);
        if is_lost {
            lost += 1;
            run.get_or_insert(k);
        } else if let Some(s) = run.take() {
            lost_epochs.push([epoch(s).to_string(), epoch(k - 1).to_string()]);
        }
    }
    sigmas.sort_by(f64::total_cmp);
    let median = (!sigmas.is_empty()).then(|| {
        let h = sigmas.len() / 2;
        if sigmas.len() % 2 == 1 {
            sigmas[h]
        } else {
            0.5 * (sigmas[h - 1] + sigmas[h])
        }
    });
    MarkerSummary {
        name: name.to_string(),
        found: sigmas.len(),
        lost,
        lost_epochs,
        median_sigma_px: median,
        max_sigma_px: sigmas.last().copied(),
    }
}

/// The tracker's seeds from the seeds file's lines: each in its epoch (or the first frame
/// tracked), inside the image.
fn seeds_in_range(
    config: &TrackConfig,
    seq: &Sequence,
    lines: &[SeedLine],
    (i0, i1): (usize, usize),
) -> Result<Vec<Seed>, Error> {
    let (w, h) = (f64::from(seq.width()), f64::from(seq.height()));
    lines
        .iter()
        .map(|s| {
            let bad = |reason: String| Error::Seeds {
                path: config.seeds.clone(),
                line: s.line,
                reason,
            };
            let frame = match &s.epoch {
                None => i0,
                Some(e) => {
                    let i = seq
                        .index_of(e)
                        .ok_or_else(|| bad(format!("epoch {e}: no frame of that epoch")))?;
                    if i < i0 || i > i1 {
                        return Err(bad(format!(
                            "epoch {e} is outside the frames tracked ({} .. {})",
                            seq.epoch(i0),
                            seq.epoch(i1)
                        )));
                    }
                    i
                }
            };
            if !(s.u_px >= 0.0 && s.u_px <= w && s.v_px >= 0.0 && s.v_px <= h) {
                return Err(bad(format!(
                    "seed ({}, {}) of '{}' is outside the {}x{} image",
                    s.u_px, s.v_px, s.marker, w, h
                )));
            }
            Ok(Seed {
                name: s.marker.clone(),
                u_px: s.u_px,
                v_px: s.v_px,
                frame: frame - i0,
            })
        })
        .collect()
}
