//! Input files: marker observations (CSV), link results (`calibrate`/`bootstrap` JSON) and the
//! outward camera's pose covariance (JSON).

use crate::Error;
use crate::csv_table::{csv_error, for_each_row, not_utf8};
use crashrig_geometry::uncertain::COVARIANCE_RELATIVE_TOLERANCE;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose};
use crashrig_input::file as input_file;
use nalgebra::Vector2;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// Which inward camera took an observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Inward {
    /// Camera B, linked to the outward camera A by the calibrated link `A_from_B`.
    B,
    /// Camera C, tied to B by `B_from_C`.
    C,
}

impl Inward {
    /// `'B'` or `'C'`.
    pub fn letter(self) -> char {
        match self {
            Inward::B => 'B',
            Inward::C => 'C',
        }
    }
}

/// One marker observation: a line of the observations CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The epoch as written (an image name after the camera-A prefix, with or without its
    /// extension).
    pub epoch: String,
    /// The camera that saw the marker.
    pub camera: Inward,
    /// The marker's name.
    pub marker: String,
    /// Pixel position, COLMAP convention (centre of the upper-left pixel at (0.5, 0.5)).
    pub pixel: Vector2<f64>,
    /// 1-based line in the file (for messages).
    pub line: u64,
}

/// How the `camera` column names the inward cameras: the letters `B`/`C` always, and the
/// COLMAP camera ids of B and C when they are known.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CameraNames {
    /// COLMAP camera id of B (accepted in the `camera` column besides `B`).
    pub b_id: Option<u32>,
    /// COLMAP camera id of C; `None` with `has_c == true` accepts only the letter.
    pub c_id: Option<u32>,
    /// Whether a camera C is configured at all (else `C` is an unknown camera).
    pub has_c: bool,
}

impl CameraNames {
    fn parse(&self, text: &str) -> Option<Inward> {
        match text {
            "B" | "b" => return Some(Inward::B),
            "C" | "c" if self.has_c => return Some(Inward::C),
            _ => {}
        }
        let id: u32 = text.parse().ok()?;
        if self.b_id == Some(id) {
            Some(Inward::B)
        } else if self.has_c && self.c_id == Some(id) {
            Some(Inward::C)
        } else {
            None
        }
    }

    fn expected(&self) -> String {
        let mut v = vec!["B".to_string()];
        if let Some(id) = self.b_id {
            v.push(id.to_string());
        }
        if self.has_c {
            v.push("C".into());
            if let Some(id) = self.c_id {
                v.push(id.to_string());
            }
        }
        v.join(", ")
    }
}

/// The columns of the observations CSV, in any order.
pub const OBSERVATION_COLUMNS: [&str; 5] = ["epoch", "camera", "marker", "u_px", "v_px"];

/// Reads the observations CSV (`epoch,camera,marker,u_px,v_px`; see `docs/MEASURE.md`).
///
/// The header must hold exactly the five columns (any order); the `camera` column holds `B`,
/// `C` or the COLMAP camera id of B or C ([`CameraNames`]); pixels must be finite; an
/// `(epoch, camera, marker)` may appear once.
///
/// # Errors
/// [`Error::Io`], and [`Error::Csv`] naming the line for every problem above (an empty file is
/// line 1).
pub fn read_observations(path: &Path, names: &CameraNames) -> Result<Vec<Observation>, Error> {
    let bad = |line: u64, problem: String| csv_error(path, line, problem);
    let mut out = Vec::new();
    let mut seen: HashMap<(String, Inward, String), u64> = HashMap::new();
    for_each_row(path, &OBSERVATION_COLUMNS, |line, fields| {
        let [epoch, camera, marker, _, _] = fields;
        if epoch.is_empty() {
            return Err(bad(line, "empty epoch".into()));
        }
        let camera = names.parse(camera).ok_or_else(|| {
            bad(
                line,
                format!(
                    "unknown camera `{camera}` (expected one of {})",
                    names.expected()
                ),
            )
        })?;
        if marker.is_empty() {
            return Err(bad(line, "empty marker name".into()));
        }
        let mut px = [0.0; 2];
        for (j, k) in [3, 4].into_iter().enumerate() {
            let text = fields[k];
            let v: f64 = text.parse().map_err(|_| {
                bad(
                    line,
                    format!("{} `{text}` is not a number", OBSERVATION_COLUMNS[k]),
                )
            })?;
            if !v.is_finite() {
                return Err(bad(
                    line,
                    format!(
                        "{} is {text}: pixels must be finite",
                        OBSERVATION_COLUMNS[k]
                    ),
                ));
            }
            px[j] = v;
        }
        let key = (epoch.to_string(), camera, marker.to_string());
        if let Some(first) = seen.insert(key, line) {
            return Err(bad(
                line,
                format!(
                    "marker `{marker}` seen by camera {} in epoch `{epoch}` again (first on line {first})",
                    camera.letter()
                ),
            ));
        }
        out.push(Observation {
            epoch: epoch.to_string(),
            camera,
            marker: marker.to_string(),
            pixel: Vector2::new(px[0], px[1]),
            line,
        });
        Ok(())
    })?;
    if out.is_empty() {
        return Err(bad(1, "no observations".into()));
    }
    Ok(out)
}

/// Reads the text file `path` through [`input_file::read_text_limited`]: a FIFO, device or
/// directory or a file larger than `limit` bytes is an [`Error::Io`] naming the file, before
/// anything is allocated for it; text that is not UTF-8 an [`Error::NotUtf8`] naming its line
/// and column.
pub(crate) fn read_text(path: &Path, limit: u64) -> Result<String, Error> {
    input_file::read_text_limited(path, limit).map_err(|source| {
        match input_file::NotUtf8::in_io(&source) {
            Some(at) => not_utf8(path, at),
            None => Error::Io {
                path: path.to_path_buf(),
                source,
            },
        }
    })
}

/// Reads a JSON input (a result file of another command, a measure output's `summary.json`)
/// with the JSON size limit ([`input_file::MAX_JSON_BYTES`]).
pub(crate) fn read_json(path: &Path) -> Result<serde_json::Value, Error> {
    let bytes =
        input_file::read_limited(path, input_file::MAX_JSON_BYTES).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    serde_json::from_slice(&bytes).map_err(|e| Error::Json {
        path: path.to_path_buf(),
        key: "$".into(),
        problem: format!("not valid JSON: {e}"),
    })
}

fn json_err(path: &Path, key: &str, problem: impl Into<String>) -> Error {
    Error::Json {
        path: path.to_path_buf(),
        key: key.to_string(),
        problem: problem.into(),
    }
}

fn mat6_value(path: &Path, key: &str, v: &serde_json::Value) -> Result<Mat6, Error> {
    let msg = "must be 6 rows of 6 finite numbers";
    let rows = v
        .as_array()
        .filter(|r| r.len() == 6)
        .ok_or_else(|| json_err(path, key, msg))?;
    let mut m = Mat6::zeros();
    for (i, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .filter(|r| r.len() == 6)
            .ok_or_else(|| json_err(path, key, msg))?;
        for (j, x) in row.iter().enumerate() {
            m[(i, j)] = x
                .as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| json_err(path, key, msg))?;
        }
    }
    Ok(m)
}

/// A covariance in the contract's units (mm, deg) → the library's (mm, rad), checked.
fn uncertain(
    path: &Path,
    key: &str,
    nominal: Rigid3,
    cov_deg: Mat6,
) -> Result<UncertainPose, Error> {
    UncertainPose::from_covariance_deg(nominal, cov_deg)
        .map_err(|p| json_err(path, key, p.to_string()))
}

/// Reads a link `parent_from_child` with its covariance from a `calibrate --json` or
/// `bootstrap --json` result, exactly as a scenario's `from = "…json"` reads it (one reader,
/// [`crashrig_input::result_json`]):
///
/// - `base_mm`: the child's projection centre in the parent's axes (mm);
/// - `angles_deg`: ω φ κ of `R_parent_from_child` (degrees);
/// - the covariance (contract tangent units, mm and degrees): a `calibrate` result (it has
///   `n_epochs`) gives `sem_covariance_tangent`, the uncertainty of the mean link — what a
///   crash test uses — and is refused without it (its `covariance_tangent` is the spread of
///   one epoch's link); a `bootstrap` result gives `covariance_tangent`; a link written by
///   hand (neither marker) gives `sem_covariance_tangent` if present, else
///   `covariance_tangent`.
///
/// # Errors
/// [`Error::Io`], [`Error::Json`] naming the key that is missing or invalid (a covariance that
/// is not symmetric positive semi-definite included).
pub fn load_link(path: &Path) -> Result<UncertainPose, Error> {
    let doc = read_json(path)?;
    crashrig_input::result_json::link_from_result_value(&doc)
        .map(|(_, link)| link)
        .map_err(|e| json_err(path, e.key.unwrap_or("$"), e.problem))
}

/// The outward camera's pose covariance from a JSON file: a default for every epoch and
/// per-epoch overrides (contract tangent units: mm and degrees; centre in world axes,
/// rotation about A's own axes).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ACovariance {
    /// `covariance_tangent`: used for every epoch without its own entry.
    pub default_deg: Option<Mat6>,
    /// `epochs`: epoch name → its covariance.
    pub per_epoch_deg: BTreeMap<String, Mat6>,
    /// The file (for messages).
    pub path: PathBuf,
    /// `mm_per_unit`: the scale of the model the covariance was computed on (a `crashrig
    /// covariance` result states it), the units of `measure`'s model when `--mm-per-unit` is
    /// not given ([`model_scale`]).
    pub mm_per_unit: Option<f64>,
    /// `joint`: the epochs' joint covariance; when present, A's poses of one replicate are
    /// drawn jointly from it ([`crate::engine::measure`]).
    pub joint: Option<JointA>,
}

/// Most epochs of a joint covariance (`joint.epochs`): its 6n × 6n matrix is factored once
/// (n = 500: 3 000 × 3 000, 72 MB, about 2 × 10¹⁰ flops) and every replicate costs
/// (6n)² multiply-adds; a file of this size is about 200 MB of JSON, within the 256 MB that
/// the JSON reader accepts.
pub const MAX_JOINT_EPOCHS: usize = 500;

/// Camera A's poses of several epochs with their joint covariance: `δ = (δ_A(e₁), …, δ_A(eₙ))
/// ~ N(0, Σ)`, each `δ_A(e)` in the contract's tangent convention of `world_from_A`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointA {
    /// The epochs (names or keys, as `measure` forms them) in the matrix's block order.
    pub epochs: Vec<String>,
    /// The 6n × 6n covariance in the library's units (mm, rad; epoch-major blocks of x, y, z,
    /// θx, θy, θz).
    pub covariance: nalgebra::DMatrix<f64>,
    /// The file (for messages).
    pub path: PathBuf,
}

impl JointA {
    /// A joint covariance given in the contract's units (mm, deg), checked: `6·epochs` rows
    /// of `6·epochs` finite numbers, symmetric to [`COVARIANCE_RELATIVE_TOLERANCE`], distinct
    /// epoch names, at most [`MAX_JOINT_EPOCHS`]. Positive semi-definiteness is checked when
    /// the matrix is factored ([`crate::engine::measure`]).
    ///
    /// # Errors
    /// [`Error::Json`] naming `joint.epochs` or `joint.covariance_tangent`.
    pub fn from_deg(
        path: &Path,
        epochs: Vec<String>,
        covariance_deg: nalgebra::DMatrix<f64>,
    ) -> Result<JointA, Error> {
        let key = "joint.covariance_tangent";
        check_joint_epochs(path, epochs.len())?;
        let mut seen = std::collections::BTreeSet::new();
        if let Some(dup) = epochs.iter().find(|e| !seen.insert(e.as_str())) {
            return Err(json_err(
                path,
                "joint.epochs",
                format!("epoch `{dup}` is named twice"),
            ));
        }
        let n = 6 * epochs.len();
        if covariance_deg.shape() != (n, n) {
            return Err(json_err(
                path,
                key,
                format!(
                    "is {} × {}; {} epochs need {n} × {n}",
                    covariance_deg.nrows(),
                    covariance_deg.ncols(),
                    epochs.len()
                ),
            ));
        }
        if covariance_deg.iter().any(|v| !v.is_finite()) {
            return Err(json_err(path, key, "an entry is not finite"));
        }
        let tol = COVARIANCE_RELATIVE_TOLERANCE * covariance_deg.amax();
        for i in 0..n {
            if covariance_deg[(i, i)] < 0.0 {
                return Err(json_err(
                    path,
                    key,
                    format!("the variance on row {} is negative", i + 1),
                ));
            }
            for j in i + 1..n {
                if (covariance_deg[(i, j)] - covariance_deg[(j, i)]).abs() > tol {
                    return Err(json_err(
                        path,
                        key,
                        format!(
                            "not symmetric: entry ({}, {}) differs from ({}, {})",
                            i + 1,
                            j + 1,
                            j + 1,
                            i + 1
                        ),
                    ));
                }
            }
        }
        let rad = 1.0_f64.to_radians();
        let unit = |k: usize| if k % 6 >= 3 { rad } else { 1.0 };
        let covariance = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            0.5 * (covariance_deg[(i, j)] + covariance_deg[(j, i)]) * unit(i) * unit(j)
        });
        Ok(JointA {
            epochs,
            covariance,
            path: path.to_path_buf(),
        })
    }

    /// The block of epoch `k` (index into [`JointA::epochs`]) in the contract's units (mm, deg).
    pub fn block_deg(&self, k: usize) -> Mat6 {
        let deg = 1.0_f64.to_degrees();
        let unit = |i: usize| if i >= 3 { deg } else { 1.0 };
        Mat6::from_fn(|i, j| self.covariance[(6 * k + i, 6 * k + j)] * unit(i) * unit(j))
    }
}

/// The bound on the number of jointly drawn epochs, checked before the matrix is allocated.
fn check_joint_epochs(path: &Path, n: usize) -> Result<(), Error> {
    if (1..=MAX_JOINT_EPOCHS).contains(&n) {
        return Ok(());
    }
    Err(json_err(
        path,
        "joint.epochs",
        format!("{n} epochs (from 1 to {MAX_JOINT_EPOCHS} can be drawn jointly)"),
    ))
}

/// Reads `joint`: `{"epochs": [names], "covariance_tangent": 6n × 6n}` (contract units).
fn joint_value(path: &Path, v: &serde_json::Value) -> Result<JointA, Error> {
    let epochs: Vec<String> = v
        .get("epochs")
        .and_then(|e| e.as_array())
        .and_then(|a| {
            a.iter()
                .map(|x| x.as_str().map(String::from))
                .collect::<Option<Vec<_>>>()
        })
        .ok_or_else(|| json_err(path, "joint.epochs", "must be a list of epoch names"))?;
    check_joint_epochs(path, epochs.len())?;
    let key = "joint.covariance_tangent";
    let n = 6 * epochs.len();
    let msg = format!("must be {n} rows of {n} finite numbers (6 per epoch of joint.epochs)");
    let rows = v
        .get("covariance_tangent")
        .and_then(|r| r.as_array())
        .filter(|r| r.len() == n)
        .ok_or_else(|| json_err(path, key, msg.clone()))?;
    let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
    for (i, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .filter(|r| r.len() == n)
            .ok_or_else(|| json_err(path, key, msg.clone()))?;
        for (j, x) in row.iter().enumerate() {
            m[(i, j)] = x
                .as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| json_err(path, key, msg.clone()))?;
        }
    }
    JointA::from_deg(path, epochs, m)
}

impl ACovariance {
    /// The covariance (contract units) of an epoch known by `names` (any spelling), if any.
    pub fn for_epoch(&self, names: &[&str]) -> Option<Mat6> {
        names
            .iter()
            .find_map(|n| self.per_epoch_deg.get(*n).copied())
            .or_else(|| {
                let j = self.joint.as_ref()?;
                let k = j.epochs.iter().position(|e| names.contains(&e.as_str()))?;
                Some(j.block_deg(k))
            })
            .or(self.default_deg)
    }
}

/// Reads `{"covariance_tangent": 6×6, "epochs": {"NAME": 6×6, …}}` (either key may be absent,
/// not both). Each matrix must be symmetric positive semi-definite.
///
/// # Errors
/// [`Error::Io`], [`Error::Json`] naming the key.
pub fn read_a_covariance(path: &Path) -> Result<ACovariance, Error> {
    let doc = read_json(path)?;
    let mut out = ACovariance {
        path: path.to_path_buf(),
        ..Default::default()
    };
    if let Some(v) = doc.get("covariance_tangent") {
        let m = mat6_value(path, "covariance_tangent", v)?;
        uncertain(path, "covariance_tangent", Rigid3::identity(), m)?;
        out.default_deg = Some(m);
    }
    if let Some(v) = doc.get("epochs") {
        let obj = v
            .as_object()
            .ok_or_else(|| json_err(path, "epochs", "must be an object: epoch name → 6×6"))?;
        for (name, m) in obj {
            let key = format!("epochs.{name}");
            let m = mat6_value(path, &key, m)?;
            uncertain(path, &key, Rigid3::identity(), m)?;
            out.per_epoch_deg.insert(name.clone(), m);
        }
    }
    if let Some(v) = doc.get("mm_per_unit") {
        let f = v
            .as_f64()
            .filter(|f| f.is_finite() && (MM_PER_UNIT_RANGE.0..=MM_PER_UNIT_RANGE.1).contains(f))
            .ok_or_else(|| {
                json_err(
                    path,
                    "mm_per_unit",
                    format!(
                        "must be a number from {:e} to {:e} (mm per model unit)",
                        MM_PER_UNIT_RANGE.0, MM_PER_UNIT_RANGE.1
                    ),
                )
            })?;
        out.mm_per_unit = Some(f);
    }
    if let Some(v) = doc.get("joint") {
        let joint = joint_value(path, v)?;
        // An epoch's own entry and its block of the joint matrix must be the same covariance
        // (a `crashrig covariance` result writes both from one matrix).
        for (k, name) in joint.epochs.iter().enumerate() {
            let Some(m) = out.per_epoch_deg.get(name) else {
                continue;
            };
            let block = joint.block_deg(k);
            if (block - m).amax() > COVARIANCE_RELATIVE_TOLERANCE * m.amax().max(block.amax()) {
                return Err(json_err(
                    path,
                    "joint.covariance_tangent",
                    format!("the block of epoch `{name}` differs from epochs.{name}"),
                ));
            }
        }
        out.joint = Some(joint);
    }
    if out.default_deg.is_none() && out.per_epoch_deg.is_empty() && out.joint.is_none() {
        return Err(json_err(
            path,
            "covariance_tangent",
            "missing (give covariance_tangent, epochs and/or joint)",
        ));
    }
    Ok(out)
}

/// Checks that every observation lies inside the image of the camera that took it (COLMAP
/// pixels: `0 ≤ u_px ≤ width`, `0 ≤ v_px ≤ height`). A pixel far outside the image (a typo,
/// a value in the wrong unit) would otherwise give a ray nearly parallel to the image plane,
/// an intersection behind the cameras and an infinite reprojection error.
///
/// # Errors
/// [`Error::Input`] naming the line, the column and its unit (px) and the image size; located
/// to the observations file by [`Error::in_files`].
pub fn check_in_image(
    observations: &[Observation],
    camera_b: &crashrig_camera::Camera,
    camera_c: Option<&crashrig_camera::Camera>,
) -> Result<(), Error> {
    for o in observations {
        let Some(cam) = (match o.camera {
            Inward::B => Some(camera_b),
            Inward::C => camera_c,
        }) else {
            continue;
        };
        let size = [cam.width as f64, cam.height as f64];
        for (k, (&v, &max)) in o.pixel.iter().zip(&size).enumerate() {
            if !(0.0..=max).contains(&v) {
                return Err(Error::Input(format!(
                    "line {}: `{}` = {v} px lies outside camera {}'s image of {} × {} px (marker `{}`, epoch `{}`)",
                    o.line,
                    OBSERVATION_COLUMNS[3 + k],
                    o.camera.letter(),
                    cam.width,
                    cam.height,
                    o.marker,
                    o.epoch
                )));
            }
        }
    }
    Ok(())
}

/// Smallest and largest model scale (mm per model unit): a model in nanometre …
/// kilometre-scale units.
pub use crashrig_input::options::MM_PER_UNIT_RANGE;

/// The model's units in mm: `given` (`--mm-per-unit`, `[measure] mm_per_unit`), else the
/// `mm_per_unit` that the A-covariance file states (a `crashrig covariance` result). Units
/// are never guessed: neither is an error; both, differing by more than 1 part in 10⁹, too.
///
/// # Errors
/// [`Error::Setting`] naming `key` (the flag or study key) and its unit.
pub fn model_scale(
    given: Option<f64>,
    a_covariance: Option<&ACovariance>,
    key: &'static str,
) -> Result<f64, Error> {
    let stated = a_covariance.and_then(|c| c.mm_per_unit.map(|f| (f, &c.path)));
    match (given, stated) {
        (Some(f), Some((s, path))) if (f - s).abs() > 1e-9 * f.abs().max(s.abs()) => {
            Err(Error::Setting {
                name: key,
                problem: format!(
                    "{f} mm per model unit, but {} states mm_per_unit = {s} for the same model",
                    path.display()
                ),
            })
        }
        (Some(f), _) | (None, Some((f, _))) => Ok(f),
        (None, None) => Err(Error::Setting {
            name: key,
            problem: "missing: the model's units are never guessed; give mm per model unit (1000 for a model in metres, 1 for millimetres), or an A covariance from `crashrig covariance` that states mm_per_unit".into(),
        }),
    }
}
