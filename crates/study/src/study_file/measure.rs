//! The `[measure]` section: a crash-test sequence measured with the study's link (and tie).

use super::raw::RawMeasure;
use super::validate::Ctx;
use super::{ABundle, MeasureANoise, MeasureSection};
use crate::Error;
use crashrig_geometry::Vec3;
use crashrig_measure::input::FrameTimes;
use crashrig_measure::pixel_check::PixelSigmaFrom;
use crashrig_measure::{MeasureOptions, rules};
use std::path::{Path, PathBuf};
use toml::Spanned;

/// `a_control_points` and its companions → [`MeasureANoise::Bundle`]; the companions without
/// `a_control_points`, or `a_control_points` with another source of A's σ, are errors.
fn a_bundle(cx: &Ctx<'_>, m: &RawMeasure, model: &Path) -> Result<MeasureANoise, Error> {
    let Some(cp) = &m.a_control_points else {
        unreachable!("called with a_control_points")
    };
    if m.a_covariance.is_some() || m.sigma_a_position_mm.is_some() || m.sigma_a_angles_deg.is_some()
    {
        return cx.err(
            Some(cp.span()),
            "measure.a_control_points",
            "give one source of A's σ: a_control_points (from the bundle), a_covariance, or sigma_a_position_mm / sigma_a_angles_deg",
        );
    }
    let control_points = cx.existing_path(cp, "measure.a_control_points", false)?;
    let model = match &m.a_model {
        Some(v) => cx.existing_path(v, "measure.a_model", true)?,
        None => model.to_path_buf(),
    };
    let pixel_sigma_px = m
        .a_pixel_sigma_px
        .as_ref()
        .map(|v| cx.positive(v, "measure.a_pixel_sigma_px"))
        .transpose()?;
    let intrinsics = match &m.a_intrinsics {
        None => crashrig_covariance::Intrinsics::All,
        Some(v) => crashrig_covariance::Intrinsics::parse(v.get_ref()).map_or_else(
            || {
                cx.err(
                    Some(v.span()),
                    "measure.a_intrinsics",
                    format!("`{}`: must be all, colmap or fixed", v.get_ref()),
                )
            },
            Ok,
        )?,
    };
    Ok(MeasureANoise::Bundle(ABundle {
        model,
        control_points,
        pixel_sigma_px,
        intrinsics,
    }))
}

pub(super) fn measure_section(
    cx: &Ctx<'_>,
    m: &Spanned<RawMeasure>,
    has_tie: bool,
) -> Result<MeasureSection, Error> {
    let ms = m.span();
    let m = m.get_ref();
    let req = |v: &Option<Spanned<String>>, key: &str| -> Result<Spanned<String>, Error> {
        cx.required(v, ms.clone(), key).cloned()
    };
    let model = cx.existing_path(&req(&m.model, "measure.model")?, "measure.model", true)?;
    let observations = cx.existing_path(
        &req(&m.observations, "measure.observations")?,
        "measure.observations",
        false,
    )?;
    // A marker needs two views: camera B alone measures nothing.
    let Some(c) = &m.camera_c else {
        return cx.err(
            Some(ms),
            "measure.camera_c",
            "missing: a marker needs two views, and camera B alone gives one; name the tied camera C (camera_c, with a [tie] section)",
        );
    };
    if !has_tie {
        return cx.err(
            Some(c.span()),
            "measure.camera_c",
            "needs a [tie] section (the tie link B_from_C carries camera C)",
        );
    }
    let camera_c = cx.non_empty(c, "measure.camera_c")?;
    bundle_companions(cx, m)?;
    let a_noise = match (
        &m.a_covariance,
        &m.sigma_a_position_mm,
        &m.sigma_a_angles_deg,
    ) {
        _ if m.a_control_points.is_some() => a_bundle(cx, m, &model)?,
        (Some(f), p, a) if MeasureOptions::a_sources_conflict(true, p.is_some(), a.is_some()) => {
            return cx.err(
                Some(f.span()),
                "measure.a_covariance",
                "give either a_covariance or sigma_a_position_mm / sigma_a_angles_deg, not both",
            );
        }
        (Some(f), _, _) => {
            MeasureANoise::File(cx.existing_path(f, "measure.a_covariance", false)?)
        }
        (None, p, a) => MeasureANoise::Sigmas(
            p.as_ref().map_or(Ok(Vec3::zeros()), |v| {
                cx.sigma3(v, "measure.sigma_a_position_mm")
            })?,
            a.as_ref().map_or(Ok(Vec3::zeros()), |v| {
                cx.sigma3(v, "measure.sigma_a_angles_deg")
            })?,
        ),
    };
    let mm_per_unit = m
        .mm_per_unit
        .as_ref()
        .map(|v| cx.scale(v, "measure.mm_per_unit"))
        .transpose()?;
    if mm_per_unit.is_none() && matches!(a_noise, MeasureANoise::Bundle(..)) {
        return cx.err(
            Some(ms),
            "measure.mm_per_unit",
            "missing: a_control_points computes A's covariance from the bundle, which needs the model's units (mm per model unit: 1000 for a model in metres, 1 for millimetres)",
        );
    }
    if mm_per_unit.is_none() && matches!(a_noise, MeasureANoise::Sigmas(..)) {
        return cx.err(
            Some(ms),
            "measure.mm_per_unit",
            "missing: the model's units are never guessed; give mm per model unit (1000 for a model in metres, 1 for millimetres), or an a_covariance from `crashrig covariance` that states mm_per_unit",
        );
    }
    let (pixel_sigma_px, pixel_sigma_from) = pixel_sigma_key(cx, m)?;
    let (frame_rate_hz, frame_times) = time_axis_keys(cx, m)?;
    let (cfc, sync_sigma_ms) = kinematics_keys(cx, m, frame_rate_hz)?;
    let (scale_bars, mpe_mm) = length_check_keys(cx, m)?;
    Ok(MeasureSection {
        model,
        camera_a: cx.non_empty(&req(&m.camera_a, "measure.camera_a")?, "measure.camera_a")?,
        camera_b: cx.non_empty(&req(&m.camera_b, "measure.camera_b")?, "measure.camera_b")?,
        camera_c: Some(camera_c),
        observations,
        mm_per_unit,
        a_noise,
        pixel_sigma_px,
        pixel_sigma_from,
        samples: m
            .samples
            .as_ref()
            .map(|v| {
                cx.count(
                    v,
                    "measure.samples",
                    2,
                    crashrig_measure::plausible::MAX_SAMPLES,
                )
            })
            .transpose()?,
        reference_epoch: m.reference_epoch.clone(),
        frame_rate_hz,
        frame_times,
        threshold_mm: m
            .threshold_mm
            .as_ref()
            .map_or(Ok(rules::DEFAULT_THRESHOLD_MM), |v| {
                cx.rule(v, "measure.threshold_mm", rules::threshold_mm)
            })?,
        max_reprojection_px: m
            .max_reprojection_px
            .as_ref()
            .map(|v| cx.rule(v, "measure.max_reprojection_px", rules::max_reprojection_px))
            .transpose()?,
        cfc,
        sync_sigma_ms,
        scale_bars,
        mpe_mm,
    })
}

/// `a_model`, `a_pixel_sigma_px` and `a_intrinsics` need `a_control_points`: an error naming the
/// first one given without it.
fn bundle_companions(cx: &Ctx<'_>, m: &RawMeasure) -> Result<(), Error> {
    if m.a_control_points.is_some() {
        return Ok(());
    }
    let companions = [
        (m.a_model.as_ref().map(|v| v.span()), "measure.a_model"),
        (
            m.a_pixel_sigma_px.as_ref().map(|v| v.span()),
            "measure.a_pixel_sigma_px",
        ),
        (
            m.a_intrinsics.as_ref().map(|v| v.span()),
            "measure.a_intrinsics",
        ),
    ];
    match companions.into_iter().find(|(s, _)| s.is_some()) {
        Some((span, key)) => cx.err(
            span,
            key,
            "needs measure.a_control_points (A's covariance from the bundle)",
        ),
        None => Ok(()),
    }
}

/// How a study file names a setting of `[measure]` in a problem.
fn key(k: &'static str) -> String {
    format!("measure.{k}")
}

/// `[measure]`'s length-check keys: `scale_bars` (an existing file, relative to the study
/// file) and `mpe_mm` ([`rules::mpe_mm`]); each error names the key and its line.
fn length_check_keys(
    cx: &Ctx<'_>,
    m: &RawMeasure,
) -> Result<(Option<PathBuf>, Option<f64>), Error> {
    let scale_bars = m
        .scale_bars
        .as_ref()
        .map(|v| cx.existing_path(v, "measure.scale_bars", false))
        .transpose()?;
    let mpe_mm = m
        .mpe_mm
        .as_ref()
        .map(|v| {
            cx.rule(v, "measure.mpe_mm", |x| {
                rules::mpe_mm(x, scale_bars.is_some(), &key)
            })
        })
        .transpose()?;
    Ok((scale_bars, mpe_mm))
}

/// `[measure]`'s kinematics keys: `cfc` ([`rules::cfc`]), `cfc_standard`
/// ([`rules::cfc_standard`]) and `sync_sigma_ms` ([`rules::sync_sigma_ms`]); each error names
/// the key and its line.
fn kinematics_keys(
    cx: &Ctx<'_>,
    m: &RawMeasure,
    frame_rate_hz: Option<f64>,
) -> Result<(Option<crashrig_measure::filter::CfcSpec>, f64), Error> {
    let standard = rules::cfc_standard(
        m.cfc_standard.as_ref().map(|v| v.get_ref().as_str()),
        m.cfc.is_some(),
        &key,
    )
    .or_else(|p| {
        let span = m.cfc_standard.as_ref().map(|v| v.span());
        cx.err(span, "measure.cfc_standard", p)
    })?;
    let cfc = m
        .cfc
        .as_ref()
        .map(|v| {
            rules::cfc(*v.get_ref(), standard, frame_rate_hz, &key)
                .or_else(|p| cx.err(Some(v.span()), "measure.cfc", p))
        })
        .transpose()?;
    let sync = m.sync_sigma_ms.as_ref().map_or(Ok(0.0), |v| {
        cx.rule(v, "measure.sync_sigma_ms", |x| {
            rules::sync_sigma_ms(x, frame_rate_hz.is_some(), &key)
        })
    })?;
    Ok((cfc, sync))
}

/// `pixel_sigma_px`: a number ([`rules::pixel_sigma_px`]) or `"estimate"` (the check's estimate;
/// `[measure]` always has camera C), default [`rules::DEFAULT_PIXEL_SIGMA_PX`].
fn pixel_sigma_key(cx: &Ctx<'_>, m: &RawMeasure) -> Result<(f64, PixelSigmaFrom), Error> {
    const KEY: &str = "measure.pixel_sigma_px";
    let Some(v) = &m.pixel_sigma_px else {
        return Ok((rules::DEFAULT_PIXEL_SIGMA_PX, PixelSigmaFrom::Stated));
    };
    let number = match v.get_ref() {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    };
    match (number, v.get_ref().as_str()) {
        (Some(x), _) => {
            let spanned = Spanned::new(v.span(), x);
            let x = cx.rule(&spanned, KEY, rules::pixel_sigma_px)?;
            Ok((x, PixelSigmaFrom::Stated))
        }
        (None, Some("estimate")) => Ok((rules::DEFAULT_PIXEL_SIGMA_PX, PixelSigmaFrom::Estimate)),
        _ => cx.err(
            Some(v.span()),
            KEY,
            format!("must be a number (px) or \"estimate\", got {}", v.get_ref()),
        ),
    }
}

/// `frame_rate_hz` ([`rules::frame_rate_hz`]) or `frame_times` (an existing CSV `epoch,time_s`
/// relative to the study file, read here: its mean interval gives the rate, with `cfc` its one
/// interval, [`crashrig_measure::input::read_time_axis`]); the two exclude each other.
fn time_axis_keys(
    cx: &Ctx<'_>,
    m: &RawMeasure,
) -> Result<(Option<f64>, Option<FrameTimes>), Error> {
    let rate = m
        .frame_rate_hz
        .as_ref()
        .map(|v| cx.rule(v, "measure.frame_rate_hz", rules::frame_rate_hz))
        .transpose()?;
    let Some(v) = &m.frame_times else {
        return Ok((rate, None));
    };
    if m.frame_rate_hz.is_some() {
        return cx.err(
            Some(v.span()),
            "measure.frame_times",
            "excludes measure.frame_rate_hz: the frame times are the time axis",
        );
    }
    let path = cx.existing_path(v, "measure.frame_times", false)?;
    let (rate, times) =
        crashrig_measure::input::read_time_axis(&path, m.cfc.is_some()).or_else(|e| {
            cx.err(
                Some(v.span()),
                "measure.frame_times",
                crashrig_input::message::error_line(&e),
            )
        })?;
    Ok((Some(rate), Some(times)))
}
