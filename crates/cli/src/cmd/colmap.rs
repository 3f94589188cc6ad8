//! `crashrig colmap info|convert|points`.
//!
//! Arguments → one entry of `crashrig_colmap` ([`info::model_info`], [`info::database_info`],
//! [`convert::convert`], [`lookup::points`]) → its JSON or its text. Reading, checking,
//! counting, converting and rendering live in the library.

use crate::Global;
use crashrig_colmap::lookup::{self, Points, PointsQuery};
use crashrig_colmap::{ModelFormat, convert, info};
use std::path::PathBuf;

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
    /// The five files are written into a hidden staging directory beside OUTPUT and swapped in
    /// as a whole: a reader of OUTPUT sees the old model or the complete new one.
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
        #[arg(long, requires = "near", conflicts_with = "point",
              value_parser = crate::limits::parse_image_name)]
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
        // A directory, or a path that is not there (the model reader says so, as
        // `crashrig.read_model` does); a file is a database.
        ColmapCommand::Info { path } if !path.is_file() => {
            let r = info::model_info(&path)?;
            print(g, &r, &r.warnings, &r.text_report())
        }
        ColmapCommand::Info { path } => {
            let r = info::database_info(&path)?;
            print(g, &r, &[], &r.text_report())
        }
        ColmapCommand::Convert { input, output, to } => {
            let format = match to.as_str() {
                "bin" => ModelFormat::Binary,
                "txt" => ModelFormat::Text,
                other => anyhow::bail!("--to {other}: expected bin or txt"),
            };
            let config = convert::ConvertConfig {
                input,
                output,
                format,
            };
            let r = convert::convert(&config)?;
            for w in &r.warnings {
                eprintln!("warning: {w}");
            }
            if g.json {
                return crate::output::print_json(&r);
            }
            eprint!("{}", r.text_report());
            Ok(())
        }
        ColmapCommand::Points {
            model,
            image,
            near,
            radius,
            point,
        } => {
            let query = match (image, near, point) {
                (_, _, Some(id)) => PointsQuery::Id(id),
                (Some(image), Some(xy), None) => {
                    anyhow::ensure!(
                        radius.is_finite() && radius > 0.0,
                        "--radius must be a positive number of pixels, got {radius}"
                    );
                    let pixel = [xy[0], xy[1]];
                    PointsQuery::Near {
                        image,
                        pixel,
                        radius_px: radius,
                    }
                }
                _ => anyhow::bail!("give --image NAME --near X Y, or --point ID (see --help)"),
            };
            let r = lookup::points(&model, &query)?;
            print(g, &r, &[], &r.text_report())?;
            if !g.json && matches!(&r, Points::Near(rows) if rows.is_empty()) {
                eprintln!("no 3-D point observed within {radius} px (try a larger --radius)");
            }
            Ok(())
        }
    }
}

/// The warnings on stderr, then the JSON document or the text on stdout.
fn print<T: serde::Serialize>(
    g: &Global,
    json: &T,
    warnings: &[String],
    text: &str,
) -> anyhow::Result<()> {
    for w in warnings {
        eprintln!("warning: {w}");
    }
    if g.json {
        return crate::output::print_json(json);
    }
    print!("{text}");
    Ok(())
}
