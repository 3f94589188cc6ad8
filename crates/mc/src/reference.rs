//! Links read from the JSON a crashrig command wrote, so no number is copied by hand.
//!
//! [`link_from_result_json`] reads one `calibrate --json` or `bootstrap --json` document and
//! returns the link `A_from_B` it reports as an [`UncertainPose`] (mm, rad):
//!
//! | kind (told apart by its fields) | nominal link | covariance |
//! |---|---|---|
//! | `calibrate` (has `n_epochs`) | `base_mm`, `angles_deg` (the mean over all epochs) | `sem_covariance_tangent`: the uncertainty of that mean |
//! | `bootstrap` (has `method` and `iterations`) | `base_mm`, `angles_deg` | `covariance_tangent`: the spread of the replicates |
//!
//! Both covariances are in the contract's tangent parametrization and units (centre in A's
//! axes, mm; rotation about B's own axes, degrees), checked for symmetry and positive
//! semi-definiteness. The `base_mm` / `angles_deg` are the link `A_from_B`: B's projection
//! centre in A's axes and ω φ κ of `R_A_from_B` (any ω φ κ is a valid rotation).

use crate::Error;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3, opk, quat};
use serde_json::Value;
use std::path::Path;

/// Which command wrote a result JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResultKind {
    /// `crashrig calibrate --json`: the link's covariance is `sem_covariance_tangent`.
    Calibrate,
    /// `crashrig bootstrap --json`: the link's covariance is `covariance_tangent`.
    Bootstrap,
}

impl ResultKind {
    /// `"calibrate"` or `"bootstrap"`.
    pub fn command(self) -> &'static str {
        match self {
            ResultKind::Calibrate => "calibrate",
            ResultKind::Bootstrap => "bootstrap",
        }
    }

    /// The JSON key whose matrix becomes the link's covariance.
    pub fn covariance_key(self) -> &'static str {
        match self {
            ResultKind::Calibrate => "sem_covariance_tangent",
            ResultKind::Bootstrap => "covariance_tangent",
        }
    }
}

/// Reads a `calibrate --json` or `bootstrap --json` result as the uncertain link `A_from_B`
/// (see the module docs for exactly which fields are taken).
///
/// # Errors
/// [`Error::Reference`] (with `key: None`) naming `path` when the file cannot be read, is not
/// JSON, is neither kind of result, or lacks / has a malformed field; the covariance's
/// [`crashrig_geometry::uncertain::CovarianceProblem`] is reported the same way.
pub fn link_from_result_json(path: &Path) -> Result<(ResultKind, UncertainPose), Error> {
    let fail = |problem: String| Error::Reference {
        key: None,
        file: path.to_path_buf(),
        problem,
    };
    let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    let value: Value = serde_json::from_str(&text).map_err(|e| {
        fail(format!(
            "not a JSON document (line {}, column {}): {e}",
            e.line(),
            e.column()
        ))
    })?;
    link_from_result_value(&value).map_err(fail)
}

/// [`link_from_result_json`] on a parsed document; the error is the problem's description.
///
/// # Errors
/// As [`link_from_result_json`], without the file name.
pub fn link_from_result_value(v: &Value) -> Result<(ResultKind, UncertainPose), String> {
    let obj = v
        .as_object()
        .ok_or("not a crashrig result: the document is not a JSON object")?;
    let kind = if obj.contains_key("n_epochs") {
        ResultKind::Calibrate
    } else if obj.contains_key("method") && obj.contains_key("iterations") {
        ResultKind::Bootstrap
    } else {
        return Err(
            "neither a `calibrate --json` result (it has `n_epochs`) nor a \
                    `bootstrap --json` result (it has `method` and `iterations`)"
                .into(),
        );
    };
    let what = kind.command();
    let base = vec3(v, "base_mm", what)?;
    let angles = vec3(v, "angles_deg", what)?;
    let key = kind.covariance_key();
    let cov = mat6(v, key, what)?;
    let r = opk::rotation_from_opk(
        angles.x.to_radians(),
        angles.y.to_radians(),
        angles.z.to_radians(),
    );
    let nominal: Rigid3 = quat::rigid_from_rotation(&r, &base);
    let pose = UncertainPose::from_covariance_deg(nominal, cov)
        .map_err(|p| format!("`{key}` of this {what} result: {p}"))?;
    Ok((kind, pose))
}

fn field<'a>(v: &'a Value, key: &str, what: &str) -> Result<&'a Value, String> {
    v.get(key).ok_or_else(|| {
        format!("this {what} result has no `{key}` (was it written by an older crashrig?)")
    })
}

fn number(v: &Value, key: &str, what: &str) -> Result<f64, String> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("`{key}` of this {what} result holds a non-number"))
}

fn vec3(v: &Value, key: &str, what: &str) -> Result<Vec3, String> {
    let a = field(v, key, what)?
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| format!("`{key}` of this {what} result is not an array of 3 numbers"))?;
    Ok(Vec3::new(
        number(&a[0], key, what)?,
        number(&a[1], key, what)?,
        number(&a[2], key, what)?,
    ))
}

fn mat6(v: &Value, key: &str, what: &str) -> Result<Mat6, String> {
    let shape = || format!("`{key}` of this {what} result is not 6 rows of 6 numbers");
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
    fn reference_calibrate_takes_the_mean_link_and_its_sem() {
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
    fn reference_bootstrap_takes_covariance_tangent() {
        let v = json!({"method": "absolute", "iterations": 500, "base_mm": [1.0, 2.0, 3.0],
            "angles_deg": [0.0, 0.0, 0.0], "covariance_tangent": cov_deg()});
        let (kind, pose) = link_from_result_value(&v).unwrap();
        assert_eq!(kind, ResultKind::Bootstrap);
        assert!((pose.covariance_deg()[(4, 4)] - 1e-4).abs() < 1e-18);
    }

    #[test]
    fn reference_wrong_kind_and_missing_fields_are_named() {
        let e = link_from_result_value(&json!({"samples": 3})).unwrap_err();
        assert!(e.contains("neither"), "{e}");
        let e = link_from_result_value(&json!({"n_epochs": 3, "base_mm": [0, 0, 0],
            "angles_deg": [0, 0, 0]}))
        .unwrap_err();
        assert!(e.contains("`sem_covariance_tangent`"), "{e}");
        let mut bad = cov_deg();
        bad[0][1] += 1.0;
        let e = link_from_result_value(&json!({"method": "relative", "iterations": 5,
            "base_mm": [0, 0, 0], "angles_deg": [0, 0, 0], "covariance_tangent": bad}))
        .unwrap_err();
        assert!(e.contains("not symmetric"), "{e}");
        let e = link_from_result_value(&json!({"method": "relative", "iterations": 5,
            "base_mm": [0, 0], "angles_deg": [0, 0, 0], "covariance_tangent": cov_deg()}))
        .unwrap_err();
        assert!(e.contains("`base_mm`"), "{e}");
    }

    #[test]
    fn reference_missing_file_names_it() {
        let e = link_from_result_json(Path::new("/nonexistent/calibration.json")).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("/nonexistent/calibration.json: cannot read"),
            "{msg}"
        );
    }
}
