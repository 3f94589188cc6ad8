//! Documented bounds on every scenario value that sizes memory or work, and on magnitudes, so
//! a hostile or mistyped file is an error naming the key and line instead of an allocation
//! abort, an endless run or `inf` results. The table is repeated in `docs/LIMITS.md`.
//!
//! `check_document` runs on the parsed TOML document (with spans) before the typed parse:
//! it checks array lengths, finiteness, magnitudes and counts of every key it knows, wherever
//! the key sits, so new tables that reuse the key names are covered too.

// Without the scenario reader the document walk below is not compiled and its helpers are unused.
#![cfg_attr(not(feature = "scenario"), allow(dead_code))]

use crate::Error;
#[cfg(feature = "scenario")]
use crashrig_input::location::line_of;
#[cfg(feature = "scenario")]
use std::path::Path;
#[cfg(feature = "scenario")]
use toml::de::{DeTable, DeValue};

/// Largest number of Monte Carlo draws (`samples`, `--samples`; per grid point for `grid`).
pub const MAX_SAMPLES: usize = 10_000_000;
/// Largest `count` of one grid axis (`x_mm = [start, stop, count]`).
pub const MAX_AXIS_COUNT: usize = 10_000;
/// Largest number of grid points (product of the three axis counts).
pub const MAX_GRID_POINTS: usize = 1_000_000;
/// Largest total number of draws of a grid study: points × samples (or × `max_samples` with
/// `[grid.adaptive]`).
pub const MAX_GRID_DRAWS: u64 = 10_000_000_000;
/// Smallest `[grid.adaptive] tolerance_mm` (1 nm).
pub const MIN_ADAPTIVE_TOLERANCE_MM: f64 = 1e-6;
/// Largest `[grid.adaptive] max_samples` and `batch`.
pub const MAX_ADAPTIVE_SAMPLES: usize = MAX_SAMPLES;
/// Largest number of `[[camera]]` entries, and of `[[grid.observer]]` entries.
pub const MAX_CAMERAS: usize = 1_000;
/// Largest |value| of any length in mm (coordinates, σ, thresholds): 10 km.
pub const MAX_ABS_LENGTH_MM: f64 = 1e7;
/// Largest |value| of any angle or angle σ in degrees.
pub const MAX_ABS_ANGLE_DEG: f64 = 3600.0;
/// Largest pixel quantity (`focal_px`, `pixel_sigma_px`, image sizes, camera parameters in px).
pub const MAX_PIXELS: f64 = 1e6;
/// Largest |value| of any other number in a scenario (covariance entries in mm², deg², …).
pub const MAX_ABS_OTHER: f64 = 1e14;
/// Largest scenario file (bytes).
#[cfg(feature = "scenario")]
pub const MAX_FILE_BYTES: u64 = crashrig_input::file::MAX_TOML_BYTES;
/// Largest nesting depth of arrays and inline tables in a scenario file.
pub const MAX_NESTING: usize = 16;

/// Keys whose value is a vector of exactly three numbers, wherever they appear.
pub const THREE_VECTORS: &[&str] = &[
    "position_mm",
    "angles_deg",
    "sigma_position_mm",
    "sigma_angles_deg",
    "base_mm",
];

/// Grid axis keys: `[start, stop, count]`, exactly three numbers.
pub const AXES: &[&str] = &["x_mm", "y_mm", "z_mm"];

/// A bound violation at a byte offset of the text.
fn fail(key: &str, problem: String) -> Error {
    Error::Bound {
        key: key.to_string(),
        problem,
    }
}

#[cfg(feature = "scenario")]
fn located(path: &Path, text: &str, offset: usize, e: Error) -> Error {
    Error::Located {
        path: path.to_path_buf(),
        line: line_of(text, offset),
        source: Box::new(e),
    }
}

/// Reads a scenario file with the size bound and a located UTF-8 check.
#[cfg(feature = "scenario")]
pub(crate) fn read_text(path: &Path) -> Result<String, Error> {
    let bytes =
        crashrig_input::file::read_limited(path, MAX_FILE_BYTES).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    crashrig_input::file::text_from_bytes(bytes).map_err(|e| Error::Toml {
        path: path.to_path_buf(),
        line: e.line,
        column: e.column,
        message: "not valid UTF-8 text".into(),
    })
}

/// 1-based (line, column) of the first place where arrays / inline tables nest deeper than
/// [`MAX_NESTING`] (outside strings and comments), if any: the location of a parser error
/// that has no span (e.g. its recursion limit).
pub(crate) fn deep_nesting(text: &str) -> Option<(usize, usize)> {
    let mut depth = 0usize;
    let (mut in_str, mut in_comment) = (None::<u8>, false);
    let (mut line, mut col) = (1, 0);
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        col += 1;
        match (in_str, in_comment, b) {
            (_, _, b'\n') => {
                line += 1;
                col = 0;
                in_comment = false;
                if in_str == Some(b'"') || in_str == Some(b'\'') {
                    in_str = None;
                }
            }
            (_, true, _) => {}
            (Some(q), _, _) => {
                if b == b'\\' && q == b'"' {
                    i += 1;
                } else if b == q {
                    in_str = None;
                }
            }
            (None, _, b'#') => in_comment = true,
            (None, _, b'"' | b'\'') => in_str = Some(b),
            (None, _, b'[' | b'{') => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some((line, col));
                }
            }
            (None, _, b']' | b'}') => depth = depth.saturating_sub(1),
            _ => {}
        }
        i += 1;
    }
    None
}

/// A number of the document: its value as f64 and, for an integer, as i128.
#[cfg(feature = "scenario")]
fn number(v: &DeValue<'_>) -> Option<(f64, Option<i128>)> {
    match v {
        DeValue::Integer(i) => {
            let s = i.as_str().replace('_', "");
            let n = i128::from_str_radix(s.trim_start_matches('+'), i.radix()).ok()?;
            Some((n as f64, Some(n)))
        }
        DeValue::Float(f) => {
            let s = f.as_str().replace('_', "");
            Some((s.parse::<f64>().ok()?, None))
        }
        _ => None,
    }
}

/// The magnitude bound of a number under leaf key `leaf` and its unit name.
fn magnitude_bound(leaf: &str) -> (f64, &'static str) {
    if leaf.ends_with("_mm") || leaf == "tolerance_mm" {
        (MAX_ABS_LENGTH_MM, "mm")
    } else if leaf.ends_with("_deg") {
        (MAX_ABS_ANGLE_DEG, "°")
    } else if leaf.ends_with("_px") || leaf == "params" || leaf == "width" || leaf == "height" {
        (MAX_PIXELS, "px")
    } else {
        (MAX_ABS_OTHER, "")
    }
}

/// Integer keys that are counts of work, with their bounds.
fn count_bound(leaf: &str) -> Option<u128> {
    match leaf {
        "samples" => Some(MAX_SAMPLES as u128),
        "max_samples" | "batch" => Some(MAX_ADAPTIVE_SAMPLES as u128),
        "iterations" => Some(1_000_000),
        _ => None,
    }
}

#[cfg(feature = "scenario")]
struct Walk<'a> {
    text: &'a str,
    path: &'a Path,
    /// (axis key, count) of the grid axes seen.
    axes: Vec<u128>,
    samples: Option<u128>,
    max_samples: Option<u128>,
    grid_offset: Option<usize>,
}

#[cfg(feature = "scenario")]
impl Walk<'_> {
    fn err(&self, offset: usize, key: &str, problem: String) -> Error {
        located(self.path, self.text, offset, fail(key, problem))
    }

    fn table(&mut self, t: &DeTable<'_>, prefix: &str) -> Result<(), Error> {
        for (k, v) in t.iter() {
            let leaf = k.get_ref().as_ref();
            let key = if prefix.is_empty() {
                leaf.to_string()
            } else {
                format!("{prefix}.{leaf}")
            };
            if key == "grid" {
                self.grid_offset = Some(k.span().start);
            }
            self.value(v.get_ref(), v.span().start, &key, leaf)?;
        }
        Ok(())
    }

    fn value(&mut self, v: &DeValue<'_>, at: usize, key: &str, leaf: &str) -> Result<(), Error> {
        match v {
            DeValue::Table(t) => self.table(t, key),
            DeValue::Array(a) => {
                let tables = a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_)));
                if tables && !a.is_empty() {
                    if (leaf == "camera" || leaf == "observer" || leaf == "candidate")
                        && a.len() > MAX_CAMERAS
                    {
                        return Err(self.err(
                            at,
                            key,
                            format!("{} entries exceed the limit of {MAX_CAMERAS}", a.len()),
                        ));
                    }
                    for (i, e) in a.iter().enumerate() {
                        self.value(e.get_ref(), e.span().start, &format!("{key}[{i}]"), leaf)?;
                    }
                    return Ok(());
                }
                let is_axis = AXES.contains(&leaf) && key.starts_with("grid.");
                if (THREE_VECTORS.contains(&leaf) || is_axis) && a.len() != 3 {
                    let what = if is_axis {
                        "[start, stop, count]: exactly 3 values"
                    } else {
                        "exactly 3 values"
                    };
                    return Err(self.err(at, key, format!("must have {what}, found {}", a.len())));
                }
                for (i, e) in a.iter().enumerate() {
                    let at = e.span().start;
                    if is_axis && i == 2 {
                        let count = match number(e.get_ref()) {
                            Some((f, _)) if f.fract() == 0.0 && f >= 1.0 => f,
                            _ => continue, // the typed parse reports non-counts
                        };
                        if count > MAX_AXIS_COUNT as f64 {
                            return Err(self.err(
                                at,
                                key,
                                format!("count {count} exceeds the limit of {MAX_AXIS_COUNT} values per axis"),
                            ));
                        }
                        self.axes.push(count as u128);
                        continue;
                    }
                    self.value(e.get_ref(), at, key, leaf)?;
                }
                Ok(())
            }
            DeValue::Integer(_) | DeValue::Float(_) => {
                let Some((f, int)) = number(v) else {
                    return Ok(()); // the typed parse reports it
                };
                if !f.is_finite() {
                    let e = Error::Invalid {
                        key: key.to_string(),
                        problem: "must be finite (no NaN or infinity)",
                    };
                    return Err(located(self.path, self.text, at, e));
                }
                if let (Some(limit), Some(n)) = (count_bound(leaf), int) {
                    if n > limit as i128 {
                        return Err(self.err(at, key, format!("{n} exceeds the limit of {limit}")));
                    }
                    match leaf {
                        "samples" if !key.contains('.') => self.samples = Some(n.max(0) as u128),
                        "max_samples" => self.max_samples = Some(n.max(0) as u128),
                        _ => {}
                    }
                    return Ok(());
                }
                if leaf == "seed" {
                    return Ok(());
                }
                if leaf == "tolerance_mm" && f < MIN_ADAPTIVE_TOLERANCE_MM {
                    return Err(self.err(
                        at,
                        key,
                        format!("{f:e} is below the limit of {MIN_ADAPTIVE_TOLERANCE_MM:e} mm"),
                    ));
                }
                let (bound, unit) = magnitude_bound(leaf);
                if f.abs() > bound {
                    return Err(self.err(
                        at,
                        key,
                        format!("|{f:e}| exceeds the limit of {bound:e} {unit}")
                            .trim_end()
                            .to_string(),
                    ));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}

/// Checks the bounds of a scenario document (see the module docs); errors are located at the
/// offending value's line.
#[cfg(feature = "scenario")]
pub(crate) fn check_document(text: &str, path: &Path) -> Result<(), Error> {
    let Ok(doc) = DeTable::parse(text) else {
        return Ok(()); // syntax errors are reported by the typed parse
    };
    let mut w = Walk {
        text,
        path,
        axes: Vec::new(),
        samples: None,
        max_samples: None,
        grid_offset: None,
    };
    w.table(doc.get_ref(), "")?;
    if let (3, Some(at)) = (w.axes.len(), w.grid_offset) {
        let points: u128 = w.axes.iter().product();
        if points > MAX_GRID_POINTS as u128 {
            return Err(w.err(
                at,
                "grid",
                format!(
                    "{} × {} × {} = {points} grid points exceed the limit of {MAX_GRID_POINTS}",
                    w.axes[0], w.axes[1], w.axes[2]
                ),
            ));
        }
        let per_point = w.max_samples.or(w.samples).unwrap_or(2000);
        check_grid_draws(points as usize, per_point as usize)
            .map_err(|e| located(path, text, at, e))?;
    }
    Ok(())
}

/// Locates an error found after parsing (a study or chain error) in the scenario file `path`:
/// an error with a key gets that key's line, a gimbal-lock error the line of its camera's
/// `name`. Errors that already name the file, and files that cannot be read again, are returned
/// as they are, wrapped with the path and line 1 when nothing better is known.
#[cfg(feature = "scenario")]
pub fn locate(e: Error, path: &Path) -> Error {
    if matches!(
        e,
        Error::Located { .. } | Error::Toml { .. } | Error::Io { .. }
    ) {
        return e;
    }
    let Ok(text) = read_text(path) else {
        return e;
    };
    let line = match &e {
        Error::GimbalLock { name } => camera_name_line(&text, name),
        other => other.key().and_then(|k| key_line(&text, k)),
    };
    Error::Located {
        path: path.to_path_buf(),
        line: line.unwrap_or(1),
        source: Box::new(e),
    }
}

/// Line of `name = "<name>"` inside a `[[camera]]` table.
#[cfg(feature = "scenario")]
fn camera_name_line(text: &str, name: &str) -> Option<usize> {
    let doc = DeTable::parse(text).ok()?;
    let cams = doc.get_ref().get("camera")?;
    let DeValue::Array(a) = cams.get_ref() else {
        return None;
    };
    a.iter().find_map(|c| {
        let DeValue::Table(t) = c.get_ref() else {
            return None;
        };
        let n = t.get("name")?;
        (n.get_ref().as_str() == Some(name)).then(|| line_of(text, n.span().start))
    })
}

/// Checks points × draws per point against [`MAX_GRID_DRAWS`] (`key` = `grid`).
pub fn check_grid_draws(points: usize, per_point: usize) -> Result<(), Error> {
    let draws = points as u128 * per_point as u128;
    if draws > MAX_GRID_DRAWS as u128 {
        return Err(fail(
            "grid",
            format!(
                "{points} points × {per_point} draws = {draws} draws exceed the limit of {MAX_GRID_DRAWS}"
            ),
        ));
    }
    Ok(())
}

/// Checks a number of draws (`--samples`) against [`MAX_SAMPLES`].
pub fn check_samples(samples: usize) -> Result<(), Error> {
    if samples > MAX_SAMPLES {
        return Err(fail(
            "samples",
            format!("{samples} exceeds the limit of {MAX_SAMPLES}"),
        ));
    }
    Ok(())
}

/// 1-based line of a dotted scenario key such as `camera[1].position_mm`,
/// `grid.observer[0].sigma_from`, `grid.x_mm` or `seed`: the line `name = …` inside the table the
/// key's prefix names (the table's header line when the key names the table itself). Inline
/// tables and dotted keys are not searched (`None`).
pub(crate) fn key_line(text: &str, key: &str) -> Option<usize> {
    let headers: std::collections::HashSet<&str> = text.lines().filter_map(header_of).collect();
    let (base, index) = split_index(key);
    if headers.contains(base) {
        // The key names a table (or one element of an array of tables): its header line.
        return nth_header_line(text, base, index.unwrap_or(0));
    }
    let Some(dot) = key.rfind('.') else {
        // A top-level key: `key = …` before the first header.
        return text
            .lines()
            .take_while(|l| header_of(l).is_none())
            .position(|l| is_assignment_of(l, key))
            .map(|i| i + 1);
    };
    let (table_key, leaf) = (&key[..dot], &key[dot + 1..]);
    let (table, index) = split_index(table_key);
    let start = nth_header_line(text, table, index.unwrap_or(0))?;
    let found = text
        .lines()
        .enumerate()
        .skip(start)
        .take_while(|(_, l)| header_of(l).is_none())
        .find(|(_, l)| is_assignment_of(l, leaf))
        .map(|(i, _)| i + 1);
    // An absent key (a default, or a value checked against another table) points at its table.
    found.or(Some(start))
}

/// `("grid.observer", Some(1))` for `grid.observer[1]`, `("camera", None)` for `camera`.
fn split_index(key: &str) -> (&str, Option<usize>) {
    match key.strip_suffix(']').and_then(|k| k.rsplit_once('[')) {
        Some((base, i)) => (base, i.parse().ok()),
        None => (key, None),
    }
}

/// 1-based line of the `n`-th (0-based) header of table `name`.
fn nth_header_line(text: &str, name: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| header_of(l) == Some(name))
        .nth(n)
        .map(|(i, _)| i + 1)
}

/// Whether `line` assigns `name` (`name = …`).
fn is_assignment_of(line: &str, name: &str) -> bool {
    line.split_once('=')
        .is_some_and(|(lhs, _)| lhs.trim() == name)
}

/// `camera` for `[[camera]]`, `grid` for `[grid]` (comments after the header allowed).
fn header_of(line: &str) -> Option<&str> {
    let l = line.split('#').next().unwrap_or("").trim();
    if !l.starts_with('[') {
        return None;
    }
    let inner = l
        .strip_prefix("[[")
        .and_then(|r| r.strip_suffix("]]"))
        .or_else(|| l.strip_prefix('[').and_then(|r| r.strip_suffix(']')))?;
    Some(inner.trim())
}

// The tests read scenario documents.
#[cfg(all(test, feature = "scenario"))]
mod tests {
    use super::*;

    fn check(text: &str) -> String {
        match check_document(text, Path::new("s.toml")) {
            Ok(()) => "ok".into(),
            Err(e) => crashrig_input::message::error_line(&e),
        }
    }

    #[test]
    fn limits_wrong_lengths_name_key_and_line() {
        let t = "seed = 1\n[[camera]]\nname = \"a\"\nposition_mm = [10, 20, 30, 99999]\n";
        assert_eq!(
            check(t),
            "s.toml:4: `camera[0].position_mm`: must have exactly 3 values, found 4"
        );
        let t = "[grid]\nx_mm = [400, 2000, 5, 6]\n";
        assert_eq!(
            check(t),
            "s.toml:2: `grid.x_mm`: must have [start, stop, count]: exactly 3 values, found 4"
        );
        let t = "[grid]\nx_mm = [400, 2000]\n";
        assert!(
            check(t).starts_with("s.toml:2: `grid.x_mm`"),
            "{}",
            check(t)
        );
    }

    #[test]
    fn limits_counts_and_products() {
        assert_eq!(
            check("samples = 1000000000000000\n"),
            "s.toml:1: `samples`: 1000000000000000 exceeds the limit of 10000000"
        );
        assert!(check("samples = 10000000\n") == "ok");
        let t = "[grid]\nx_mm = [0, 1, 1000000000]\ny_mm = [0, 1, 2]\nz_mm = [0, 0, 1]\n";
        assert!(
            check(t).starts_with("s.toml:2: `grid.x_mm`: count 1000000000 exceeds"),
            "{}",
            check(t)
        );
        let t = "[grid]\nx_mm = [0, 1, 10000]\ny_mm = [0, 1, 10000]\nz_mm = [0, 0, 1]\n";
        assert!(
            check(t).starts_with("s.toml:1: `grid`: 10000 × 10000 × 1 = 100000000 grid points"),
            "{}",
            check(t)
        );
        // 1000 points × 10⁷ draws = 10¹⁰: at the limit; × 2 beyond it.
        let t =
            "samples = 10000000\n[grid]\nx_mm = [0, 1, 1000]\ny_mm = [0, 1, 1]\nz_mm = [0, 0, 1]\n";
        assert_eq!(check(t), "ok");
        let t =
            "samples = 10000000\n[grid]\nx_mm = [0, 1, 2000]\ny_mm = [0, 1, 1]\nz_mm = [0, 0, 1]\n";
        assert!(
            check(t).contains("20000000000 draws exceed"),
            "{}",
            check(t)
        );
        let t = "[grid]\n[grid.adaptive]\nmax_samples = 1000000000000000\n";
        assert!(
            check(t).starts_with("s.toml:3: `grid.adaptive.max_samples`"),
            "{}",
            check(t)
        );
        let t = "[grid]\n[grid.adaptive]\ntolerance_mm = 1e-12\n";
        assert!(
            check(t).starts_with("s.toml:3: `grid.adaptive.tolerance_mm`: 1e-12 is below"),
            "{}",
            check(t)
        );
    }

    #[test]
    fn limits_extreme_and_non_finite_values() {
        let t = "[[camera]]\nname = \"a\"\nsigma_position_mm = [1e300, 1, 1]\n";
        assert!(
            check(t).starts_with(
                "s.toml:3: `camera[0].sigma_position_mm`: |1e300| exceeds the limit of 1e7 mm"
            ),
            "{}",
            check(t)
        );
        let t = "[grid]\n[[grid.observer]]\nposition_mm = [1e308, 0, 0]\n";
        assert!(
            check(t).starts_with("s.toml:3: `grid.observer[0].position_mm`"),
            "{}",
            check(t)
        );
        let t = "[grid]\nthreshold_mm = nan\n";
        assert_eq!(
            check(t),
            "s.toml:2: `grid.threshold_mm`: must be finite (no NaN or infinity)"
        );
        let t = "[[camera]]\nangles_deg = [0, 0, -inf]\n";
        assert!(
            check(t).starts_with("s.toml:2: `camera[0].angles_deg`: must be finite"),
            "{}",
            check(t)
        );
        // At the bounds: fine.
        assert_eq!(check("[[camera]]\nposition_mm = [1e7, -1e7, 0]\n"), "ok");
    }

    #[test]
    fn limits_locate_gimbal_and_keyed_errors() {
        let dir = std::env::temp_dir().join(format!("crashrig-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("g.toml");
        std::fs::write(
            &path,
            "[[camera]]\nname = \"a\"\n[[camera]]\nname = \"b\"\n[grid]\n",
        )
        .unwrap();
        let e = locate(Error::GimbalLock { name: "b".into() }, &path);
        assert_eq!(
            crashrig_input::message::error_line(&e),
            format!(
                "{}:4: camera `b`: world orientation at gimbal lock (φ = ±90°)",
                path.display()
            )
        );
        let e = locate(Error::NoGrid, &path);
        assert!(
            crashrig_input::message::error_line(&e).starts_with(&format!("{}:5: ", path.display())),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn limits_deep_nesting_is_located() {
        let text = format!("a = 1\nb = {}1{}\n", "[".repeat(40), "]".repeat(40));
        assert_eq!(deep_nesting(&text), Some((2, 4 + MAX_NESTING + 1)));
        assert_eq!(
            deep_nesting("a = \"[[[[[[[[[[[[[[[[[[[[[[\" # [[[[[[[[[[[[[[[[[[[\n"),
            None
        );
    }
}
