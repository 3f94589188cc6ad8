//! A sequence (or a range of it) written as one 16-bit grey PNG per frame, `<epoch>.png`,
//! holding the camera's values unscaled, plus `frames.csv` (`epoch,time_s`), through a
//! staged output directory: an interrupted or failed export leaves nothing.

use std::path::{Path, PathBuf};

use crate::{FramesError, GreyFrame, Result, Sequence, SourceKind};

/// What to export.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportConfig {
    /// The frame source (directory, `.cine`, `.cih`/`.cihx`).
    pub source: PathBuf,
    /// The output directory (created, or replaced when it holds only files an export writes).
    pub out: PathBuf,
    /// The epoch name of the first frame to export (default: the first frame).
    pub first: Option<String>,
    /// The epoch name of the last frame to export (default: the last frame).
    pub last: Option<String>,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    /// The output directory.
    pub out: PathBuf,
    /// The kind of source read.
    pub kind: SourceKind,
    /// Frames written.
    pub frames: usize,
    /// Epoch name of the first frame written.
    pub first: String,
    /// Epoch name of the last frame written.
    pub last: String,
}

/// Names an export writes: an old export made only of them may be replaced.
pub fn is_export_file(name: &str) -> bool {
    name == "frames.csv" || name.ends_with(".png")
}

/// The index range `first..=last` of the epochs named (inclusive), or an error naming the
/// source when an epoch is unknown or the range is empty.
pub fn index_range(
    seq: &Sequence,
    first: Option<&str>,
    last: Option<&str>,
) -> Result<(usize, usize)> {
    let find = |epoch: &str, flag: &str| {
        seq.index_of(epoch).ok_or_else(|| FramesError::Range {
            path: seq.path().to_path_buf(),
            problem: format!("{flag} {epoch}: no frame has this epoch name"),
        })
    };
    let a = first.map(|e| find(e, "--first")).transpose()?.unwrap_or(0);
    let b = last
        .map(|e| find(e, "--last"))
        .transpose()?
        .unwrap_or(seq.len() - 1);
    if a > b {
        return Err(FramesError::Range {
            path: seq.path().to_path_buf(),
            problem: format!(
                "no frame in the range: --first {} comes after --last {}",
                seq.epoch(a),
                seq.epoch(b)
            ),
        });
    }
    Ok((a, b))
}

/// Encodes a frame as a 16-bit grey PNG of its values as they are (no scaling).
pub fn png16_of_frame(frame: &GreyFrame, name: &Path) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let err = |e: png::EncodingError| FramesError::Encode {
        path: name.to_path_buf(),
        problem: e.to_string(),
    };
    {
        let mut enc = png::Encoder::new(&mut bytes, frame.width, frame.height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Sixteen);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header().map_err(err)?;
        let data: Vec<u8> = frame.pixels.iter().flat_map(|v| v.to_be_bytes()).collect();
        w.write_image_data(&data).map_err(err)?;
        w.finish().map_err(err)?;
    }
    Ok(bytes)
}

/// Exports the frames `config.first..=config.last` of `config.source` into `config.out`:
/// `<epoch>.png` for each and `frames.csv` (`epoch,time_s`; `time_s` empty for a directory).
/// Frames are read, encoded and written one at a time. Nothing appears in `config.out` unless
/// every frame was written.
pub fn export(config: &ExportConfig) -> Result<Exported> {
    let seq = Sequence::open(&config.source)?;
    let (a, b) = index_range(&seq, config.first.as_deref(), config.last.as_deref())?;
    let mut staged = crashrig_outdir::Staged::new(&config.out, is_export_file)?;
    let mut frame = GreyFrame::default();
    let mut csv = String::from("epoch,time_s\n");
    for i in a..=b {
        seq.read(i, &mut frame)?;
        let name = format!("{}.png", seq.epoch(i));
        let png = png16_of_frame(&frame, Path::new(&name))?;
        staged.write(&name, &png)?;
        csv.push_str(seq.epoch(i));
        csv.push(',');
        if let Some(t) = seq.time_s(i) {
            csv.push_str(&t.to_string());
        }
        csv.push('\n');
    }
    staged.write("frames.csv", csv.as_bytes())?;
    staged.commit()?;
    Ok(Exported {
        out: config.out.clone(),
        kind: seq.kind(),
        frames: b - a + 1,
        first: seq.epoch(a).to_string(),
        last: seq.epoch(b).to_string(),
    })
}
