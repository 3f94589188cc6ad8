//! `crashrig colmap info|convert`.

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

fn convert(input: &Path, output: &Path, to: &str, g: &Global) -> anyhow::Result<()> {
    let format = match to {
        "bin" => ModelFormat::Binary,
        "txt" => ModelFormat::Text,
        other => anyhow::bail!("--to {other}: expected bin or txt"),
    };
    let model = Reconstruction::read(input)?;
    // A reader prefers binary files: text written next to old binary files would be hidden.
    let other = match format {
        ModelFormat::Binary => "txt",
        ModelFormat::Text => "bin",
    };
    if format == ModelFormat::Text {
        if let Some(w) = model.text_format_warning() {
            eprintln!("warning: {w}");
        }
        for stem in ["cameras", "images", "points3D"] {
            let stale = output.join(format!("{stem}.{other}"));
            if stale.exists() {
                anyhow::bail!(
                    "{}: exists; COLMAP would read it instead of the text model, remove it or choose another output directory",
                    stale.display()
                );
            }
        }
    }
    model
        .write(output, format)
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
