//! `crashrig bootstrap`: pose uncertainty of image B relative to A by resampling correspondences.
//!
//! The correspondences come from the COLMAP model and database:
//! - `absolute`: B's 2-D observations of the model's 3-D points (the model's tracks); B is
//!   resected (P3P LO-RANSAC + LM through B's camera model), A's pose is the model's.
//! - `relative`: the verified A–B matches of the database (`two_view_geometries` inliers,
//!   keypoints of both images), undistorted through each image's camera; the essential matrix
//!   gives `B_from_A` up to scale; the base length comes from the model's projection centres
//!   (or `--base-mm`).
//!
//! Each bootstrap replicate resamples the RANSAC inliers with replacement and re-runs the
//! Levenberg–Marquardt refinement warm-started from the full-sample pose (see the
//! `crashrig-pose` crate docs for why that is sound); failed replicates are counted and listed.
//! Reported: B relative to A (`A_from_B`): base = B's centre in A's frame (mm), ω φ κ of
//! `R_A_from_B` (degrees); the point estimate is the full-sample one, σ the bootstrap σ (n − 1,
//! wrap-safe for angles), `ci95` the percentile interval, plus BCa intervals and the
//! first-order (covariance) σ as extensions.
//!
//! With `relative`, the base length (model or `--base-mm`) is held fixed: the reported σ of the
//! base comes from the direction and rotation only, not from the scale.
//!
//! Angle intervals and histograms are taken on the replicate values unwrapped about the
//! estimate (within ±180° of it), so an interval around ω ≈ 180° may read `[179.9, 180.1]`.
//!
//! Extension fields of the JSON: `seed`, `mm_per_unit`, `n_candidates` (correspondences before
//! RANSAC; `n_correspondences` are the inliers that are resampled), `ci95_bca` (BCa intervals,
//! jackknife acceleration; `null` when undefined), `first_order` (`base_sigma_mm`,
//! `angles_sigma_deg` from the estimator's covariance), `bootstrap_mean`, `bootstrap_bias` (mean − estimate) and `failures`
//! (`replicate`, `error` of every failed replicate).

use crate::Global;
use anyhow::{Context, bail};
use crashrig_bootstrap as boot;
use crashrig_camera::Camera;
use crashrig_colmap::Reconstruction;
use crashrig_colmap::database::Database;
use crashrig_geometry::angles::{unwrap_about, wrapped_stats};
use crashrig_geometry::{Mat6, Rigid3, Vec3};
use crashrig_pose::{
    Projector, RansacOptions, estimate_absolute_pose, estimate_relative_pose,
    link_covariance_absolute, link_covariance_relative, link_parameters, normalize_pixels,
    refine_absolute_pose, refine_relative_pose, scaled_a_from_b,
};
use nalgebra::Vector2;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `crashrig bootstrap`.
#[derive(Debug, clap::Args)]
pub struct BootstrapArgs {
    /// COLMAP database.db with verified matches.
    pub database: PathBuf,
    /// COLMAP model directory (3D points, cameras, poses).
    #[arg(long)]
    pub model: PathBuf,
    /// Name of image A (the reference).
    #[arg(long = "image-a", value_name = "NAME")]
    pub image_a: String,
    /// Name of image B (reported relative to A).
    #[arg(long = "image-b", value_name = "NAME")]
    pub image_b: String,
    /// `absolute` (resection of B) or `relative` (essential matrix A–B).
    #[arg(long, default_value = "absolute", value_parser = ["absolute", "relative"])]
    pub method: String,
    /// Number of bootstrap replicates.
    #[arg(long, default_value_t = 500, value_parser = crate::limits::parse_iterations)]
    pub iterations: usize,
    /// Millimetres per model unit.
    #[arg(long = "mm-per-unit", value_name = "F", default_value_t = 1.0, value_parser = crate::limits::parse_mm_per_unit)]
    pub mm_per_unit: f64,
    /// Directory for histograms (PNG and SVG).
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// RANSAC inlier threshold in pixels (reprojection error, or Sampson error for relative).
    #[arg(long = "max-error-px", value_name = "PX", default_value_t = 4.0)]
    pub max_error_px: f64,
    /// Relative method: base length in mm instead of the model's projection centres.
    #[arg(long = "base-mm", value_name = "L")]
    pub base_mm: Option<f64>,
}

/// Seed used when `--seed` is not given.
const DEFAULT_SEED: u64 = 1;
/// Confidence level of the reported intervals.
const LEVEL: f64 = 0.95;
/// Parameter names, in the order of `link_parameters`.
const PARAMS: [&str; 6] = ["x", "y", "z", "omega", "phi", "kappa"];
/// Axis labels of the histograms.
const LABELS: [&str; 6] = [
    "base x [mm]",
    "base y [mm]",
    "base z [mm]",
    "omega [deg]",
    "phi [deg]",
    "kappa [deg]",
];

/// Resection input: B's observations of 3-D points (mm) and A's fixed pose.
pub(crate) struct AbsoluteInput<C> {
    pub camera_b: C,
    pub pixels_b: Vec<Vector2<f64>>,
    pub points_mm: Vec<Vec3>,
    pub a_from_world: Rigid3,
}

/// Relative-orientation input: matched pixels and the base length (mm).
pub(crate) struct RelativeInput<C> {
    pub camera_a: C,
    pub camera_b: C,
    pub pixels_a: Vec<Vector2<f64>>,
    pub pixels_b: Vec<Vector2<f64>>,
    pub base_mm: f64,
}

/// Full-sample estimate, replicates and first-order covariance of the link `A_from_B`
/// (parameters `[x, y, z (mm), ω, φ, κ (rad)]`).
pub(crate) struct LinkBootstrap {
    pub n_candidates: usize,
    pub n_inliers: usize,
    pub estimate: [f64; 6],
    pub replicates: boot::Replicates<[f64; 6], String>,
    /// Leave-one-out values (empty when not asked for).
    pub jackknife: Vec<Result<[f64; 6], String>>,
    pub first_order: Mat6,
}

/// Resection of B, then the bootstrap of the link.
pub(crate) fn bootstrap_absolute<C: Projector>(
    input: &AbsoluteInput<C>,
    iterations: usize,
    seed: u64,
    ransac: &RansacOptions,
    with_jackknife: bool,
) -> anyhow::Result<LinkBootstrap> {
    let est = estimate_absolute_pose(&input.camera_b, &input.pixels_b, &input.points_mm, ransac)
        .context("resection of image B failed")?;
    let inliers = est.inliers;
    let full = est.refinement;
    let a_from_world = input.a_from_world;
    let link = |b_from_world: &Rigid3| link_parameters(&(a_from_world * b_from_world.inverse()));
    let stat = |idx: &[usize]| -> Result<[f64; 6], String> {
        let sel: Vec<usize> = idx.iter().map(|&i| inliers[i]).collect();
        refine_absolute_pose(
            &input.camera_b,
            &input.pixels_b,
            &input.points_mm,
            &sel,
            &full.cam_from_world,
        )
        .map(|r| link(&r.cam_from_world))
        .map_err(|e| e.to_string())
    };
    let replicates = boot::run(inliers.len(), iterations, seed, stat)?;
    let jackknife = if with_jackknife {
        boot::jackknife(inliers.len(), stat)?
    } else {
        Vec::new()
    };
    Ok(LinkBootstrap {
        n_candidates: input.pixels_b.len(),
        n_inliers: inliers.len(),
        estimate: link(&full.cam_from_world),
        replicates,
        jackknife,
        first_order: link_covariance_absolute(
            &a_from_world,
            &full.cam_from_world,
            &full.covariance,
        ),
    })
}

/// Relative orientation A–B, then the bootstrap of the link.
pub(crate) fn bootstrap_relative<C: Projector>(
    input: &RelativeInput<C>,
    iterations: usize,
    seed: u64,
    ransac: &RansacOptions,
    with_jackknife: bool,
) -> anyhow::Result<LinkBootstrap> {
    let xa = normalize_pixels(&input.camera_a, &input.pixels_a)
        .context("undistorting the matched keypoints of image A")?;
    let xb = normalize_pixels(&input.camera_b, &input.pixels_b)
        .context("undistorting the matched keypoints of image B")?;
    let focal = 0.5 * (input.camera_a.focal_px() + input.camera_b.focal_px());
    let est = estimate_relative_pose(&xa, &xb, focal, ransac)
        .context("relative orientation A-B failed")?;
    let inliers = est.inliers;
    let full = est.refinement;
    let base = input.base_mm;
    let link = |b_from_a: &Rigid3| link_parameters(&scaled_a_from_b(b_from_a, base));
    let stat = |idx: &[usize]| -> Result<[f64; 6], String> {
        let sel: Vec<usize> = idx.iter().map(|&i| inliers[i]).collect();
        refine_relative_pose(&xa, &xb, &sel, &full.b_from_a)
            .map(|r| link(&r.b_from_a))
            .map_err(|e| e.to_string())
    };
    let replicates = boot::run(inliers.len(), iterations, seed, stat)?;
    let jackknife = if with_jackknife {
        boot::jackknife(inliers.len(), stat)?
    } else {
        Vec::new()
    };
    Ok(LinkBootstrap {
        n_candidates: input.pixels_a.len(),
        n_inliers: inliers.len(),
        estimate: link(&full.b_from_a),
        replicates,
        jackknife,
        first_order: link_covariance_relative(&full.b_from_a, base, &full.covariance),
    })
}

/// Per-parameter summary in output units (mm, degrees).
#[derive(Debug, Clone)]
pub(crate) struct ParamSummary {
    estimate: f64,
    sigma: f64,
    mean: f64,
    bias: f64,
    ci95: [f64; 2],
    ci95_bca: Option<[f64; 2]>,
    first_order_sigma: f64,
    /// Replicate values, unwrapped about the estimate for angles (for the histograms).
    values: Vec<f64>,
}

/// Summaries of the six link parameters.
pub(crate) fn summarize(lb: &LinkBootstrap) -> anyhow::Result<Vec<ParamSummary>> {
    let n_ok = lb.replicates.values.len();
    if n_ok < 2 {
        bail!(
            "only {n_ok} of {} bootstrap replicates succeeded; first failure: {}",
            lb.replicates.replicates,
            lb.replicates
                .failures
                .first()
                .map_or("none", |f| f.error.as_str())
        );
    }
    let jk_ok: Option<Vec<[f64; 6]>> = if lb.jackknife.is_empty() {
        None
    } else {
        lb.jackknife
            .iter()
            .map(|r| r.as_ref().ok().copied())
            .collect()
    };
    let mut out = Vec::with_capacity(6);
    for j in 0..6 {
        let raw: Vec<f64> = lb.replicates.values_only().map(|v| v[j]).collect();
        let angle = j >= 3;
        let est = lb.estimate[j];
        // Angles: unwrap about the full-sample estimate so ω ≈ 180° stays continuous.
        let values = if angle {
            unwrap_about(&raw, est)
        } else {
            raw.clone()
        };
        let sigma = if angle {
            wrapped_stats(&raw)?.sigma
        } else {
            boot::sigma(&values)?
        };
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let ci = boot::percentile_interval(&values, LEVEL)?;
        let bca = jk_ok.as_ref().and_then(|jk| {
            let jv: Vec<f64> = jk.iter().map(|v| v[j]).collect();
            let jv = if angle { unwrap_about(&jv, est) } else { jv };
            boot::bca_interval(&values, est, &jv, LEVEL).ok()
        });
        let k = if angle { 1f64.to_degrees() } else { 1.0 };
        out.push(ParamSummary {
            estimate: est * k,
            sigma: sigma * k,
            mean: mean * k,
            bias: (mean - est) * k,
            ci95: [ci.lo * k, ci.hi * k],
            ci95_bca: bca.map(|c| [c.lo * k, c.hi * k]),
            first_order_sigma: lb.first_order[(j, j)].sqrt() * k,
            values: values.iter().map(|v| v * k).collect(),
        });
    }
    Ok(out)
}

#[derive(Debug, Serialize)]
struct Ci {
    base_mm: [[f64; 2]; 3],
    angles_deg: [[f64; 2]; 3],
}

#[derive(Debug, Serialize)]
struct FirstOrder {
    base_sigma_mm: [f64; 3],
    angles_sigma_deg: [f64; 3],
}

#[derive(Debug, Serialize)]
struct Means {
    base_mm: [f64; 3],
    angles_deg: [f64; 3],
}

#[derive(Debug, Serialize)]
struct FailureJson {
    replicate: usize,
    error: String,
}

#[derive(Debug, Serialize)]
struct Output {
    method: String,
    iterations: usize,
    n_correspondences: usize,
    failed_iterations: usize,
    base_mm: [f64; 3],
    base_sigma_mm: [f64; 3],
    angles_deg: [f64; 3],
    angles_sigma_deg: [f64; 3],
    ci95: Ci,
    // Extensions.
    seed: u64,
    mm_per_unit: f64,
    n_candidates: usize,
    ci95_bca: Option<Ci>,
    first_order: FirstOrder,
    bootstrap_mean: Means,
    bootstrap_bias: Means,
    failures: Vec<FailureJson>,
}

fn output(a: &BootstrapArgs, seed: u64, lb: &LinkBootstrap, s: &[ParamSummary]) -> Output {
    let pick = |f: &dyn Fn(&ParamSummary) -> f64, off: usize| -> [f64; 3] {
        [f(&s[off]), f(&s[off + 1]), f(&s[off + 2])]
    };
    let ci = |off: usize| [s[off].ci95, s[off + 1].ci95, s[off + 2].ci95];
    let bca = |off: usize| -> Option<[[f64; 2]; 3]> {
        Some([s[off].ci95_bca?, s[off + 1].ci95_bca?, s[off + 2].ci95_bca?])
    };
    Output {
        method: a.method.clone(),
        iterations: a.iterations,
        n_correspondences: lb.n_inliers,
        failed_iterations: lb.replicates.failures.len(),
        base_mm: pick(&|p| p.estimate, 0),
        base_sigma_mm: pick(&|p| p.sigma, 0),
        angles_deg: pick(&|p| p.estimate, 3),
        angles_sigma_deg: pick(&|p| p.sigma, 3),
        ci95: Ci {
            base_mm: ci(0),
            angles_deg: ci(3),
        },
        seed,
        mm_per_unit: a.mm_per_unit,
        n_candidates: lb.n_candidates,
        ci95_bca: bca(0).zip(bca(3)).map(|(b, g)| Ci {
            base_mm: b,
            angles_deg: g,
        }),
        first_order: FirstOrder {
            base_sigma_mm: pick(&|p| p.first_order_sigma, 0),
            angles_sigma_deg: pick(&|p| p.first_order_sigma, 3),
        },
        bootstrap_mean: Means {
            base_mm: pick(&|p| p.mean, 0),
            angles_deg: pick(&|p| p.mean, 3),
        },
        bootstrap_bias: Means {
            base_mm: pick(&|p| p.bias, 0),
            angles_deg: pick(&|p| p.bias, 3),
        },
        failures: lb
            .replicates
            .failures
            .iter()
            .map(|f| FailureJson {
                replicate: f.replicate,
                error: f.error.clone(),
            })
            .collect(),
    }
}

fn model_image<'a>(
    model: &'a Reconstruction,
    dir: &Path,
    name: &str,
) -> anyhow::Result<(&'a crashrig_colmap::Image, Camera, Rigid3)> {
    let image = model
        .image_by_name(name)
        .with_context(|| format!("{}: image {name:?} is not in the model", dir.display()))?;
    let camera = model
        .camera(image.camera_id)
        .with_context(|| {
            format!(
                "{}: camera {} of image {name:?} is not in the model",
                dir.display(),
                image.camera_id
            )
        })?
        .camera
        .clone();
    camera.validate().with_context(|| {
        format!(
            "{}: camera {} of image {name:?} is invalid",
            dir.display(),
            image.camera_id
        )
    })?;
    let pose = model
        .image_cam_from_world(image.image_id)
        .with_context(|| format!("{}: image {name:?} has no pose", dir.display()))?;
    Ok((image, camera, pose))
}

fn scale_pose(p: &Rigid3, k: f64) -> Rigid3 {
    Rigid3::from_parts((p.translation.vector * k).into(), p.rotation)
}

/// Runs `crashrig bootstrap`.
pub fn run(a: BootstrapArgs, g: &Global) -> anyhow::Result<()> {
    let r = compute(&a, g.seed.unwrap_or(DEFAULT_SEED))?;
    if g.json {
        return crate::output::print_json(&r.json);
    }
    print!("{}", r.text);
    Ok(())
}

/// A finished bootstrap, not yet printed (for `crashrig paper` and other in-process callers).
pub struct BootstrapRun {
    /// The contract's JSON document with the extension fields.
    pub json: serde_json::Value,
    /// The text report.
    pub text: String,
}

/// Runs the bootstrap as `crashrig bootstrap` does (plots included when `--plots` is given),
/// without printing.
pub fn compute(a: &BootstrapArgs, seed: u64) -> anyhow::Result<BootstrapRun> {
    if !(a.mm_per_unit.is_finite() && a.mm_per_unit > 0.0) {
        bail!(
            "--mm-per-unit must be a positive number, got {}",
            a.mm_per_unit
        );
    }
    if a.iterations < 2 {
        bail!("--iterations must be at least 2, got {}", a.iterations);
    }
    if !(a.max_error_px.is_finite() && a.max_error_px > 0.0) {
        bail!(
            "--max-error-px must be a positive number, got {}",
            a.max_error_px
        );
    }
    let model = Reconstruction::read(&a.model)
        .with_context(|| format!("{}: cannot read the COLMAP model", a.model.display()))?;
    let db = Database::open(&a.database)
        .with_context(|| format!("{}: cannot open the COLMAP database", a.database.display()))?;
    let (img_a, cam_a, a_from_world) = model_image(&model, &a.model, &a.image_a)?;
    let (img_b, cam_b, b_from_world) = model_image(&model, &a.model, &a.image_b)?;
    if img_a.image_id == img_b.image_id {
        bail!(
            "--image-a and --image-b name the same image {:?}",
            a.image_a
        );
    }
    let db_id = |name: &str| -> anyhow::Result<u32> {
        db.image_id_by_name(name)
            .with_context(|| format!("{}: reading the images table", a.database.display()))?
            .with_context(|| {
                format!(
                    "{}: image {name:?} is not in the database",
                    a.database.display()
                )
            })
    };
    let (db_a, db_b) = (db_id(&a.image_a)?, db_id(&a.image_b)?);
    let k = a.mm_per_unit;
    let a_from_world = scale_pose(&a_from_world, k);
    let b_from_world = scale_pose(&b_from_world, k);
    let mut ransac = RansacOptions::new(seed);
    ransac.max_error_px = a.max_error_px;
    let lb = if a.method == "absolute" {
        let mut pixels_b = Vec::new();
        let mut points_mm = Vec::new();
        for p in &img_b.points2d {
            if let Some(pt) = p.point3d_id.and_then(|id| model.point3d(id)) {
                pixels_b.push(Vector2::new(p.xy[0], p.xy[1]));
                points_mm.push(Vec3::new(pt.xyz[0], pt.xyz[1], pt.xyz[2]) * k);
            }
        }
        let input = AbsoluteInput {
            camera_b: cam_b,
            pixels_b,
            points_mm,
            a_from_world,
        };
        bootstrap_absolute(&input, a.iterations, seed, &ransac, true).with_context(|| {
            format!(
                "{}: image {:?} ({} observations of 3-D points)",
                a.model.display(),
                a.image_b,
                input.pixels_b.len()
            )
        })?
    } else {
        let tvg = db
            .two_view_geometry(db_a, db_b)
            .with_context(|| format!("{}: reading two_view_geometries", a.database.display()))?
            .with_context(|| {
                format!(
                    "{}: no verified matches between {:?} and {:?}",
                    a.database.display(),
                    a.image_a,
                    a.image_b
                )
            })?;
        let kp = |id: u32, name: &str| -> anyhow::Result<Vec<Vector2<f64>>> {
            Ok(db
                .keypoints(id)
                .with_context(|| format!("{}: keypoints of {name:?}", a.database.display()))?
                .iter()
                .map(|k| Vector2::new(f64::from(k.xy[0]), f64::from(k.xy[1])))
                .collect())
        };
        let (kp_a, kp_b) = (kp(db_a, &a.image_a)?, kp(db_b, &a.image_b)?);
        let mut pixels_a = Vec::new();
        let mut pixels_b = Vec::new();
        for m in &tvg.inliers {
            let (Some(xa), Some(xb)) = (kp_a.get(m[0] as usize), kp_b.get(m[1] as usize)) else {
                bail!(
                    "{}: a verified match of {:?}-{:?} names keypoint {:?} beyond the keypoints",
                    a.database.display(),
                    a.image_a,
                    a.image_b,
                    m
                );
            };
            pixels_a.push(*xa);
            pixels_b.push(*xb);
        }
        let base_mm = match a.base_mm {
            Some(b) if b.is_finite() && b > 0.0 => b,
            Some(b) => bail!("--base-mm must be a positive number, got {b}"),
            None => {
                let ca = crashrig_geometry::projection_center(&a_from_world);
                let cb = crashrig_geometry::projection_center(&b_from_world);
                let d = (cb - ca).norm();
                if d.is_nan() || d <= 0.0 {
                    bail!(
                        "{}: images {:?} and {:?} have the same projection centre; give --base-mm",
                        a.model.display(),
                        a.image_a,
                        a.image_b
                    );
                }
                d
            }
        };
        let input = RelativeInput {
            camera_a: cam_a,
            camera_b: cam_b,
            pixels_a,
            pixels_b,
            base_mm,
        };
        bootstrap_relative(&input, a.iterations, seed, &ransac, true).with_context(|| {
            format!(
                "{}: {} verified matches {:?}-{:?}",
                a.database.display(),
                input.pixels_a.len(),
                a.image_a,
                a.image_b
            )
        })?
    };
    let s = summarize(&lb)?;
    if !lb.replicates.failures.is_empty() {
        eprintln!(
            "warning: {} of {} bootstrap replicates failed (first: replicate {}: {})",
            lb.replicates.failures.len(),
            a.iterations,
            lb.replicates.failures[0].replicate,
            lb.replicates.failures[0].error
        );
    }
    if let Some(dir) = &a.plots {
        write_plots(dir, &s)?;
    }
    let out = output(a, seed, &lb, &s);
    Ok(BootstrapRun {
        json: serde_json::to_value(&out).context("serialising the bootstrap result")?,
        text: text_report(&out, &s),
    })
}

fn write_plots(dir: &Path, s: &[ParamSummary]) -> anyhow::Result<()> {
    use crashrig_plot::{Format, histogram};
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the plot directory", dir.display()))?;
    for (j, p) in s.iter().enumerate() {
        for (fmt, ext) in [(Format::Png, "png"), (Format::Svg, "svg")] {
            let bytes = histogram(
                &p.values,
                &[p.mean - p.sigma, p.mean + p.sigma],
                &format!(
                    "{} over {} replicates (lines: mean ± σ)",
                    LABELS[j],
                    p.values.len()
                ),
                LABELS[j],
                fmt,
            )
            .with_context(|| format!("plotting the {} histogram", PARAMS[j]))?;
            let path = dir.join(format!("bootstrap_{}.{ext}", PARAMS[j]));
            crate::output::write_atomic(&path, &bytes)?;
        }
    }
    Ok(())
}

fn text_report(o: &Output, s: &[ParamSummary]) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "B relative to A ({}), {} correspondences ({} candidates), {} replicates, {} failed, seed {}",
        o.method, o.n_correspondences, o.n_candidates, o.iterations, o.failed_iterations, o.seed
    );
    let _ = writeln!(
        t,
        "{:<14} {:>14} {:>12} {:>12} {:>26}",
        "parameter", "estimate", "σ bootstrap", "σ 1st order", "95 % percentile interval"
    );
    for (j, p) in s.iter().enumerate() {
        let _ = writeln!(
            t,
            "{:<14} {:>14.4} {:>12.5} {:>12.5}   [{:.4}, {:.4}]",
            LABELS[j], p.estimate, p.sigma, p.first_order_sigma, p.ci95[0], p.ci95[1]
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_geometry::opk;
    use crashrig_pose::Pinhole;
    use nalgebra::Translation3;

    /// SplitMix64 (Steele, Lea & Flood 2014): a seeded test-only generator (the CLI crate does
    /// not depend on rand); uniforms in [0, 1) and Box–Muller normals.
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
        }
        fn normal(&mut self) -> f64 {
            let u1 = self.uniform(0.0, 1.0).max(f64::MIN_POSITIVE);
            let u2 = self.uniform(0.0, 1.0);
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }

    /// The paper-like link: A at the origin, B 600 mm to the side, turned by a few degrees.
    fn b_from_world() -> Rigid3 {
        let r = opk::rotation_from_opk(0.03, -0.12, 0.05);
        let c = Vec3::new(600.0, 20.0, 100.0);
        Rigid3::from_parts(
            Translation3::from(-(r * c)),
            crashrig_geometry::quat::unit_quaternion_from_rotation(&r),
        )
    }

    fn camera() -> Pinhole {
        Pinhole {
            fx: 1000.0,
            fy: 1000.0,
            cx: 800.0,
            cy: 600.0,
        }
    }

    struct Scene {
        points: Vec<Vec3>,
        px_a: Vec<Vector2<f64>>,
        px_b: Vec<Vector2<f64>>,
    }

    fn scene(n: usize) -> Scene {
        let cam = camera();
        let b = b_from_world();
        let mut rng = Rng(2024);
        let mut s = Scene {
            points: vec![],
            px_a: vec![],
            px_b: vec![],
        };
        let inside = |x: &Vector2<f64>| x.x > 0.0 && x.x < 1600.0 && x.y > 0.0 && x.y < 1200.0;
        while s.points.len() < n {
            let z = rng.uniform(2000.0, 5000.0);
            let p = Vec3::new(rng.uniform(-0.7, 0.7) * z, rng.uniform(-0.5, 0.5) * z, z);
            let pb = b.transform_point(&p.into()).coords;
            if let (Some(xa), Some(xb)) = (cam.project(&p), cam.project(&pb))
                && inside(&xa)
                && inside(&xb)
            {
                s.points.push(p);
                s.px_a.push(xa);
                s.px_b.push(xb);
            }
        }
        s
    }

    fn noisy(px: &[Vector2<f64>], sigma: f64, seed: u64, draw: u64) -> Vec<Vector2<f64>> {
        let mut rng = Rng(seed.wrapping_mul(0x1000_0000_01B3) ^ draw);
        px.iter()
            .map(|x| x + Vector2::new(rng.normal(), rng.normal()) * sigma)
            .collect()
    }

    fn absolute_input(s: &Scene, draw: u64) -> AbsoluteInput<Pinhole> {
        AbsoluteInput {
            camera_b: camera(),
            pixels_b: noisy(&s.px_b, 0.5, 31, draw),
            points_mm: s.points.clone(),
            a_from_world: Rigid3::identity(),
        }
    }

    fn relative_input(s: &Scene, draw: u64) -> RelativeInput<Pinhole> {
        RelativeInput {
            camera_a: camera(),
            camera_b: camera(),
            pixels_a: noisy(&s.px_a, 0.5, 32, draw),
            pixels_b: noisy(&s.px_b, 0.5, 33, draw),
            base_mm: b_from_world().inverse().translation.vector.norm(),
        }
    }

    /// (true spread over `draws` noise draws, mean bootstrap σ over `boot_draws` draws with
    /// `b` replicates each, mean first-order σ over the same draws), per parameter.
    fn validity(
        relative: bool,
        n: usize,
        draws: u64,
        boot_draws: u64,
        b: usize,
    ) -> [(f64, f64, f64); 6] {
        let s = scene(n);
        let ransac = RansacOptions::new(5);
        let mut est: Vec<[f64; 6]> = Vec::new();
        let mut boot_sigma = [0.0; 6];
        let mut first = [0.0; 6];
        for d in 0..draws {
            let iters = if d < boot_draws { b } else { 2 };
            let lb = if relative {
                bootstrap_relative(&relative_input(&s, d), iters, d, &ransac, false).unwrap()
            } else {
                bootstrap_absolute(&absolute_input(&s, d), iters, d, &ransac, false).unwrap()
            };
            assert!(lb.replicates.failures.is_empty());
            est.push(lb.estimate);
            if d < boot_draws {
                let sm = summarize(&lb).unwrap();
                for j in 0..6 {
                    boot_sigma[j] += sm[j].sigma / boot_draws as f64;
                    first[j] += sm[j].first_order_sigma / boot_draws as f64;
                }
            }
        }
        std::array::from_fn(|j| {
            let v: Vec<f64> = est.iter().map(|e| e[j]).collect();
            let truth = if j < 3 {
                boot::sigma(&v).unwrap()
            } else {
                wrapped_stats(&v).unwrap().sigma.to_degrees()
            };
            (truth, boot_sigma[j], first[j])
        })
    }

    fn check(what: &str, r: &[(f64, f64, f64); 6], tol: f64) {
        for (j, (truth, bs, fo)) in r.iter().enumerate() {
            eprintln!(
                "{what} {}: true σ {truth:.5}, bootstrap σ {bs:.5} ({:+.1} %), first-order σ {fo:.5} ({:+.1} %)",
                PARAMS[j],
                100.0 * (bs / truth - 1.0),
                100.0 * (fo / truth - 1.0)
            );
            assert!(
                (bs / truth - 1.0).abs() <= tol,
                "{}: bootstrap σ",
                PARAMS[j]
            );
            assert!(
                (fo / truth - 1.0).abs() <= tol,
                "{}: first-order σ",
                PARAMS[j]
            );
        }
    }

    // The fast versions: 60 draws give the true σ to ±9 % (1 s.e., 1/√(2·59)); the bootstrap σ
    // averaged over 4 draws × 100 replicates is good to ~±4 %, so ±30 % is ≈ 3 combined s.e.

    #[test]
    fn validity_fast_absolute() {
        check("absolute", &validity(false, 300, 60, 4, 100), 0.30);
    }

    #[test]
    fn validity_fast_relative() {
        check("relative", &validity(true, 300, 60, 4, 100), 0.30);
    }

    /// The evidence: 300 points, 0.5 px, ≥ 200 independent noise draws; bootstrap σ
    /// from 20 draws × 500 replicates. The true σ is then good to ±5 % (1 s.e.).
    #[test]
    fn slow_validity_absolute_and_relative() {
        if std::env::var_os("CRASHRIG_SLOW").is_none() {
            return;
        }
        check("absolute", &validity(false, 300, 300, 20, 500), 0.30);
        check("relative", &validity(true, 300, 300, 20, 500), 0.30);
    }

    #[test]
    fn determinism_nominal_one_and_two_threads() {
        let s = scene(120);
        let ransac = RansacOptions::new(9);
        let go = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let lb = bootstrap_absolute(&absolute_input(&s, 0), 64, 3, &ransac, true).unwrap();
                let sm = summarize(&lb).unwrap();
                let a = BootstrapArgs {
                    database: "db".into(),
                    model: "m".into(),
                    image_a: "a".into(),
                    image_b: "b".into(),
                    method: "absolute".into(),
                    iterations: 64,
                    mm_per_unit: 1.0,
                    plots: None,
                    max_error_px: 4.0,
                    base_mm: None,
                };
                serde_json::to_string(&output(&a, 3, &lb, &sm)).unwrap()
            })
        };
        assert_eq!(go(1), go(2));
    }

    /// Speed evidence: 500 replicates of absolute orientation on 300 correspondences (RANSAC
    /// on the full sample, then 500 warm-started LM refinements; then the 300-sample jackknife).
    /// Timing only, no assertion on time; run with
    /// `CRASHRIG_SLOW=1 cargo test --release -p crashrig-cli slow_timing -- --nocapture`.
    #[test]
    fn slow_timing_absolute_500_on_300() {
        if std::env::var_os("CRASHRIG_SLOW").is_none() {
            return;
        }
        let s = scene(300);
        let input = absolute_input(&s, 0);
        let ransac = RansacOptions::new(1);
        for jk in [false, true] {
            let t0 = std::time::Instant::now();
            let lb = bootstrap_absolute(&input, 500, 7, &ransac, jk).unwrap();
            let dt = t0.elapsed().as_secs_f64();
            assert_eq!(lb.replicates.values.len(), 500);
            eprintln!(
                "PINHOLE, 300 correspondences, 500 replicates, jackknife {jk}: {dt:.3} s on {} threads",
                rayon::current_num_threads()
            );
        }
        // The real camera model with distortion (forward-mode dual-number Jacobians).
        let cam = Camera::new(
            crashrig_camera::ModelId::from_name("OPENCV").unwrap(),
            1600,
            1200,
            vec![1000.0, 1000.0, 800.0, 600.0, -0.08, 0.02, 0.0005, -0.0003],
        )
        .unwrap();
        let b = b_from_world();
        let exact: Vec<Vector2<f64>> = s
            .points
            .iter()
            .map(|p| {
                cam.img_from_cam(&b.transform_point(&(*p).into()).coords)
                    .unwrap()
            })
            .collect();
        let input = AbsoluteInput {
            camera_b: cam,
            pixels_b: noisy(&exact, 0.5, 3, 0),
            points_mm: s.points.clone(),
            a_from_world: Rigid3::identity(),
        };
        for jk in [false, true] {
            let t0 = std::time::Instant::now();
            let lb = bootstrap_absolute(&input, 500, 7, &ransac, jk).unwrap();
            let dt = t0.elapsed().as_secs_f64();
            assert_eq!(lb.replicates.values.len(), 500);
            eprintln!(
                "OPENCV, 300 correspondences, 500 replicates, jackknife {jk}: {dt:.3} s on {} threads",
                rayon::current_num_threads()
            );
        }
    }

    fn run_args(image_a: &str, image_b: &str, method: &str) -> BootstrapArgs {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/paper/twoview");
        BootstrapArgs {
            database: format!("{root}/database.db").into(),
            model: format!("{root}/model").into(),
            image_a: image_a.into(),
            image_b: image_b.into(),
            method: method.into(),
            iterations: 20,
            mm_per_unit: 1000.0,
            plots: None,
            max_error_px: 4.0,
            base_mm: None,
        }
    }

    fn global() -> Global {
        Global {
            json: true,
            seed: Some(1),
            threads: None,
        }
    }

    #[test]
    fn run_errors_name_the_missing_image() {
        let err = run(
            run_args("nope.png", "cam_door/000001.png", "absolute"),
            &global(),
        )
        .err()
        .unwrap();
        let msg = format!("{err:#}");
        assert!(msg.contains("\"nope.png\" is not in the model"), "{msg}");
        assert!(msg.contains("twoview/model"), "{msg}");
        let err = run(
            run_args("cam_in/000001.png", "cam_in/000001.png", "relative"),
            &global(),
        )
        .err()
        .unwrap();
        assert!(format!("{err:#}").contains("same image"), "{err:#}");
        let mut a = run_args("cam_in/000001.png", "cam_door/000001.png", "absolute");
        a.mm_per_unit = -1.0;
        let err = run(a, &global()).err().unwrap();
        assert!(format!("{err:#}").contains("--mm-per-unit"), "{err:#}");
        let mut a = run_args("cam_in/000001.png", "cam_door/000001.png", "relative");
        a.base_mm = Some(0.0);
        let err = run(a, &global()).err().unwrap();
        assert!(format!("{err:#}").contains("--base-mm"), "{err:#}");
    }

    #[test]
    fn run_errors_image_missing_from_database() {
        // The fixture model with image B renamed: it is in the model but not in the database.
        let a = run_args("cam_in/000001.png", "cam_door/000001.png", "absolute");
        let m = Reconstruction::read(&a.model).unwrap();
        let mut images = m.images().to_vec();
        for im in &mut images {
            if im.name == "cam_door/000001.png" {
                im.name = "renamed.png".into();
            }
        }
        let renamed = Reconstruction::from_records(
            m.cameras().to_vec(),
            m.rigs().to_vec(),
            m.frames().to_vec(),
            images,
            m.points3d().to_vec(),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        renamed
            .write(dir.path(), crashrig_colmap::ModelFormat::Binary)
            .unwrap();
        let mut a = run_args("cam_in/000001.png", "renamed.png", "absolute");
        a.model = dir.path().to_path_buf();
        let msg = format!("{:#}", run(a, &global()).err().unwrap());
        assert!(
            msg.contains("\"renamed.png\" is not in the database"),
            "{msg}"
        );
        assert!(msg.contains("database.db"), "{msg}");
    }

    #[test]
    fn bootstrap_relative_degenerate_pure_rotation() {
        // Zero baseline: the translation direction is unobservable.
        let cam = camera();
        let r = b_from_world().rotation;
        let mut rng = Rng(5);
        let mut px_a = Vec::new();
        let mut px_b = Vec::new();
        while px_a.len() < 100 {
            let p = Vec3::new(rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), 1.0)
                * rng.uniform(2000.0, 5000.0);
            if let (Some(a), Some(b)) = (cam.project(&p), cam.project(&(r * p))) {
                px_a.push(a);
                px_b.push(b);
            }
        }
        let input = RelativeInput {
            camera_a: cam,
            camera_b: cam,
            pixels_a: noisy(&px_a, 0.5, 1, 0),
            pixels_b: noisy(&px_b, 0.5, 1, 1),
            base_mm: 100.0,
        };
        let err = bootstrap_relative(&input, 10, 1, &RansacOptions::new(1), false)
            .err()
            .unwrap();
        let msg = format!("{err:#}");
        assert!(
            msg.contains("degenerate") || msg.contains("RANSAC found no pose"),
            "{msg}"
        );
    }

    #[test]
    fn bootstrap_absolute_too_few_correspondences() {
        let s = scene(10);
        let err = bootstrap_absolute(&absolute_input(&s, 0), 10, 1, &RansacOptions::new(1), false)
            .err()
            .unwrap();
        let msg = format!("{err:#}");
        assert!(msg.contains("too few correspondences"), "{msg}");
    }
}
