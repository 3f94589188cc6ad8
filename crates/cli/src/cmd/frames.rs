//! `crashrig frames info|export`: what a camera file holds, and its frames as 16-bit grey PNGs.
//! Arguments → [`crashrig_frames::Sequence::open`] / [`crashrig_frames::export::ExportConfig`] →
//! one library call → the report. Formats and fields: `docs/FRAMES.md`.

use crate::Global;
use crashrig_frames::export::{ExportConfig, export};
use crashrig_frames::{Sequence, SequenceInfo};
use serde::Serialize;
use std::path::PathBuf;

/// `crashrig frames …`.
#[derive(Debug, clap::Subcommand)]
pub enum FramesCommand {
    /// What a frame source holds: frames, size, bits, frame rate, trigger, first image number, exposure.
    Info(InfoArgs),
    /// Each frame as a 16-bit grey PNG DIR/EPOCH.png, the camera's values unscaled (EPOCH: the file stem in a directory, the index from 0 in a movie file), plus DIR/frames.csv.
    Export(ExportArgs),
}

/// Arguments of `crashrig frames info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// A Phantom .cine, a Photron .cihx/.cih (its .mraw beside it) or a directory of PNG/TIFF frames.
    pub source: PathBuf,
}

/// Arguments of `crashrig frames export`.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// A Phantom .cine, a Photron .cihx/.cih (its .mraw beside it) or a directory of PNG/TIFF frames.
    pub source: PathBuf,
    /// Output directory (written all-or-nothing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Epoch name of the first frame to export (default: the first).
    #[arg(long, value_name = "EPOCH")]
    pub first: Option<String>,
    /// Epoch name of the last frame to export (default: the last).
    #[arg(long, value_name = "EPOCH")]
    pub last: Option<String>,
}

/// The `info --json` document (fields: docs/REFERENCE.md).
fn info_json(seq: &Sequence) -> serde_json::Value {
    let i: &SequenceInfo = seq.info();
    let last = seq.len() - 1;
    serde_json::json!({
        "path": i.path, "source": i.kind.name(), "frames": i.frames,
        "width": i.width, "height": i.height, "bits": i.bits, "layout": i.layout.name(),
        "frame_rate_hz": i.frame_rate_hz, "exposure_s": i.exposure_s,
        "trigger_utc": i.trigger_utc, "trigger_frame": i.trigger_frame,
        "first_image_number": i.first_image_number, "frame_step": i.frame_step,
        "camera": i.camera, "time_source": i.time_source.name(),
        "first_epoch": seq.epoch(0), "last_epoch": seq.epoch(last),
        "first_time_s": seq.time_s(0), "last_time_s": seq.time_s(last),
    })
}

#[derive(Debug, Serialize)]
struct ExportReport {
    out: PathBuf,
    source: &'static str,
    frames: usize,
    first_epoch: String,
    last_epoch: String,
}

/// Runs `crashrig frames`.
pub fn run(c: FramesCommand, g: &Global) -> anyhow::Result<()> {
    match c {
        FramesCommand::Info(a) => {
            let seq = Sequence::open(&a.source)?;
            if g.json {
                crate::output::print_json(&info_json(&seq))?;
            } else {
                print_info(&seq);
            }
        }
        FramesCommand::Export(a) => {
            let e = export(&ExportConfig {
                source: a.source.clone(),
                out: a.out.clone(),
                first: a.first.clone(),
                last: a.last.clone(),
            })?;
            let r = ExportReport {
                out: e.out,
                source: e.kind.name(),
                frames: e.frames,
                first_epoch: e.first,
                last_epoch: e.last,
            };
            if g.json {
                crate::output::print_json(&r)?;
            } else {
                println!(
                    "wrote {} frames ({} … {}) as 16-bit grey PNGs and frames.csv to {}",
                    r.frames,
                    r.first_epoch,
                    r.last_epoch,
                    r.out.display()
                );
            }
        }
    }
    Ok(())
}

fn print_info(seq: &Sequence) {
    let (i, last) = (seq.info(), seq.len() - 1);
    let opt = |v: Option<String>| v.unwrap_or_else(|| "not stated".to_string());
    let times = match (seq.time_s(0), seq.time_s(last)) {
        (Some(a), Some(b)) => format!("{a} s … {b} s from the trigger ({})", i.time_source.name()),
        _ => "none".to_string(),
    };
    let rows = [
        ("frames", Some(i.frames.to_string())),
        ("size", Some(format!("{} x {} px", i.width, i.height))),
        ("bits", Some(format!("{} ({})", i.bits, i.layout.name()))),
        (
            "frame rate",
            Some(opt(i.frame_rate_hz.map(|f| format!("{f} Hz")))),
        ),
        (
            "exposure",
            Some(opt(i.exposure_s.map(|e| format!("{e} s")))),
        ),
        ("trigger", i.trigger_utc.clone()),
        ("trigger frame", i.trigger_frame.map(|t| t.to_string())),
        (
            "first image number",
            Some(opt(i.first_image_number.map(|n| n.to_string()))),
        ),
        (
            "frame step",
            i.frame_step.filter(|&s| s != 1).map(|s| s.to_string()),
        ),
        ("camera", i.camera.clone()),
        (
            "epochs",
            Some(format!("{} … {}", seq.epoch(0), seq.epoch(last))),
        ),
        ("times", Some(times)),
    ];
    println!("{} ({})", i.path.display(), i.kind.name());
    for (k, v) in rows.iter().filter_map(|(k, v)| v.as_ref().map(|v| (k, v))) {
        println!("  {k:<19} {v}");
    }
}
