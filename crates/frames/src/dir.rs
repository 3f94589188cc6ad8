//! A directory with one PNG or TIFF image per frame, taken in byte-wise order of file name.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use crate::error::io_err;
use crate::{
    FramesError, GreyFrame, Opened, PixelLayout, Result, SequenceInfo, Source, SourceKind,
    TimeSource,
};

/// The largest decoded image (bytes) a PNG or TIFF decoder may allocate: 16-bit RGBA at
/// 16 384 × 16 384. Larger images are refused by the decoder (a decode error naming the file).
const DECODE_LIMIT_BYTES: usize = 16_384 * 16_384 * 8;

#[derive(Debug)]
pub(crate) struct DirSource {
    files: Vec<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Png,
    Tiff,
}

fn format_of(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some(Format::Png),
        "tif" | "tiff" => Some(Format::Tiff),
        _ => None,
    }
}

/// What one image file's header says.
struct Header {
    width: u32,
    height: u32,
    bits: u8,
}

pub(crate) fn open(path: &Path) -> Result<Opened> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(path).map_err(io_err(path, "cannot list the directory"))? {
        let entry = entry.map_err(io_err(path, "cannot list the directory"))?;
        let file = entry.path();
        if format_of(&file).is_none() {
            continue;
        }
        let meta = std::fs::metadata(&file).map_err(io_err(&file, "cannot open"))?;
        if meta.is_file() {
            files.push(file);
        }
    }
    // Byte-wise order of the file name (not locale, not natural order).
    files.sort_by(|a, b| {
        let a = a.file_name().map(|n| n.as_encoded_bytes());
        let b = b.file_name().map(|n| n.as_encoded_bytes());
        a.cmp(&b)
    });
    if files.is_empty() {
        return Err(FramesError::NoFrames {
            path: path.to_path_buf(),
        });
    }
    let mut epochs: Vec<String> = Vec::with_capacity(files.len());
    let mut first: Option<(Header, String)> = None;
    for file in &files {
        let Some(stem) = file.file_stem().and_then(|s| s.to_str()) else {
            return Err(FramesError::Decode {
                path: file.clone(),
                problem: "the file name is not UTF-8, so it cannot name an epoch".to_string(),
            });
        };
        let h = header(file)?;
        match &first {
            None => first = Some((h, file_name(file))),
            Some((f, name)) => {
                if (h.width, h.height, h.bits) != (f.width, f.height, f.bits) {
                    return Err(FramesError::Mismatch {
                        path: file.clone(),
                        width: h.width,
                        height: h.height,
                        bits: h.bits,
                        first: name.clone(),
                        first_width: f.width,
                        first_height: f.height,
                        first_bits: f.bits,
                    });
                }
            }
        }
        epochs.push(stem.to_string());
    }
    // Two files with one stem (`a.png`, `a.tif`) would give two frames one epoch name.
    {
        let mut sorted: Vec<&str> = epochs.iter().map(String::as_str).collect();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            let stem = w[0];
            let file = files
                .iter()
                .filter(|f| f.file_stem().and_then(|s| s.to_str()) == Some(stem))
                .nth(1)
                .cloned()
                .unwrap_or_else(|| path.to_path_buf());
            return Err(FramesError::Decode {
                path: file,
                problem: format!(
                    "a second frame named `{stem}` (epoch names are file names without extension)"
                ),
            });
        }
    }
    let (h, _) = first.expect("at least one file");
    let info = SequenceInfo {
        path: path.to_path_buf(),
        kind: SourceKind::Directory,
        frames: files.len(),
        width: h.width,
        height: h.height,
        bits: h.bits,
        layout: PixelLayout::ImageFiles,
        frame_rate_hz: None,
        exposure_s: None,
        trigger_utc: None,
        trigger_frame: None,
        first_image_number: None,
        frame_step: None,
        camera: None,
        time_source: TimeSource::None,
    };
    Ok(Opened {
        info,
        epochs,
        times_s: None,
        source: Source::Dir(DirSource { files }),
    })
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn decode_err(path: &Path, e: impl std::fmt::Display) -> FramesError {
    FramesError::Decode {
        path: path.to_path_buf(),
        problem: e.to_string(),
    }
}

fn unsupported(path: &Path, what: impl Into<String>) -> FramesError {
    FramesError::Unsupported {
        path: path.to_path_buf(),
        what: what.into(),
    }
}

fn header(path: &Path) -> Result<Header> {
    match format_of(path) {
        Some(Format::Png) => {
            let reader = png_reader(path)?;
            let (w, h, bits) = png_shape(path, &reader)?;
            Ok(Header {
                width: w,
                height: h,
                bits,
            })
        }
        Some(Format::Tiff) => {
            let mut dec = tiff_decoder(path)?;
            let (w, h) = dec.dimensions().map_err(|e| decode_err(path, e))?;
            let (_, bits) = tiff_kind(path, &mut dec)?;
            Ok(Header {
                width: w,
                height: h,
                bits,
            })
        }
        None => unreachable!("only image files are listed"),
    }
}

fn png_reader(path: &Path) -> Result<png::Reader<BufReader<File>>> {
    let file = File::open(path).map_err(io_err(path, "cannot open"))?;
    let mut dec = png::Decoder::new_with_limits(
        BufReader::new(file),
        png::Limits {
            bytes: DECODE_LIMIT_BYTES,
        },
    );
    // Palettes and tRNS expand to RGB(A); 16 bits stay 16 bits.
    dec.set_transformations(png::Transformations::EXPAND);
    dec.read_info().map_err(|e| decode_err(path, e))
}

/// Width, height and bits of a PNG, refusing bit depths other than 8 and 16.
fn png_shape(path: &Path, reader: &png::Reader<BufReader<File>>) -> Result<(u32, u32, u8)> {
    let info = reader.info();
    let bits = match (info.color_type, info.bit_depth) {
        (png::ColorType::Indexed, _) => 8, // palette entries are 8-bit RGB
        (_, png::BitDepth::Eight) => 8,
        (_, png::BitDepth::Sixteen) => 16,
        (_, d) => {
            return Err(unsupported(
                path,
                format!("{}-bit PNG (8 or 16 bits per sample are read)", d as u8),
            ));
        }
    };
    Ok((info.width, info.height, bits))
}

fn tiff_decoder(path: &Path) -> Result<tiff::decoder::Decoder<BufReader<File>>> {
    let file = File::open(path).map_err(io_err(path, "cannot open"))?;
    let mut limits = tiff::decoder::Limits::default();
    limits.decoding_buffer_size = DECODE_LIMIT_BYTES;
    Ok(tiff::decoder::Decoder::new(BufReader::new(file))
        .map_err(|e| decode_err(path, e))?
        .with_limits(limits))
}

/// Samples per pixel used (1 grey, 3 colour) and the samples to skip after them, of a TIFF.
#[derive(Clone, Copy)]
struct TiffKind {
    colour: bool,
    stride: usize,
}

fn tiff_kind(
    path: &Path,
    dec: &mut tiff::decoder::Decoder<BufReader<File>>,
) -> Result<(TiffKind, u8)> {
    use tiff::ColorType as C;
    if dec.more_images() {
        return Err(unsupported(
            path,
            "a TIFF with several images (one image per file is read)",
        ));
    }
    let photometric: Option<u16> = dec
        .find_tag_unsigned(tiff::tags::Tag::PhotometricInterpretation)
        .map_err(|e| decode_err(path, e))?;
    if photometric == Some(0) {
        return Err(unsupported(
            path,
            "WhiteIsZero TIFF (inverted grey; BlackIsZero grey and RGB are read)",
        ));
    }
    let ct = dec.colortype().map_err(|e| decode_err(path, e))?;
    let (kind, bits) = match ct {
        C::Gray(b) => (
            TiffKind {
                colour: false,
                stride: 1,
            },
            b,
        ),
        C::Multiband {
            bit_depth,
            num_samples: 2,
        } => (
            TiffKind {
                colour: false,
                stride: 2,
            },
            bit_depth,
        ),
        C::GrayA(b) => (
            TiffKind {
                colour: false,
                stride: 2,
            },
            b,
        ),
        C::RGB(b) => (
            TiffKind {
                colour: true,
                stride: 3,
            },
            b,
        ),
        C::RGBA(b) => (
            TiffKind {
                colour: true,
                stride: 4,
            },
            b,
        ),
        other => {
            return Err(unsupported(
                path,
                format!("TIFF colour type {other:?} (grey and RGB are read)"),
            ));
        }
    };
    if bits != 8 && bits != 16 {
        return Err(unsupported(
            path,
            format!("{bits}-bit TIFF (8 or 16 bits per sample are read)"),
        ));
    }
    Ok((kind, bits))
}

/// `0.299 R + 0.587 G + 0.114 B` rounded to nearest (halves up), in integers.
fn grey_of(r: u32, g: u32, b: u32) -> u16 {
    // ≤ 1000 · 65535, fits u32; the result ≤ 65535.
    ((299 * r + 587 * g + 114 * b + 500) / 1000) as u16
}

/// Converts interleaved samples (`stride` per pixel, the first one grey or the first three
/// RGB) to grey values.
fn to_grey<T: Copy + Into<u32>>(samples: &[T], colour: bool, stride: usize, out: &mut [u16]) {
    for (o, px) in out.iter_mut().zip(samples.chunks_exact(stride)) {
        *o = if colour {
            grey_of(px[0].into(), px[1].into(), px[2].into())
        } else {
            px[0].into() as u16
        };
    }
}

impl DirSource {
    pub(crate) fn read(
        &self,
        index: usize,
        info: &SequenceInfo,
        into: &mut GreyFrame,
    ) -> Result<()> {
        let path = &self.files[index];
        let (w, h, bits) = match format_of(path) {
            Some(Format::Png) => read_png(path, into)?,
            Some(Format::Tiff) => read_tiff(path, into)?,
            None => unreachable!("only image files are listed"),
        };
        // The file may have changed since it was opened.
        if (w, h, bits) != (info.width, info.height, info.bits) {
            return Err(FramesError::Mismatch {
                path: path.clone(),
                width: w,
                height: h,
                bits,
                first: self.files.first().map(|f| file_name(f)).unwrap_or_default(),
                first_width: info.width,
                first_height: info.height,
                first_bits: info.bits,
            });
        }
        Ok(())
    }
}

fn read_png(path: &Path, into: &mut GreyFrame) -> Result<(u32, u32, u8)> {
    let mut reader = png_reader(path)?;
    let (w, h, bits) = png_shape(path, &reader)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| decode_err(path, "image too large"))?;
    let mut buf = vec![0u8; size];
    let out = reader
        .next_frame(&mut buf)
        .map_err(|e| decode_err(path, e))?;
    let (ct, depth) = (out.color_type, out.bit_depth);
    let samples = ct.samples();
    let (colour, stride) = match ct {
        png::ColorType::Grayscale | png::ColorType::GrayscaleAlpha => (false, samples),
        png::ColorType::Rgb | png::ColorType::Rgba => (true, samples),
        png::ColorType::Indexed => return Err(decode_err(path, "palette not expanded")),
    };
    let pixels = into.reshape(w, h, bits);
    let row_values = w as usize * stride;
    match depth {
        png::BitDepth::Eight => {
            for (v, row) in buf.chunks_exact(out.line_size).take(h as usize).enumerate() {
                let dst = &mut pixels[v * w as usize..(v + 1) * w as usize];
                to_grey(&row[..row_values], colour, stride, dst);
            }
        }
        png::BitDepth::Sixteen => {
            let mut vals = vec![0u16; row_values];
            for (v, row) in buf.chunks_exact(out.line_size).take(h as usize).enumerate() {
                for (d, b) in vals.iter_mut().zip(row.chunks_exact(2)) {
                    *d = u16::from_be_bytes([b[0], b[1]]);
                }
                let dst = &mut pixels[v * w as usize..(v + 1) * w as usize];
                to_grey(&vals, colour, stride, dst);
            }
        }
        d => return Err(unsupported(path, format!("{}-bit PNG", d as u8))),
    }
    Ok((w, h, bits))
}

fn read_tiff(path: &Path, into: &mut GreyFrame) -> Result<(u32, u32, u8)> {
    let mut dec = tiff_decoder(path)?;
    let (w, h) = dec.dimensions().map_err(|e| decode_err(path, e))?;
    let (kind, bits) = tiff_kind(path, &mut dec)?;
    let image = dec.read_image().map_err(|e| decode_err(path, e))?;
    let n = w as usize * h as usize;
    let pixels = into.reshape(w, h, bits);
    let short = || decode_err(path, "fewer samples than the image size needs");
    match (image, bits) {
        (tiff::decoder::DecodingResult::U8(s), 8) => {
            if s.len() < n * kind.stride {
                return Err(short());
            }
            to_grey(&s, kind.colour, kind.stride, pixels);
        }
        (tiff::decoder::DecodingResult::U16(s), 16) => {
            if s.len() < n * kind.stride {
                return Err(short());
            }
            to_grey(&s, kind.colour, kind.stride, pixels);
        }
        _ => {
            return Err(unsupported(
                path,
                "TIFF samples that are not unsigned integers (signed or floating-point)",
            ));
        }
    }
    Ok((w, h, bits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_of_nominal() {
        assert_eq!(grey_of(255, 255, 255), 255);
        assert_eq!(grey_of(65535, 65535, 65535), 65535);
        assert_eq!(grey_of(0, 0, 0), 0);
        // 0.299 · 100 = 29.9 → 30; 0.587 · 100 = 58.7 → 59; 0.114 · 100 = 11.4 → 11.
        assert_eq!(grey_of(100, 0, 0), 30);
        assert_eq!(grey_of(0, 100, 0), 59);
        assert_eq!(grey_of(0, 0, 100), 11);
        // 0.299·10 + 0.587·20 + 0.114·30 = 2.99 + 11.74 + 3.42 = 18.15 → 18.
        assert_eq!(grey_of(10, 20, 30), 18);
    }
}
