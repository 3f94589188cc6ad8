//! One function per command, each calling the command's library entry: the same inputs and
//! seed give the same dict as the command's `--json` (`grid`: its `grid.csv` columns).

use crate::args::{self, Source, TextFile};
use crate::convert::{document, to_python};
use crate::watch::{self, Watch};
use crate::{py_error, to_py_err};
use crashrig_input::options::{ScaleOptions, Spelling, check_mm_per_unit};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// Emits each library warning as a Python `UserWarning`.
fn warn_all(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in warnings {
        let text =
            std::ffi::CString::new(w.replace('\0', " ")).map_err(|e| py_error(e.to_string()))?;
        PyErr::warn(py, &category, &text, 1)?;
    }
    Ok(())
}

/// How a scenario given as text is checked: as `propagate` and `grid` read it, or as `place`
/// reads its base layout (fewer than two observers allowed).
type ScenarioCheck =
    fn(&str, &std::path::Path) -> Result<crashrig_mc::Scenario, crashrig_mc::Error>;

/// A scenario as a file the libraries can read: the path, or the TOML text checked (so its
/// errors name `<scenario>` and the line) and written to a temporary file.
fn scenario_file(source: Source, check: ScenarioCheck) -> PyResult<(PathBuf, Option<TextFile>)> {
    match source {
        Source::Path(p) => Ok((p, None)),
        Source::Text(text) => {
            check(&text, std::path::Path::new("<scenario>")).map_err(to_py_err)?;
            let file = TextFile::new(&text, "scenario.toml")?;
            Ok((file.path.clone(), Some(file)))
        }
    }
}

/// Rig calibration (`crashrig calibrate --json`): base and ω φ κ of B relative to A from an
/// epoch sequence.
///
/// Example:
///
/// ```python
/// r = crashrig.calibrate("lab/model", camera_a="cam_out/", camera_b="cam_in/", mm_per_unit=1000.0)
/// print(r["base_mm"], r["sem_covariance_tangent"])
/// ```
#[pyfunction]
#[pyo3(signature = (model, camera_a, camera_b, *, scale_points=None, scale_length_mm=None,
    mm_per_unit=None, max_lag=10, refine=true, accept_rig_constrained=false, plots=None,
    progress=None))]
#[allow(clippy::too_many_arguments)]
fn calibrate<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    camera_a: &Bound<'py, PyAny>,
    camera_b: &Bound<'py, PyAny>,
    scale_points: Option<Vec<u64>>,
    scale_length_mm: Option<f64>,
    mm_per_unit: Option<f64>,
    max_lag: usize,
    refine: bool,
    accept_rig_constrained: bool,
    plots: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_calibrate::{CalibrationConfig, Scale, calibrate};
    let options = ScaleOptions {
        scale_points,
        scale_length_mm,
        mm_per_unit,
    };
    let scale = Scale::from_options(&options, Spelling::Keyword).map_err(to_py_err)?;
    let config = CalibrationConfig {
        model: args::path(model, "model")?,
        camera_a: args::camera(camera_a, "camera_a")?,
        camera_b: args::camera(camera_b, "camera_b")?,
        scale,
        max_lag,
        refine,
        accept_rig_constrained,
    };
    let plots = args::opt_path(plots, "plots")?;
    let r = watch::run(py, progress, |w: &Watch| {
        calibrate(&config, Some(&w.monitor("refinement: weighting rounds")))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.warnings)?;
    if let Some(dir) = &plots {
        r.write_plots(dir).map_err(to_py_err)?;
    }
    to_python(py, &r.to_json())
}

/// Pose uncertainty of image B relative to A by resampling correspondences
/// (`crashrig bootstrap --json`).
///
/// Example:
///
/// ```python
/// t = crashrig.bootstrap("fixtures/paper/twoview/database.db", model="fixtures/paper/twoview/model",
///                        image_a="cam_in/000001.png", image_b="cam_door/000001.png",
///                        iterations=200, mm_per_unit=1000.0, seed=1)
/// print(t["covariance_tangent"])
/// ```
///
/// `plots` (a folder) receives the histograms `bootstrap_{x,y,z,omega,phi,kappa}.{png,svg}`
/// and `replicates` (a CSV file) every replicate, as the command's `--plots` and
/// `--replicates`.
#[pyfunction]
#[pyo3(signature = (database, model, image_a, image_b, *, method="absolute", iterations=500,
    mm_per_unit=1.0, max_error_px=4.0, base_mm=None, resample="inliers", seed=None, plots=None,
    replicates=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn bootstrap<'py>(
    py: Python<'py>,
    database: &Bound<'py, PyAny>,
    model: &Bound<'py, PyAny>,
    image_a: String,
    image_b: String,
    method: &str,
    iterations: usize,
    mm_per_unit: f64,
    max_error_px: f64,
    base_mm: Option<f64>,
    resample: &str,
    seed: Option<u64>,
    plots: Option<&Bound<'py, PyAny>>,
    replicates: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_tie::{self as tie, Method, Resample, TieConfig};
    let plots = args::opt_path(plots, "plots")?;
    let replicates_csv = args::opt_path(replicates, "replicates")?;
    let method = Method::from_name(method).ok_or_else(|| {
        py_error(format!(
            "method: {method:?} is not one of \"absolute\", \"relative\""
        ))
    })?;
    let resample = Resample::from_name(resample).ok_or_else(|| {
        py_error(format!(
            "resample: {resample:?} is not one of \"inliers\", \"matches\""
        ))
    })?;
    let max = crashrig_bootstrap::MAX_ITERATIONS;
    if !(2..=max).contains(&iterations) {
        return Err(py_error(format!("iterations: must be from 2 to {max}")));
    }
    check_mm_per_unit(mm_per_unit, "mm_per_unit").map_err(to_py_err)?;
    let config = TieConfig {
        database: args::path(database, "database")?,
        model: args::path(model, "model")?,
        image_a: args::image_name(image_a, "image_a")?,
        image_b: args::image_name(image_b, "image_b")?,
        method,
        iterations,
        // The command's default seed.
        seed: seed.unwrap_or(1),
        mm_per_unit,
        max_error_px,
        base_mm,
        resample,
    };
    let r = watch::run(py, progress, |w: &Watch| {
        tie::bootstrap(&config, Some(&w.monitor("replicates + jackknife")))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.warnings())?;
    r.write_files(plots.as_deref(), replicates_csv.as_deref())
        .map_err(to_py_err)?;
    to_python(py, &r.to_json())
}

/// Monte Carlo and first-order propagation through a camera chain
/// (`crashrig propagate --json`); `scenario` is a path or the TOML text.
///
/// Example:
///
/// ```python
/// p = crashrig.propagate("fixtures/scenarios/paper_chain.toml", samples=2000, seed=1)
/// for c in p["cameras"]:
///     print(c["name"], c["position_sigma_mm"])
/// ```
#[pyfunction]
#[pyo3(signature = (scenario, *, samples=None, seed=None, progress=None))]
fn propagate<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    samples: Option<usize>,
    seed: Option<u64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (path, _text) = scenario_file(
        Source::extract(scenario, "scenario")?,
        crashrig_mc::Scenario::from_toml_str,
    )?;
    let config = crashrig_grid::PropagateConfig {
        scenario: path,
        samples,
        seed,
    };
    let r = watch::run(py, progress, |w: &Watch| {
        crashrig_grid::run_propagate(&config, Some(w))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.warnings)?;
    document(py, &r.document)
}

/// Forward-intersection precision over a grid (`crashrig grid`): a dict of NumPy arrays, one
/// per `grid.csv` column, with the command's values (empty cells are NaN; `converged` holds
/// `True`/`False`/`None`). With `out`, the command's output directory is written as well.
///
/// Example:
///
/// ```python
/// import pandas
/// g = pandas.DataFrame(crashrig.grid("fixtures/scenarios/three_cameras_z0.toml", samples=500, seed=1))
/// print(g["sigma_max_mm"].median())
/// ```
#[pyfunction]
#[pyo3(signature = (scenario, *, samples=None, seed=None, out=None, progress=None))]
fn grid<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    samples: Option<usize>,
    seed: Option<u64>,
    out: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    use crashrig_grid::ColumnValues;
    let (path, _text) = scenario_file(
        Source::extract(scenario, "scenario")?,
        crashrig_mc::Scenario::from_toml_str,
    )?;
    let out = args::opt_path(out, "out")?;
    // Without `out` the files go to a temporary folder (no heat maps) that is removed again.
    let scratch = match out {
        Some(_) => None,
        None => Some(
            tempfile::tempdir()
                .map_err(|e| py_error(format!("cannot create a temporary folder: {e}")))?,
        ),
    };
    let config = crashrig_grid::GridConfig {
        scenario: path,
        out: out
            .clone()
            .or_else(|| scratch.as_ref().map(|d| d.path().join("grid")))
            .unwrap_or_default(),
        samples,
        seed,
        plots: out.is_some(),
    };
    let r = watch::run(py, progress, |w: &Watch| {
        crashrig_grid::run_grid(&config, Some(w))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.warnings)?;
    let dict = PyDict::new(py);
    for c in r.columns() {
        match c.values {
            ColumnValues::Float { values, .. } => {
                dict.set_item(c.name, PyArray1::from_vec(py, values))?
            }
            ColumnValues::Count(v) => dict.set_item(c.name, PyArray1::from_vec(py, v))?,
            ColumnValues::Flag(v) => dict.set_item(c.name, PyArray1::from_vec(py, v))?,
            ColumnValues::MaybeFlag(v) => {
                let numpy = py.import("numpy")?;
                let kwargs = PyDict::new(py);
                kwargs.set_item("dtype", "object")?;
                let array = numpy.call_method("array", (PyList::new(py, v)?,), Some(&kwargs))?;
                dict.set_item(c.name, array)?
            }
        }
    }
    Ok(dict)
}

/// Marker trajectories with σ from a crash-test sequence (`crashrig measure --json`): the
/// summary document. `out` (optional here) receives the command's files. `scale_bars` (a
/// scale-bar CSV) adds the length check (`"length_check"`, and `length_check.csv` in `out`),
/// `mpe_mm` each bar's `"within_mpe"`. `progress(stage, done, total)` sees the replicates
/// drawn; Ctrl-C or an exception it raises stops the call between chunks of replicates, with
/// nothing written.
///
/// Example:
///
/// ```python
/// s = crashrig.measure("seq/model", camera_a="cam_out/", camera_b="cam_in/", link="link.json",
///                      observations="markers.csv", out="measure_out", mm_per_unit=1000.0,
///                      sigma_a_position_mm=[0.5, 0.5, 0.5], sigma_a_angles_deg=[0.01, 0.01, 0.01],
///                      samples=2000, seed=1)
/// print(s["numbers"]["fraction_below_threshold"])
/// ```
#[pyfunction]
#[pyo3(signature = (model, camera_a, camera_b, link, observations, *, out=None, camera_c=None,
    tie=None, mm_per_unit=None, sigma_a_position_mm=None, sigma_a_angles_deg=None,
    a_covariance=None, pixel_sigma_px=None, samples=2000, seed=None, reference_epoch=None,
    frame_rate_hz=None, threshold_mm=5.0, max_reprojection_px=None, plots=true, cfc=None,
    cfc_standard=None, sync_sigma_ms=0.0, scale_bars=None, mpe_mm=None, frame_times=None,
    progress=None))]
#[allow(clippy::too_many_arguments)]
fn measure<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    camera_a: &Bound<'py, PyAny>,
    camera_b: &Bound<'py, PyAny>,
    link: &Bound<'py, PyAny>,
    observations: &Bound<'py, PyAny>,
    out: Option<&Bound<'py, PyAny>>,
    camera_c: Option<&Bound<'py, PyAny>>,
    tie: Option<&Bound<'py, PyAny>>,
    mm_per_unit: Option<f64>,
    sigma_a_position_mm: Option<[f64; 3]>,
    sigma_a_angles_deg: Option<[f64; 3]>,
    a_covariance: Option<&Bound<'py, PyAny>>,
    pixel_sigma_px: Option<&Bound<'py, PyAny>>,
    samples: usize,
    seed: Option<u64>,
    reference_epoch: Option<String>,
    frame_rate_hz: Option<f64>,
    threshold_mm: f64,
    max_reprojection_px: Option<f64>,
    plots: bool,
    cfc: Option<u32>,
    cfc_standard: Option<String>,
    sync_sigma_ms: f64,
    scale_bars: Option<&Bound<'py, PyAny>>,
    mpe_mm: Option<f64>,
    frame_times: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_measure::pixel_check::PixelSigmaFrom;
    use crashrig_measure::{MeasureOptions, OutputDir};
    // A number (px) or "estimate" (the pixel σ check's estimate); None: the default.
    let (pixel_sigma_px, pixel_sigma_from) = match pixel_sigma_px.filter(|v| !v.is_none()) {
        None => (
            MeasureOptions::DEFAULT_PIXEL_SIGMA_PX,
            PixelSigmaFrom::Stated,
        ),
        Some(v) => match v.extract::<String>() {
            Ok(word) if word == "estimate" => (
                MeasureOptions::DEFAULT_PIXEL_SIGMA_PX,
                PixelSigmaFrom::Estimate,
            ),
            Ok(word) => {
                return Err(py_error(format!(
                    "pixel_sigma_px: `{word}` is neither a number (px) nor \"estimate\""
                )));
            }
            Err(_) => (v.extract::<f64>()?, PixelSigmaFrom::Stated),
        },
    };
    let out = args::opt_path(out, "out")?;
    let camera_c = camera_c
        .filter(|c| !c.is_none())
        .map(|c| args::camera(c, "camera_c"))
        .transpose()?;
    let options = MeasureOptions {
        camera_c,
        tie: args::opt_path(tie, "tie")?,
        out: out.map(|dir| OutputDir { dir, plots }),
        mm_per_unit,
        sigma_a_position_mm,
        sigma_a_angles_deg,
        a_covariance: args::opt_path(a_covariance, "a_covariance")?,
        pixel_sigma_px,
        pixel_sigma_from,
        samples,
        seed,
        reference_epoch,
        frame_rate_hz,
        threshold_mm,
        max_reprojection_px,
        cfc,
        cfc_standard,
        sync_sigma_ms,
        scale_bars: args::opt_path(scale_bars, "scale_bars")?,
        mpe_mm,
        frame_times: args::opt_path(frame_times, "frame_times")?,
        ..MeasureOptions::new(
            args::path(model, "model")?,
            args::camera(camera_a, "camera_a")?,
            args::camera(camera_b, "camera_b")?,
            args::path(link, "link")?,
            args::path(observations, "observations")?,
        )
    };
    let config = options.config(Spelling::Keyword).map_err(to_py_err)?;
    let r = watch::run(py, progress, |w: &Watch| {
        crashrig_measure::run(&config, Some(&w.monitor("replicates")))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &options.warnings(&r, Spelling::Keyword))?;
    document(py, &r.summary)
}

/// Camera A's per-epoch pose covariance from the bundle (`crashrig covariance --json`);
/// with `out` the document is also written there (what `measure(a_covariance=)` reads).
/// `progress(stage, done, total)` sees its 4 phases; Ctrl-C or an exception it raises stops
/// the call between phases, with nothing written.
///
/// Example:
///
/// ```python
/// c = crashrig.covariance("lab/model", camera="cam_out/", control_points="control.csv",
///                         mm_per_unit=1000.0, out="a_cov.json")
/// print(c["sigma0_px"], len(c["epochs"]))
/// ```
#[pyfunction]
#[pyo3(signature = (model, camera, control_points, *, out=None, mm_per_unit=None,
    scale_points=None, scale_length_mm=None, pixel_sigma_px=None, intrinsics="all",
    progress=None))]
#[allow(clippy::too_many_arguments)]
fn covariance<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    camera: &Bound<'py, PyAny>,
    control_points: &Bound<'py, PyAny>,
    out: Option<&Bound<'py, PyAny>>,
    mm_per_unit: Option<f64>,
    scale_points: Option<Vec<u64>>,
    scale_length_mm: Option<f64>,
    pixel_sigma_px: Option<f64>,
    intrinsics: &str,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_covariance::{CovarianceConfig, Intrinsics, Scale};
    let options = ScaleOptions {
        scale_points,
        scale_length_mm,
        mm_per_unit,
    };
    let scale = Scale::from_options(&options, Spelling::Keyword).map_err(to_py_err)?;
    let intrinsics = Intrinsics::parse(intrinsics).ok_or_else(|| {
        py_error(format!(
            "intrinsics: {intrinsics:?} is not one of \"all\", \"colmap\", \"fixed\""
        ))
    })?;
    let config = CovarianceConfig {
        model: args::path(model, "model")?,
        camera_a: args::camera(camera, "camera")?,
        control_points: args::path(control_points, "control_points")?,
        scale,
        pixel_sigma_px,
        intrinsics,
    };
    let out = args::opt_path(out, "out")?;
    let r = watch::run(py, progress, |w: &Watch| {
        crashrig_covariance::run(&config, Some(&w.monitor("phases")))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.warnings)?;
    if let Some(out) = &out {
        crashrig_outdir::write_file(out, r.json_text().as_bytes()).map_err(to_py_err)?;
    }
    let doc = r.to_json();
    to_python(py, &doc)
}

/// The whole study on a COLMAP project (`crashrig study --json`): runs every step, writes
/// `out` (results.json, report.html, …) and returns `results.json`. `study` is a path or the
/// TOML text (relative paths in text resolve against the current folder).
///
/// Example:
///
/// ```python
/// r = crashrig.study("fixtures/study/study.toml", out="study_out", seed=1)
/// for layout in r["layouts"]:
///     print(layout["name"], layout["summary"]["fraction_below_threshold"])
/// ```
#[pyfunction]
#[pyo3(signature = (study, out, *, seed=None, samples=None, no_sensitivity=false, progress=None))]
fn study<'py>(
    py: Python<'py>,
    study: &Bound<'py, PyAny>,
    out: &Bound<'py, PyAny>,
    seed: Option<u64>,
    samples: Option<usize>,
    no_sensitivity: bool,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_study::Study;
    use crashrig_study::{StudyRunConfig, run_to_dir};
    let out = args::path(out, "out")?;
    if let Some(n) = samples
        && n < 2
    {
        return Err(py_error(format!("samples: must be at least 2, got {n}")));
    }
    let (study_path, parsed) = match Source::extract(study, "study")? {
        Source::Path(p) => {
            let s = Study::from_path(&p).map_err(to_py_err)?;
            (p, s)
        }
        Source::Text(text) => {
            let cwd = std::env::current_dir()
                .map_err(|e| py_error(format!("cannot read the current folder: {e}")))?;
            let p = cwd.join("<study>");
            let s = Study::from_toml_str(&text, &p).map_err(to_py_err)?;
            (p, s)
        }
    };
    let config = StudyRunConfig {
        command: format!(
            "crashrig.study({:?}, out={:?}{})",
            study_path.display().to_string(),
            out.display().to_string(),
            seed.map(|s| format!(", seed={s}")).unwrap_or_default()
        ),
        study_path,
        out,
        seed,
        samples,
        no_sensitivity,
    };
    let run = watch::run(py, progress, |w: &Watch| {
        let report = |stage: &str, done: u64, total: u64| w.note_u64(stage, done, total);
        run_to_dir(&parsed, &config, Some(&report), None)
    })?
    .map_err(to_py_err)?;
    warn_all(py, &run.warnings)?;
    to_python(py, &run.json)
}

/// Where to mount the cameras (`crashrig place --json`): chooses `choose` observers from the
/// candidates file, writes `out` (`placement.json`, the chosen layout's grid output in
/// `out/grid/`) and returns `placement.json`. `scenario` is a path or the TOML text.
///
/// Example:
///
/// ```python
/// p = crashrig.place("examples/place/scenario.toml", candidates="examples/place/candidates.toml",
///                    choose=2, out="place_out", samples=300, seed=3)
/// print(p["chosen"], p["share_below_threshold"])
/// ```
#[pyfunction]
#[pyo3(signature = (scenario, candidates, choose, out, *, samples=None, seed=None, plots=true,
    progress=None))]
#[allow(clippy::too_many_arguments)]
fn place<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    candidates: &Bound<'py, PyAny>,
    choose: usize,
    out: &Bound<'py, PyAny>,
    samples: Option<usize>,
    seed: Option<u64>,
    plots: bool,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (path, _text) = scenario_file(
        Source::extract(scenario, "scenario")?,
        crashrig_mc::Scenario::from_toml_str_for_placement,
    )?;
    let config = crashrig_place::PlaceConfig {
        scenario: path,
        candidates: args::path(candidates, "candidates")?,
        choose,
        out: args::path(out, "out")?,
        samples,
        seed,
        plots,
    };
    let r = watch::run(py, progress, |w: &Watch| {
        crashrig_place::run(&config, Some(w))
    })?
    .map_err(to_py_err)?;
    warn_all(py, &r.grid.warnings)?;
    document(py, &r.placement)
}

/// Merges the shard directories of a `--shard i/N` run into `out` (`crashrig merge --json`):
/// exactly what the unsharded run writes; returns its `--json` document (`grid` shards:
/// `summary.json`; `place` shards: `placement.json`). `progress(stage, done, total)` sees the
/// shards read; Ctrl-C or an exception it raises stops the call before the next shard or
/// before writing, with nothing written.
///
/// Example:
///
/// ```python
/// import subprocess
/// for i in (1, 2):
///     subprocess.run(["crashrig", "grid", "scenario.toml", "--shard", f"{i}/2",
///                     "--out", f"shards/{i}"], check=True)
/// s = crashrig.merge(["shards/1", "shards/2"], out="grid_out")
/// print(s["points"], s["median_sigma_max_mm"])
/// ```
#[pyfunction]
#[pyo3(signature = (shards, out, *, plots=true, progress=None))]
fn merge<'py>(
    py: Python<'py>,
    shards: &Bound<'py, PyAny>,
    out: &Bound<'py, PyAny>,
    plots: bool,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use crashrig_merge::{Merged, merge_shards};
    if shards.is_instance_of::<pyo3::types::PyString>() {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "shards: expected a list of shard directories, got one str",
        ));
    }
    let dirs = shards
        .try_iter()?
        .map(|d| args::path(&d?, "shards"))
        .collect::<PyResult<Vec<_>>>()?;
    let out = args::path(out, "out")?;
    let r = watch::run(py, progress, |w: &Watch| {
        merge_shards(&dirs, &out, plots, Some(&w.monitor("shards read")))
    })?
    .map_err(to_py_err)?;
    match r {
        Merged::Place(r) => {
            warn_all(py, &r.grid.warnings)?;
            document(py, &r.placement)
        }
        Merged::Measure(r) => {
            warn_all(py, &r.warnings)?;
            document(py, &r.summary)
        }
        Merged::Grid(r) => {
            warn_all(py, &r.warnings)?;
            document(py, &r.summary)
        }
    }
}

/// Adds the command functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(bootstrap, m)?)?;
    m.add_function(wrap_pyfunction!(propagate, m)?)?;
    m.add_function(wrap_pyfunction!(grid, m)?)?;
    m.add_function(wrap_pyfunction!(measure, m)?)?;
    m.add_function(wrap_pyfunction!(covariance, m)?)?;
    m.add_function(wrap_pyfunction!(study, m)?)?;
    m.add_function(wrap_pyfunction!(place, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    Ok(())
}
