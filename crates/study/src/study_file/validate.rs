//! The validator's context: the study file being read and the checks of its values, each
//! error naming the file, line and key.

use super::line_of;
use crate::Error;
use crashrig_geometry::{Mat6, Rigid3, UncertainPose, Vec3};
use std::path::{Path, PathBuf};
use toml::Spanned;

/// A number as the user would type it: `1e300`, not three hundred digits.
fn short(x: f64) -> String {
    if x.abs() >= 1e15 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

pub(super) struct Ctx<'a> {
    pub(super) path: &'a Path,
    pub(super) text: &'a str,
    pub(super) dir: PathBuf,
}

impl Ctx<'_> {
    pub(super) fn err<T>(
        &self,
        span: Option<std::ops::Range<usize>>,
        key: &str,
        message: impl Into<String>,
    ) -> Result<T, Error> {
        Err(Error::Key {
            path: self.path.to_path_buf(),
            line: span.map(|s| line_of(self.text, s.start)),
            key: key.to_string(),
            message: message.into(),
        })
    }

    pub(super) fn required<'v, T>(
        &self,
        v: &'v Option<Spanned<T>>,
        section: std::ops::Range<usize>,
        key: &str,
    ) -> Result<&'v Spanned<T>, Error> {
        match v {
            Some(s) => Ok(s),
            None => self.err(Some(section), key, "missing (required)"),
        }
    }

    /// A name (a camera selector, an image name) that must not be empty or blank: an empty
    /// camera prefix would select every image.
    pub(super) fn non_empty(&self, v: &Spanned<String>, key: &str) -> Result<String, Error> {
        if v.get_ref().trim().is_empty() {
            return self.err(Some(v.span()), key, "must not be empty");
        }
        Ok(v.get_ref().clone())
    }

    /// A path relative to the study file that must exist.
    pub(super) fn existing_path(
        &self,
        v: &Spanned<String>,
        key: &str,
        dir_expected: bool,
    ) -> Result<PathBuf, Error> {
        let p = self.dir.join(v.get_ref());
        let ok = if dir_expected {
            p.is_dir()
        } else {
            p.is_file()
        };
        if !ok {
            let what = if dir_expected { "directory" } else { "file" };
            return self.err(
                Some(v.span()),
                key,
                format!("{} does not exist or is not a {what}", p.display()),
            );
        }
        Ok(p)
    }

    /// A positive number; a length (a key ending in `_mm`) at most
    /// [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] (the scenario's bound, docs/LIMITS.md).
    pub(super) fn positive(&self, v: &Spanned<f64>, key: &str) -> Result<f64, Error> {
        let x = *v.get_ref();
        if !(x.is_finite() && x > 0.0) {
            return self.err(
                Some(v.span()),
                key,
                format!("must be a positive number, got {x}"),
            );
        }
        self.length_limit(v, key)
    }

    /// A number through one of `measure`'s [`crashrig_measure::rules`] (its problem at the
    /// key's line), and a length (a key ending in `_mm`) at most
    /// [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] as every length of a study file.
    pub(super) fn rule(
        &self,
        v: &Spanned<f64>,
        key: &str,
        rule: impl FnOnce(f64) -> Result<f64, String>,
    ) -> Result<f64, Error> {
        rule(*v.get_ref()).or_else(|p| self.err(Some(v.span()), key, p))?;
        self.length_limit(v, key)
    }

    /// `v` itself when it is no length (its key does not end in `_mm`) or a length at most
    /// [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] (the scenario's bound, docs/LIMITS.md).
    fn length_limit(&self, v: &Spanned<f64>, key: &str) -> Result<f64, Error> {
        let x = *v.get_ref();
        let max = crashrig_mc::limits::MAX_ABS_LENGTH_MM;
        if key.ends_with("_mm") && x.abs() > max {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{} mm exceeds the limit of {max} mm (10 km; docs/LIMITS.md)",
                    short(x)
                ),
            );
        }
        Ok(x)
    }

    /// A model scale (mm per model unit) within [`crashrig_measure::input::MM_PER_UNIT_RANGE`]
    /// ([`crashrig_input::options::mm_per_unit_problem`], every command's rule).
    pub(super) fn scale(&self, v: &Spanned<f64>, key: &str) -> Result<f64, Error> {
        let x = *v.get_ref();
        match crashrig_input::options::mm_per_unit_problem(x) {
            Some(p) => self.err(Some(v.span()), key, format!("{p}, got {x}")),
            None => Ok(x),
        }
    }

    /// A count of work `min ..= max` (checked before anything is allocated or run).
    pub(super) fn count(
        &self,
        v: &Spanned<i64>,
        key: &str,
        min: i64,
        max: usize,
    ) -> Result<usize, Error> {
        let x = *v.get_ref();
        if x < min {
            return self.err(
                Some(v.span()),
                key,
                format!("must be at least {min}, got {x}"),
            );
        }
        if x as u64 > max as u64 {
            return self.err(
                Some(v.span()),
                key,
                format!("{x} exceeds the limit of {max}"),
            );
        }
        Ok(x as usize)
    }

    /// Three finite numbers, each within the scenario's bound of its unit (docs/LIMITS.md):
    /// |v| ≤ [`crashrig_mc::limits::MAX_ABS_LENGTH_MM`] under a key ending in `_mm`, ≤
    /// [`crashrig_mc::limits::MAX_ABS_ANGLE_DEG`] under one ending in `_deg`.
    pub(super) fn finite3(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vec3, Error> {
        use crashrig_mc::limits::{MAX_ABS_ANGLE_DEG, MAX_ABS_LENGTH_MM};
        let a = v.get_ref();
        if a.iter().any(|x| !x.is_finite()) {
            return self.err(Some(v.span()), key, "values must be finite");
        }
        let bound = if key.ends_with("_mm") {
            Some((MAX_ABS_LENGTH_MM, " mm", " (10 km)"))
        } else if key.ends_with("_deg") {
            Some((MAX_ABS_ANGLE_DEG, "°", ""))
        } else {
            None
        };
        if let Some((max, unit, what)) = bound
            && let Some(x) = a.iter().find(|x| x.abs() > max)
        {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{x}{unit} exceeds the limit of {max}{unit}{what} in size (docs/LIMITS.md)"
                ),
            );
        }
        Ok(Vec3::new(a[0], a[1], a[2]))
    }

    pub(super) fn sigma3(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vec3, Error> {
        let s = self.finite3(v, key)?;
        if s.iter().any(|x| *x < 0.0) {
            return self.err(Some(v.span()), key, "σ must not be negative");
        }
        Ok(s)
    }

    /// `covariance_tangent` (mm, deg) → covariance (mm, rad).
    pub(super) fn covariance(&self, v: &Spanned<Vec<Vec<f64>>>, key: &str) -> Result<Mat6, Error> {
        let rows = v.get_ref();
        if rows.len() != 6 || rows.iter().any(|r| r.len() != 6) {
            return self.err(
                Some(v.span()),
                key,
                "must be 6 rows of 6 numbers (x y z mm, θx θy θz deg)",
            );
        }
        let m = Mat6::from_fn(|i, j| rows[i][j]);
        match UncertainPose::from_covariance_deg(Rigid3::identity(), m) {
            Ok(p) => Ok(p.covariance),
            Err(problem) => self.err(Some(v.span()), key, problem.to_string()),
        }
    }

    /// σ keys or `covariance_tangent` (exactly one form) → covariance (mm, rad).
    pub(super) fn noise(
        &self,
        section: std::ops::Range<usize>,
        prefix: &str,
        sp: &Option<Spanned<[f64; 3]>>,
        sa: &Option<Spanned<[f64; 3]>>,
        cov: &Option<Spanned<Vec<Vec<f64>>>>,
    ) -> Result<Mat6, Error> {
        let k = |f: &str| format!("{prefix}.{f}");
        match (sp, sa, cov) {
            (None, None, Some(c)) => self.covariance(c, &k("covariance_tangent")),
            (Some(p), Some(a), None) => {
                let p = self.sigma3(p, &k("sigma_position_mm"))?;
                let a = self.sigma3(a, &k("sigma_angles_deg"))?.map(f64::to_radians);
                Ok(UncertainPose::from_sigmas(Rigid3::identity(), p, a).covariance)
            }
            (_, _, Some(c)) => self.err(
                Some(c.span()),
                &k("covariance_tangent"),
                "give either covariance_tangent or sigma_position_mm + sigma_angles_deg, not both",
            ),
            (None, _, None) => self.err(
                Some(section),
                &k("sigma_position_mm"),
                "missing (or give covariance_tangent)",
            ),
            (_, None, None) => self.err(
                Some(section),
                &k("sigma_angles_deg"),
                "missing (or give covariance_tangent)",
            ),
        }
    }

    pub(super) fn axis(
        &self,
        v: &Option<Spanned<[f64; 3]>>,
        section: std::ops::Range<usize>,
        key: &str,
    ) -> Result<(f64, f64, usize), Error> {
        let v = self.required(v, section, key)?;
        let a = v.get_ref();
        let c = a[2];
        if !(a[0].is_finite() && a[1].is_finite()) || c < 1.0 || c.fract() != 0.0 {
            return self.err(
                Some(v.span()),
                key,
                "must be [start, stop, count] with finite mm and a whole count ≥ 1",
            );
        }
        let max_mm = crashrig_mc::limits::MAX_ABS_LENGTH_MM;
        if let Some(x) = a[..2].iter().find(|x| x.abs() > max_mm) {
            return self.err(
                Some(v.span()),
                key,
                format!(
                    "{} mm exceeds the limit of {max_mm} mm (10 km) in size (docs/LIMITS.md)",
                    short(*x)
                ),
            );
        }
        let max = crashrig_mc::limits::MAX_AXIS_COUNT;
        if c > max as f64 {
            return self.err(
                Some(v.span()),
                key,
                format!("count {c} exceeds the limit of {max} values per axis"),
            );
        }
        let axis = crashrig_mc::Axis {
            start: a[0],
            stop: a[1],
            count: c as usize,
        };
        if let Some(problem) = axis.problem() {
            return self.err(Some(v.span()), key, problem);
        }
        Ok((a[0], a[1], c as usize))
    }
}

/// A missing section has no line of its own: the file's first line.
pub(super) fn missing_section(cx: &Ctx<'_>, name: &str) -> Error {
    Error::Key {
        path: cx.path.to_path_buf(),
        line: Some(1),
        key: name.to_string(),
        message: "missing section (required)".into(),
    }
}
