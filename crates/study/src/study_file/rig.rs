//! The rig's sections: `[calibration]`, `[tie]` and `[outward]`.

use super::raw::{RawCalibration, RawPose, RawTie};
use super::validate::{Ctx, missing_section};
use super::{CalibrationSection, StudyScale, TieMethod, TieResample, TieSection};
use crate::Error;
use crashrig_geometry::{Rigid3, UncertainPose};
use toml::Spanned;

/// `[calibration]`.
pub(super) fn calibration_section(
    cx: &Ctx<'_>,
    c: Option<&Spanned<RawCalibration>>,
) -> Result<CalibrationSection, Error> {
    let c = c.ok_or_else(|| missing_section(cx, "[calibration]"))?;
    let cs = c.span();
    let c = c.get_ref();
    let model = cx.existing_path(
        cx.required(&c.model, cs.clone(), "calibration.model")?,
        "calibration.model",
        true,
    )?;
    let name = |v: &Option<Spanned<String>>, key: &str| -> Result<String, Error> {
        cx.non_empty(cx.required(v, cs.clone(), key)?, key)
    };
    let camera_a = name(&c.camera_a, "calibration.camera_a")?;
    let camera_b = name(&c.camera_b, "calibration.camera_b")?;
    let scale = calibration_scale(cx, c, cs)?;
    Ok(CalibrationSection {
        model,
        camera_a,
        camera_b,
        scale,
        max_lag: c.max_lag.as_ref().map_or(Ok(10), |v| {
            cx.count(v, "calibration.max_lag", 1, usize::MAX)
        })?,
        refine: c.refine.unwrap_or(true),
        accept_rig_constrained: c.accept_rig_constrained.unwrap_or(false),
    })
}

/// The scale of `[calibration]`: a scale bar (`scale_points` + `scale_length_mm`) or
/// `mm_per_unit`, exactly one of them.
fn calibration_scale(
    cx: &Ctx<'_>,
    c: &RawCalibration,
    cs: std::ops::Range<usize>,
) -> Result<StudyScale, Error> {
    Ok(
        match (&c.scale_points, &c.scale_length_mm, &c.mm_per_unit) {
            (Some(p), Some(l), None) => {
                if p.get_ref().len() != 2 || p.get_ref()[0] == p.get_ref()[1] {
                    return cx.err(
                        Some(p.span()),
                        "calibration.scale_points",
                        "must be two different point3D ids",
                    );
                }
                StudyScale::ScaleBar {
                    points: [p.get_ref()[0], p.get_ref()[1]],
                    length_mm: cx.positive(l, "calibration.scale_length_mm")?,
                }
            }
            (None, None, Some(f)) => StudyScale::MmPerUnit(cx.scale(f, "calibration.mm_per_unit")?),
            // Located at the key that is there (the missing one has no line).
            (Some(p), None, _) => {
                return cx.err(
                    Some(p.span()),
                    "calibration.scale_length_mm",
                    "required with scale_points",
                );
            }
            (None, Some(l), _) => {
                return cx.err(
                    Some(l.span()),
                    "calibration.scale_points",
                    "required with scale_length_mm",
                );
            }
            (Some(_), Some(_), Some(f)) => {
                return cx.err(
                    Some(f.span()),
                    "calibration.mm_per_unit",
                    "give either mm_per_unit or the scale bar, not both",
                );
            }
            (None, None, None) => {
                return cx.err(
                    Some(cs),
                    "calibration.scale_points",
                    "missing: give scale_points + scale_length_mm or mm_per_unit",
                );
            }
        },
    )
}

/// `[tie]`.
pub(super) fn tie_section(cx: &Ctx<'_>, t: &Spanned<RawTie>) -> Result<TieSection, Error> {
    let ts = t.span();
    let t = t.get_ref();
    let req = |v: &Option<Spanned<String>>, key: &str| -> Result<Spanned<String>, Error> {
        cx.required(v, ts.clone(), key).cloned()
    };
    let database = cx.existing_path(&req(&t.database, "tie.database")?, "tie.database", false)?;
    let model = cx.existing_path(&req(&t.model, "tie.model")?, "tie.model", true)?;
    let method = match t.method.as_ref().map(|m| (m.get_ref().as_str(), m.span())) {
        None | Some(("absolute", _)) => TieMethod::Absolute,
        Some(("relative", _)) => TieMethod::Relative,
        Some((other, span)) => {
            return cx.err(
                Some(span),
                "tie.method",
                format!("must be \"absolute\" or \"relative\", got {other:?}"),
            );
        }
    };
    let resample = match t
        .resample
        .as_ref()
        .map(|m| (m.get_ref().as_str(), m.span()))
    {
        None | Some(("inliers", _)) => TieResample::Inliers,
        Some(("matches", _)) => TieResample::AllMatches,
        Some((other, span)) => {
            return cx.err(
                Some(span),
                "tie.resample",
                format!("must be \"inliers\" or \"matches\", got {other:?}"),
            );
        }
    };
    Ok(TieSection {
        database,
        model,
        image_a: cx.non_empty(&req(&t.image_a, "tie.image_a")?, "tie.image_a")?,
        image_b: cx.non_empty(&req(&t.image_b, "tie.image_b")?, "tie.image_b")?,
        method,
        iterations: t.iterations.as_ref().map_or(Ok(500), |v| {
            cx.count(v, "tie.iterations", 2, crashrig_bootstrap::MAX_ITERATIONS)
        })?,
        mm_per_unit: t
            .mm_per_unit
            .as_ref()
            .map_or(Ok(1.0), |v| cx.scale(v, "tie.mm_per_unit"))?,
        max_error_px: t
            .max_error_px
            .as_ref()
            .map_or(Ok(4.0), |v| cx.positive(v, "tie.max_error_px"))?,
        base_mm: t
            .base_mm
            .as_ref()
            .map(|v| cx.positive(v, "tie.base_mm"))
            .transpose()?,
        resample,
    })
}

/// `[outward]`: camera A's world pose with its covariance.
pub(super) fn outward_section(
    cx: &Ctx<'_>,
    o: Option<&Spanned<RawPose>>,
) -> Result<UncertainPose, Error> {
    let o = o.ok_or_else(|| missing_section(cx, "[outward]"))?;
    let os = o.span();
    let o = o.get_ref();
    let position = cx.finite3(
        cx.required(&o.position_mm, os.clone(), "outward.position_mm")?,
        "outward.position_mm",
    )?;
    let angles = cx
        .finite3(
            cx.required(&o.angles_deg, os.clone(), "outward.angles_deg")?,
            "outward.angles_deg",
        )?
        .map(f64::to_radians);
    let covariance = cx.noise(
        os,
        "outward",
        &o.sigma_position_mm,
        &o.sigma_angles_deg,
        &o.covariance_tangent,
    )?;
    let world_from_a = Rigid3::from_parts(
        position.into(),
        crashrig_geometry::opk::rotation_from_opk(angles.x, angles.y, angles.z).into(),
    );
    Ok(UncertainPose {
        b_from_a: world_from_a,
        covariance,
    })
}
