//! `crashrig grid --shard i/N` and the grid half of `crashrig merge` (docs/SCALE.md).
//!
//! A shard runs the grid points `Shard::range(points)` (contiguous, in `grid.csv` order) with
//! [`crashrig_mc::GridStudy::with_points`]: a point's draws come from its own streams, so its
//! statistics are bit-identical to the same point's in the unsharded run. The shard directory
//! holds them exactly (`points.csv`: every number in Rust's shortest round-trip form, which
//! parses back to the same bits; `points_independent.csv` in correlated mode) and
//! `shard.json` ([`crashrig_outdir::shard::Manifest`]). [`merge_grid`] reads the shards back
//! into one [`crashrig_mc::GridResult`] and reports it through the very code of
//! [`crate::run_grid`] (`run::finish`): the same `grid.csv`, `grid_detail.csv`, maps and
//! `summary.json` (equal except `elapsed_s` and `samples_per_second`, which add up the shards'
//! times).
//!
//! # Example
//! ```no_run
//! use crashrig_outdir::shard::{Shard, read_set};
//! use crashrig_grid::GridConfig;
//! use crashrig_grid::shard::{merge_grid, run_grid_shard};
//!
//! let mut dirs = Vec::new();
//! for i in 1..=2 {
//!     let config = GridConfig {
//!         scenario: "fixtures/scenarios/three_cameras_z0.toml".into(),
//!         out: format!("shards/{i}").into(),
//!         samples: Some(2000),
//!         seed: Some(1),
//!         plots: false,
//!     };
//!     run_grid_shard(&config, Shard::new(i, 2)?, None)?;
//!     dirs.push(config.out);
//! }
//! let merged = merge_grid(&read_set(&dirs)?, "merged".as_ref(), true, None)?;
//! println!("{} points", merged.summary.points);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::Error;
use crate::run::{
    Computed, GridConfig, GridRun, Pending, Prepared, compute, finish, prepare, prepare_scenario,
};
use crashrig_mc::{GridResult, PointStats, Scenario};
use crashrig_outdir::shard::{MANIFEST, Manifest, Shard, fingerprint};
use crashrig_stats::progress::{Counter, Monitor, Reporter};
use nalgebra::{Matrix3, Vector3};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The rows of a grid shard.
pub const POINTS_FILE: &str = "points.csv";
/// The rows with independent observers (correlated mode only).
pub const INDEPENDENT_FILE: &str = "points_independent.csv";

/// The `command` of a grid shard's manifest.
pub const COMMAND: &str = "grid";

/// Whether a top-level entry of an existing shard directory is something a grid shard writes.
pub fn shard_replaceable(name: &str) -> bool {
    [MANIFEST, POINTS_FILE, INDEPENDENT_FILE].contains(&name) || name.starts_with(".tmp")
}

/// What a shard run wrote.
#[derive(Debug, Clone)]
pub struct ShardRun {
    /// Its `shard.json`.
    pub manifest: Manifest,
    /// Files written (`shard.json` included).
    pub files: usize,
}

/// The fingerprint of a grid run's inputs: the scenario file's bytes and the scenario as read
/// (which holds the content of every file it names, e.g. `from = "link.json"`).
fn input_fingerprint(path: &Path, scenario: &Scenario) -> Result<String, Error> {
    fingerprint_inputs(COMMAND, &[path], &[format!("{scenario:?}")])
}

/// The fingerprint of a sharded run's inputs ([`crashrig_outdir::shard::fingerprint`]): the
/// command, the bytes of every input file (each read with the scenario files' size bound) and
/// the inputs as read (`resolved`: e.g. the scenario's `Debug` form, which holds the content of
/// every file it names, and the options that shape the work).
///
/// # Errors
/// [`Error::Read`] for a file that cannot be read.
pub fn fingerprint_inputs(
    command: &str,
    files: &[&Path],
    resolved: &[String],
) -> Result<String, Error> {
    let mut parts = vec![command.as_bytes().to_vec()];
    for path in files {
        let bytes = crashrig_input::file::read_limited(path, crashrig_input::file::MAX_TOML_BYTES)
            .map_err(|source| Error::Read {
                path: path.to_path_buf(),
                source,
            })?;
        parts.push(bytes);
    }
    parts.extend(resolved.iter().map(|r| r.as_bytes().to_vec()));
    let refs: Vec<&[u8]> = parts.iter().map(Vec::as_slice).collect();
    Ok(fingerprint(&refs))
}

/// Runs shard `shard` of `config`'s grid and writes the shard directory `config.out`
/// (`config.plots` is ignored: maps are drawn by the merge).
///
/// # Errors
/// As [`crate::run_grid`].
pub fn run_grid_shard(
    config: &GridConfig,
    shard: Shard,
    progress: Option<&dyn Reporter>,
) -> Result<ShardRun, Error> {
    let p = prepare(&config.scenario, config.samples, config.seed)?;
    let mut files = Pending::new(&config.out, shard_replaceable)?;
    let total = p.study.grid().points().len();
    let range = shard.range(total);
    let rows = shard_rows(&p, range.clone(), &config.scenario, "", progress)?;
    let input = std::fs::canonicalize(&config.scenario).unwrap_or(config.scenario.clone());
    let mut manifest = Manifest::new(
        COMMAND,
        shard,
        total,
        range,
        input_fingerprint(&config.scenario, &p.scenario)?,
        p.seed,
        p.samples as u64,
        input,
    );
    manifest.elapsed_s = rows.elapsed_s;
    manifest.threads = rows.threads;
    for (name, bytes) in &rows.files {
        files.write(name, bytes)?;
    }
    files.write(MANIFEST, &manifest.to_json())?;
    Ok(ShardRun {
        manifest,
        files: files.commit()?,
    })
}

/// A shard's rows of one grid: the files and the run's seconds and threads.
struct Rows {
    files: Vec<(String, Vec<u8>)>,
    elapsed_s: f64,
    threads: usize,
}

/// Runs the points `range` of `p`'s grid; the rows go to `{prefix}points.csv` and, in
/// correlated mode, `{prefix}points_independent.csv`.
fn shard_rows(
    p: &Prepared,
    range: Range<usize>,
    path: &Path,
    prefix: &str,
    progress: Option<&dyn Reporter>,
) -> Result<Rows, Error> {
    let study = p
        .study
        .with_points(range.clone())
        .map_err(|e| Error::Scenario {
            path: path.to_path_buf(),
            source: e,
        })?;
    let c = compute(p, &study, path, progress)?;
    let mut files = vec![(
        format!("{prefix}{POINTS_FILE}"),
        rows_csv(range.start, &c.result.points)?,
    )];
    if let Some(ind) = &c.independent {
        files.push((
            format!("{prefix}{INDEPENDENT_FILE}"),
            rows_csv(range.start, &ind.points)?,
        ));
    }
    Ok(Rows {
        files,
        elapsed_s: c.elapsed_s,
        threads: c.threads,
    })
}

/// Runs the grid points `range` of `scenario` (read or built in memory, e.g. a layout of
/// `crashrig place`; `path` names it in messages) exactly as a grid shard runs them, and
/// writes their rows to `staged` as `{prefix}points.csv` (and
/// `{prefix}points_independent.csv` in correlated mode), for [`read_scenario_rows`] to read
/// back. Returns the number of files written.
///
/// # Errors
/// As [`crate::run_grid_scenario`].
#[allow(clippy::too_many_arguments)]
pub fn write_scenario_rows(
    scenario: &Scenario,
    path: &Path,
    samples: usize,
    seed: u64,
    range: Range<usize>,
    prefix: &str,
    staged: &mut crashrig_outdir::Staged,
    progress: Option<&dyn Reporter>,
) -> Result<usize, Error> {
    let p = prepare_scenario(scenario.clone(), path, Some(samples), Some(seed))?;
    let rows = shard_rows(&p, range, path, prefix, progress)?;
    for (name, bytes) in &rows.files {
        staged.write(name, bytes)?;
    }
    Ok(rows.files.len())
}

/// One grid's Monte Carlo statistics read back from its shards' rows
/// ([`read_scenario_rows`]), to be reported through the code of `crashrig grid`
/// ([`MergedRows::write`]).
pub struct MergedRows {
    p: Prepared,
    computed: Computed,
    path: PathBuf,
}

impl MergedRows {
    /// The statistics of every grid point in `grid.csv` order (degenerate points not yet
    /// blanked), bit-identical to the unsharded run's.
    pub fn result(&self) -> &GridResult {
        &self.computed.result
    }

    /// The grid.
    pub fn grid(&self) -> &crashrig_mc::Grid {
        self.p.study.grid()
    }

    /// Writes `out` exactly as `crashrig grid` writes it (timings: the shards' added up).
    ///
    /// # Errors
    /// As [`crate::run_grid`].
    pub fn write(self, out: &Path, plots: bool) -> Result<GridRun, Error> {
        let files = Pending::new(out, crate::run::replaceable)?;
        finish(&self.p, self.computed, &self.path, plots, files)
    }
}

/// Reads the rows [`write_scenario_rows`] wrote with `prefix` into each of `shards` (checked,
/// in shard order, as [`crashrig_outdir::shard::read_set`] returns them) back into one grid
/// result of `scenario` (`path` names it in messages).
///
/// # Errors
/// [`Error::Shard`] for a shard file that cannot be read or does not hold the shard's points
/// of this grid (file and line), and the errors of [`crate::run_grid_scenario`].
pub fn read_scenario_rows(
    scenario: Scenario,
    path: &Path,
    samples: usize,
    seed: u64,
    shards: &[(PathBuf, Manifest)],
    prefix: &str,
) -> Result<MergedRows, Error> {
    let p = prepare_scenario(scenario, path, Some(samples), Some(seed))?;
    read_prepared_rows(p, path, shards, prefix, &Counter::silent())
}

fn read_prepared_rows(
    p: Prepared,
    path: &Path,
    shards: &[(PathBuf, Manifest)],
    prefix: &str,
    read: &Counter<'_>,
) -> Result<MergedRows, Error> {
    let Some((dir0, m0)) = shards.first() else {
        return Err(Error::Shard {
            path: PathBuf::from("merge"),
            line: None,
            problem: "no shard directory given".into(),
        });
    };
    let all = p.study.grid().points();
    if all.len() != m0.items.total {
        return Err(Error::Shard {
            path: dir0.join(MANIFEST),
            line: None,
            problem: format!(
                "the shards hold {} grid points, the scenario has {}",
                m0.items.total,
                all.len()
            ),
        });
    }
    // The observers' resolved noise (the same in every shard): a run of no points.
    let none = |s: &crashrig_mc::GridStudy| -> Result<GridResult, Error> {
        s.with_points(0..0)
            .and_then(|s| s.run(&crashrig_mc::RunOptions::samples(p.samples, p.seed), None))
            .map_err(|e| Error::Scenario {
                path: path.to_path_buf(),
                source: e,
            })
    };
    let mut result = none(&p.study)?;
    let mut independent = result
        .correlated
        .then(|| none(&p.study.independent()))
        .transpose()?;
    let (mut elapsed_s, mut threads) = (0.0, 0);
    let points_file = format!("{prefix}{POINTS_FILE}");
    let independent_file = format!("{prefix}{INDEPENDENT_FILE}");
    for (dir, m) in shards {
        read.check()?;
        let range = m.range();
        result
            .points
            .extend(read_rows(&dir.join(&points_file), range.clone(), &all)?);
        if let Some(ind) = &mut independent {
            ind.points
                .extend(read_rows(&dir.join(&independent_file), range, &all)?);
        }
        elapsed_s += m.elapsed_s;
        threads = threads.max(m.threads);
        read.add(1);
    }
    let computed = Computed {
        result,
        independent,
        elapsed_s,
        threads,
    };
    Ok(MergedRows {
        p,
        computed,
        path: path.to_path_buf(),
    })
}

/// Merges the shards of one grid run (`shards` as [`crashrig_outdir::shard::read_set`]
/// returns them: checked, in shard order) into `out`: exactly what `crashrig grid` writes.
/// The scenario is read again from the manifests' `input` and must have the fingerprint the
/// shards recorded. Nothing is written unless every shard is read.
///
/// `monitor` (optional) gets `(shards read, shards)` and is asked before each shard and before
/// writing whether to stop ([`Error::Cancelled`], nothing written); the output does not depend
/// on it.
///
/// # Errors
/// [`Error::Grid`] when the shards are not grid shards or the scenario changed,
/// [`Error::Shard`] for a shard file that cannot be read (file and line), and the errors of
/// [`crate::run_grid`].
pub fn merge_grid(
    shards: &[(PathBuf, Manifest)],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<GridRun, Error> {
    let Some((dir0, m0)) = shards.first() else {
        return Err(Error::Shard {
            path: PathBuf::from("merge"),
            line: None,
            problem: "no shard directory given".into(),
        });
    };
    if m0.command != COMMAND {
        return Err(Error::Shard {
            path: dir0.join(MANIFEST),
            line: None,
            problem: format!("a `{}` shard, not a grid shard", m0.command),
        });
    }
    let path = &m0.input;
    let p = prepare(path, Some(m0.samples as usize), Some(m0.seed))?;
    if input_fingerprint(path, &p.scenario)? != m0.fingerprint {
        return Err(Error::Grid {
            path: path.clone(),
            problem: format!(
                "the scenario (or a file it names) changed since the shards ran: its fingerprint differs from {}",
                dir0.join(MANIFEST).display()
            ),
        });
    }
    // Checked before the output directory is touched.
    let read = Counter::monitored(monitor, shards.len());
    let rows = read_prepared_rows(p, path, shards, "", &read)?;
    read.check()?;
    rows.write(out, plots)
}

/// The columns of `points.csv`.
const COLUMNS: [&str; 32] = [
    "point",
    "x_mm",
    "y_mm",
    "z_mm",
    "count",
    "mean_x_mm",
    "mean_y_mm",
    "mean_z_mm",
    "cov_xx_mm2",
    "cov_xy_mm2",
    "cov_xz_mm2",
    "cov_yx_mm2",
    "cov_yy_mm2",
    "cov_yz_mm2",
    "cov_zx_mm2",
    "cov_zy_mm2",
    "cov_zz_mm2",
    "sigma_x_mm",
    "sigma_y_mm",
    "sigma_z_mm",
    "sigma_max_mm",
    "lin_cov_xx_mm2",
    "lin_cov_xy_mm2",
    "lin_cov_xz_mm2",
    "lin_cov_yx_mm2",
    "lin_cov_yy_mm2",
    "lin_cov_yz_mm2",
    "lin_cov_zx_mm2",
    "lin_cov_zy_mm2",
    "lin_cov_zz_mm2",
    "observers_seen",
    "converged",
];

/// `points.csv`: one row per point (its global index first), every field of [`PointStats`].
fn rows_csv(first: usize, points: &[PointStats]) -> Result<Vec<u8>, Error> {
    crate::run::csv_bytes(|w| {
        w.write_record(COLUMNS)?;
        for (k, p) in points.iter().enumerate() {
            let mut rec = vec![(first + k).to_string()];
            let v3 = |v: &Vector3<f64>| [v.x, v.y, v.z].map(|x| x.to_string());
            // Row-major, all nine (the accumulator's covariance need not be symmetric in its
            // last bit).
            let m3 = |m: &Matrix3<f64>| {
                (0..9)
                    .map(|i| m[(i / 3, i % 3)].to_string())
                    .collect::<Vec<_>>()
            };
            rec.extend(v3(&p.point));
            rec.push(p.count.to_string());
            rec.extend(v3(&p.mean_mm));
            rec.extend(m3(&p.covariance));
            rec.extend(v3(&p.sigma_mm));
            rec.push(p.sigma_max_mm.to_string());
            rec.extend(m3(&p.linear_covariance));
            rec.push(p.observers_seen.to_string());
            rec.push(p.converged.map_or_else(String::new, |c| c.to_string()));
            w.write_record(&rec)?;
        }
        Ok(())
    })
}

/// Bytes of one `points.csv` row at most (32 numbers of at most 24 characters and commas).
const MAX_ROW_BYTES: u64 = 1024;

/// Reads `points.csv` of the shard holding `range`; every row must be the next point of the
/// range with the grid point's own coordinates.
fn read_rows(
    path: &Path,
    range: Range<usize>,
    all: &[Vector3<f64>],
) -> Result<Vec<PointStats>, Error> {
    let err = |line: Option<usize>, problem: String| Error::Shard {
        path: path.to_path_buf(),
        line,
        problem,
    };
    let limit = (range.len() as u64 + 1) * MAX_ROW_BYTES;
    let bytes = crashrig_input::file::read_limited(path, limit).map_err(|source| Error::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(bytes.as_slice());
    let header = r
        .headers()
        .map_err(|e| err(Some(1), format!("unreadable header: {e}")))?;
    if header.iter().ne(COLUMNS) {
        return Err(err(
            Some(1),
            "not the header of a grid shard's points.csv".into(),
        ));
    }
    let mut out = Vec::with_capacity(range.len());
    for (k, rec) in r.records().enumerate() {
        let line = k + 2;
        let rec = rec.map_err(|e| err(Some(line), e.to_string()))?;
        let expect = range.start + k;
        if expect >= range.end {
            return Err(err(
                Some(line),
                format!("more rows than the shard's {} points", range.len()),
            ));
        }
        let p = parse_row(&rec, expect, &all[expect]).map_err(|e| err(Some(line), e))?;
        out.push(p);
    }
    if out.len() != range.len() {
        return Err(err(
            None,
            format!(
                "{} rows, the shard holds {} points (an incomplete shard?)",
                out.len(),
                range.len()
            ),
        ));
    }
    Ok(out)
}

fn parse_row(
    rec: &csv::StringRecord,
    index: usize,
    at: &Vector3<f64>,
) -> Result<PointStats, String> {
    if rec.len() != COLUMNS.len() {
        return Err(format!("{} fields, expected {}", rec.len(), COLUMNS.len()));
    }
    let f = |i: usize| -> Result<f64, String> {
        rec[i]
            .parse::<f64>()
            .map_err(|_| format!("`{}`: `{}` is not a number", COLUMNS[i], &rec[i]))
    };
    let u = |i: usize| -> Result<u64, String> {
        rec[i]
            .parse::<u64>()
            .map_err(|_| format!("`{}`: `{}` is not a count", COLUMNS[i], &rec[i]))
    };
    let v3 = |i: usize| -> Result<Vector3<f64>, String> {
        Ok(Vector3::new(f(i)?, f(i + 1)?, f(i + 2)?))
    };
    let m3 = |i: usize| -> Result<Matrix3<f64>, String> {
        let mut m = Matrix3::zeros();
        for k in 0..9 {
            m[(k / 3, k % 3)] = f(i + k)?;
        }
        Ok(m)
    };
    if u(0)? != index as u64 {
        return Err(format!(
            "point {} where point {index} was expected",
            &rec[0]
        ));
    }
    let point = v3(1)?;
    if point
        .iter()
        .zip(at.iter())
        .any(|(a, b)| a.to_bits() != b.to_bits())
    {
        return Err(format!(
            "point {index} is at ({}, {}, {}) mm, the scenario's grid point is at ({}, {}, {}) mm",
            point.x, point.y, point.z, at.x, at.y, at.z
        ));
    }
    let observers_seen =
        usize::try_from(u(30)?).map_err(|_| "observers_seen too large".to_string())?;
    let converged = match &rec[31] {
        "" => None,
        "true" => Some(true),
        "false" => Some(false),
        other => {
            return Err(format!(
                "`converged`: `{other}` is not true, false or empty"
            ));
        }
    };
    Ok(PointStats {
        point,
        count: u(4)?,
        mean_mm: v3(5)?,
        covariance: m3(8)?,
        sigma_mm: v3(17)?,
        sigma_max_mm: f(20)?,
        linear_covariance: m3(21)?,
        observers_seen,
        converged,
    })
}
