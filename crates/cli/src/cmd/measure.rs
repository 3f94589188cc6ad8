//! `crashrig measure`: marker trajectories with their uncertainty from a crash-test sequence.

use crate::Global;
use anyhow::Context;
use crashrig_colmap::Reconstruction;
use crashrig_geometry::{Mat6, UncertainPose, Vec3};
use crashrig_measure::engine::{Epoch, Measurement, Rig, Settings};
use crashrig_measure::filter::{CfcSpec, Standard};
use crashrig_measure::input::{self, CameraNames};
use crashrig_measure::output;
use crashrig_measure::sequence::{self, CameraSelector};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Output files: path relative to `DIR`, bytes.
type Files = Vec<(String, Vec<u8>)>;

/// Default seed of `measure` when `--seed` is not given.
pub const DEFAULT_SEED: u64 = 1;

/// Arguments of `crashrig measure`.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasureArgs {
    /// COLMAP model of the sequence (camera A registered against the lab per epoch).
    pub model: PathBuf,
    /// Camera A: image-name prefix (e.g. `cam_out/`) or camera id; epochs are its images.
    #[arg(long, value_name = "A")]
    pub camera_a: String,
    /// Camera B (inward, linked to A): camera id or an image-name prefix, for its intrinsics.
    #[arg(long, value_name = "B")]
    pub camera_b: String,
    /// Camera C (tied to B by `--tie`): camera id or an image-name prefix.
    #[arg(long, value_name = "C")]
    pub camera_c: Option<String>,
    /// The calibrated link A_from_B: a `calibrate --json` result (uses sem_covariance_tangent).
    #[arg(long, value_name = "JSON")]
    pub link: PathBuf,
    /// The tie B_from_C: a `bootstrap --json` result (uses covariance_tangent).
    #[arg(long, value_name = "JSON")]
    pub tie: Option<PathBuf>,
    /// Marker observations: CSV `epoch,camera,marker,u_px,v_px` (COLMAP pixels).
    #[arg(long, value_name = "CSV")]
    pub observations: PathBuf,
    /// Output directory (written all-or-nothing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Model units → mm.
    #[arg(long, value_name = "F", default_value_t = 1.0)]
    pub mm_per_unit: f64,
    /// σ of A's projection centre per epoch (world axes, mm).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_position_mm: Option<Vec<f64>>,
    /// σ of A's rotation per epoch about its own axes (tangent, degrees).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub sigma_a_angles_deg: Option<Vec<f64>>,
    /// A's pose covariance per epoch: JSON with `covariance_tangent` and/or `epochs`.
    #[arg(long, value_name = "JSON", conflicts_with_all = ["sigma_a_position_mm", "sigma_a_angles_deg"])]
    pub a_covariance: Option<PathBuf>,
    /// σ of each pixel coordinate of an observation (px).
    #[arg(long, value_name = "PX", default_value_t = 0.5)]
    pub pixel_sigma_px: f64,
    /// Monte Carlo replicates per row.
    #[arg(long, value_name = "N", default_value_t = 2000)]
    pub samples: usize,
    /// Reference epoch of the displacements (default: the first measured epoch).
    #[arg(long, value_name = "EPOCH")]
    pub reference_epoch: Option<String>,
    /// Frame rate (Hz): adds times and velocities (finite differences).
    #[arg(long, value_name = "HZ")]
    pub frame_rate_hz: Option<f64>,
    /// Rows whose σ_max exceeds this are flagged (mm).
    #[arg(long, value_name = "MM", default_value_t = 5.0)]
    pub threshold_mm: f64,
    /// Rows whose largest reprojection residual exceeds this are flagged (px; default: the
    /// robust limit median + 5·1.4826·MAD of the sequence's residuals).
    #[arg(long, value_name = "PX")]
    pub max_reprojection_px: Option<f64>,
    /// Skip the trajectory plots.
    #[arg(long)]
    pub no_plots: bool,
    /// CFC filter class (60, 180, 600, 1000) of the kinematics: each marker's displacement
    /// filtered in every replicate, velocity and acceleration from it (kinematics.csv; needs
    /// --frame-rate-hz).
    #[arg(long, value_name = "CLASS")]
    pub cfc: Option<u32>,
    /// The filter's standard: j211 (SAE J211-1, default) or iso6487 (ISO 6487).
    #[arg(long, value_name = "STANDARD", requires = "cfc")]
    pub cfc_standard: Option<String>,
    /// σ of camera A's trigger offset against the inward cameras (ms; needs --frame-rate-hz).
    #[arg(
        long,
        value_name = "MS",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub sync_sigma_ms: f64,
}

#[derive(Debug, Serialize)]
struct Skipped {
    epoch: String,
    observations: usize,
}

/// `summary.json` (and the `--json` output): the measurement's numbers
/// ([`output::Summary`]), then the skipped epochs, names, files and timing.
#[derive(Debug, Serialize)]
pub struct Summary {
    #[serde(flatten)]
    numbers: output::Summary,
    skipped_epochs: Vec<Skipped>,
    epoch_names: Vec<String>,
    marker_names: Vec<String>,
    files: Vec<String>,
    elapsed_s: f64,
}

/// Runs the command: computes, writes DIR, prints the summary.
pub fn run(a: MeasureArgs, g: &Global) -> anyhow::Result<()> {
    let summary = compute(&a, g.seed)?;
    if g.json {
        crate::output::print_json(&summary)?;
    } else {
        println!(
            "measured {} rows ({} epochs × {} markers seen), {} draws each; {:.1} % below {} mm; {} flagged; written to {}",
            summary.numbers.rows,
            summary.numbers.epochs,
            summary.numbers.markers,
            summary.numbers.samples_per_point,
            100.0 * summary.numbers.fraction_below_threshold,
            summary.numbers.threshold_mm,
            summary.numbers.rows_flagged,
            a.out.display()
        );
        if let Some(s) = &summary.numbers.sync_offset {
            println!("{}", s.line());
        }
    }
    Ok(())
}

fn vec3(v: &Option<Vec<f64>>, name: &str) -> anyhow::Result<Vec3> {
    match v {
        None => Ok(Vec3::zeros()),
        Some(v) => {
            let x = Vec3::new(v[0], v[1], v[2]);
            anyhow::ensure!(
                x.iter().all(|c| c.is_finite() && *c >= 0.0),
                "{name}: σ must be finite numbers ≥ 0"
            );
            Ok(x)
        }
    }
}

/// Reads the inputs, measures, and writes `DIR` (all-or-nothing); returns the summary.
pub fn compute(a: &MeasureArgs, seed: Option<u64>) -> anyhow::Result<Summary> {
    let started = std::time::Instant::now();
    let seed = seed.unwrap_or(DEFAULT_SEED);
    check_out_dir(&a.out)?;
    anyhow::ensure!(
        a.camera_c.is_some() == a.tie.is_some(),
        "--camera-c and --tie go together (give both for a tied-in camera C, or neither)"
    );
    let model = Reconstruction::read(&a.model)?;
    let sel_a = CameraSelector::parse(&a.camera_a);
    let seq = sequence::a_sequence(&model, &sel_a, a.mm_per_unit)?;
    let (b_id, camera_b) =
        sequence::inward_camera(&model, &CameraSelector::parse(&a.camera_b), 'B')?;
    let c = match (&a.camera_c, &a.tie) {
        (Some(sel), Some(tie)) => {
            let (id, cam) = sequence::inward_camera(&model, &CameraSelector::parse(sel), 'C')?;
            Some((id, input::load_link(tie)?, cam))
        }
        _ => None,
    };
    let a_from_b = input::load_link(&a.link)?;
    let names = CameraNames {
        b_id: Some(b_id),
        c_id: c.as_ref().map(|(id, _, _)| *id),
        has_c: c.is_some(),
    };
    let observations = input::read_observations(&a.observations, &names)?;

    // A's per-epoch uncertainty.
    let a_cov = a
        .a_covariance
        .as_deref()
        .map(input::read_a_covariance)
        .transpose()?;
    if a_cov.is_none() && a.sigma_a_position_mm.is_none() && a.sigma_a_angles_deg.is_none() {
        eprintln!(
            "warning: no uncertainty given for camera A's pose (--sigma-a-position-mm, --sigma-a-angles-deg or --a-covariance): it is treated as exact"
        );
    }
    let sig_pos = vec3(&a.sigma_a_position_mm, "--sigma-a-position-mm")?;
    let sig_ang = vec3(&a.sigma_a_angles_deg, "--sigma-a-angles-deg")?.map(f64::to_radians);
    let mut epochs = Vec::with_capacity(seq.poses.len());
    for p in &seq.poses {
        let world_from_a = match &a_cov {
            Some(cov) => {
                let m: Mat6 = cov.for_epoch(&[&p.key, &p.name]).with_context(|| {
                    format!(
                        "{}: epochs: no covariance for epoch `{}` and no default covariance_tangent",
                        cov.path.display(),
                        p.name
                    )
                })?;
                UncertainPose::from_covariance_deg(p.world_from_a, m)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", cov.path.display()))?
            }
            None => UncertainPose::from_sigmas(p.world_from_a, sig_pos, sig_ang),
        };
        epochs.push(Epoch {
            key: p.key.clone(),
            name: p.name.clone(),
            world_from_a,
        });
    }
    let settings = Settings {
        samples: a.samples,
        seed,
        pixel_sigma_px: a.pixel_sigma_px,
        reference_epoch: a.reference_epoch.clone(),
        frame_rate_hz: a.frame_rate_hz,
        threshold_mm: a.threshold_mm,
        max_reprojection_px: a.max_reprojection_px,
        cfc: match a.cfc {
            Some(class) => Some(CfcSpec {
                class,
                standard: Standard::parse(a.cfc_standard.as_deref().unwrap_or("j211"))?,
            }),
            None => None,
        },
        sync_sigma_ms: a.sync_sigma_ms,
    };
    let rig = Rig {
        a_from_b,
        camera_b,
        c: c.map(|(_, tie, cam)| (tie, cam)),
    };
    let m = crashrig_measure::measure(&epochs, &rig, &observations, &settings)
        .map_err(|e| e.in_files(&a.observations, &a.model))?;
    for s in &m.skipped {
        eprintln!(
            "warning: epoch `{}` has no pose of camera A ({}) in {}: its {} observation(s) are skipped",
            s.epoch,
            a.camera_a,
            a.model.display(),
            s.observations
        );
    }

    // Files.
    let mut files: Files = vec![
        (
            "trajectories.csv".into(),
            output::trajectories_csv(&m).into_bytes(),
        ),
        (
            "displacements.csv".into(),
            output::displacements_csv(&m).into_bytes(),
        ),
    ];
    if let Some(k) = output::kinematics_csv(&m) {
        files.push(("kinematics.csv".into(), k.into_bytes()));
    }
    if !a.no_plots {
        for p in output::marker_plots(&m)?
            .into_iter()
            .chain(output::kinematics_plots(&m)?)
        {
            files.push((format!("plots/{}.png", p.stem), p.png));
            files.push((format!("plots/{}.svg", p.stem), p.svg));
        }
    }
    let mut summary = summarize(&m, &settings, a, &files);
    summary.files.push("summary.json".into());
    summary.elapsed_s = started.elapsed().as_secs_f64();
    let mut json = serde_json::to_vec_pretty(&summary).context("serializing summary.json")?;
    json.push(b'\n');
    files.push(("summary.json".into(), json));
    write_dir(&a.out, &files)?;
    Ok(summary)
}

fn summarize(
    m: &Measurement,
    settings: &Settings,
    a: &MeasureArgs,
    files: &[(String, Vec<u8>)],
) -> Summary {
    Summary {
        numbers: output::Summary::new(m, settings, a.mm_per_unit, a.tie.is_some()),
        skipped_epochs: m
            .skipped
            .iter()
            .map(|s| Skipped {
                epoch: s.epoch.clone(),
                observations: s.observations,
            })
            .collect(),
        epoch_names: m.epochs.iter().map(|e| e.name.clone()).collect(),
        marker_names: m.markers.clone(),
        files: files.iter().map(|(n, _)| n.clone()).collect(),
        elapsed_s: 0.0,
    }
}

/// A directory `measure` may replace: absent, empty, or a previous `measure` output (it holds
/// `trajectories.csv` and `summary.json`). Anything else is refused before any work is done.
fn check_out_dir(dir: &Path) -> anyhow::Result<()> {
    if !dir.exists() {
        return Ok(());
    }
    anyhow::ensure!(
        dir.is_dir(),
        "{}: exists and is not a directory",
        dir.display()
    );
    let mut entries =
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))?;
    if entries.next().is_none() {
        return Ok(());
    }
    anyhow::ensure!(
        dir.join("trajectories.csv").is_file() && dir.join("summary.json").is_file(),
        "{}: exists and is not empty and not a previous `measure` output; choose another --out",
        dir.display()
    );
    Ok(())
}

/// Top-level entries of an existing `--out` that `measure` writes (directories end with `/`).
fn replaceable(name: &str) -> bool {
    matches!(
        name,
        "trajectories.csv" | "displacements.csv" | "kinematics.csv" | "summary.json" | "plots/"
    )
}

/// Writes `files` (paths relative to `dir`) as one unit through `crashrig-outdir`: into a
/// staging directory beside `dir`, swapped in whole (a previous output is replaced, never
/// mixed; SIGINT/SIGTERM remove the staging directory). This is the only function that writes
/// the output directory.
fn write_dir(dir: &Path, files: &[(String, Vec<u8>)]) -> anyhow::Result<()> {
    check_out_dir(dir)?;
    let mut staged = crashrig_outdir::Staged::new(dir, replaceable)?;
    for (name, bytes) in files {
        staged.write(name, bytes)?;
    }
    staged.commit()?;
    Ok(())
}
