//! The report's "3-D view" section: the cameras, the grid points of each layout coloured by
//! worst-direction σ and the measured markers with their σ ellipsoids, drawn in the page by
//! three.js (vendored: `crates/study/assets/three/`, MIT licence) from the data blob
//! `<script type="application/json" id="crashrig-3d">` ([`blob`]; docs/REFERENCE.md). Nothing is
//! loaded from the network; without WebGL the page shows a static picture ([`fallback_svg`]).

use crate::html::{Block, Report, escape};
use crate::pipeline::{LayoutResult, StudyResult};
use crate::study_file::ObserverNoise;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;

/// three.js r187 with OrbitControls, bundled by `assets/three/vendor.sh` (checked against
/// `assets/three/SHA256SUMS` by a test).
pub(crate) const THREE_JS: &str = include_str!("../../assets/three/three-view.min.js");
/// The viewer that draws the blob.
const VIEW_JS: &str = include_str!("view3d.js");
/// The pinned three.js release (npm `three@0.187.0`).
pub(crate) const THREE_VERSION: &str = "r187 (npm three@0.187.0)";

/// Where the rig's cameras A, B and C stand in a layout's frame: when an observer that takes its
/// σ from a chain camera (`from = …`) stands at that camera's world position (within
/// [`crashrig_mc::CORRELATED_POSITION_TOLERANCE_MM`]), the chain and the grid share one frame.
fn rig_in_frame(l: &LayoutResult, r: &StudyResult) -> bool {
    l.layout.observers.iter().any(|o| {
        let ObserverNoise::From(cam) = o.noise else {
            return false;
        };
        r.chain.iter().any(|c| {
            c.camera == cam
                && (o.position_mm - c.mc.nominal.position_mm).norm()
                    <= crashrig_mc::CORRELATED_POSITION_TOLERANCE_MM
        })
    })
}

fn deg3(v: Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

/// `world_from_cam` of a camera in the blob (angles null for an aimed observer).
#[derive(Serialize)]
struct PoseView {
    position_mm: [f64; 3],
    angles_deg: Option<[f64; 3]>,
}

/// A camera of the blob: a chain camera, or a layout's observer (with `from`).
#[derive(Serialize)]
struct CameraView<'a> {
    name: &'a str,
    world_from_cam: PoseView,
    #[serde(skip_serializing_if = "Option::is_none")]
    from: Option<Option<&'a str>>,
}

/// A layout of the blob: points `[x, y, z, σ_worst or null]`.
#[derive(Serialize)]
struct LayoutView<'a> {
    name: &'a str,
    threshold_mm: f64,
    points: Vec<(f64, f64, f64, Option<f64>)>,
    cameras: Vec<CameraView<'a>>,
    rig_in_frame: bool,
}

/// A σ ellipsoid of a marker at one epoch.
#[derive(Serialize)]
struct EllipsoidView<'a> {
    role: &'a str,
    epoch_index: usize,
    epoch: &'a str,
    position_mm: [f64; 3],
    sigma_max_mm: Option<f64>,
    semi_axes_mm: [[f64; 3]; 3],
}

/// A marker's trajectory: its position per epoch, null where not measured.
#[derive(Serialize)]
struct TrajectoryView<'a> {
    marker: &'a str,
    epochs: Vec<Option<[f64; 3]>>,
    ellipsoids: Vec<EllipsoidView<'a>>,
}

/// The whole blob (docs/REFERENCE.md).
#[derive(Serialize)]
struct Blob<'a> {
    layouts: Vec<LayoutView<'a>>,
    cameras: Vec<CameraView<'a>>,
    trajectories: Vec<TrajectoryView<'a>>,
}

fn layout_view<'a>(l: &'a LayoutResult, r: &StudyResult) -> LayoutView<'a> {
    let points = l
        .result
        .points
        .iter()
        .map(|p| {
            let w = p.sigma_worst_mm();
            let s = (p.is_measurable() && w.is_finite()).then_some(w);
            (p.point.x, p.point.y, p.point.z, s)
        })
        .collect();
    let cameras = l
        .grid
        .observers
        .iter()
        .zip(&l.layout.observers)
        .map(|(o, lo)| {
            let angles_deg = match &o.aim {
                crashrig_mc::Aim::Fixed(f) => Some(deg3(f.angles_rad)),
                crashrig_mc::Aim::Point => None,
            };
            let from = match lo.noise {
                ObserverNoise::From(c) => Some(c.name()),
                ObserverNoise::Given(_) => None,
            };
            CameraView {
                name: &o.name,
                world_from_cam: PoseView {
                    position_mm: o.position_mm.into(),
                    angles_deg,
                },
                from: Some(from),
            }
        })
        .collect();
    LayoutView {
        name: &l.layout.name,
        threshold_mm: l.layout.threshold_mm,
        points,
        cameras,
        rig_in_frame: rig_in_frame(l, r),
    }
}

/// The semi-axes of the 1σ ellipsoid of `c` (mm): √λᵢ·vᵢ, largest first.
pub(crate) fn semi_axes_mm(c: &Matrix3<f64>) -> [[f64; 3]; 3] {
    let e = SymmetricEigen::new(*c);
    let mut k = [0usize, 1, 2];
    k.sort_by(|a, b| e.eigenvalues[*b].total_cmp(&e.eigenvalues[*a]));
    k.map(|i| {
        let v = e.eigenvectors.column(i) * e.eigenvalues[i].max(0.0).sqrt();
        [v.x, v.y, v.z]
    })
}

fn trajectories_view(r: &StudyResult) -> Vec<TrajectoryView<'_>> {
    let Some(m) = &r.measure else {
        return Vec::new();
    };
    let ms = &m.measurement;
    ms.markers
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut epochs = vec![None; ms.epochs.len()];
            let rows: Vec<_> = ms.rows.iter().filter(|row| row.marker == k).collect();
            for row in &rows {
                if let Some(p) = row.position_mm {
                    epochs[row.epoch] = Some([p.x, p.y, p.z]);
                }
            }
            let with_cov = |row: &crashrig_measure::Row| {
                row.position_mm.is_some() && row.covariance_mm2.is_some()
            };
            let reference = rows
                .iter()
                .copied()
                .find(|row| row.epoch == ms.reference_epoch)
                .filter(|row| with_cov(row));
            let largest = rows
                .iter()
                .copied()
                .filter(|row| with_cov(row))
                .filter(|row| row.sigma_max_mm().is_some())
                .max_by(|a, b| {
                    a.sigma_max_mm()
                        .unwrap_or(0.0)
                        .total_cmp(&b.sigma_max_mm().unwrap_or(0.0))
                });
            let mut ellipsoids = Vec::new();
            let mut push = |row: &crashrig_measure::Row, role: &'static str| {
                if let (Some(p), Some(c)) = (row.position_mm, row.covariance_mm2) {
                    ellipsoids.push(EllipsoidView {
                        role,
                        epoch_index: row.epoch,
                        epoch: &ms.epochs[row.epoch].name,
                        position_mm: [p.x, p.y, p.z],
                        sigma_max_mm: row.sigma_max_mm(),
                        semi_axes_mm: semi_axes_mm(&c),
                    });
                }
            };
            if let Some(row) = reference {
                push(row, "reference");
            }
            if let Some(row) = largest
                && reference.is_none_or(|f| f.epoch != row.epoch)
            {
                push(row, "largest");
            }
            TrajectoryView {
                marker: name,
                epochs,
                ellipsoids,
            }
        })
        .collect()
}

/// The data blob of the 3-D view (docs/REFERENCE.md, "report.html: the 3-D view's data"):
/// `layouts` (name, threshold, points `[x, y, z, σ_worst or null]` as in `grid/<layout>/grid.csv`,
/// the layout's observers under `cameras`, whether the rig stands in its frame), `cameras` (the
/// chain's world poses as in `results.json` → `propagation.cameras`) and `trajectories` (per marker its
/// position per measured epoch, null where not measured, and the σ ellipsoids at the reference
/// epoch and at the epoch of its largest σ).
pub fn blob(r: &StudyResult) -> Value {
    let cameras = r
        .chain
        .iter()
        .map(|c| CameraView {
            name: c.camera.name(),
            world_from_cam: PoseView {
                position_mm: c.mc.nominal.position_mm.into(),
                angles_deg: Some(deg3(c.mc.nominal.angles_rad())),
            },
            from: None,
        })
        .collect();
    let blob = Blob {
        layouts: r.layouts.iter().map(|l| layout_view(l, r)).collect(),
        cameras,
        trajectories: trajectories_view(r),
    };
    // Every field is a number, string, bool or null: serialising cannot fail.
    serde_json::to_value(&blob).unwrap_or(Value::Null)
}

/// JSON safe inside `<script>`: every `<` escaped (it occurs only inside strings).
fn script_json(v: &Value) -> String {
    serde_json::to_string(v)
        .unwrap_or_default()
        .replace('<', "\\u003c")
}

/// The colour of a σ on the view's scale (the same function as `view3d.js`): below the
/// threshold dark blue → teal → light green, at and above it orange → dark red up to `top`.
fn sigma_colour(s: f64, thr: f64, top: f64) -> [f64; 3] {
    const BELOW: [[f64; 3]; 3] = [[0.10, 0.20, 0.60], [0.05, 0.55, 0.65], [0.45, 0.80, 0.35]];
    const ABOVE: [[f64; 3]; 3] = [[1.00, 0.60, 0.10], [0.85, 0.15, 0.10], [0.45, 0.00, 0.10]];
    let ramp = |stops: &[[f64; 3]; 3], t: f64| {
        let t = t.clamp(0.0, 1.0);
        let k = ((t * 2.0).floor() as usize).min(1);
        let u = t * 2.0 - k as f64;
        std::array::from_fn(|i| stops[k][i] + (stops[k + 1][i] - stops[k][i]) * u)
    };
    if s < thr {
        ramp(&BELOW, s / thr)
    } else if top > thr {
        ramp(&ABOVE, (s - thr) / (top - thr))
    } else {
        ramp(&ABOVE, 1.0)
    }
}

/// The static picture shown without WebGL: the first layout's grid points, coloured as in the
/// view, and its cameras, projected along the view's opening direction (inline SVG).
pub(crate) fn fallback_svg(l: &LayoutResult) -> String {
    let dir = Vector3::new(-0.55, -0.75, 0.55).normalize();
    let right = dir.cross(&Vector3::z()).normalize();
    let up = right.cross(&dir);
    let pts: Vec<(Vector3<f64>, f64)> = l
        .result
        .points
        .iter()
        .map(|p| {
            let w = p.sigma_worst_mm();
            (p.point, if p.is_measurable() { w } else { f64::NAN })
        })
        .collect();
    let cams: Vec<(Vector3<f64>, &str)> = l
        .grid
        .observers
        .iter()
        .map(|o| (o.position_mm, o.name.as_str()))
        .collect();
    let proj = |p: &Vector3<f64>| (p.dot(&right), p.dot(&up));
    let all: Vec<(f64, f64)> = pts
        .iter()
        .map(|(p, _)| proj(p))
        .chain(cams.iter().map(|(p, _)| proj(p)))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in &all {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    let (w, h) = (900.0, 480.0);
    let k = ((w - 160.0) / (x1 - x0).max(1.0)).min((h - 60.0) / (y1 - y0).max(1.0));
    let sx = |x: f64| 80.0 + (x - x0) * k;
    let sy = |y: f64| h - 30.0 - (y - y0) * k;
    let thr = l.layout.threshold_mm;
    let finite_max = pts
        .iter()
        .map(|(_, s)| *s)
        .filter(|s| s.is_finite())
        .fold(0.0, f64::max);
    let top = crashrig_grid::summary::nice_ceil(finite_max.max(1.25 * thr));
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {w} {h}\" width=\"{w}\" style=\"max-width:100%;background:#fff;border:1px solid #ccc\">"
    );
    // Far points first, so that near ones cover them.
    let mut order: Vec<usize> = (0..pts.len()).collect();
    order.sort_by(|a, b| pts[*b].0.dot(&dir).total_cmp(&pts[*a].0.dot(&dir)));
    for i in order {
        let (p, sig) = &pts[i];
        let (x, y) = proj(p);
        if sig.is_finite() {
            let c = sigma_colour(*sig, thr, top).map(|v| (v * 255.0).round());
            let _ = write!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"rgb({},{},{})\"/>",
                sx(x),
                sy(y),
                c[0],
                c[1],
                c[2]
            );
        } else {
            let _ = write!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\" fill=\"none\" stroke=\"#8a8a8a\" stroke-width=\"1.5\"/>",
                sx(x),
                sy(y)
            );
        }
    }
    for (p, name) in &cams {
        let (x, y) = proj(p);
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"10\" height=\"10\" fill=\"#1060c0\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"13\" fill=\"#036\">{}</text>",
            sx(x) - 5.0,
            sy(y) - 5.0,
            sx(x) + 8.0,
            sy(y) - 8.0,
            escape(name)
        );
    }
    let _ = write!(
        s,
        "<text x=\"8\" y=\"18\" font-size=\"13\">{}: grid points coloured by worst-direction σ (threshold {} mm); hollow grey = not measurable; blue squares = cameras</text></svg>",
        escape(&l.layout.name),
        thr
    );
    s
}

const CSS: &str = "<style>\
.v3d-controls{display:flex;flex-wrap:wrap;gap:.6em 1.2em;align-items:center;margin:.5em 0}\
.v3d-controls select,.v3d-controls button{font-size:1em}\
.v3d-help{color:#444;font-size:.9em}\
.v3d-canvas{position:relative;width:100%;height:min(62vh,600px);min-height:360px;border:1px solid #ccc;overflow:hidden;background:#fff}\
.v3d-canvas canvas{display:block;width:100%;height:100%}\
.v3d-labels,.v3d-leaders{position:absolute;left:0;top:0;width:100%;height:100%;pointer-events:none}\
#v3d-hidden{min-height:1.3em;margin:.2em 0}\
.v3d-label{position:absolute;left:0;top:0;font-size:13px;white-space:nowrap;padding:0 3px;border-radius:3px;background:rgba(255,255,255,.8)}\
.v3d-label.cam{color:#0b4a94;font-weight:bold}.v3d-label.rig{color:#a04800;font-weight:bold}.v3d-label.axis{font-weight:bold;background:none}.v3d-label.marker{color:#333;font-size:12px}\
.v3d-legend{display:flex;flex-wrap:wrap;gap:.5em 2em;font-size:.92em;margin:.4em 0}\
.v3d-scale{flex:1 1 340px;max-width:520px}.v3d-barwrap{position:relative;height:18px;margin:.3em 0 1.6em;border:1px solid #888}\
#v3d-bar{position:absolute;inset:0}.v3d-thr{position:absolute;top:-5px;bottom:-5px;width:0;border-left:3px solid #000}\
.v3d-thr span{position:absolute;top:24px;left:-4em;width:8em;text-align:center;font-weight:bold}\
.v3d-ticks{display:flex;justify-content:space-between}\
.v3d-keys{flex:2 1 420px;margin:0;padding-left:1.2em}.v3d-keys li{margin:.15em 0}\
.v3d-sw{display:inline-block;width:14px;height:14px;vertical-align:-2px;margin-right:.35em}\
</style>";

/// Console errors, uncaught exceptions and content-security-policy violations (the page's
/// policy allows nothing but itself and `data:` images) from here on, counted for the browser check
/// (`<body data-v3d-errors>`), before three.js runs.
const ERROR_COUNTER: &str = "<script>(function(){var n=0,b=document.body;function bump(){n++;b.setAttribute('data-v3d-errors',String(n));}b.setAttribute('data-v3d-errors','0');window.addEventListener('error',bump);window.addEventListener('unhandledrejection',bump);document.addEventListener('securitypolicyviolation',bump);var e=console.error;console.error=function(){bump();return e.apply(console,arguments);};})();</script>";

/// Pushes the section "3-D view" (open on arrival) onto `rep`.
pub(crate) fn section(rep: &mut Report, r: &StudyResult) {
    let Some(first) = r.layouts.first() else {
        return;
    };
    let data = blob(r);
    let has_rig = r.layouts.iter().any(|l| rig_in_frame(l, r));
    let has_markers = r.measure.is_some();
    rep.push(Block::HeadingOpen(
        "3-D view: the cameras, each layout's grid σ and the measured markers".into(),
    ));
    let mut h = String::from(CSS);
    h.push_str("<div id=\"v3d\">");
    h.push_str("<p>The grid points of one layout in the frame the grid is given in (mm), coloured by their <b>worst-direction σ</b>: the standard uncertainty along the direction in which a point is least certain, so it is never smaller than σ_max of the tables. Choose the layout below; drag to look around.</p>");
    h.push_str("<div id=\"v3d-controls\" class=\"v3d-controls\"><label>Layout: <select id=\"v3d-layout\"></select></label><button id=\"v3d-home\" type=\"button\">Reset view</button><span class=\"v3d-help\">drag = rotate · right-drag or Shift+drag = move · wheel = zoom</span></div>");
    h.push_str("<div id=\"v3d-canvas\" class=\"v3d-canvas\"><div id=\"v3d-labels\" class=\"v3d-labels\"></div></div><p id=\"v3d-hidden\" class=\"v3d-help\"></p>");
    let _ = write!(
        h,
        "<div id=\"v3d-fallback\" hidden><p id=\"v3d-why\" class=\"note\"></p>{}</div>",
        fallback_svg(first)
    );
    h.push_str("<p id=\"v3d-status\"></p><div class=\"v3d-legend\"><div class=\"v3d-scale\"><div>worst-direction σ of a grid point (1σ, mm)</div><div class=\"v3d-barwrap\"><div id=\"v3d-bar\"></div><div id=\"v3d-thr\" class=\"v3d-thr\"><span id=\"v3d-thr-text\"></span></div></div><div class=\"v3d-ticks\"><span>0 mm</span><span id=\"v3d-top\"></span></div><div>blue to green: below the threshold (the target is met there); orange to dark red: at or above it.</div></div><ul class=\"v3d-keys\">");
    let key = |h: &mut String, swatch: &str, text: &str| {
        let _ = write!(
            h,
            "<li><span class=\"v3d-sw\" style=\"{swatch}\"></span>{text}</li>"
        );
    };
    key(
        &mut h,
        "border-radius:50%;background:#2a8c6a",
        "filled dot: a grid point, coloured by its σ on the bar",
    );
    key(
        &mut h,
        "border-radius:50%;border:3px solid #8a8a8a;box-sizing:border-box",
        "hollow grey ring: not measurable — fewer than two cameras see the point, so it has no σ (neither below nor above the threshold)",
    );
    key(
        &mut h,
        "border:2px solid #1060c0;box-sizing:border-box",
        "blue pyramid: one of the layout's interior cameras, its tip at the camera, opening where it looks (the notch marks the image's top); a camera marked fixed is bolted in place, the others turn to each grid point and are drawn looking at the grid's centre; \"σ of B\" (or C): the camera takes the pose σ of the rig's camera B (inward) or C (tie), propagated through the chain",
    );
    if has_rig {
        key(
            &mut h,
            "border:2px solid #d06000;box-sizing:border-box",
            "orange pyramid: the rig's cameras A (outward), B (inward) and C (tie) where the study places them; dashed orange: the calibrated link A–B and the tie B–C",
        );
    }
    if has_markers {
        key(
            &mut h,
            "background:#333;height:3px;vertical-align:4px",
            "dark line: a measured marker's trajectory through the test (the same in every layout)",
        );
        let _ = write!(
            h,
            "<li><span class=\"v3d-sw\" style=\"border-radius:50%;background:#7030a0\"></span><span class=\"v3d-sw\" style=\"border-radius:50%;background:#e02080\"></span>σ ellipsoids of a marker at the reference epoch (purple) and at the epoch of its largest σ (pink): 1σ, enlarged <b id=\"v3d-scale\"></b> so that they can be seen</li>"
        );
    } else {
        h.push_str("<li hidden><b id=\"v3d-scale\"></b></li>");
    }
    key(
        &mut h,
        "border:1px solid #ccc;box-sizing:border-box",
        "light grey box: the extent of the grid; red, green, blue lines: the x, y, z axes of its frame",
    );
    let _ = write!(
        h,
        "</ul></div><p class=\"meta\">Drawn in the page by three.js {THREE_VERSION}, MIT licence, © three.js authors (crashrig's repository: crates/study/assets/three/LICENSE), embedded in this file: nothing is loaded from the network. The numbers are those of results.json and grid/&lt;layout&gt;/grid.csv, also in grid/&lt;layout&gt;/grid.ply for CloudCompare, Open3D or MeshLab.</p>"
    );
    let _ = write!(
        h,
        "<script type=\"application/json\" id=\"crashrig-3d\">{}</script>",
        script_json(&data)
    );
    h.push_str(ERROR_COUNTER);
    let _ = write!(
        h,
        "<script>{THREE_JS}</script><script>{VIEW_JS}</script></div>"
    );
    rep.push(Block::Raw(h));
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;
    use sha2::{Digest, Sha256};

    #[test]
    fn the_vendored_three_js_is_the_one_vendor_sh_made() {
        let sums = include_str!("../../assets/three/SHA256SUMS");
        let want = |file: &str| {
            sums.lines()
                .find_map(|l| l.strip_suffix(file).map(|h| h.trim().to_string()))
                .unwrap_or_else(|| panic!("{file} in SHA256SUMS"))
        };
        let hex = |b: &[u8]| {
            Sha256::digest(b)
                .iter()
                .map(|x| format!("{x:02x}"))
                .collect::<String>()
        };
        assert_eq!(hex(THREE_JS.as_bytes()), want("three-view.min.js"));
        let licence = include_str!("../../assets/three/LICENSE");
        assert_eq!(hex(licence.as_bytes()), want("LICENSE"));
        assert!(licence.contains("The MIT License"));
        // Inlined in a <script>: it must not end the element early.
        assert!(!THREE_JS.contains("</script") && !VIEW_JS.contains("</script"));
    }

    #[test]
    fn semi_axes_rebuild_the_covariance() {
        let c = Matrix3::new(4.0, 1.0, 0.5, 1.0, 2.0, 0.2, 0.5, 0.2, 1.0);
        let a = semi_axes_mm(&c);
        let mut back = Matrix3::zeros();
        for v in &a {
            let v = Vector3::from(*v);
            back += v * v.transpose();
        }
        assert!((back - c).abs().max() < 1e-12, "{back} vs {c}");
        let n = |v: &[f64; 3]| Vector3::from(*v).norm();
        assert!(n(&a[0]) >= n(&a[1]) && n(&a[1]) >= n(&a[2]));
    }

    #[test]
    fn script_json_cannot_close_the_script() {
        let v = json!({"name": "</script><!--"});
        let s = script_json(&v);
        assert!(!s.contains('<'));
        assert_eq!(serde_json::from_str::<Value>(&s).unwrap(), v);
    }

    #[test]
    fn colours_split_at_the_threshold() {
        let below = sigma_colour(4.999, 5.0, 10.0);
        let at = sigma_colour(5.0, 5.0, 10.0);
        assert!(below[1] > 0.7 && at[0] == 1.0, "{below:?} {at:?}");
        assert_eq!(sigma_colour(0.0, 5.0, 10.0), [0.10, 0.20, 0.60]);
        assert_eq!(sigma_colour(10.0, 5.0, 10.0), [0.45, 0.00, 0.10]);
    }
}
