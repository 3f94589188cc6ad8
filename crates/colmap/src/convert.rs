//! `crashrig colmap convert`: any COLMAP model rewritten as all five files in the current
//! layout, binary or text, swapped into the output directory as a whole.
//!
//! ```
//! # fn main() -> crashrig_colmap::Result<()> {
//! # let input = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/tie/model");
//! use crashrig_colmap::ModelFormat;
//! use crashrig_colmap::convert::{ConvertConfig, convert};
//! let out = tempfile::tempdir().map_err(|source| crashrig_colmap::Error::Io {
//!     path: "tempdir".into(),
//!     source,
//! })?;
//! let output = out.path().join("txt");
//! let done = convert(&ConvertConfig { input, output: output.clone(), format: ModelFormat::Text })?;
//! assert!(output.join("rigs.txt").is_file());
//! assert_eq!(done.format, ModelFormat::Text);
//! # Ok(()) }
//! ```

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::{Error, ModelFormat, Reconstruction, Result};

/// What to convert where.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertConfig {
    /// The input model directory (3.x or ≥ 3.12, binary or text).
    pub input: PathBuf,
    /// The output directory (created if missing; an older model in it is replaced as a whole).
    pub output: PathBuf,
    /// The format to write.
    pub format: ModelFormat,
}

/// What was written (`crashrig colmap convert --json`).
///
/// The fields are in alphabetical order: the key order of the command's JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Converted {
    /// Number of cameras.
    pub cameras: usize,
    /// The format written.
    pub format: ModelFormat,
    /// Number of frames written.
    pub frames: usize,
    /// Number of images.
    pub images: usize,
    /// The input directory, as given.
    pub input: String,
    /// The input was a 3.x three-file model (its trivial rigs and frames were written).
    pub legacy_input: bool,
    /// The output directory, as given.
    pub output: String,
    /// Number of 3-D points.
    #[serde(rename = "points3D")]
    pub points3d: usize,
    /// Number of rigs written.
    pub rigs: usize,
    /// Lines for stderr (each printed after `warning: `).
    #[serde(skip)]
    pub warnings: Vec<String>,
}

impl Converted {
    /// The one line `crashrig colmap convert` prints on stderr without `--json`.
    pub fn text_report(&self) -> String {
        format!(
            "wrote {} model to {} ({} cameras, {} images, {} points3D)\n",
            self.format.name(),
            self.output,
            self.cameras,
            self.images,
            self.points3d
        )
    }
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

/// Reads `config.input` and writes it to `config.output` in `config.format`. The model is
/// written into a staging directory beside the output and swapped in as a whole: an
/// interrupted convert leaves the old output untouched, and no file of an older model (of
/// either format) survives beside the new one.
///
/// # Errors
/// [`Error::ConvertInPlace`] when the output is the input directory; any error of
/// [`Reconstruction::read`]; [`Error::Staging`] when the output cannot be staged (e.g. it holds
/// files that are not a model's); [`Error::Writing`] / [`Error::Commit`] when writing fails.
pub fn convert(config: &ConvertConfig) -> Result<Converted> {
    let (input, output, format) = (&config.input, &config.output, config.format);
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
    if same(input, output) {
        return Err(Error::ConvertInPlace {
            path: output.clone(),
        });
    }
    let model = Reconstruction::read(input)?;
    let warnings = match format {
        ModelFormat::Text => model.text_format_warning().into_iter().collect(),
        ModelFormat::Binary => Vec::new(),
    };
    let files = model.encode(format).map_err(|source| Error::Writing {
        path: output.clone(),
        source: Box::new(source),
    })?;
    let mut staged = crashrig_outdir::Staged::new(output, model_file_name).map_err(|problem| {
        Error::Staging {
            path: output.clone(),
            problem,
        }
    })?;
    // Each file straight into the staging directory; the directory is swapped in as a whole.
    for (name, bytes) in &files {
        staged.write(name, bytes).map_err(|source| Error::Commit {
            path: output.clone(),
            source,
        })?;
    }
    staged.commit().map_err(|source| Error::Commit {
        path: output.clone(),
        source,
    })?;
    Ok(Converted {
        cameras: model.cameras().len(),
        format,
        frames: model.frames().len(),
        images: model.images().len(),
        input: input.display().to_string(),
        legacy_input: model.is_legacy(),
        output: output.display().to_string(),
        points3d: model.points3d().len(),
        rigs: model.rigs().len(),
        warnings,
    })
}
