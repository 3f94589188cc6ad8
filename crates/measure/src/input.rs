//! Input files: marker observations (CSV), link results (`calibrate`/`bootstrap` JSON) and the
//! outward camera's pose covariance (JSON).

use crate::Error;
use crate::csv_table::{csv_error, for_each_row_with, not_utf8};
use crashrig_geometry::uncertain::COVARIANCE_RELATIVE_TOLERANCE;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose};
use crashrig_input::file as input_file;
use nalgebra::{Matrix2, Vector2};
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
    /// This observation's own pixel noise (the `sigma_u_px,sigma_v_px[,rho_uv]` columns);
    /// `None`: the measurement's `pixel_sigma_px` on each axis.
    pub sigma: Option<PixelSigma>,
    /// 1-based line in the file (for messages).
    pub line: u64,
}

/// One observation's pixel noise: σ of u and of v (px, > 0) and their correlation ρ
/// (|ρ| < 1), i.e. the covariance `Σ = [[σu², ρσuσv], [ρσuσv, σv²]]` (px²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelSigma {
    /// σ of the u coordinate (px).
    pub sigma_u_px: f64,
    /// σ of the v coordinate (px).
    pub sigma_v_px: f64,
    /// Correlation of the u and v errors (0 when the file has no `rho_uv`).
    pub rho_uv: f64,
}

impl PixelSigma {
    /// σ on both axes, uncorrelated.
    pub fn isotropic(sigma_px: f64) -> PixelSigma {
        PixelSigma {
            sigma_u_px: sigma_px,
            sigma_v_px: sigma_px,
            rho_uv: 0.0,
        }
    }

    /// The covariance Σ (px²).
    pub fn covariance(&self) -> Matrix2<f64> {
        let c = self.rho_uv * self.sigma_u_px * self.sigma_v_px;
        Matrix2::new(
            self.sigma_u_px * self.sigma_u_px,
            c,
            c,
            self.sigma_v_px * self.sigma_v_px,
        )
    }

    /// The lower Cholesky factor `L` of Σ (`L·Lᵀ = Σ`): `L·ε` with `ε ~ N(0, I₂)` is one
    /// draw of the pixel noise.
    pub fn factor(&self) -> Matrix2<f64> {
        let (su, sv, rho) = (self.sigma_u_px, self.sigma_v_px, self.rho_uv);
        Matrix2::new(su, 0.0, rho * sv, sv * (1.0 - rho * rho).sqrt())
    }

    /// Checks σ > 0 and finite, |ρ| < 1 and finite; the problem in words otherwise.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("sigma_u_px", self.sigma_u_px),
            ("sigma_v_px", self.sigma_v_px),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "{name} is {v}: a pixel σ must be a finite number > 0 (px)"
                ));
            }
        }
        if !(self.rho_uv.is_finite() && self.rho_uv.abs() < 1.0) {
            return Err(format!(
                "rho_uv is {}: a correlation must be a finite number with |ρ| < 1",
                self.rho_uv
            ));
        }
        Ok(())
    }
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

/// The optional columns of the observations CSV: each observation's own pixel σ
/// (`sigma_u_px` and `sigma_v_px` together, or neither) and their correlation `rho_uv`
/// (needs the two σ).
pub const OBSERVATION_SIGMA_COLUMNS: [&str; 3] = ["sigma_u_px", "sigma_v_px", "rho_uv"];

/// Reads the observations CSV (`epoch,camera,marker,u_px,v_px` and optionally
/// `sigma_u_px,sigma_v_px[,rho_uv]`; see `docs/MEASURE.md`).
///
/// The header must hold the five columns (any order), and may hold `sigma_u_px` and
/// `sigma_v_px` (both or neither) and `rho_uv` (only with them); the `camera` column holds
/// `B`, `C` or the COLMAP camera id of B or C ([`CameraNames`]); pixels must be finite; an
/// `(epoch, camera, marker)` may appear once. A row whose two σ cells are empty (and whose
/// `rho_uv` is empty) has no σ of its own ([`Observation::sigma`] `None`); otherwise both σ
/// must be finite numbers > 0 and ρ (empty: 0) a finite number with |ρ| < 1
/// ([`PixelSigma::check`]).
///
/// # Errors
/// [`Error::Io`], and [`Error::Csv`] naming the line for every problem above (an empty file is
/// line 1; a σ column without the other, or `rho_uv` without them, is line 1).
pub fn read_observations(path: &Path, names: &CameraNames) -> Result<Vec<Observation>, Error> {
    let bad = |line: u64, problem: String| csv_error(path, line, problem);
    let mut out = Vec::new();
    let mut seen: HashMap<(String, Inward, String), u64> = HashMap::new();
    let header = |[u, v, rho]: [bool; 3]| match (u, v, rho) {
        (true, false, _) => Err(
            "column `sigma_u_px` without `sigma_v_px` (give both σ columns, or neither)"
                .to_string(),
        ),
        (false, true, _) => Err(
            "column `sigma_v_px` without `sigma_u_px` (give both σ columns, or neither)"
                .to_string(),
        ),
        (false, false, true) => Err(
            "column `rho_uv` without `sigma_u_px` and `sigma_v_px` (the correlation of the two σ)"
                .to_string(),
        ),
        _ => Ok(()),
    };
    for_each_row_with(
        path,
        &OBSERVATION_COLUMNS,
        &OBSERVATION_SIGMA_COLUMNS,
        header,
        |line, fields, sigma_fields| {
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
            let sigma = pixel_sigma(sigma_fields).map_err(|p| bad(line, p))?;
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
                sigma,
                line,
            });
            Ok(())
        },
    )?;
    if out.is_empty() {
        return Err(bad(1, "no observations".into()));
    }
    Ok(out)
}

/// One row's σ cells (`None` where the header lacks the column) → its own pixel σ, `None` when
/// every cell is empty (the measurement's `pixel_sigma_px` applies).
fn pixel_sigma([u, v, rho]: [Option<&str>; 3]) -> Result<Option<PixelSigma>, String> {
    let (u, v, rho) = (u.unwrap_or(""), v.unwrap_or(""), rho.unwrap_or(""));
    if u.is_empty() && v.is_empty() {
        return match rho.is_empty() {
            true => Ok(None),
            false => Err(format!(
                "rho_uv is `{rho}` but sigma_u_px and sigma_v_px are empty (a correlation needs its two σ)"
            )),
        };
    }
    let number = |name: &str, text: &str| -> Result<f64, String> {
        if text.is_empty() {
            return Err(format!(
                "{name} is empty but the other σ of the row is given (give both, or neither for --pixel-sigma-px)"
            ));
        }
        text.parse()
            .map_err(|_| format!("{name} `{text}` is not a number"))
    };
    let s = PixelSigma {
        sigma_u_px: number("sigma_u_px", u)?,
        sigma_v_px: number("sigma_v_px", v)?,
        rho_uv: match rho.is_empty() {
            true => 0.0,
            false => rho
                .parse()
                .map_err(|_| format!("rho_uv `{rho}` is not a number"))?,
        },
    };
    s.check()?;
    Ok(Some(s))
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
            .ok_or_else(|| "is not a number".to_string())
            .and_then(|f| crashrig_input::options::mm_per_unit_problem(f).map_or(Ok(f), Err))
            .map_err(|p| json_err(path, "mm_per_unit", p))?;
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

/// The columns of a frame-times CSV (`track`'s `frames.csv`).
pub const FRAME_TIME_COLUMNS: [&str; 2] = ["epoch", "time_s"];

/// Most relative deviation of a frame interval from the mean interval that the CFC filter
/// accepts ([`FrameTimes::uniform_interval`]): SAE J211-1 and ISO 6487 filter a record of one
/// sampling interval; a camera clock's jitter of up to 1 % of the interval moves a sample by
/// at most 1 % of one frame's motion.
pub const MAX_INTERVAL_DEVIATION: f64 = 0.01;

/// Each frame's time from the camera's own clock (`--frame-times`, header `epoch,time_s`, as
/// `crashrig track` writes `frames.csv`): the time axis of velocities, the CFC filter and the
/// ISO-MME export instead of `frame / --frame-rate-hz`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTimes {
    /// The file (for messages).
    pub path: PathBuf,
    /// `(epoch, time_s)` in file order, times strictly increasing.
    pub frames: Vec<(String, f64)>,
    index: HashMap<String, usize>,
}

impl FrameTimes {
    /// Frame times from `(epoch, time_s)` pairs in their order (the index of a pair is its
    /// frame number); `None` for no pair, a repeated epoch, a time that is not finite or that
    /// does not increase.
    pub fn new(path: PathBuf, frames: Vec<(String, f64)>) -> Option<FrameTimes> {
        let mut index = HashMap::new();
        for (i, (e, t)) in frames.iter().enumerate() {
            if !t.is_finite() || index.insert(e.clone(), i).is_some() {
                return None;
            }
            if i > 0 && frames[i - 1].1 >= *t {
                return None;
            }
        }
        (!frames.is_empty()).then_some(FrameTimes {
            path,
            frames,
            index,
        })
    }

    /// The frame number (index in the file) and time of the epoch known by `names` (any
    /// spelling: name or key).
    pub fn lookup(&self, names: &[&str]) -> Option<(u64, f64)> {
        names
            .iter()
            .find_map(|n| self.index.get(*n))
            .map(|&i| (i as u64, self.frames[i].1))
    }

    /// The mean interval (s) between the file's frames, `(t_last − t_first) / (n − 1)`;
    /// `None` for a single frame.
    pub fn mean_interval_s(&self) -> Option<f64> {
        let n = self.frames.len();
        (n >= 2).then(|| (self.frames[n - 1].1 - self.frames[0].1) / (n - 1) as f64)
    }

    /// The file's largest deviation of an interval from the mean interval, relative to it,
    /// with the two epochs of that interval.
    pub fn largest_deviation(&self) -> Option<(f64, &str, &str, f64)> {
        let mean = self.mean_interval_s()?;
        self.frames
            .windows(2)
            .map(|w| {
                let dt = w[1].1 - w[0].1;
                (
                    (dt - mean).abs() / mean,
                    w[0].0.as_str(),
                    w[1].0.as_str(),
                    dt,
                )
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// The one sampling interval (s) of the file for the CFC filter: the mean interval, when
    /// every interval is within [`MAX_INTERVAL_DEVIATION`] of it.
    ///
    /// # Errors
    /// [`Error::Input`] naming the file, the interval that deviates most and why the filter
    /// needs one interval.
    pub fn uniform_interval(&self) -> Result<f64, Error> {
        let mean = self.mean_interval_s().ok_or_else(|| {
            Error::Input(format!(
                "{}: one frame time: the CFC filter needs a sampling interval",
                self.path.display()
            ))
        })?;
        match self.largest_deviation() {
            Some((dev, a, b, dt)) if dev > MAX_INTERVAL_DEVIATION => Err(Error::Input(format!(
                "{}: the frame interval from epoch `{a}` to `{b}` is {:.6} ms, {:.1} % off the mean interval of {:.6} ms: the CFC filter of SAE J211-1 / ISO 6487 is a recursive digital filter of one sampling interval and is defined only for equally spaced samples (at most {:.0} % deviation accepted); measure without --cfc (velocities then use the real frame times) or resample the series",
                self.path.display(),
                dt * 1e3,
                100.0 * dev,
                mean * 1e3,
                100.0 * MAX_INTERVAL_DEVIATION
            ))),
            _ => Ok(mean),
        }
    }
}

/// The time axis of a `--frame-times` file: the frame times and the frame rate of their mean
/// interval — with a CFC filter (`cfc`) the one interval the filter runs on,
/// [`FrameTimes::uniform_interval`].
///
/// # Errors
/// [`read_frame_times`]'s; [`FrameTimes::uniform_interval`]'s with `cfc`; [`Error::Input`] for
/// a file of one frame (velocities need two).
pub fn read_time_axis(path: &Path, cfc: bool) -> Result<(f64, FrameTimes), Error> {
    let times = read_frame_times(path)?;
    let interval = if cfc {
        times.uniform_interval()?
    } else {
        times.mean_interval_s().ok_or_else(|| {
            Error::Input(format!(
                "{}: one frame time is no time axis (velocities need two frames)",
                path.display()
            ))
        })?
    };
    Ok((1.0 / interval, times))
}

/// Reads a frame-times CSV (`epoch,time_s`, any column order; `crashrig track`'s
/// `frames.csv`): one line per frame in frame order, times in seconds strictly increasing.
///
/// # Errors
/// [`Error::Io`], and [`Error::Csv`] naming the line: a missing or unknown column, an empty
/// epoch, an epoch named twice, an empty `time_s` (frames from an image directory have no
/// clock: use `--frame-rate-hz`), a time that is not a finite number or not greater than the
/// previous line's, no frame at all.
pub fn read_frame_times(path: &Path) -> Result<FrameTimes, Error> {
    let bad = |line: u64, problem: String| csv_error(path, line, problem);
    let mut frames: Vec<(String, f64)> = Vec::new();
    let mut seen: HashMap<String, u64> = HashMap::new();
    let mut last: Option<(f64, u64)> = None;
    crate::csv_table::for_each_row(path, &FRAME_TIME_COLUMNS, |line, [epoch, time]| {
        if epoch.is_empty() {
            return Err(bad(line, "empty epoch".into()));
        }
        if time.is_empty() {
            return Err(bad(
                line,
                format!(
                    "time_s of epoch `{epoch}` is empty (frames without a clock: give --frame-rate-hz instead)"
                ),
            ));
        }
        let t: f64 = time
            .parse()
            .map_err(|_| bad(line, format!("time_s `{time}` is not a number (s)")))?;
        if !t.is_finite() {
            return Err(bad(
                line,
                format!("time_s is {time}: times must be finite (s)"),
            ));
        }
        if let Some((prev, prev_line)) = last
            && t <= prev
        {
            return Err(bad(
                line,
                format!(
                    "time_s {t} s of epoch `{epoch}` does not increase (line {prev_line} has {prev} s): frame times must increase along the sequence"
                ),
            ));
        }
        if let Some(first) = seen.insert(epoch.to_string(), line) {
            return Err(bad(
                line,
                format!("epoch `{epoch}` again (first on line {first})"),
            ));
        }
        last = Some((t, line));
        frames.push((epoch.to_string(), t));
        Ok(())
    })?;
    FrameTimes::new(path.to_path_buf(), frames).ok_or_else(|| bad(1, "no frame times".into()))
}
