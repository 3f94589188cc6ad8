//! Links read from the JSON a crashrig command wrote, so no number is copied by hand.
//!
//! [`link_from_result_json`] reads one `calibrate --json` or `bootstrap --json` document and
//! returns the link `A_from_B` it reports as an [`UncertainPose`] (mm, rad). Which fields are
//! taken is defined once, in [`crashrig_input::result_json`] (shared with `measure`):
//! a `calibrate` result (it has `n_epochs`) gives the mean link and `sem_covariance_tangent`,
//! the uncertainty of that mean; a `bootstrap` result (`method` and `iterations`) gives
//! `covariance_tangent`, the spread of its replicates; a link written by hand (neither marker)
//! gives `sem_covariance_tangent` if present, else `covariance_tangent`.

use crate::error::Error;
use crashrig_geometry::UncertainPose;
pub use crashrig_input::result_json::ResultKind;
use serde_json::Value;
use std::path::Path;

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
    let text = crashrig_input::file::read_text_limited(path, crashrig_input::file::MAX_JSON_BYTES)
        .map_err(|e| fail(format!("cannot read: {e}")))?;
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
    crashrig_input::result_json::link_from_result_value(v).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_missing_file_names_it() {
        let e = link_from_result_json(Path::new("/nonexistent/calibration.json")).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("/nonexistent/calibration.json: cannot read"),
            "{msg}"
        );
    }

    #[test]
    fn reference_bad_json_gives_its_line() {
        let dir = std::env::temp_dir().join(format!("crashrig-ref-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("bad.json");
        std::fs::write(&f, "{\n  \"n_epochs\": 3,\n  oops\n}").unwrap();
        let msg = link_from_result_json(&f).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(msg.contains("bad.json") && msg.contains("line 3"), "{msg}");
    }
}
