//! The uncertain link a crashrig command reports, read back from its JSON (feature `json`).
//!
//! One reader serves every consumer of `calibrate --json` and `bootstrap --json` results (the
//! scenario's `from = "…json"`, `measure --link/--tie`), so each file means the same link
//! everywhere and no number is copied by hand:
//!
//! | kind (told apart by its fields) | nominal link `A_from_B` | covariance |
//! |---|---|---|
//! | `calibrate` (has `n_epochs`) | `link.base_mm`, `link.angles_deg`: the mean the tangent covariances are taken about (mean centre, Karcher mean rotation); the top-level `base_mm`, `angles_deg` (per-angle means, the paper's table) only if `link` is absent | `sem_covariance_tangent`: the uncertainty of that mean (required: a calibrate result's `covariance_tangent` is the spread of one epoch's link) |
//! | `bootstrap` (has `method` and `iterations`) | `base_mm`, `angles_deg` | `covariance_tangent`: the spread of the replicates |
//! | a link written by hand (neither marker) | `base_mm`, `angles_deg` | `sem_covariance_tangent` if present, else `covariance_tangent` |
//!
//! `base_mm` is B's projection centre in A's axes (mm), `angles_deg` ω φ κ of `R_A_from_B`
//! (degrees; any ω φ κ is a valid rotation); the covariance is in the contract's tangent units
//! (centre in A's axes, mm; rotation about B's own axes, degrees), checked for symmetry and
//! positive semi-definiteness.
//!
//! ```
//! use crashrig_input::result_json::{ResultKind, link_from_result_value};
//! let diag = |i: usize, j: usize| if i != j { 0.0 } else if i < 3 { 0.04 } else { 1e-4 };
//! let cov: Vec<Vec<f64>> = (0..6).map(|i| (0..6).map(|j| diag(i, j)).collect()).collect();
//! let doc = serde_json::json!({"method": "absolute", "iterations": 500,
//!     "base_mm": [60.0, 0.0, 180.0], "angles_deg": [0.0, 180.0, 0.0],
//!     "covariance_tangent": cov});
//! let (kind, link) = link_from_result_value(&doc).unwrap();
//! assert_eq!(kind, ResultKind::Bootstrap);
//! assert!((link.center().x - 60.0).abs() < 1e-12);
//! assert!((link.covariance_deg()[(3, 3)] - 1e-4).abs() < 1e-18); // back in degrees²
//! ```

use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3, opk, quat};
use serde_json::Value;

/// Which kind of document a link was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResultKind {
    /// `crashrig calibrate --json`: the link's covariance is `sem_covariance_tangent`.
    Calibrate,
    /// `crashrig bootstrap --json`: the link's covariance is `covariance_tangent`.
    Bootstrap,
    /// Neither marker: a link written by hand (`base_mm`, `angles_deg` and a covariance).
    Link,
}

impl ResultKind {
    /// `"calibrate"`, `"bootstrap"` or `"link"`.
    pub fn command(self) -> &'static str {
        match self {
            ResultKind::Calibrate => "calibrate",
            ResultKind::Bootstrap => "bootstrap",
            ResultKind::Link => "link",
        }
    }
}

/// What is wrong with a result document: the key (if one is to blame) and the problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{problem}", key.map(|k| format!("`{k}`: ")).unwrap_or_default())]
pub struct ResultJsonError {
    /// The offending key, `None` for the document as a whole.
    pub key: Option<&'static str>,
    /// What is wrong.
    pub problem: String,
}

fn fail(key: Option<&'static str>, problem: impl Into<String>) -> ResultJsonError {
    ResultJsonError {
        key,
        problem: problem.into(),
    }
}

/// Reads the uncertain link `A_from_B` from a parsed result document (module docs).
///
/// # Errors
/// [`ResultJsonError`] naming the key that is missing, malformed or not a valid covariance
/// (not symmetric, not positive semi-definite), or the document if it is not an object or has
/// no covariance at all.
pub fn link_from_result_value(v: &Value) -> Result<(ResultKind, UncertainPose), ResultJsonError> {
    let obj = v.as_object().ok_or_else(|| {
        fail(
            None,
            "not a crashrig result: the document is not a JSON object",
        )
    })?;
    let kind = if obj.contains_key("n_epochs") {
        ResultKind::Calibrate
    } else if obj.contains_key("method") && obj.contains_key("iterations") {
        ResultKind::Bootstrap
    } else {
        ResultKind::Link
    };
    let what = kind.command();
    let key: &'static str = match kind {
        ResultKind::Calibrate => "sem_covariance_tangent",
        ResultKind::Bootstrap => "covariance_tangent",
        ResultKind::Link if obj.contains_key("sem_covariance_tangent") => "sem_covariance_tangent",
        ResultKind::Link if obj.contains_key("covariance_tangent") => "covariance_tangent",
        ResultKind::Link => {
            return Err(fail(
                None,
                "neither a `calibrate --json` result (it has `n_epochs`), nor a \
                 `bootstrap --json` result (it has `method` and `iterations`), nor a link \
                 with `sem_covariance_tangent` or `covariance_tangent`",
            ));
        }
    };
    // A calibrate result reports its per-angle means at the top level (the paper's table) and,
    // under `link`, the mean its tangent covariances are centred on: that one is the link.
    let nominal_of = match v.get("link") {
        Some(link) if kind == ResultKind::Calibrate => link,
        _ => v,
    };
    let base = vec3(nominal_of, "base_mm", what)?;
    let angles = vec3(nominal_of, "angles_deg", what)?;
    if kind == ResultKind::Calibrate && v.get(key).is_none() {
        return Err(fail(
            Some(key),
            "missing: a calibrate result must give the uncertainty of its mean link \
             (its `covariance_tangent` is the spread of one epoch's link)",
        ));
    }
    let cov = mat6(v, key, what)?;
    let r = opk::rotation_from_opk(
        angles.x.to_radians(),
        angles.y.to_radians(),
        angles.z.to_radians(),
    );
    let nominal: Rigid3 = quat::rigid_from_rotation(&r, &base);
    let pose = UncertainPose::from_covariance_deg(nominal, cov)
        .map_err(|p| fail(Some(key), format!("of this {what} result: {p}")))?;
    Ok((kind, pose))
}

fn field<'a>(v: &'a Value, key: &'static str, what: &str) -> Result<&'a Value, ResultJsonError> {
    v.get(key).ok_or_else(|| {
        fail(
            Some(key),
            format!("missing from this {what} result (was it written by an older crashrig?)"),
        )
    })
}

fn number(v: &Value, key: &'static str, what: &str) -> Result<f64, ResultJsonError> {
    v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
        fail(
            Some(key),
            format!("holds a non-number in this {what} result"),
        )
    })
}

fn vec3(v: &Value, key: &'static str, what: &str) -> Result<Vec3, ResultJsonError> {
    let a = field(v, key, what)?
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| {
            fail(
                Some(key),
                format!("not an array of 3 numbers in this {what} result"),
            )
        })?;
    Ok(Vec3::new(
        number(&a[0], key, what)?,
        number(&a[1], key, what)?,
        number(&a[2], key, what)?,
    ))
}

fn mat6(v: &Value, key: &'static str, what: &str) -> Result<Mat6, ResultJsonError> {
    let shape = || {
        fail(
            Some(key),
            format!("not 6 rows of 6 numbers in this {what} result"),
        )
    };
    let rows = field(v, key, what)?
        .as_array()
        .filter(|a| a.len() == 6)
        .ok_or_else(shape)?;
    let mut m = Mat6::zeros();
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == 6).ok_or_else(shape)?;
        for (j, x) in row.iter().enumerate() {
            m[(i, j)] = number(x, key, what)?;
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn cov_deg() -> Vec<Vec<f64>> {
        // A full, positive-definite covariance: 0.04 mm², 1e-4 deg², mixed terms.
        let mut m = vec![vec![0.0; 6]; 6];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                let s = |k: usize| if k < 3 { 0.2 } else { 0.01 };
                let rho = if i == j { 1.0 } else { 0.3 };
                *x = rho * s(i) * s(j);
            }
        }
        m
    }

    #[test]
    fn calibrate_takes_the_mean_link_and_its_sem() {
        let v = json!({"n_epochs": 140, "base_mm": [61.98, -1.71, 179.76],
            "angles_deg": [179.92, -90.0, 179.76], "covariance_tangent": vec![vec![9.0; 6]; 6],
            "sem_covariance_tangent": cov_deg()});
        let (kind, pose) = link_from_result_value(&v).unwrap();
        assert_eq!(kind, ResultKind::Calibrate);
        assert!((pose.center() - Vec3::new(61.98, -1.71, 179.76)).norm() < 1e-12);
        // φ = −90° is an ordinary input: the rotation is Rx(ω)·Ry(φ)·Rz(κ).
        let r = opk::rotation_from_opk(
            179.92f64.to_radians(),
            -90f64.to_radians(),
            179.76f64.to_radians(),
        );
        assert!((pose.rotation().matrix() - r.matrix()).amax() < 1e-15);
        let back = pose.covariance_deg();
        let want = cov_deg();
        for i in 0..6 {
            for j in 0..6 {
                assert!((back[(i, j)] - want[i][j]).abs() < 1e-15, "{i} {j}");
            }
        }
    }

    #[test]
    fn calibrate_takes_the_link_its_covariances_are_centred_on() {
        let v = json!({"n_epochs": 140, "base_mm": [61.98, -1.71, 179.76],
            "angles_deg": [179.92, -0.09, 179.76],
            "link": {"base_mm": [61.97, -1.72, 179.75], "angles_deg": [179.921, -0.091, 179.761]},
            "sem_covariance_tangent": cov_deg()});
        let (_, pose) = link_from_result_value(&v).unwrap();
        assert!((pose.center() - Vec3::new(61.97, -1.72, 179.75)).norm() < 1e-12);
        let r = opk::rotation_from_opk(
            179.921f64.to_radians(),
            -0.091f64.to_radians(),
            179.761f64.to_radians(),
        );
        assert!((pose.rotation().matrix() - r.matrix()).amax() < 1e-15);
    }

    #[test]
    fn bootstrap_takes_covariance_tangent() {
        let v = json!({"method": "absolute", "iterations": 500, "base_mm": [1.0, 2.0, 3.0],
            "angles_deg": [0.0, 0.0, 0.0], "covariance_tangent": cov_deg(),
            "sem_covariance_tangent": vec![vec![9.0; 6]; 6]});
        let (kind, pose) = link_from_result_value(&v).unwrap();
        assert_eq!(kind, ResultKind::Bootstrap);
        assert!((pose.covariance_deg()[(4, 4)] - 1e-4).abs() < 1e-18);
    }

    #[test]
    fn a_hand_written_link_prefers_the_sem() {
        let mut scaled = cov_deg();
        scaled.iter_mut().flatten().for_each(|x| *x *= 4.0);
        let v = json!({"base_mm": [1.0, 2.0, 3.0], "angles_deg": [0.0, 0.0, 0.0],
            "covariance_tangent": scaled, "sem_covariance_tangent": cov_deg()});
        let (kind, pose) = link_from_result_value(&v).unwrap();
        assert_eq!(kind, ResultKind::Link);
        assert!((pose.covariance_deg()[(0, 0)] - 0.04).abs() < 1e-15);
        let v = json!({"base_mm": [1.0, 2.0, 3.0], "angles_deg": [0.0, 0.0, 0.0],
            "covariance_tangent": cov_deg()});
        assert_eq!(link_from_result_value(&v).unwrap().0, ResultKind::Link);
    }

    #[test]
    fn wrong_kind_and_missing_fields_are_named() {
        let e = link_from_result_value(&json!({"samples": 3})).unwrap_err();
        assert_eq!(e.key, None);
        assert!(e.problem.contains("neither"), "{e}");
        let e = link_from_result_value(&json!([1, 2])).unwrap_err();
        assert!(e.problem.contains("not a JSON object"), "{e}");
        let e = link_from_result_value(&json!({"n_epochs": 3, "base_mm": [0, 0, 0],
            "angles_deg": [0, 0, 0], "covariance_tangent": cov_deg()}))
        .unwrap_err();
        assert_eq!(e.key, Some("sem_covariance_tangent"), "{e}");
        let mut bad = cov_deg();
        bad[0][1] += 1.0;
        let e = link_from_result_value(&json!({"method": "relative", "iterations": 5,
            "base_mm": [0, 0, 0], "angles_deg": [0, 0, 0], "covariance_tangent": bad}))
        .unwrap_err();
        assert!(e.to_string().contains("not symmetric"), "{e}");
        let e = link_from_result_value(&json!({"method": "relative", "iterations": 5,
            "base_mm": [0, 0], "angles_deg": [0, 0, 0], "covariance_tangent": cov_deg()}))
        .unwrap_err();
        assert_eq!(e.key, Some("base_mm"));
        assert!(e.to_string().starts_with("`base_mm`: "), "{e}");
        let e = link_from_result_value(&json!({"method": "relative", "iterations": 5,
            "base_mm": [0, 0, "x"], "angles_deg": [0, 0, 0], "covariance_tangent": cov_deg()}))
        .unwrap_err();
        assert!(e.problem.contains("non-number"), "{e}");
    }
}
