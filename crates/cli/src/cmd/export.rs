//! `crashrig export iso-mme`: a measure output as an ISO/TS 13499 (ISO-MME) test.
//!
//! Arguments → [`ExportConfig`] → [`crashrig_measure::isomme::export`] → the files, written as
//! one unit through `crashrig-outdir`. Format, axes, codes and the σ dimension are documented
//! in `crashrig_measure::isomme` and `docs/KINEMATICS.md`.

use crate::Global;
use crashrig_geometry::opk::rotation_from_opk;
use crashrig_measure::isomme::{ExportConfig, export};
use serde::Serialize;
use std::path::PathBuf;

/// `crashrig export …`.
#[derive(Debug, clap::Subcommand)]
pub enum ExportCommand {
    /// A measure output as an ISO/TS 13499 (ISO-MME 1.6) test: T.mme, Channel/T.chn, Channel/T.NNN.
    IsoMme(IsoMmeArgs),
}

/// Arguments of `crashrig export iso-mme`.
#[derive(Debug, clap::Args)]
pub struct IsoMmeArgs {
    /// A `crashrig measure` output directory (run with --frame-rate-hz).
    pub measure_dir: PathBuf,
    /// Output directory of the test (written all-or-nothing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Test number: names T.mme and the channel files (letters, digits, `-`, `_`).
    #[arg(long, value_name = "T")]
    pub test_number: String,
    /// CSV `marker,code` with a 16-character ISO-MME channel code per marker.
    #[arg(long, value_name = "FILE")]
    pub channel_map: Option<PathBuf>,
    /// ω φ κ (degrees) of R_vehicle_from_world, R = Rx(ω)·Ry(φ)·Rz(κ): SAE J211 vehicle axes
    /// (x forward, y right, z down) from the model's world axes (default: identity).
    #[arg(long, num_args = 3, value_names = ["OMEGA", "PHI", "KAPPA"], allow_negative_numbers = true)]
    pub vehicle_from_world: Option<Vec<f64>>,
}

#[derive(Debug, Serialize)]
struct Report {
    out: PathBuf,
    test_number: String,
    source: String,
    filter_class: char,
    channels: Vec<Channel>,
}

#[derive(Debug, Serialize)]
struct Channel {
    file: String,
    code: String,
    marker: String,
    samples: usize,
}

/// Runs `crashrig export`.
pub fn run(c: ExportCommand, g: &Global) -> anyhow::Result<()> {
    let ExportCommand::IsoMme(a) = c;
    let mut cfg = ExportConfig::new(&a.measure_dir, &a.test_number);
    cfg.channel_map = a.channel_map.clone();
    if let Some(v) = &a.vehicle_from_world {
        anyhow::ensure!(
            v.iter().all(|x| x.is_finite()),
            "--vehicle-from-world: the angles must be finite numbers (degrees)"
        );
        cfg.vehicle_from_world =
            rotation_from_opk(v[0].to_radians(), v[1].to_radians(), v[2].to_radians()).into_inner();
    }
    let e = export(&cfg)?;
    for w in &e.warnings {
        eprintln!("warning: {w}");
    }
    let t = a.test_number.clone();
    let ours = move |name: &str| name == format!("{t}.mme") || name == "Channel/";
    let mut staged = crashrig_outdir::Staged::new(&a.out, ours)?;
    for (name, bytes) in &e.files {
        staged.write(name, bytes)?;
    }
    staged.commit()?;
    let report = Report {
        out: a.out.clone(),
        test_number: a.test_number.clone(),
        source: e.source.clone(),
        filter_class: e.filter_class,
        channels: e
            .channels
            .iter()
            .map(|c| Channel {
                file: c.file.clone(),
                code: c.code.clone(),
                marker: c.marker.clone(),
                samples: c.samples,
            })
            .collect(),
    };
    if g.json {
        crate::output::print_json(&report)?;
    } else {
        println!(
            "wrote ISO-MME test {} ({} channels from {}, filter class {}) to {}",
            report.test_number,
            report.channels.len(),
            report.source,
            report.filter_class,
            a.out.display()
        );
    }
    Ok(())
}
