//! `crashrig colmap info|convert|points`.

use crate::Global;
use anyhow::Context;
use crashrig_colmap::database::Database;
use crashrig_colmap::{ModelFormat, Reconstruction};
use std::path::{Path, PathBuf};

/// COLMAP subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum ColmapCommand {
    /// Counts of a sparse model directory or a database.db.
    ///
    /// Model: format, legacy (no rigs/frames files), cameras, rigs, frames, images, points3D,
    /// observations, as COLMAP reports them (legacy models get one rig per camera and one frame
    /// per image). Database: user_version, row counts, `keypoints` = images with a keypoints
    /// row, `matched_pairs` / `verified_pairs` = pairs with at least one match / inlier. The
    /// database is opened read-only and never modified.
    Info {
        /// A sparse model directory (binary or text, 3.x or >=3.12) or a database.db file.
        path: PathBuf,
    },
    /// Read any COLMAP model and write all five files in the current layout.
    ///
    /// Accepts 3.x three-file and >=3.12 five-file models, binary or text (binary wins when
    /// both exist). Doubles survive bin->txt->bin bit-exactly (text uses %.17g, like COLMAP).
    /// The five files are written to temporary files first and renamed at the end.
    Convert {
        /// Input model directory.
        input: PathBuf,
        /// Output directory (created if missing).
        output: PathBuf,
        /// Output format.
        #[arg(long, value_parser = ["bin", "txt"])]
        to: String,
    },
    /// The 3-D points an image observes near a pixel (nearest first), or one point by id:
    /// how to find the point3D ids of scale-bar targets for `calibrate --scale-points`.
    Points {
        /// A sparse model directory.
        model: PathBuf,
        /// The image (its name in the model, e.g. `cam_out/000001.png`).
        #[arg(long, requires = "near", conflicts_with = "point")]
        image: Option<String>,
        /// The pixel (x y, COLMAP convention: upper-left corner of the image at 0 0).
        #[arg(long, num_args = 2, value_names = ["X", "Y"], requires = "image")]
        near: Option<Vec<f64>>,
        /// Search radius around the pixel (px).
        #[arg(long, default_value_t = 10.0)]
        radius: f64,
        /// Instead: one point3D id (its position and track).
        #[arg(long)]
        point: Option<u64>,
    },
}

/// Runs a COLMAP subcommand.
pub fn run(cmd: ColmapCommand, g: &Global) -> anyhow::Result<()> {
    match cmd {
        ColmapCommand::Info { path } => {
            if path.is_dir() {
                model_info(&path, g)
            } else {
                database_info(&path, g)
            }
        }
        ColmapCommand::Convert { input, output, to } => convert(&input, &output, &to, g),
        ColmapCommand::Points {
            model,
            image,
            near,
            radius,
            point,
        } => points(&model, image.as_deref(), near.as_deref(), radius, point, g),
    }
}

/// `colmap points`: one JSON object per point, or a table.
fn points(
    dir: &Path,
    image: Option<&str>,
    near: Option<&[f64]>,
    radius: f64,
    point: Option<u64>,
    g: &Global,
) -> anyhow::Result<()> {
    let model = Reconstruction::read(dir)?;
    let rows: Vec<serde_json::Value> = match (image, near, point) {
        (_, _, Some(id)) => {
            let p = model
                .point3d(id)
                .with_context(|| format!("{}: no point3D with id {id}", dir.display()))?;
            let track: Vec<serde_json::Value> = p
                .track
                .iter()
                .filter_map(|t| {
                    let img = model.images().iter().find(|i| i.image_id == t.image_id)?;
                    let xy = img.points2d.get(t.point2d_idx as usize)?.xy;
                    Some(serde_json::json!({"image": img.name, "pixel": xy}))
                })
                .collect();
            vec![
                serde_json::json!({"point3D_id": id, "xyz": p.xyz, "track_length": p.track.len(),
                "error_px": p.error, "track": track}),
            ]
        }
        (Some(name), Some(xy), None) => {
            anyhow::ensure!(
                radius.is_finite() && radius > 0.0,
                "--radius must be a positive number of pixels, got {radius}"
            );
            crashrig_colmap::lookup::points_near(&model, name, [xy[0], xy[1]], radius)
                .with_context(|| format!("{}: image {name:?} is not in the model", dir.display()))?
                .into_iter()
                .map(|p| {
                    serde_json::json!({"point3D_id": p.point3d_id, "xyz": p.xyz, "pixel": p.pixel,
                        "distance_px": p.distance_px, "track_length": p.track_length, "error_px": p.error_px})
                })
                .collect()
        }
        _ => anyhow::bail!("give --image NAME --near X Y, or --point ID (see --help)"),
    };
    if g.json {
        return crate::output::print_json(&rows);
    }
    if point.is_some() {
        print_point_with_track(&rows[0]);
        return Ok(());
    }
    println!(
        "{:>10} {:>12} {:>12} {:>12} {:>9} {:>9} {:>6}",
        "point3D_id", "x", "y", "z", "u", "v", "track"
    );
    for r in &rows {
        let f = |v: &serde_json::Value, i: usize| v[i].as_f64().unwrap_or(f64::NAN);
        println!(
            "{:>10} {:>12.4} {:>12.4} {:>12.4} {:>9.1} {:>9.1} {:>6}",
            r["point3D_id"],
            f(&r["xyz"], 0),
            f(&r["xyz"], 1),
            f(&r["xyz"], 2),
            f(&r["pixel"], 0),
            f(&r["pixel"], 1),
            r["track_length"]
        );
    }
    if rows.is_empty() {
        eprintln!("no 3-D point observed within {radius} px (try a larger --radius)");
    }
    Ok(())
}

/// Text mode of `colmap points --point ID`: the point's position, track length and reprojection
/// error, then one line per observation (image name and pixel) — a point has no single pixel.
fn print_point_with_track(r: &serde_json::Value) {
    let f = |v: &serde_json::Value, i: usize| v[i].as_f64().unwrap_or(f64::NAN);
    println!(
        "{:>10} {:>12} {:>12} {:>12} {:>9} {:>6}",
        "point3D_id", "x", "y", "z", "error_px", "track"
    );
    println!(
        "{:>10} {:>12.4} {:>12.4} {:>12.4} {:>9.3} {:>6}",
        r["point3D_id"],
        f(&r["xyz"], 0),
        f(&r["xyz"], 1),
        f(&r["xyz"], 2),
        r["error_px"].as_f64().unwrap_or(f64::NAN),
        r["track_length"]
    );
    let track = r["track"].as_array().map_or(&[][..], Vec::as_slice);
    if !track.is_empty() {
        println!("track:");
        println!("  {:>9} {:>9}  image", "u", "v");
        for t in track {
            println!(
                "  {:>9.2} {:>9.2}  {}",
                f(&t["pixel"], 0),
                f(&t["pixel"], 1),
                t["image"].as_str().unwrap_or("")
            );
        }
    }
}

fn model_info(dir: &Path, g: &Global) -> anyhow::Result<()> {
    let model = Reconstruction::read(dir)?;
    let info = serde_json::json!({
        "format": model.format().name(),
        "legacy": model.is_legacy(),
        "cameras": model.cameras().len(),
        "rigs": model.rigs().len(),
        "frames": model.frames().len(),
        "images": model.images().len(),
        "points3D": model.points3d().len(),
        "observations": model.num_observations(),
    });
    warn_stored_pose_deviation(&model);
    if g.json {
        return crate::output::print_json(&info);
    }
    println!("COLMAP model {}", dir.display());
    println!(
        "  format        {}{}",
        model.format().name(),
        if model.is_legacy() {
            " (legacy three-file model: trivial rigs and frames)"
        } else {
            ""
        }
    );
    println!("  cameras       {}", model.cameras().len());
    println!("  rigs          {}", model.rigs().len());
    println!("  frames        {}", model.frames().len());
    println!("  images        {}", model.images().len());
    println!("  points3D      {}", model.points3d().len());
    println!("  observations  {}", model.num_observations());
    Ok(())
}

/// COLMAP uses the rig/frame pose and ignores the one in images.*; say so on stderr when they
/// disagree (colmap#4752), since other tools may read the images.* pose.
fn warn_stored_pose_deviation(model: &Reconstruction) {
    let mut worst: Option<(u32, f64, f64)> = None;
    let mut count = 0usize;
    for im in model.images() {
        let Some((angle, dt)) = model.stored_pose_deviation(im.image_id) else {
            continue;
        };
        let scale = model
            .image_cam_from_world(im.image_id)
            .map_or(1.0, |p| p.translation.vector.norm().max(1.0));
        if angle > 1e-6 || dt > 1e-6 * scale {
            count += 1;
            if worst.is_none_or(|(_, a, d)| angle + dt / scale > a + d / scale) {
                worst = Some((im.image_id, angle, dt));
            }
        }
    }
    if let Some((id, angle, dt)) = worst {
        eprintln!(
            "warning: {count} image(s) store a pose in images.* that differs from the rig/frame pose COLMAP uses \
             (worst: image {id}, {:.3e} deg, {dt:.3e} model units); the rig/frame pose is used",
            angle.to_degrees()
        );
    }
}

fn database_info(path: &Path, g: &Global) -> anyhow::Result<()> {
    let db = Database::open(path)?;
    let c = db.counts()?;
    let info = serde_json::json!({
        "user_version": c.user_version,
        "cameras": c.cameras,
        "images": c.images,
        "rigs": c.rigs,
        "frames": c.frames,
        "keypoints": c.keypoints,
        "matched_pairs": c.matched_pairs,
        "verified_pairs": c.verified_pairs,
    });
    if g.json {
        return crate::output::print_json(&info);
    }
    println!("COLMAP database {}", path.display());
    println!("  user_version    {}", c.user_version);
    println!("  cameras         {}", c.cameras);
    println!("  images          {}", c.images);
    println!("  rigs            {}", c.rigs);
    println!("  frames          {}", c.frames);
    println!("  keypoints       {} images", c.keypoints);
    println!("  matched pairs   {}", c.matched_pairs);
    println!(
        "  verified pairs  {} (with at least one inlier)",
        c.verified_pairs
    );
    Ok(())
}

/// Whether `name` is a file an older `colmap convert` (or COLMAP) writes into a model
/// directory, so an old model made of such files may be replaced as a whole.
fn model_file_name(name: &str) -> bool {
    let stem_ok = |stem: &str| ["cameras", "images", "points3D", "rigs", "frames"].contains(&stem);
    name.starts_with(".tmp")
        || name
            .rsplit_once('.')
            .is_some_and(|(stem, ext)| (ext == "bin" || ext == "txt") && stem_ok(stem))
}

fn convert(input: &Path, output: &Path, to: &str, g: &Global) -> anyhow::Result<()> {
    let format = match to {
        "bin" => ModelFormat::Binary,
        "txt" => ModelFormat::Text,
        other => anyhow::bail!("--to {other}: expected bin or txt"),
    };
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
    if same(input, output) {
        anyhow::bail!(
            "{}: is the input model directory; converting in place would replace the input, choose another output directory",
            output.display()
        );
    }
    let model = Reconstruction::read(input)?;
    if format == ModelFormat::Text
        && let Some(w) = model.text_format_warning()
    {
        eprintln!("warning: {w}");
    }
    // The model is written into a staging directory beside OUT and swapped in as a whole:
    // an interrupted convert leaves the old OUT untouched, and no file of an older model
    // (of either format) survives beside the new one.
    let staged = crashrig_outdir::Staged::new(output, model_file_name)?;
    model
        .write(staged.dir(), format)
        .with_context(|| format!("writing {}", output.display()))?;
    staged
        .commit()
        .with_context(|| format!("writing {}", output.display()))?;
    let info = serde_json::json!({
        "input": input.display().to_string(),
        "output": output.display().to_string(),
        "format": format.name(),
        "legacy_input": model.is_legacy(),
        "cameras": model.cameras().len(),
        "rigs": model.rigs().len(),
        "frames": model.frames().len(),
        "images": model.images().len(),
        "points3D": model.points3d().len(),
    });
    if g.json {
        crate::output::print_json(&info)
    } else {
        eprintln!(
            "wrote {} model to {} ({} cameras, {} images, {} points3D)",
            format.name(),
            output.display(),
            model.cameras().len(),
            model.images().len(),
            model.points3d().len()
        );
        Ok(())
    }
}
