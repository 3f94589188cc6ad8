//! The lab's control points: a CSV file with the column `point3D_id` and an optional
//! `sigma_mm` (absent, empty or 0: the point is held fixed; > 0: a prior `N(model position, σ²)`
//! on each axis). Other columns (a name, surveyed coordinates, …) are ignored.

use crate::Error;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// Most control points a file may hold (checked before the list grows past it).
pub const MAX_CONTROL_POINTS: usize = 1_000_000;

/// One control point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlPoint {
    /// The COLMAP `point3D_id`.
    pub point3d_id: u64,
    /// Prior σ on each axis in mm; 0 holds the point fixed.
    pub sigma_mm: f64,
    /// 1-based line of the file (for messages).
    pub line: u64,
}

/// The control points of one file.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlPoints {
    /// The file (for messages).
    pub path: PathBuf,
    /// The points in file order.
    pub points: Vec<ControlPoint>,
}

impl ControlPoints {
    /// Control points built in code (no file): every id with the same σ.
    pub fn from_ids(label: &str, ids: &[u64], sigma_mm: f64) -> ControlPoints {
        ControlPoints {
            path: PathBuf::from(label),
            points: ids
                .iter()
                .enumerate()
                .map(|(i, &point3d_id)| ControlPoint {
                    point3d_id,
                    sigma_mm,
                    line: i as u64 + 2,
                })
                .collect(),
        }
    }
}

/// Reads a control-point CSV.
///
/// # Errors
/// [`Error::Io`]; [`Error::ControlCsv`] naming the line: an empty file, a header without
/// `point3D_id`, an id that is not a non-negative integer, a σ that is not a finite number
/// ≥ 0, an id given twice, a file without any point.
pub fn read_control_points(path: &Path) -> Result<ControlPoints, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let err = |line: u64, problem: String| Error::ControlCsv {
        path: path.to_path_buf(),
        line,
        problem,
    };
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(err(
            1,
            "empty file (expected a header with `point3D_id`)".into(),
        ));
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(bytes.as_slice());
    let headers = reader
        .headers()
        .map_err(|e| err(1, format!("unreadable header: {e}")))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h.eq_ignore_ascii_case(name));
    let id_col = col("point3D_id").ok_or_else(|| {
        err(
            1,
            "no column `point3D_id` in the header (columns: point3D_id[,sigma_mm])".into(),
        )
    })?;
    let sigma_col = col("sigma_mm");
    let mut points = Vec::new();
    let mut seen = HashSet::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            err(line, format!("{e}"))
        })?;
        let line = record.position().map_or(0, |p| p.line());
        if record.iter().all(str::is_empty) {
            continue;
        }
        let id_text = record.get(id_col).unwrap_or("");
        let point3d_id: u64 = id_text.parse().map_err(|_| {
            err(
                line,
                format!("point3D_id `{id_text}` is not a non-negative integer"),
            )
        })?;
        let sigma_text = sigma_col.and_then(|c| record.get(c)).unwrap_or("");
        let sigma_mm = if sigma_text.is_empty() {
            0.0
        } else {
            match sigma_text.parse::<f64>() {
                Ok(s) if s.is_finite() && s >= 0.0 => s,
                _ => {
                    return Err(err(
                        line,
                        format!("sigma_mm `{sigma_text}` is not a finite number ≥ 0 (mm)"),
                    ));
                }
            }
        };
        if !seen.insert(point3d_id) {
            return Err(err(line, format!("point3D_id {point3d_id} given twice")));
        }
        if points.len() >= MAX_CONTROL_POINTS {
            return Err(err(
                line,
                format!("more than {MAX_CONTROL_POINTS} control points"),
            ));
        }
        points.push(ControlPoint {
            point3d_id,
            sigma_mm,
            line,
        });
    }
    if points.is_empty() {
        return Err(err(2, "no control point (only a header)".into()));
    }
    Ok(ControlPoints {
        path: path.to_path_buf(),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cp.csv");
        std::fs::write(&p, text).unwrap();
        (dir, p)
    }

    #[test]
    fn reads_ids_and_sigmas() {
        let (_d, p) = write("name,point3D_id,sigma_mm\nA,1,\nB,2,0.5\nC,7,0\n");
        let c = read_control_points(&p).unwrap();
        let got: Vec<(u64, f64, u64)> = c
            .points
            .iter()
            .map(|q| (q.point3d_id, q.sigma_mm, q.line))
            .collect();
        assert_eq!(got, vec![(1, 0.0, 2), (2, 0.5, 3), (7, 0.0, 4)]);
    }

    #[test]
    fn bad_files_name_the_line() {
        for (text, want) in [
            ("", ":1: empty file"),
            ("id\n1\n", ":1: no column `point3D_id`"),
            ("point3D_id\n", ":2: no control point"),
            ("point3D_id,sigma_mm\n1,0\n2,abc\n", ":3: sigma_mm `abc`"),
            ("point3D_id,sigma_mm\n1,-1\n", ":2: sigma_mm `-1`"),
            ("point3D_id,sigma_mm\n1,NaN\n", ":2: sigma_mm `NaN`"),
            ("point3D_id\n1\nx\n", ":3: point3D_id `x`"),
            ("point3D_id\n1\n1\n", ":3: point3D_id 1 given twice"),
        ] {
            let (_d, p) = write(text);
            let e = read_control_points(&p).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }
}
