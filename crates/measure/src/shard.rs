//! `measure --shard i/N` and its merge: the markers split into N contiguous shares, each
//! shard's Monte Carlo moments written exactly, and the merge reporting them through the very
//! code of the unsharded run ([`crate::run`]), so that every file it writes is the unsharded
//! run's byte for byte (`summary.json` except `elapsed_s`).
//!
//! # Why markers
//! Every row's accumulators take the replicates in replicate order (a Welford merge of
//! replicate blocks would not be bit-identical), and the kinematics filter needs every epoch
//! of a marker in one process. So shard i of N owns the markers
//! `⌊(i−1)·M/N⌋ .. ⌊i·M/N⌋` of the M markers (sorted by name): it draws every stream in full —
//! the link, A's poses and **every** observation's pixel noise, so the streams stay aligned —
//! but intersects, accumulates and filters only its markers' rows. The moments of a row depend
//! only on its own marker's positions (its reference epoch and velocity neighbours are the
//! same marker's), hence they are the unsharded run's bit for bit. With N > M some shards own
//! no marker: they are valid (empty) shards and merge.
//!
//! Scale bars (`--scale-bars`, [`crate::length`]) are split the same way: shard i owns the bars
//! `⌊(i−1)·B/N⌋ .. ⌊i·B/N⌋` of the B bars (file order) and also intersects both markers of each
//! of them (the other shards' markers' rows are left out of its moments), so a bar's moments
//! come from one process, replicate by replicate, as in the unsharded run.
//!
//! # The shard directory
//! `shard.json` ([`crashrig_outdir::shard::Manifest`], `command = "measure"`, its `items` the
//! marker range), [`OPTIONS`] (the options with absolute paths: what the merge runs again)
//! and [`MOMENTS`] (every accumulator of its rows and kinematic runs in Rust's shortest
//! round-trip decimals, per pass: 0 the measurement, 1 the one without the trigger offset).
//! The fingerprint covers the bytes of every input file (the model directory's files, the
//! link, the tie, the observations, A's covariance, the scale bars) and every option except the paths, the
//! output directory, the seed and the sample count (which the manifest states).
//!
//! # Example
//! ```
//! use crashrig_measure::{MeasureOptions, shard};
//! use crashrig_outdir::shard::{Shard, read_set};
//! use std::path::Path;
//!
//! let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence");
//! let options = MeasureOptions {
//!     camera_c: Some("3".into()),
//!     tie: Some(f.join("tie.json")),
//!     mm_per_unit: Some(1000.0),
//!     sigma_a_position_mm: Some([0.5; 3]),
//!     samples: 40,
//!     ..MeasureOptions::new(f.join("model"), "cam_out/", "2", f.join("link.json"), f.join("observations.csv"))
//! };
//! let tmp = tempfile::tempdir()?;
//! let dirs: Vec<_> = (1..=2).map(|i| tmp.path().join(format!("s{i}"))).collect();
//! for (i, dir) in dirs.iter().enumerate() {
//!     shard::run(&options, Shard::new(i + 1, 2)?, dir, None)?;
//! }
//! let merged = shard::merge(&read_set(&dirs)?, &tmp.path().join("merged"), false, None)?;
//! let whole = crashrig_measure::run(&options.config(crashrig_input::options::Spelling::Flag)?, None)?;
//! assert_eq!(merged.measurement, whole.measurement);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::engine::{Acc, Accs, Draws};
use crate::kinematics::{AxisMoments, RunAcc};
use crate::length::{self, BarAcc};
use crate::{Error, MeasureOptions, MeasureRun, OutputDir};
use crashrig_geometry::{Mat3, Vec3};
use crashrig_input::options::Spelling;
use crashrig_outdir::shard::{Manifest, Shard, check_set, fingerprint};
use crashrig_stats::Moments;
use crashrig_stats::progress::Monitor;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// `shard.json`'s `command` of a measure shard.
pub const COMMAND: &str = "measure";
/// The options of the run (JSON, absolute paths).
pub const OPTIONS: &str = crate::output::SHARD_OPTIONS;
/// The Monte Carlo moments of the shard's rows and runs.
pub const MOMENTS: &str = crate::output::SHARD_MOMENTS;
/// The header of [`MOMENTS`].
const HEADER: &str = "pass,kind,epoch,marker,moments";
/// Largest [`MOMENTS`] file read (bytes): about 1 kB per row, so a million rows.
const MAX_MOMENTS_BYTES: u64 = 1 << 30;

/// What a shard run wrote.
#[derive(Debug, Clone)]
pub struct ShardRun {
    /// Its `shard.json`.
    pub manifest: Manifest,
    /// Files written.
    pub files: usize,
    /// The shard's run: its measurement's rows of the other shards' markers have no σ.
    pub run: MeasureRun,
}

/// Runs shard `shard` of `options` (its [`MeasureOptions::out`] is ignored) and writes the
/// shard directory `out` all-or-nothing.
///
/// # Errors
/// Every error of [`crate::run`] (the inputs, the settings, the engine), and
/// [`Error::OutDir`] when `out` is neither absent, empty nor a previous measure output or
/// shard.
pub fn run(
    options: &MeasureOptions,
    shard: Shard,
    out: &Path,
    monitor: Option<&dyn Monitor>,
) -> Result<ShardRun, Error> {
    let started = std::time::Instant::now();
    crate::output::check_out_dir(out)?;
    let options = absolute(options)?;
    let config = options.config(Spelling::Flag)?;
    let fp = inputs_fingerprint(&options)?;
    let (r, accs) = crate::run::run_parts(&config, Draws::Shard(shard), monitor)?;
    let markers = r.measurement.markers.len();
    let mine = shard.range(markers);
    let mut manifest = Manifest::new(
        COMMAND,
        shard,
        markers,
        mine,
        fp,
        config.settings.seed,
        config.settings.samples as u64,
        options.observations.clone(),
    );
    manifest.threads = rayon::current_num_threads();
    let options_json = crate::output::json_pretty(&options)?;
    let moments = moments_csv(&accs).into_bytes();
    manifest.elapsed_s = started.elapsed().as_secs_f64();
    let files = vec![
        (
            crashrig_outdir::shard::MANIFEST.to_string(),
            manifest.to_json(),
        ),
        (OPTIONS.to_string(), options_json),
        (MOMENTS.to_string(), moments),
    ];
    crate::output::write_dir(out, &files)?;
    Ok(ShardRun {
        manifest,
        files: files.len(),
        run: r,
    })
}

/// Merges the measure shards `shards` (directory, manifest; e.g. from
/// [`crashrig_outdir::shard::read_set`]) into `out` (`plots`: as the unsharded run without
/// `--no-plots`): exactly what the unsharded run writes.
///
/// # Errors
/// [`Error::Write`] for the shard set (missing, repeated or foreign shards, naming them);
/// [`Error::Json`] / [`Error::Csv`] for a shard's files (file and line); [`Error::Input`] when
/// the inputs changed since the shards ran (naming the shard's [`OPTIONS`]); every error of
/// [`crate::run`]. Nothing is written on error.
pub fn merge(
    shards: &[(PathBuf, Manifest)],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<MeasureRun, Error> {
    let order = check_set(shards)?;
    crate::output::check_out_dir(out)?;
    let (dir0, m0) = &shards[order[0]];
    let options_path = dir0.join(OPTIONS);
    let mut options: MeasureOptions = read_options(&options_path)?;
    if inputs_fingerprint(&options)? != m0.fingerprint {
        return Err(Error::Input(format!(
            "{}: the inputs (model, link, tie, observations, A's covariance, scale bars) or options are not those the shards ran with: rerun the shards",
            options_path.display()
        )));
    }
    let mut accs: Vec<Accs> = Vec::new();
    for (done, &k) in order.iter().enumerate() {
        crashrig_stats::progress::check(monitor)?;
        let (dir, m) = &shards[k];
        read_moments(&dir.join(MOMENTS), m.range(), &mut accs)?;
        if let Some(p) = monitor {
            p.report(done + 1, order.len());
        }
    }
    options.out = Some(OutputDir {
        dir: out.to_path_buf(),
        plots,
    });
    let config = options.config(Spelling::Flag)?;
    crate::run::run_parts(&config, Draws::Given(&accs), monitor).map(|(r, _)| r)
}

/// The options with every input path absolute (the merge may run elsewhere) and no output.
fn absolute(options: &MeasureOptions) -> Result<MeasureOptions, Error> {
    let abs = |p: &Path| {
        std::path::absolute(p).map_err(|e| Error::Io {
            path: p.to_path_buf(),
            source: e,
        })
    };
    let opt = |p: &Option<PathBuf>| p.as_deref().map(abs).transpose();
    Ok(MeasureOptions {
        model: abs(&options.model)?,
        link: abs(&options.link)?,
        tie: opt(&options.tie)?,
        observations: abs(&options.observations)?,
        a_covariance: opt(&options.a_covariance)?,
        scale_bars: opt(&options.scale_bars)?,
        out: None,
        ..options.clone()
    })
}

/// The fingerprint of a run's inputs: every option but the paths, the output, the seed and
/// the sample count (as their shortest round-trip text), and the bytes of every input file (each of the model
/// directory's regular files with its name).
fn inputs_fingerprint(options: &MeasureOptions) -> Result<String, Error> {
    let read = |p: &Path| {
        std::fs::read(p).map_err(|e| Error::Io {
            path: p.to_path_buf(),
            source: e,
        })
    };
    let mut parts: Vec<String> = Vec::new();
    let mut model_files: Vec<PathBuf> = std::fs::read_dir(&options.model)
        .map_err(|e| Error::Io {
            path: options.model.clone(),
            source: e,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    model_files.sort();
    for p in &model_files {
        let name = p.file_name().unwrap_or_default().to_string_lossy();
        parts.push(format!("{name}:{}", fingerprint(&[&read(p)?])));
    }
    let files = [
        Some(&options.link),
        options.tie.as_ref(),
        Some(&options.observations),
        options.a_covariance.as_ref(),
        options.scale_bars.as_ref(),
    ];
    for f in files {
        parts.push(match f {
            Some(p) => fingerprint(&[&read(p)?]),
            None => "-".into(),
        });
    }
    let bare = MeasureOptions {
        model: PathBuf::new(),
        link: PathBuf::new(),
        tie: options.tie.as_ref().map(|_| PathBuf::new()),
        observations: PathBuf::new(),
        a_covariance: options.a_covariance.as_ref().map(|_| PathBuf::new()),
        scale_bars: options.scale_bars.as_ref().map(|_| PathBuf::new()),
        out: None,
        // The manifest states these two, so that a shard of another seed or sample count is
        // named as such.
        seed: None,
        samples: 0,
        ..options.clone()
    };
    parts.push(format!("{bare:?}"));
    let bytes: Vec<&[u8]> = parts.iter().map(|p| p.as_bytes()).collect();
    Ok(fingerprint(&bytes))
}

fn read_options(path: &Path) -> Result<MeasureOptions, Error> {
    let bad = |problem: String| Error::Json {
        path: path.to_path_buf(),
        key: "(file)".into(),
        problem,
    };
    let meta = std::fs::metadata(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    if meta.len() > 1 << 20 {
        return Err(bad("larger than 1 MiB: not a shard's options".into()));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    serde_json::from_slice(&bytes).map_err(|e| bad(format!("line {}: {e}", e.line())))
}

/// Shortest round-trip decimal of `x` (parses back to the same bits).
fn push_num(s: &mut String, x: f64) {
    let _ = write!(s, ",{x:?}");
}

fn push_moments(s: &mut String, m: &Moments<3>) {
    let (n, mean, m2) = m.parts();
    let _ = write!(s, ",{n}");
    mean.iter().chain(m2.iter()).for_each(|&x| push_num(s, x));
}

/// [`MOMENTS`]: per pass, a `row` line per (measured epoch, marker) — position, displacement
/// and velocity moments, each `n, mean (3), m2 (9, column-major)` — a `run` line per
/// kinematic run (first epoch, marker, `n`, then per epoch of the run the mean and m2 per axis
/// of the filtered displacement, velocity and acceleration) and a `bar` line per scale bar
/// (its number of epochs in the `epoch` column, its index in the `marker` column, then the
/// moments of the replicates' mean distance and scatter statistic and per epoch of the
/// distance and its deviation from the mean, each `n, mean, m2`; [`crate::length`]).
fn moments_csv(accs: &[Accs]) -> String {
    let mut s = format!("{HEADER}\n");
    for (pass, a) in accs.iter().enumerate() {
        for (&(e, m), acc) in &a.rows {
            let _ = write!(s, "{pass},row,{e},{m}");
            for q in [&acc.pos, &acc.disp, &acc.vel] {
                push_moments(&mut s, q);
            }
            s.push('\n');
        }
        for (&(m, start), acc) in &a.runs {
            let _ = write!(s, "{pass},run,{start},{m},{}", acc.n);
            for q in acc.m.iter().flatten() {
                q.mean
                    .iter()
                    .chain(q.m2.iter())
                    .for_each(|&x| push_num(&mut s, x));
            }
            s.push('\n');
        }
        for (&b, acc) in &a.bars {
            let _ = write!(s, "{pass},bar,{},{b}", acc.dist.len());
            let epochs = acc.dist.iter().zip(&acc.dev).flat_map(|(d, v)| [d, v]);
            for q in [&acc.mean, &acc.scatter].into_iter().chain(epochs) {
                let (n, mean, m2) = length::scalar_parts(q);
                let _ = write!(s, ",{n}");
                push_num(&mut s, mean);
                push_num(&mut s, m2);
            }
            s.push('\n');
        }
    }
    s
}

/// Reads a shard's [`MOMENTS`] into `accs` (one [`Accs`] per pass), refusing rows of markers
/// outside `markers` (the shard's items) and rows given twice.
fn read_moments(path: &Path, markers: Range<usize>, accs: &mut Vec<Accs>) -> Result<(), Error> {
    let meta = std::fs::metadata(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    if meta.len() > MAX_MOMENTS_BYTES {
        return Err(Error::Csv {
            path: path.to_path_buf(),
            line: 1,
            problem: format!("larger than {MAX_MOMENTS_BYTES} bytes"),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    let mut lines = text.lines();
    if lines.next() != Some(HEADER) {
        return Err(Error::Csv {
            path: path.to_path_buf(),
            line: 1,
            problem: format!("expected the header `{HEADER}`"),
        });
    }
    for (k, line) in lines.enumerate() {
        let at = |problem: String| Error::Csv {
            path: path.to_path_buf(),
            line: k as u64 + 2,
            problem,
        };
        parse_line(line, &markers, accs).map_err(at)?;
    }
    Ok(())
}

fn parse_line(line: &str, markers: &Range<usize>, accs: &mut Vec<Accs>) -> Result<(), String> {
    let f: Vec<&str> = line.split(',').collect();
    if f.len() < 5 {
        return Err("expected pass,kind,epoch,marker,moments…".into());
    }
    let int = |t: &str, what: &str| -> Result<usize, String> {
        t.parse::<usize>()
            .map_err(|_| format!("{what} `{t}` is not a whole number"))
    };
    let pass = int(f[0], "pass")?;
    if pass > 1 {
        return Err(format!("pass {pass} is not 0 or 1"));
    }
    let (e, m) = (int(f[2], "epoch")?, int(f[3], "marker")?);
    if f[1] == "bar" {
        // `epoch` is the bar's number of epochs, `marker` its index: any shard may own a bar.
        let acc = parse_bar(&f[4..], e)?;
        if accs.len() <= pass {
            accs.resize_with(pass + 1, Accs::default);
        }
        if accs[pass].bars.insert(m, acc).is_some() {
            return Err(format!("the moments of scale bar {m} are given twice"));
        }
        return Ok(());
    }
    if !markers.contains(&m) {
        return Err(format!(
            "marker {m} is not one of this shard's markers {}..{}",
            markers.start, markers.end
        ));
    }
    let nums = |t: &[&str]| -> Result<Vec<f64>, String> {
        t.iter()
            .map(|x| {
                x.parse::<f64>()
                    .map_err(|_| format!("`{x}` is not a number"))
            })
            .collect()
    };
    if accs.len() <= pass {
        accs.resize_with(pass + 1, Accs::default);
    }
    let a = &mut accs[pass];
    let twice = || format!("the moments of epoch {e}, marker {m} are given twice");
    match f[1] {
        "row" => {
            if f.len() != 4 + 3 * 13 {
                return Err(format!("a row has {} fields, not 43", f.len()));
            }
            let mut q = [Moments::<3>::new(); 3];
            for (i, q) in q.iter_mut().enumerate() {
                let g = &f[4 + 13 * i..4 + 13 * (i + 1)];
                let n = int(g[0], "count")? as u64;
                let x = nums(&g[1..])?;
                *q = Moments::from_parts(
                    n,
                    Vec3::from_column_slice(&x[..3]),
                    Mat3::from_column_slice(&x[3..]),
                );
            }
            let acc = Acc {
                pos: q[0],
                disp: q[1],
                vel: q[2],
            };
            if a.rows.insert((e, m), acc).is_some() {
                return Err(twice());
            }
        }
        "run" => {
            let x = nums(&f[5..])?;
            if x.is_empty() || x.len() % 18 != 0 {
                return Err(format!(
                    "a run has {} moments, not a multiple of 18",
                    x.len()
                ));
            }
            let axis = |c: &[f64]| AxisMoments {
                mean: Vec3::from_column_slice(&c[..3]),
                m2: Vec3::from_column_slice(&c[3..6]),
            };
            let acc = RunAcc {
                n: int(f[4], "count")? as u64,
                m: x.chunks(18)
                    .map(|c| [axis(&c[..6]), axis(&c[6..12]), axis(&c[12..])])
                    .collect(),
            };
            if a.runs.insert((m, e), acc).is_some() {
                return Err(twice());
            }
        }
        other => return Err(format!("kind `{other}` is not `row`, `run` or `bar`")),
    }
    Ok(())
}

/// A `bar` line's moments (after its first four fields) of a bar with `n` epochs.
fn parse_bar(f: &[&str], n: usize) -> Result<BarAcc, String> {
    let groups = 2 + 2 * n;
    if f.len() != 3 * groups {
        return Err(format!(
            "a scale bar of {n} epochs has {} moments, not {}",
            f.len(),
            3 * groups
        ));
    }
    let mut q = Vec::with_capacity(groups);
    for g in f.chunks(3) {
        let count = g[0]
            .parse::<u64>()
            .map_err(|_| format!("count `{}` is not a whole number", g[0]))?;
        let x = |t: &str| {
            t.parse::<f64>()
                .map_err(|_| format!("`{t}` is not a number"))
        };
        q.push(length::scalar_from_parts(count, x(g[1])?, x(g[2])?));
    }
    Ok(BarAcc {
        mean: q[0],
        scatter: q[1],
        dist: q[2..].iter().step_by(2).copied().collect(),
        dev: q[3..].iter().step_by(2).copied().collect(),
    })
}
