//! `crashrig frames info|export`: what a camera file holds, and its frames as 16-bit grey PNGs.
//!
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
    /// Each frame as a 16-bit grey PNG DIR/<epoch>.png (the camera's values unscaled) plus DIR/frames.csv.
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

#[derive(Debug, Serialize)]
struct InfoReport {
    path: PathBuf,
    source: &'static str,
    frames: usize,
    width: u32,
    height: u32,
    bits: u8,
    layout: &'static str,
    frame_rate_hz: Option<f64>,
    exposure_s: Option<f64>,
    trigger_utc: Option<String>,
    trigger_frame: Option<i64>,
    first_image_number: Option<i64>,
    frame_step: Option<u32>,
    camera: Option<String>,
    time_source: &'static str,
    first_epoch: String,
    last_epoch: String,
    first_time_s: Option<f64>,
    last_time_s: Option<f64>,
}

fn info_report(seq: &Sequence) -> InfoReport {
    let i: &SequenceInfo = seq.info();
    let last = seq.len() - 1;
    InfoReport {
        path: i.path.clone(),
        source: i.kind.name(),
        frames: i.frames,
        width: i.width,
        height: i.height,
        bits: i.bits,
        layout: i.layout.name(),
        frame_rate_hz: i.frame_rate_hz,
        exposure_s: i.exposure_s,
        trigger_utc: i.trigger_utc.clone(),
        trigger_frame: i.trigger_frame,
        first_image_number: i.first_image_number,
        frame_step: i.frame_step,
        camera: i.camera.clone(),
        time_source: i.time_source.name(),
        first_epoch: seq.epoch(0).to_string(),
        last_epoch: seq.epoch(last).to_string(),
        first_time_s: seq.time_s(0),
        last_time_s: seq.time_s(last),
    }
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
            let r = info_report(&seq);
            if g.json {
                crate::output::print_json(&r)?;
            } else {
                print_info(&r);
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

fn print_info(r: &InfoReport) {
    let opt = |v: Option<String>| v.unwrap_or_else(|| "not stated".to_string());
    println!("{} ({})", r.path.display(), r.source);
    println!("  frames              {}", r.frames);
    println!("  size                {} x {} px", r.width, r.height);
    println!("  bits                {} ({})", r.bits, r.layout);
    println!(
        "  frame rate          {}",
        opt(r.frame_rate_hz.map(|f| format!("{f} Hz")))
    );
    println!(
        "  exposure            {}",
        opt(r.exposure_s.map(|e| format!("{e} s")))
    );
    if let Some(t) = &r.trigger_utc {
        println!("  trigger             {t}");
    }
    if let Some(t) = r.trigger_frame {
        println!("  trigger frame       {t}");
    }
    println!(
        "  first image number  {}",
        opt(r.first_image_number.map(|n| n.to_string()))
    );
    if let Some(s) = r.frame_step.filter(|&s| s != 1) {
        println!("  frame step          {s}");
    }
    if let Some(c) = &r.camera {
        println!("  camera              {c}");
    }
    println!("  epochs              {} … {}", r.first_epoch, r.last_epoch);
    match (r.first_time_s, r.last_time_s) {
        (Some(a), Some(b)) => println!(
            "  times               {a} s … {b} s relative to the trigger (from {})",
            r.time_source
        ),
        _ => println!("  times               none"),
    }
}
