//! Fixed observers of a study layout (`aim = "fixed"`): the keys of a scenario's fixed
//! `[[grid.observer]]` (`angles_deg` or `look_at_mm`, `camera = { model, width, height,
//! params }` or `camera_from = "<model dir>:<camera id>"`, `pixel_sigma_px`), read into the
//! Monte Carlo library's own [`FixedCamera`] so the grid runs them through
//! [`crashrig_mc::GridBuilder::fixed_observer`] exactly as `crashrig grid` does.
//!
//! The rules are those of the scenario (`docs/FIXED_CAMERAS.md`); the errors name the study
//! file, the key (`layout[i].observer[j].camera`) and its line.

use crate::Error;
use crashrig_camera::{Camera as Lens, ModelId};
use crashrig_mc::FixedCamera;
use nalgebra::Vector3;
use serde::Deserialize;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The inline table `camera = { model, width, height, params }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLens {
    model: String,
    width: i64,
    height: i64,
    params: Vec<f64>,
}

/// The fixed-camera keys of a `[[layout.observer]]`.
pub(crate) struct RawFixed<'a> {
    pub aim: &'a Option<Spanned<String>>,
    pub angles_deg: &'a Option<Spanned<[f64; 3]>>,
    pub look_at_mm: &'a Option<Spanned<[f64; 3]>>,
    pub camera: &'a Option<Spanned<RawLens>>,
    pub camera_from: &'a Option<Spanned<String>>,
    pub pixel_sigma_px: &'a Option<Spanned<f64>>,
}

/// Where errors point: the study file, its text, the observer's key prefix and span.
pub(crate) struct Site<'a> {
    pub path: &'a Path,
    pub text: &'a str,
    pub dir: &'a Path,
    pub prefix: String,
    pub span: Range<usize>,
}

impl Site<'_> {
    fn err<T>(
        &self,
        span: Option<Range<usize>>,
        key: &str,
        message: impl Into<String>,
    ) -> Result<T, Error> {
        let span = span.unwrap_or_else(|| self.span.clone());
        Err(Error::Key {
            path: self.path.to_path_buf(),
            line: Some(crate::study_file::line_of(self.text, span.start)),
            key: format!("{}.{key}", self.prefix),
            message: message.into(),
        })
    }
}

/// `None` for an aimed observer (`aim` absent or `"point"`; the fixed keys are then errors),
/// the fixed camera for `aim = "fixed"`.
pub(crate) fn fixed_from_raw(
    site: &Site<'_>,
    raw: &RawFixed<'_>,
    position: &Vector3<f64>,
) -> Result<Option<FixedCamera>, Error> {
    match raw.aim.as_ref().map(|a| (a.get_ref().as_str(), a.span())) {
        None | Some(("point", _)) => {
            let extra = [
                ("angles_deg", raw.angles_deg.as_ref().map(Spanned::span)),
                ("look_at_mm", raw.look_at_mm.as_ref().map(Spanned::span)),
                ("camera", raw.camera.as_ref().map(Spanned::span)),
                ("camera_from", raw.camera_from.as_ref().map(Spanned::span)),
                (
                    "pixel_sigma_px",
                    raw.pixel_sigma_px.as_ref().map(Spanned::span),
                ),
            ];
            if let Some((name, Some(span))) = extra.into_iter().find(|(_, s)| s.is_some()) {
                return site.err(
                    Some(span),
                    name,
                    "is only allowed with aim = \"fixed\" (an aimed observer takes the layout's pixel_sigma_px and focal_px)",
                );
            }
            Ok(None)
        }
        Some(("fixed", _)) => fixed(site, raw, position).map(Some),
        Some((other, span)) => site.err(
            Some(span),
            "aim",
            format!("must be \"point\" or \"fixed\", got {other:?}"),
        ),
    }
}

fn finite3(site: &Site<'_>, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vector3<f64>, Error> {
    let a = v.get_ref();
    if a.iter().any(|x| !x.is_finite()) {
        return site.err(Some(v.span()), key, "values must be finite");
    }
    Ok(Vector3::new(a[0], a[1], a[2]))
}

fn fixed(
    site: &Site<'_>,
    raw: &RawFixed<'_>,
    position: &Vector3<f64>,
) -> Result<FixedCamera, Error> {
    let rotation = match (raw.angles_deg, raw.look_at_mm) {
        (Some(a), None) => {
            let a = finite3(site, a, "angles_deg")?.map(f64::to_radians);
            *crashrig_geometry::opk::rotation_from_opk(a.x, a.y, a.z).matrix()
        }
        (None, Some(t)) => {
            let target = finite3(site, t, "look_at_mm")?;
            match crashrig_geometry::look_at::world_from_cam_look_at(position, &target) {
                Ok(r) => r.into_inner(),
                Err(_) => {
                    return site.err(
                        Some(t.span()),
                        "look_at_mm",
                        "must differ from position_mm and not lie straight above or below it (the no-roll aim is undefined)",
                    );
                }
            }
        }
        (Some(_), Some(t)) => {
            return site.err(
                Some(t.span()),
                "look_at_mm",
                "give either angles_deg or look_at_mm for a fixed observer, not both",
            );
        }
        (None, None) => {
            return site.err(
                None,
                "angles_deg",
                "is missing: a fixed observer needs angles_deg (ω φ κ of R_world_from_cam) or look_at_mm",
            );
        }
    };
    let opk = crashrig_geometry::opk::opk_from_rotation(
        &nalgebra::Rotation3::from_matrix_unchecked(rotation),
    );
    let lens = match (raw.camera, raw.camera_from) {
        (Some(c), None) => lens_from_raw(site, c)?,
        (None, Some(spec)) => lens_from_model(site, spec)?,
        (Some(_), Some(spec)) => {
            return site.err(
                Some(spec.span()),
                "camera_from",
                "give either camera or camera_from for a fixed observer, not both",
            );
        }
        (None, None) => {
            return site.err(
                None,
                "camera",
                "is missing: a fixed observer needs camera = { model, width, height, params } or camera_from",
            );
        }
    };
    if lens.model == ModelId::Equirectangular {
        return site.err(
            raw.camera.as_ref().map(Spanned::span),
            "camera",
            "EQUIRECTANGULAR has no optical axis; use a perspective or fisheye model",
        );
    }
    let pixel_sigma_px = match raw.pixel_sigma_px {
        None => 0.0,
        Some(s) => {
            let v = *s.get_ref();
            if !(v.is_finite() && v >= 0.0) {
                return site.err(
                    Some(s.span()),
                    "pixel_sigma_px",
                    "σ must be finite and not negative",
                );
            }
            v
        }
    };
    Ok(FixedCamera {
        rotation,
        angles_rad: Vector3::new(opk.omega, opk.phi, opk.kappa),
        lens,
        pixel_sigma_px,
    })
}

fn lens_from_raw(site: &Site<'_>, c: &Spanned<RawLens>) -> Result<Lens, Error> {
    let raw = c.get_ref();
    let model = match ModelId::from_name(&raw.model) {
        Ok(m) => m,
        Err(e) => return site.err(Some(c.span()), "camera", e.to_string()),
    };
    let size = |v: i64| u64::try_from(v).ok().filter(|v| *v > 0);
    let (Some(width), Some(height)) = (size(raw.width), size(raw.height)) else {
        return site.err(
            Some(c.span()),
            "camera",
            "width and height must be positive integers",
        );
    };
    Lens::new(model, width, height, raw.params.clone())
        .or_else(|e| site.err(Some(c.span()), "camera", e.to_string()))
}

fn lens_from_model(site: &Site<'_>, spec: &Spanned<String>) -> Result<Lens, Error> {
    let span = Some(spec.span());
    let Some((dir, id)) = spec.get_ref().rsplit_once(':') else {
        return site.err(span, "camera_from", "must be \"<model dir>:<camera id>\"");
    };
    let Ok(id) = id.trim().parse::<u32>() else {
        return site.err(
            span,
            "camera_from",
            "the camera id after ':' must be a non-negative integer",
        );
    };
    let dir: PathBuf = site.dir.join(dir);
    let model = match crashrig_colmap::Reconstruction::read(&dir) {
        Ok(m) => m,
        Err(e) => return site.err(span, "camera_from", format!("{}: {e}", dir.display())),
    };
    let Some(record) = model.camera(id) else {
        return site.err(
            span,
            "camera_from",
            format!("the model {} has no camera {id}", dir.display()),
        );
    };
    let lens = record.camera.clone();
    if let Err(e) = lens.validate() {
        return site.err(span, "camera_from", e.to_string());
    }
    if lens.width == 0 || lens.height == 0 {
        return site.err(
            span,
            "camera_from",
            "the model's camera has width or height 0",
        );
    }
    Ok(lens)
}
