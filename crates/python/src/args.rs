//! Arguments shared by several functions: a scenario or study given as a path or as TOML text.

use pyo3::prelude::*;
use pyo3::types::PyString;
use std::path::PathBuf;

/// A scenario or study file: a path, or the TOML text itself.
pub enum Source {
    /// A file.
    Path(PathBuf),
    /// TOML text (a `str` holding a newline or `=`).
    Text(String),
}

impl Source {
    /// A `str` with a newline or `=` is TOML text; any other `str` or `os.PathLike` is a path.
    ///
    /// # Errors
    /// `TypeError` naming `what` for any other type.
    pub fn extract(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Source> {
        if let Ok(s) = obj.cast::<PyString>() {
            let s = s.to_cow()?;
            if s.contains('\n') || s.contains('=') {
                return Ok(Source::Text(s.into_owned()));
            }
            return Ok(Source::Path(PathBuf::from(s.as_ref())));
        }
        obj.extract::<PathBuf>().map(Source::Path).map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "{what}: expected a path (str or os.PathLike) or TOML text, got {}",
                type_name(obj)
            ))
        })
    }
}

/// The type name of a Python object, for messages.
pub fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// A path argument (`str` or `os.PathLike`).
///
/// # Errors
/// `TypeError` naming the argument.
pub fn path(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: expected a path (str or os.PathLike), got {}",
            type_name(obj)
        ))
    })
}

/// An optional path argument.
///
/// # Errors
/// As [`path`].
pub fn opt_path(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<PathBuf>> {
    obj.filter(|o| !o.is_none())
        .map(|o| path(o, what))
        .transpose()
}

/// A camera given as a name prefix (`str`) or a camera id (`int`), as the commands take it.
///
/// # Errors
/// `TypeError` for another type; `crashrig.Error` for an empty name.
pub fn camera(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    let text = if let Ok(s) = obj.cast::<PyString>() {
        s.to_cow()?.into_owned()
    } else if let Ok(i) = obj.extract::<u64>() {
        i.to_string()
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: expected a camera name prefix (str) or a camera id (int), got {}",
            type_name(obj)
        )));
    };
    if text.trim().is_empty() {
        return Err(crate::py_error(format!(
            "{what}: must name a camera (an image-name prefix such as `cam_in/`, or a camera id)"
        )));
    }
    Ok(text)
}

/// An image name as the commands take it (`image_a=`, `image_b=`).
///
/// # Errors
/// `crashrig.Error` for an empty or blank name.
pub fn image_name(text: String, what: &str) -> PyResult<String> {
    if text.trim().is_empty() {
        return Err(crate::py_error(format!(
            "{what}: must name an image of the model (e.g. `cam_in/000001.png`)"
        )));
    }
    Ok(text)
}

/// A temporary file holding TOML text (the libraries read their inputs from files).
pub struct TextFile {
    _dir: tempfile::TempDir,
    /// The file.
    pub path: PathBuf,
}

impl TextFile {
    /// Writes `text` to `<temporary folder>/<name>`.
    ///
    /// # Errors
    /// `crashrig.Error` when the temporary folder cannot be written.
    pub fn new(text: &str, name: &str) -> PyResult<TextFile> {
        let dir = tempfile::tempdir()
            .map_err(|e| crate::py_error(format!("cannot create a temporary folder: {e}")))?;
        let path = dir.path().join(name);
        std::fs::write(&path, text)
            .map_err(|e| crate::py_error(format!("{}: cannot write: {e}", path.display())))?;
        Ok(TextFile { _dir: dir, path })
    }
}
