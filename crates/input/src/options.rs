//! Options as a front end gives them (the CLI's flags, Python's keywords): how their names are
//! spelled in messages, the range of a model scale, and the scale options of `calibrate` and
//! `covariance` (a factor or a scale bar).
//!
//! ```
//! use crashrig_input::options::{GivenScale, ScaleOptions, Spelling};
//! let o = ScaleOptions { mm_per_unit: Some(1000.0), ..ScaleOptions::default() };
//! assert_eq!(o.given(Spelling::Flag)?, Some(GivenScale::MmPerUnit(1000.0)));
//! let both = ScaleOptions { scale_points: Some(vec![1, 2]), ..o };
//! let e = both.given(Spelling::Keyword).unwrap_err().to_string();
//! assert!(e.starts_with("scale_points and scale_length_mm go together"), "{e}");
//! # Ok::<(), crashrig_input::Error>(())
//! ```

use crate::Error;

/// How option names are spelled in messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spelling {
    /// The CLI's flags: `--mm-per-unit`.
    Flag,
    /// Python's keyword arguments: `mm_per_unit`.
    Keyword,
}

/// The options whose names appear in messages, as (keyword, flag).
const NAMES: &[(&str, &str)] = &[
    ("a_covariance", "--a-covariance"),
    ("camera_c", "--camera-c"),
    ("cfc", "--cfc"),
    ("cfc_standard", "--cfc-standard"),
    ("frame_rate_hz", "--frame-rate-hz"),
    ("mm_per_unit", "--mm-per-unit"),
    ("mpe_mm", "--mpe-mm"),
    ("pixel_sigma_px", "--pixel-sigma-px"),
    ("scale_bars", "--scale-bars"),
    ("scale_length_mm", "--scale-length-mm"),
    ("scale_points", "--scale-points"),
    ("sigma_a_angles_deg", "--sigma-a-angles-deg"),
    ("sigma_a_position_mm", "--sigma-a-position-mm"),
    ("tie", "--tie"),
];

impl Spelling {
    /// The option `keyword` (snake_case, one of the options named in messages) as this front end
    /// spells it; an unknown keyword is returned as it is.
    pub fn name(self, keyword: &'static str) -> &'static str {
        match self {
            Spelling::Keyword => keyword,
            Spelling::Flag => NAMES
                .iter()
                .find(|(k, _)| *k == keyword)
                .map_or(keyword, |(_, flag)| flag),
        }
    }
}

/// The plausible range of a model scale (mm per model unit) every command accepts.
pub const MM_PER_UNIT_RANGE: (f64, f64) = (1e-9, 1e9);

/// Why `f` is not a model scale every command accepts (`None`: it is).
pub fn mm_per_unit_problem(f: f64) -> Option<String> {
    let (lo, hi) = MM_PER_UNIT_RANGE;
    (!(f.is_finite() && (lo..=hi).contains(&f)))
        .then(|| format!("must be a number from {lo:e} to {hi:e} mm per model unit"))
}

/// `f` within [`MM_PER_UNIT_RANGE`].
///
/// # Errors
/// [`Error::Usage`] naming the option (`name`) and the range.
pub fn check_mm_per_unit(f: f64, name: &str) -> Result<f64, Error> {
    match mm_per_unit_problem(f) {
        Some(problem) => Err(Error::Usage(format!("{name}: {problem}"))),
        None => Ok(f),
    }
}

/// The scale of a model as the options give it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GivenScale {
    /// A factor: millimetres per model unit.
    MmPerUnit(f64),
    /// Two point3D ids a known distance apart.
    ScaleBar {
        /// The two point3D ids.
        points: [u64; 2],
        /// Their distance (mm).
        length_mm: f64,
    },
}

/// The scale options of `calibrate` and `covariance`: a factor or a scale bar.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScaleOptions {
    /// Two point3D ids a known distance apart (`--scale-points ID1 ID2`).
    pub scale_points: Option<Vec<u64>>,
    /// Their distance in mm (`--scale-length-mm`).
    pub scale_length_mm: Option<f64>,
    /// Millimetres per model unit (`--mm-per-unit`).
    pub mm_per_unit: Option<f64>,
}

impl ScaleOptions {
    /// The scale given (`None`: neither a factor nor a scale bar).
    ///
    /// # Errors
    /// [`Error::Usage`] with the names in `spelling`: a scale bar without its length or
    /// without its points, not exactly two points, a bar and a factor together, a factor out
    /// of [`MM_PER_UNIT_RANGE`].
    pub fn given(&self, spelling: Spelling) -> Result<Option<GivenScale>, Error> {
        let name = |k| spelling.name(k);
        let bar = match (&self.scale_points, self.scale_length_mm) {
            (None, None) => None,
            (Some(p), Some(length_mm)) if p.len() == 2 => Some(([p[0], p[1]], length_mm)),
            (Some(_), Some(_)) => {
                return Err(Error::Usage(format!(
                    "{}: give exactly two point3D ids",
                    name("scale_points")
                )));
            }
            _ => {
                return Err(Error::Usage(format!(
                    "{} and {} go together (a scale bar: two point3D ids and their distance in mm)",
                    name("scale_points"),
                    name("scale_length_mm")
                )));
            }
        };
        let factor = self
            .mm_per_unit
            .map(|f| check_mm_per_unit(f, name("mm_per_unit")))
            .transpose()?;
        match (bar, factor) {
            (Some(_), Some(_)) => Err(Error::Usage(format!(
                "{} and {} exclude each other (give a scale bar or a factor)",
                name("scale_points"),
                name("mm_per_unit")
            ))),
            (Some((points, length_mm)), None) => {
                Ok(Some(GivenScale::ScaleBar { points, length_mm }))
            }
            (None, Some(f)) => Ok(Some(GivenScale::MmPerUnit(f))),
            (None, None) => Ok(None),
        }
    }

    /// The scale given, which must be given.
    ///
    /// # Errors
    /// As [`ScaleOptions::given`], and [`Error::Usage`] when neither a factor nor a scale bar
    /// is given.
    pub fn required(&self, spelling: Spelling) -> Result<GivenScale, Error> {
        self.given(spelling)?.ok_or_else(|| {
            Error::Usage(format!(
                "give {} or a scale bar ({} and {})",
                spelling.name("mm_per_unit"),
                spelling.name("scale_points"),
                spelling.name("scale_length_mm")
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(o: &ScaleOptions, spelling: Spelling) -> String {
        o.given(spelling).unwrap_err().to_string()
    }

    #[test]
    fn flags_and_keywords_are_spelled_as_each_front_end_writes_them() {
        assert_eq!(
            Spelling::Flag.name("sigma_a_position_mm"),
            "--sigma-a-position-mm"
        );
        assert_eq!(
            Spelling::Keyword.name("sigma_a_position_mm"),
            "sigma_a_position_mm"
        );
        // Every flag is its keyword with dashes.
        for (k, f) in NAMES {
            assert_eq!(*f, format!("--{}", k.replace('_', "-")));
        }
    }

    #[test]
    fn scale_options_give_one_scale_or_say_what_is_wrong() {
        let bar = ScaleOptions {
            scale_points: Some(vec![3, 7]),
            scale_length_mm: Some(500.0),
            mm_per_unit: None,
        };
        assert_eq!(
            bar.given(Spelling::Flag).unwrap(),
            Some(GivenScale::ScaleBar {
                points: [3, 7],
                length_mm: 500.0
            })
        );
        assert_eq!(ScaleOptions::default().given(Spelling::Flag).unwrap(), None);
        let three = ScaleOptions {
            scale_points: Some(vec![1, 2, 3]),
            ..bar.clone()
        };
        assert_eq!(
            message(&three, Spelling::Keyword),
            "scale_points: give exactly two point3D ids"
        );
        let both = ScaleOptions {
            mm_per_unit: Some(2.0),
            ..bar.clone()
        };
        assert_eq!(
            message(&both, Spelling::Flag),
            "--scale-points and --mm-per-unit exclude each other (give a scale bar or a factor)"
        );
        let far = ScaleOptions {
            mm_per_unit: Some(1e10),
            ..ScaleOptions::default()
        };
        assert_eq!(
            message(&far, Spelling::Keyword),
            "mm_per_unit: must be a number from 1e-9 to 1e9 mm per model unit"
        );
        let e = ScaleOptions::default()
            .required(Spelling::Keyword)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "give mm_per_unit or a scale bar (scale_points and scale_length_mm)"
        );
    }
}
