//! The library entry of `crashrig measure`: a typed [`MeasureConfig`] → [`run`] → a typed
//! [`MeasureRun`] (and, with [`MeasureConfig::out`], the output directory written
//! all-or-nothing). The command and the study's `[measure]` step both call it.
//!
//! # Example
//! The bundled synthetic sequence (`fixtures/measure/sequence`), measured without writing:
//! ```
//! use crashrig_geometry::Vec3;
//! use crashrig_measure::{ANoise, MeasureConfig, Settings, input, run};
//! use std::path::Path;
//!
//! let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence");
//! let config = MeasureConfig {
//!     model: f.join("model"),
//!     camera_a: "cam_out/".into(),
//!     camera_b: "2".into(),
//!     camera_c: Some("3".into()),
//!     a_from_b: input::load_link(&f.join("link.json"))?,
//!     b_from_c: Some(input::load_link(&f.join("tie.json"))?),
//!     observations: f.join("observations.csv"),
//!     mm_per_unit: 1000.0,
//!     a_noise: ANoise::Sigmas { position_mm: Vec3::repeat(0.5), angles_deg: Vec3::zeros() },
//!     settings: Settings {
//!         samples: 100,
//!         seed: 1,
//!         pixel_sigma_px: 0.1,
//!         reference_epoch: None,
//!         frame_rate_hz: None,
//!         frame_times: None,
//!         threshold_mm: 5.0,
//!         max_reprojection_px: None,
//!         cfc: None,
//!         sync_sigma_ms: 0.0,
//!     },
//!     pixel_sigma_from: Default::default(),
//!     scale_bars: None,
//!     out: None,
//! };
//! let r = run(&config, None)?;
//! assert_eq!(r.summary.numbers.rows, r.measurement.rows.len());
//! assert_eq!(r.summary.numbers.cameras, ["B", "C"]);
//! // Nothing written: no files listed.
//! assert!(r.summary.files.is_empty());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::Error;
use crate::engine::{Accs, Draws, Epoch, Input, Measurement, Rig, Settings};
use crate::input::{self, CameraNames, JointA};
use crate::length::{self, ScaleBars};
use crate::output::{self, Skipped, SummaryDocument};
use crate::sequence::{self, APose, CameraSelector};
use crashrig_geometry::{UncertainPose, Vec3};
use crashrig_stats::progress::Monitor;
use std::path::{Path, PathBuf};

/// Camera A's per-epoch pose uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub enum ANoise {
    /// The same σ for every epoch: projection centre (world axes, mm) and rotation about A's
    /// own axes (degrees). Zeros: A's pose is exact.
    Sigmas {
        /// σ of the centre (mm).
        position_mm: Vec3,
        /// σ of the rotation (degrees).
        angles_deg: Vec3,
    },
    /// A JSON file with `covariance_tangent`, `epochs` and/or `joint`
    /// ([`input::read_a_covariance`]); with `joint`, A's poses of one replicate are drawn
    /// jointly ([`crate::engine::measure`]).
    File(PathBuf),
    /// A covariance already read or computed (typed, no file round trip: e.g. a study's
    /// `crashrig_covariance` result), with the meaning of [`ANoise::File`]'s contents.
    Covariance(Box<input::ACovariance>),
}

/// Where and how [`run`] writes the output directory.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OutputDir {
    /// The directory (absent, empty, or a previous `measure` output; replaced whole).
    pub dir: PathBuf,
    /// Draw the per-marker trajectory plots (`plots/<marker>.png|svg`).
    pub plots: bool,
}

/// The length check's inputs (`--scale-bars`, `--mpe-mm`; [`crate::length`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ScaleBarsFile {
    /// The scale-bar CSV `name,marker_1,marker_2,length_mm,sigma_mm`.
    pub path: PathBuf,
    /// The lab's maximum permissible error of a length (mm, > 0), if any.
    pub mpe_mm: Option<f64>,
}

/// Everything a measurement needs, typed: the files of the sequence, the rig's links as
/// uncertain poses, and the settings.
#[derive(Debug, Clone)]
pub struct MeasureConfig {
    /// COLMAP model of the sequence (camera A registered against the lab per epoch).
    pub model: PathBuf,
    /// Camera A: image-name prefix or camera id; its images are the epochs.
    pub camera_a: String,
    /// Inward camera B: camera id or image-name prefix (intrinsics).
    pub camera_b: String,
    /// Tied-in camera C: camera id or image-name prefix; needs [`MeasureConfig::b_from_c`].
    pub camera_c: Option<String>,
    /// The calibrated link `A_from_B` with the uncertainty of the mean link (mm, rad).
    pub a_from_b: UncertainPose,
    /// The tie `B_from_C` with its uncertainty; needs [`MeasureConfig::camera_c`].
    pub b_from_c: Option<UncertainPose>,
    /// Marker observations CSV `epoch,camera,marker,u_px,v_px`.
    pub observations: PathBuf,
    /// Model units → mm.
    pub mm_per_unit: f64,
    /// Camera A's per-epoch uncertainty.
    pub a_noise: ANoise,
    /// Replicates, seed, pixel σ, reference epoch, frame rate, thresholds.
    pub settings: Settings,
    /// The stated pixel σ, or the pixel σ check's estimate (`--pixel-sigma-px estimate`;
    /// needs camera C).
    pub pixel_sigma_from: crate::pixel_check::PixelSigmaFrom,
    /// The scale bars of the length check, if any.
    pub scale_bars: Option<ScaleBarsFile>,
    /// The output directory; `None`: compute only.
    pub out: Option<OutputDir>,
}

/// The result of [`run`].
#[derive(Debug, Clone)]
pub struct MeasureRun {
    /// The rows, epochs and markers (typed).
    pub measurement: Measurement,
    /// The pixel σ checked on the sequence's residuals (with B and C; [`crate::pixel_check`]).
    pub pixel_sigma_check: Option<crate::pixel_check::PixelSigmaCheck>,
    /// `summary.json` (its numbers, skipped epochs, names, the files written, the time).
    pub summary: SummaryDocument,
    /// Warnings for the user (epochs of the observations without a pose of camera A, scale
    /// bars whose check is not `consistent`), one sentence each without the `warning:`
    /// prefix; also in `summary.json`'s `warnings`.
    pub warnings: Vec<String>,
}

/// Reads the sequence, measures it and, with [`MeasureConfig::out`], writes `trajectories.csv`,
/// `displacements.csv`, the plots and `summary.json` as one unit through `crashrig-outdir`
/// (a previous output is replaced, never mixed).
///
/// `monitor` (optional) gets `(done, total)` replicates drawn, a chunk of replicates at a time
/// (with a sync σ the run is made twice, with and without it: `total` is twice the
/// replicates), and is asked between chunks and before writing whether to stop. The result
/// does not depend on it.
///
/// # Errors
/// Every [`Error`] of the inputs (each names its file), of the settings, of the engine
/// (placed in its file by [`Error::in_files`]), and of the output directory
/// ([`Error::OutDir`], checked before any work); [`Error::Cancelled`] when `monitor` asked to
/// stop (nothing is written then).
pub fn run(config: &MeasureConfig, monitor: Option<&dyn Monitor>) -> Result<MeasureRun, Error> {
    let whole = Draws::Shard(crashrig_outdir::shard::Shard::whole());
    run_parts(config, whole, monitor).map(|(r, _)| r)
}

/// [`run`] with the Monte Carlo's moments drawn for one shard's markers or given by a shard
/// set ([`Draws`]), and the accumulators per pass ([`crate::engine::measure_parts`]).
pub(crate) fn run_parts(
    config: &MeasureConfig,
    draws: Draws<'_>,
    monitor: Option<&dyn Monitor>,
) -> Result<(MeasureRun, Vec<Accs>), Error> {
    let started = std::time::Instant::now();
    if let Some(out) = &config.out {
        output::check_out_dir(&out.dir)?;
    }
    if config.camera_c.is_some() != config.b_from_c.is_some() {
        return Err(Error::Input(
            "camera C and the tie B_from_C go together (give both, or neither)".into(),
        ));
    }
    let model = crashrig_colmap::Reconstruction::read(&config.model)?;
    let seq = sequence::a_sequence(
        &model,
        &CameraSelector::parse(&config.camera_a),
        config.mm_per_unit,
    )?;
    let (b_id, camera_b) =
        sequence::inward_camera(&model, &CameraSelector::parse(&config.camera_b), 'B')?;
    let c = match (&config.camera_c, &config.b_from_c) {
        (Some(sel), Some(tie)) => {
            let (id, cam) = sequence::inward_camera(&model, &CameraSelector::parse(sel), 'C')?;
            Some((id, *tie, cam))
        }
        _ => None,
    };
    let names = CameraNames {
        b_id: Some(b_id),
        c_id: c.as_ref().map(|(id, _, _)| *id),
        has_c: c.is_some(),
    };
    let observations = input::read_observations(&config.observations, &names)?;
    let scale_bars = config
        .scale_bars
        .as_ref()
        .map(|f| scale_bars(f, &observations))
        .transpose()?;
    let (epochs, joint) = a_epochs(&seq.poses, &config.a_noise)?;
    let rig = Rig {
        a_from_b: config.a_from_b,
        camera_b,
        c: c.map(|(_, tie, cam)| (tie, cam)),
    };
    let check = crate::pixel_check::pixel_sigma_check(
        &epochs,
        &rig,
        &observations,
        config.settings.pixel_sigma_px,
    );
    let stated_from = match observations.iter().filter(|o| o.sigma.is_some()).count() {
        0 => "pixel_sigma_px",
        n if n == observations.len() => "observations",
        _ => "observations_and_pixel_sigma_px",
    };
    let (observations, estimate) = pixel_noise(config, &check, observations)?;
    let input = Input {
        epochs: &epochs,
        joint: joint.as_ref(),
        rig: &rig,
        observations: &observations,
        scale_bars: scale_bars.as_ref(),
    };
    let (measurement, accs) =
        crate::engine::measure_parts(&input, &config.settings, draws, monitor)
            .and_then(|(m, accs)| {
                crate::plausible::check_measurable(&m)?;
                crate::plausible::check_finite(&m)?;
                Ok((m, accs))
            })
            .map_err(|e| e.in_files(&config.observations, &config.model))?;
    let mut warnings: Vec<String> = measurement
        .skipped
        .iter()
        .map(|s| {
            format!(
                "epoch `{}` has no pose of camera A ({}) in {}: its {} observation(s) are skipped",
                s.epoch,
                config.camera_a,
                config.model.display(),
                s.observations
            )
        })
        .collect();
    if let Some(lc) = &measurement.length_check {
        warnings.extend(lc.warnings());
    }
    match &estimate {
        Some(used) => warnings.extend(used.warning()),
        None => warnings.extend(check.as_ref().and_then(|c| c.warning())),
    }
    let mut summary = summary_document(&measurement, config, &warnings);
    summary.numbers.pixel_sigma_estimate = estimate.as_ref().map(output::EstimateSummary::new);
    summary.numbers.pixel_sigma_check = check
        .as_ref()
        .map(|c| output::PixelCheckSummary::new(c, stated_from));

    if let Some(out) = &config.out {
        let mut files = output_files(&measurement, out.plots)?;
        summary.files = files.iter().map(|(n, _)| n.clone()).collect();
        summary.files.push("summary.json".into());
        summary.elapsed_s = started.elapsed().as_secs_f64();
        files.push(("summary.json".into(), output::json_pretty(&summary)?));
        crashrig_stats::progress::check(monitor)?;
        output::write_dir(&out.dir, &files)?;
    }
    let r = MeasureRun {
        measurement,
        pixel_sigma_check: check,
        summary,
        warnings,
    };
    Ok((r, accs))
}

/// The scale bars of `f` (their markers checked against the observations' markers) and the
/// maximum permissible error.
///
/// # Errors
/// [`length::read_scale_bars`]'s; [`Error::Setting`] for a maximum permissible error that is
/// not a finite number > 0.
fn scale_bars(f: &ScaleBarsFile, observations: &[input::Observation]) -> Result<ScaleBars, Error> {
    if let Some(e) = f.mpe_mm {
        crate::rules::mpe_mm(e, true, &|k| k.to_string()).map_err(|problem| Error::Setting {
            name: "--mpe-mm",
            problem,
        })?;
    }
    Ok(ScaleBars {
        path: f.path.clone(),
        bars: length::read_scale_bars(&f.path, observations)?,
        mpe_mm: f.mpe_mm,
    })
}

/// The epochs of A's sequence with their uncertain poses, and the file's joint covariance of
/// the epochs (if it has one).
fn a_epochs(poses: &[APose], noise: &ANoise) -> Result<(Vec<Epoch>, Option<JointA>), Error> {
    let mut a_cov = match noise {
        ANoise::File(p) => Some(input::read_a_covariance(p)?),
        ANoise::Covariance(c) => Some(c.as_ref().clone()),
        ANoise::Sigmas { .. } => None,
    };
    let mut epochs = Vec::with_capacity(poses.len());
    for p in poses {
        let world_from_a = match (&a_cov, noise) {
            (Some(cov), _) => {
                let m = cov
                    .for_epoch(&[&p.key, &p.name])
                    .ok_or_else(|| Error::Json {
                        path: cov.path.clone(),
                        key: "epochs".into(),
                        problem: format!(
                            "no covariance for epoch `{}` and no default covariance_tangent",
                            p.name
                        ),
                    })?;
                UncertainPose::from_covariance_deg(p.world_from_a, m)
                    .map_err(|e| Error::Input(format!("{}: {e}", cov.path.display())))?
            }
            (
                None,
                ANoise::Sigmas {
                    position_mm,
                    angles_deg,
                },
            ) => UncertainPose::from_sigmas(
                p.world_from_a,
                *position_mm,
                angles_deg.map(f64::to_radians),
            ),
            (None, ANoise::File(_) | ANoise::Covariance(_)) => unreachable!("read above"),
        };
        epochs.push(Epoch {
            key: p.key.clone(),
            name: p.name.clone(),
            world_from_a,
        });
    }
    Ok((epochs, a_cov.as_mut().and_then(|c| c.joint.take())))
}

/// `summary.json` without the files and the time (filled in by [`run`] when it writes).
/// The observations the Monte Carlo draws from: as read, or with
/// [`PixelSigmaFrom::Estimate`](crate::pixel_check::PixelSigmaFrom) each one's σ scaled by the
/// check's estimate ([`crate::pixel_check::apply_estimate`]).
///
/// # Errors
/// [`Error::Setting`] (`--pixel-sigma-px`) when there is nothing to estimate from: no camera C,
/// no marker-epoch seen by both B and C, or residuals of exactly 0.
fn pixel_noise(
    config: &MeasureConfig,
    check: &Option<crate::pixel_check::PixelSigmaCheck>,
    observations: Vec<input::Observation>,
) -> Result<
    (
        Vec<input::Observation>,
        Option<crate::pixel_check::EstimateUsed>,
    ),
    Error,
> {
    if config.pixel_sigma_from == crate::pixel_check::PixelSigmaFrom::Stated {
        return Ok((observations, None));
    }
    let bad = |problem: &str| Error::Setting {
        name: "--pixel-sigma-px",
        problem: format!("estimate: {problem}"),
    };
    if config.camera_c.is_none() {
        return Err(bad(
            "needs camera C and its tie (the estimate comes from the rays of B and C missing each other)",
        ));
    }
    let Some(check) = check else {
        return Err(bad(
            "no marker-epoch seen by both B and C has rays to check (too few, or degenerate): nothing to estimate the pixel σ from",
        ));
    };
    crate::pixel_check::apply_estimate(check, &observations, config.settings.pixel_sigma_px)
        .map(|(o, used)| (o, Some(used)))
        .ok_or_else(|| {
            bad("the residuals of B and C are exactly 0: nothing to estimate the pixel σ from")
        })
}

fn summary_document(
    m: &Measurement,
    config: &MeasureConfig,
    warnings: &[String],
) -> SummaryDocument {
    SummaryDocument {
        numbers: output::Summary::new(
            m,
            &config.settings,
            config.mm_per_unit,
            config.b_from_c.is_some(),
        ),
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
        warnings: warnings.to_vec(),
        files: Vec::new(),
        elapsed_s: 0.0,
    }
}

/// The CSV files and (with `plots`) the plots of `m`: path relative to the directory, bytes.
fn output_files(m: &Measurement, plots: bool) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let mut files = vec![
        (
            "trajectories.csv".to_string(),
            output::trajectories_csv(m).into_bytes(),
        ),
        (
            "displacements.csv".to_string(),
            output::displacements_csv(m).into_bytes(),
        ),
        ("trajectories.ply".to_string(), output::trajectories_ply(m)),
    ];
    if let Some(k) = output::kinematics_csv(m) {
        files.push(("kinematics.csv".to_string(), k.into_bytes()));
    }
    if let Some(l) = output::length_check_csv(m) {
        files.push((output::LENGTH_CHECK_CSV.to_string(), l.into_bytes()));
    }
    if plots {
        if let Some(p) = output::length_check_plot(m)? {
            files.push(("length_check.png".to_string(), p.png));
            files.push(("length_check.svg".to_string(), p.svg));
        }
        for p in output::marker_plots(m)?
            .into_iter()
            .chain(output::kinematics_plots(m)?)
        {
            files.push((format!("plots/{}.png", p.stem), p.png));
            files.push((format!("plots/{}.svg", p.stem), p.svg));
        }
    }
    Ok(files)
}

/// Whether `path` is usable as [`OutputDir::dir`] (`output::check_out_dir`); for front ends
/// that check before reading their own inputs.
///
/// # Errors
/// [`Error::OutDir`].
pub fn check_out(path: &Path) -> Result<(), Error> {
    output::check_out_dir(path)
}
