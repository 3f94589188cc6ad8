//! Fixed observers (`aim = "fixed"`): a camera bolted in place with a real lens.
//!
//! Parsed from the keys `aim`, `angles_deg` / `look_at_mm`, `camera = { model, width, height,
//! params }` / `camera_from = "<model dir>:<camera id>"` and `pixel_sigma_px` of a
//! `[[grid.observer]]` (contract: `docs/REFERENCE.md` → `docs/FIXED_CAMERAS.md`, "Fixed cameras with
//! real lenses").

use super::{RawObserver, finite3};
use crate::error::Error;
use crate::model::{Aim, FixedCamera};
use crashrig_camera::{Camera as Lens, ModelId};
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::Path;

/// The inline table `camera = { model, width, height, params }` as written (validated by
/// [`aim_from_keys`]).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LensKeys {
    /// COLMAP model name, e.g. `OPENCV`.
    pub model: String,
    /// Image width (px).
    pub width: i64,
    /// Image height (px).
    pub height: i64,
    /// Parameters in COLMAP's order.
    pub params: Vec<f64>,
}

/// The keys of an observer that decide how it aims, as any front end (a scenario's
/// `[[grid.observer]]`, a study's `[[layout.observer]]`) reads them.
#[derive(Debug, Clone, Copy, Default)]
pub struct AimKeys<'a> {
    /// `aim`: `"point"` (default) or `"fixed"`.
    pub aim: Option<&'a str>,
    /// `angles_deg`: ω φ κ of `R_world_from_cam` (deg).
    pub angles_deg: Option<[f64; 3]>,
    /// `look_at_mm`: a target on the optical axis (world mm), no roll.
    pub look_at_mm: Option<[f64; 3]>,
    /// `camera = { … }`.
    pub camera: Option<&'a LensKeys>,
    /// `camera_from = "<model dir>:<camera id>"` (relative to `base` of [`aim_from_keys`]).
    pub camera_from: Option<&'a str>,
    /// `pixel_sigma_px`.
    pub pixel_sigma_px: Option<f64>,
}

fn invalid(key: String, problem: &'static str) -> Error {
    Error::Invalid { key, problem }
}

/// The [`Aim`] of an observer at `position` from its keys; errors name `{prefix}.{key}`
/// (e.g. `grid.observer[2].camera`), and `camera_from` paths are relative to `base`. The one
/// reader of these keys for scenarios and studies (rules: `docs/FIXED_CAMERAS.md`).
///
/// # Errors
/// [`Error::Invalid`], [`Error::Camera`], [`Error::ColmapModel`], [`Error::NoSuchCamera`]
/// naming the key: fixed-camera keys on an aimed observer, an unknown `aim`, neither or both of
/// `angles_deg`/`look_at_mm` or of `camera`/`camera_from`, non-finite values, an invalid lens.
pub fn aim_from_keys(
    keys: &AimKeys<'_>,
    prefix: &str,
    position: &Vector3<f64>,
    base: &Path,
) -> Result<Aim, Error> {
    let k = |f: &str| format!("{prefix}.{f}");
    match keys.aim.unwrap_or("point") {
        "point" => {
            let extra = [
                ("angles_deg", keys.angles_deg.is_some()),
                ("look_at_mm", keys.look_at_mm.is_some()),
                ("camera", keys.camera.is_some()),
                ("camera_from", keys.camera_from.is_some()),
                ("pixel_sigma_px", keys.pixel_sigma_px.is_some()),
            ];
            if let Some((name, _)) = extra.iter().find(|(_, set)| *set) {
                return Err(invalid(
                    k(name),
                    "is only allowed with aim = \"fixed\" (an aimed observer takes the pixel noise of its grid or layout: pixel_sigma_px and focal_px)",
                ));
            }
            Ok(Aim::Point)
        }
        "fixed" => fixed_from_keys(keys, &k, position, base).map(|f| Aim::Fixed(Box::new(f))),
        _ => Err(invalid(k("aim"), "must be \"point\" or \"fixed\"")),
    }
}

/// The [`Aim`] of the observer table `prefix` (e.g. `grid.observer[2]`, `candidate[0]`).
pub(super) fn aim_from_raw(
    prefix: &str,
    o: &RawObserver,
    position: &Vector3<f64>,
    base: &Path,
) -> Result<Aim, Error> {
    let keys = AimKeys {
        aim: o.aim.as_deref(),
        angles_deg: o.angles_deg,
        look_at_mm: o.look_at_mm,
        camera: o.camera.as_ref(),
        camera_from: o.camera_from.as_deref(),
        pixel_sigma_px: o.pixel_sigma_px,
    };
    aim_from_keys(&keys, prefix, position, base)
}

fn fixed_from_keys(
    o: &AimKeys<'_>,
    k: &dyn Fn(&str) -> String,
    position: &Vector3<f64>,
    base: &Path,
) -> Result<FixedCamera, Error> {
    let rotation = match (o.angles_deg, o.look_at_mm) {
        (Some(a), None) => {
            let a = finite3(k("angles_deg"), a)?.map(f64::to_radians);
            *crashrig_geometry::opk::rotation_from_opk(a.x, a.y, a.z).matrix()
        }
        (None, Some(t)) => {
            let t = finite3(k("look_at_mm"), t)?;
            crashrig_geometry::look_at::world_from_cam_look_at(position, &t)
                .map_err(|_| {
                    invalid(
                        k("look_at_mm"),
                        "must differ from position_mm and not lie straight above or below it (the no-roll aim is undefined)",
                    )
                })?
                .into_inner()
        }
        (Some(_), Some(_)) => {
            return Err(invalid(
                k("look_at_mm"),
                "give either angles_deg or look_at_mm for a fixed observer, not both",
            ));
        }
        (None, None) => {
            return Err(invalid(
                k("angles_deg"),
                "is missing: a fixed observer needs angles_deg (ω φ κ of R_world_from_cam) or look_at_mm",
            ));
        }
    };
    let opk = crashrig_geometry::opk::opk_from_rotation(
        &nalgebra::Rotation3::from_matrix_unchecked(rotation),
    );
    let lens = match (o.camera, o.camera_from) {
        (Some(raw), None) => lens_from_raw(k("camera"), raw)?,
        (None, Some(spec)) => lens_from_model(k("camera_from"), spec, base)?,
        (Some(_), Some(_)) => {
            return Err(invalid(
                k("camera_from"),
                "give either camera or camera_from for a fixed observer, not both",
            ));
        }
        (None, None) => {
            return Err(invalid(
                k("camera"),
                "is missing: a fixed observer needs camera = { model, width, height, params } or camera_from",
            ));
        }
    };
    if lens.model == ModelId::Equirectangular {
        return Err(invalid(
            k("camera"),
            "EQUIRECTANGULAR has no optical axis; use a perspective or fisheye model",
        ));
    }
    let pixel_sigma_px = o.pixel_sigma_px.unwrap_or(0.0);
    if !pixel_sigma_px.is_finite() || pixel_sigma_px < 0.0 {
        return Err(invalid(
            k("pixel_sigma_px"),
            "σ must be finite and not negative",
        ));
    }
    Ok(FixedCamera {
        rotation,
        angles_rad: Vector3::new(opk.omega, opk.phi, opk.kappa),
        lens,
        pixel_sigma_px,
    })
}

fn lens_from_raw(key: String, raw: &LensKeys) -> Result<Lens, Error> {
    let model = ModelId::from_name(&raw.model).map_err(|source| Error::Camera {
        key: key.clone(),
        source,
    })?;
    let size = |v: i64| u64::try_from(v).ok().filter(|v| *v > 0);
    let (Some(width), Some(height)) = (size(raw.width), size(raw.height)) else {
        return Err(invalid(key, "width and height must be positive integers"));
    };
    Lens::new(model, width, height, raw.params.clone())
        .map_err(|source| Error::Camera { key, source })
}

fn lens_from_model(key: String, spec: &str, base: &Path) -> Result<Lens, Error> {
    let Some((dir, id)) = spec.rsplit_once(':') else {
        return Err(invalid(key, "must be \"<model dir>:<camera id>\""));
    };
    let Ok(id) = id.trim().parse::<u32>() else {
        return Err(invalid(
            key,
            "the camera id after ':' must be a non-negative integer",
        ));
    };
    let dir = base.join(dir);
    let model =
        crashrig_colmap::Reconstruction::read(&dir).map_err(|source| Error::ColmapModel {
            key: key.clone(),
            source: Box::new(source),
        })?;
    let Some(record) = model.camera(id) else {
        return Err(Error::NoSuchCamera {
            key,
            dir,
            camera_id: id,
        });
    };
    let lens = record.camera.clone();
    lens.validate().map_err(|source| Error::Camera {
        key: key.clone(),
        source,
    })?;
    if lens.width == 0 || lens.height == 0 {
        return Err(invalid(key, "the model's camera has width or height 0"));
    }
    Ok(lens)
}
