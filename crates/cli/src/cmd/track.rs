//! `crashrig track`: markers followed through one camera's frames. Arguments →
//! [`TrackConfig`] → [`crashrig_track::run()`] → print.

use crate::Global;
use crashrig_track::{MarkerKind, TrackConfig};
use std::path::PathBuf;

/// The camera a track's observations belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TrackCamera {
    /// Camera B.
    B,
    /// Camera C.
    C,
}

/// The marker kinds of `--marker`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MarkerArg {
    /// A disc in four quadrants (the crash-test target); centre = the saddle point.
    Quadrant,
    /// A disc brighter or darker than its surround.
    Dot,
}

/// Arguments of `crashrig track`.
#[derive(Debug, clap::Args)]
pub struct TrackArgs {
    /// The frames: a directory of PNG/TIFF images, a Phantom .cine, or a Photron .cih/.cihx.
    pub frames: PathBuf,
    /// Seeds: CSV with header marker,u_px,v_px (optional epoch), each marker's centre roughly
    /// (within 3 px) in the first frame or the epoch named.
    #[arg(long)]
    pub seeds: PathBuf,
    /// The camera the frames come from (written in observations.csv).
    #[arg(long, value_enum, ignore_case = true)]
    pub camera: TrackCamera,
    /// Output directory: observations.csv, frames.csv, summary.json.
    #[arg(long)]
    pub out: PathBuf,
    /// The kind of marker.
    #[arg(long, value_enum, default_value = "quadrant")]
    pub marker: MarkerArg,
    /// The first epoch tracked (default: the first frame).
    #[arg(long, value_name = "EPOCH")]
    pub first: Option<String>,
    /// The last epoch tracked (default: the last frame).
    #[arg(long, value_name = "EPOCH")]
    pub last: Option<String>,
}

/// Runs `crashrig track`.
pub fn run(a: TrackArgs, g: &Global) -> anyhow::Result<()> {
    let config = TrackConfig {
        frames: a.frames,
        seeds: a.seeds,
        camera: match a.camera {
            TrackCamera::B => "B",
            TrackCamera::C => "C",
        }
        .to_string(),
        out: a.out,
        kind: match a.marker {
            MarkerArg::Quadrant => MarkerKind::Quadrant,
            MarkerArg::Dot => MarkerKind::Dot,
        },
        first: a.first,
        last: a.last,
    };
    let bar = crate::progress::Bar::new("crashrig track");
    let frames = bar.stage("frames");
    let r = crashrig_track::run(&config, bar.monitor(&frames))?;
    bar.finish();
    let s = &r.summary;
    if g.json {
        return crate::output::print_json(s);
    }
    let print = || -> std::io::Result<()> {
        use std::io::Write;
        let mut w = std::io::stdout().lock();
        writeln!(
            w,
            "{} markers × {} frames ({} to {}): {} observations in {:.3} s ({:.0} per second)",
            s.markers.len(),
            s.frames,
            s.first_epoch,
            s.last_epoch,
            s.observations,
            s.elapsed_s,
            s.observations_per_second
        )?;
        for m in &s.markers {
            let sigma = m
                .median_sigma_px
                .map_or("-".to_string(), |x| format!("{x:.3}"));
            writeln!(
                w,
                "  {}: found {}, lost {}, median σ {} px",
                m.name, m.found, m.lost, sigma
            )?;
        }
        writeln!(w, "wrote {} files to {}", r.files, config.out.display())
    };
    crate::output::quiet_pipe(print())
}
