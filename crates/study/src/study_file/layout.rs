//! The `[[layout]]` sections and their observers.

use super::raw::{RawLayout, RawObserver};
use super::validate::{Ctx, missing_section};
use super::{ChainCamera, Layout, Observer, ObserverNoise, line_of};
use crate::Error;
use toml::Spanned;

/// Two observers of a layout closer than this (mm) are coincident: an error naming both.
pub const MIN_OBSERVER_DISTANCE_MM: f64 = 1.0;

/// Checks a layout's grid size against [`crashrig_mc::limits::MAX_GRID_POINTS`] and its draws
/// (points × `samples`) against [`crashrig_mc::limits::MAX_GRID_DRAWS`], before anything is
/// allocated; the message gives the memory the grid's results would need.
///
/// # Errors
/// The message (the caller names the file, line and key).
pub(crate) fn check_layout_size(layout: &Layout, samples: usize) -> Result<(), String> {
    use crashrig_mc::limits::{MAX_GRID_DRAWS, MAX_GRID_POINTS};
    let (nx, ny, nz) = (layout.x_mm.2, layout.y_mm.2, layout.z_mm.2);
    let points = nx as u128 * ny as u128 * nz as u128;
    if points > MAX_GRID_POINTS as u128 {
        // Per point: its statistics and at least one row of grid.csv (~200 bytes).
        let bytes = points * (std::mem::size_of::<crashrig_mc::PointStats>() as u128 + 200);
        return Err(format!(
            "{nx} × {ny} × {nz} = {points} grid points exceed the limit of {MAX_GRID_POINTS} (their results alone would need {} MiB)",
            bytes >> 20
        ));
    }
    let draws = points * samples as u128;
    if draws > MAX_GRID_DRAWS as u128 {
        return Err(format!(
            "{points} grid points × {samples} samples = {draws} draws exceed the limit of {MAX_GRID_DRAWS}"
        ));
    }
    Ok(())
}

/// The `[[layout]]` sections (at least one; names unique once made file-name safe).
pub(super) fn layout_sections(
    cx: &Ctx<'_>,
    raw: &[Spanned<RawLayout>],
    has_tie: bool,
    samples: usize,
) -> Result<Vec<Layout>, Error> {
    if raw.is_empty() {
        return Err(missing_section(cx, "[[layout]]"));
    }
    let mut layouts: Vec<Layout> = Vec::new();
    for (li, l) in raw.iter().enumerate() {
        let ls = l.span();
        let k = |f: &str| format!("layout[{li}].{f}");
        let layout_name_span = l
            .get_ref()
            .name
            .as_ref()
            .map(|n| n.span())
            .unwrap_or(ls.clone());
        let layout = layout_section(cx, li, l, has_tie)?;
        check_layout_size(&layout, samples).map_err(|message| Error::Key {
            path: cx.path.to_path_buf(),
            line: Some(line_of(cx.text, ls.start)),
            key: format!("layout[{li}]"),
            message,
        })?;
        if layout.slug().is_empty() || layouts.iter().any(|o| o.slug() == layout.slug()) {
            return cx.err(
                Some(layout_name_span),
                &k("name"),
                format!(
                    "{:?} is empty or not unique once made file-name safe",
                    layout.name
                ),
            );
        }
        layouts.push(layout);
    }
    Ok(layouts)
}

/// One `[[layout]]` (the `li`-th): name, pixel noise, observers, grid, threshold.
fn layout_section(
    cx: &Ctx<'_>,
    li: usize,
    l: &Spanned<RawLayout>,
    has_tie: bool,
) -> Result<Layout, Error> {
    let ls = l.span();
    let l = l.get_ref();
    let k = |f: &str| format!("layout[{li}].{f}");
    let name = match &l.name {
        Some(n) if !n.get_ref().trim().is_empty() => n.get_ref().clone(),
        Some(n) => return cx.err(Some(n.span()), &k("name"), "must not be empty"),
        None => format!("layout{}", li + 1),
    };
    let pixel = match (&l.pixel_sigma_px, &l.focal_px) {
        (None, None) => None,
        (Some(s), Some(f)) => {
            let sv = *s.get_ref();
            if !(sv.is_finite() && sv >= 0.0) {
                return cx.err(
                    Some(s.span()),
                    &k("pixel_sigma_px"),
                    "must be finite and not negative",
                );
            }
            Some((sv, cx.positive(f, &k("focal_px"))?))
        }
        // Located at the key that is there (the missing one has no line).
        (Some(s), None) => {
            return cx.err(
                Some(s.span()),
                &k("focal_px"),
                "required with pixel_sigma_px",
            );
        }
        (None, Some(f)) => {
            return cx.err(
                Some(f.span()),
                &k("pixel_sigma_px"),
                "required with focal_px",
            );
        }
    };
    if l.observer.len() < 2 {
        return cx.err(
            Some(ls),
            &k("observer"),
            format!(
                "needs at least two [[layout.observer]], found {}",
                l.observer.len()
            ),
        );
    }
    let mut observers: Vec<Observer> = Vec::new();
    for (oi, ob) in l.observer.iter().enumerate() {
        let o = observer_section(cx, (li, oi), ob, &observers, l.correlated, has_tie)?;
        observers.push(o);
    }
    Ok(Layout {
        name,
        description: l.description.clone().unwrap_or_default(),
        x_mm: cx.axis(&l.x_mm, ls.clone(), &k("x_mm"))?,
        y_mm: cx.axis(&l.y_mm, ls.clone(), &k("y_mm"))?,
        z_mm: cx.axis(&l.z_mm, ls.clone(), &k("z_mm"))?,
        threshold_mm: l
            .threshold_mm
            .as_ref()
            .map_or(Ok(5.0), |v| cx.positive(v, &k("threshold_mm")))?,
        pixel,
        correlated: l.correlated,
        observers,
    })
}

/// One `[[layout.observer]]` (observer `oi` of layout `li`), checked against the layout's
/// observers before it (`earlier`): position, noise (`from` a chain camera or given σ) and,
/// with `aim = "fixed"`, its fixed camera.
fn observer_section(
    cx: &Ctx<'_>,
    (li, oi): (usize, usize),
    ob: &Spanned<RawObserver>,
    earlier: &[Observer],
    correlated: Option<bool>,
    has_tie: bool,
) -> Result<Observer, Error> {
    let obs = ob.span();
    let ob = ob.get_ref();
    let ko = |f: &str| format!("layout[{li}].observer[{oi}].{f}");
    let position = cx.required(&ob.position_mm, obs.clone(), &ko("position_mm"))?;
    let position_mm = cx.finite3(position, &ko("position_mm"))?;
    if let Some((oj, other)) = earlier
        .iter()
        .enumerate()
        .find(|(_, o)| (o.position_mm - position_mm).norm() < MIN_OBSERVER_DISTANCE_MM)
    {
        return cx.err(
            Some(position.span()),
            &ko("position_mm"),
            format!(
                "observer {:?} is {:.3} mm from observer[{oj}] {:?} (less than {MIN_OBSERVER_DISTANCE_MM} mm): coincident cameras see a point along the same ray and cannot intersect it (σ would be empty)",
                ob.name.clone().unwrap_or_else(|| format!("obs{}", oi + 1)),
                (other.position_mm - position_mm).norm(),
                other.name
            ),
        );
    }
    let noise = match &ob.from {
        Some(f) => observer_from(cx, &ko("from"), ob, f, has_tie)?,
        None => ObserverNoise::Given(cx.noise(
            obs.clone(),
            &format!("layout[{li}].observer[{oi}]"),
            &ob.sigma_position_mm,
            &ob.sigma_angles_deg,
            &ob.covariance_tangent,
        )?),
    };
    let fixed = crate::fixed_observer::fixed_from_raw(
        &crate::fixed_observer::Site {
            path: cx.path,
            text: cx.text,
            dir: &cx.dir,
            prefix: format!("layout[{li}].observer[{oi}]"),
            span: obs.clone(),
        },
        &crate::fixed_observer::RawFixed {
            aim: &ob.aim,
            angles_deg: &ob.angles_deg,
            look_at_mm: &ob.look_at_mm,
            camera: &ob.camera,
            camera_from: &ob.camera_from,
            pixel_sigma_px: &ob.pixel_sigma_px,
        },
        &position_mm,
    )?;
    if fixed.is_some()
        && correlated == Some(true)
        && let (ObserverNoise::From(_), Some(f)) = (&noise, &ob.from)
    {
        return cx.err(
            Some(f.span()),
            &ko("from"),
            "a fixed observer takes the chain camera's propagated covariance, drawn independently; it cannot be drawn jointly (correlated = true)",
        );
    }
    Ok(Observer {
        name: ob.name.clone().unwrap_or_else(|| format!("obs{}", oi + 1)),
        position_mm,
        noise,
        fixed: fixed.map(Box::new),
    })
}

/// An observer's `from` (key `key`): the chain camera whose propagated covariance it takes
/// (not together with its own σ keys; `tie` only with a `[tie]`).
fn observer_from(
    cx: &Ctx<'_>,
    key: &str,
    ob: &RawObserver,
    f: &Spanned<String>,
    has_tie: bool,
) -> Result<ObserverNoise, Error> {
    if ob.sigma_position_mm.is_some()
        || ob.sigma_angles_deg.is_some()
        || ob.covariance_tangent.is_some()
    {
        return cx.err(
            Some(f.span()),
            key,
            "give either from or the σ / covariance_tangent keys, not both",
        );
    }
    Ok(match f.get_ref().as_str() {
        "outward" => ObserverNoise::From(ChainCamera::Outward),
        "inward" => ObserverNoise::From(ChainCamera::Inward),
        "tie" if has_tie => ObserverNoise::From(ChainCamera::Tie),
        "tie" => {
            return cx.err(Some(f.span()), key, "\"tie\" needs a [tie] section");
        }
        other => {
            return cx.err(
                Some(f.span()),
                key,
                format!("must be \"outward\", \"inward\" or \"tie\", got {other:?}"),
            );
        }
    })
}
