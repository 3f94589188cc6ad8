//! High-speed camera files read as grey frames, one frame at a time: a directory of PNG or TIFF
//! images, a Phantom `.cine`, or a Photron `.cih`/`.cihx` header with its `.mraw`. No image
//! processing: the pixels are the camera's values, unscaled.
//!
//! # Conventions
//! - A [`GreyFrame`] is row-major, top row first, `width × height` values of type `u16`; 8-bit
//!   data stays in 0..=255, 10-, 12- and 16-bit data are the values as stored
//!   ([`GreyFrame::bits`] says how many bits they span).
//! - Colour images (PNG/TIFF only) become grey as `0.299 R + 0.587 G + 0.114 B`, rounded to the
//!   nearest integer (halves up); alpha is ignored.
//! - A frame's **epoch name** is its file stem for a directory and its index in the file from 0
//!   in six digits (`000000`, `000001`, …) for a `.cine`/`.mraw`.
//! - Times are seconds relative to the trigger ([`Sequence::time_s`]); a directory has none.
//! - Frames are streamed: [`Sequence::read`] decodes one frame into a buffer the caller reuses,
//!   so memory does not grow with the number of frames. It takes `&self`, so threads may read
//!   frames of one sequence in parallel.
//! - Nothing in a file is trusted: every header count is checked against the file's length
//!   before anything is allocated, and a malformed file is an error naming it (and the frame),
//!   never a panic.
//!
//! The formats, their fields and what is refused: `docs/FRAMES.md`.
//!
//! # Entry points
//! - [`Sequence::open`]: open a directory, `.cine`, `.cih` or `.cihx`.
//! - [`Sequence::read`]: decode frame `index` into a [`GreyFrame`].
//! - [`Sequence::info`]: what the header states ([`SequenceInfo`]).
//! - [`export::export`]: every frame (or a range) as a 16-bit grey PNG plus `frames.csv`, written
//!   through a crash-safe staged output directory.
//!
//! # Features
//! None: the crate has no cargo features.
//!
//! # Example
//! ```
//! use crashrig_frames::{GreyFrame, Sequence, SourceKind};
//!
//! // Two 3×2 grey PNG frames in a directory.
//! let dir = tempfile::tempdir()?;
//! for (name, base) in [("0001", 10u8), ("0002", 20)] {
//!     let file = std::fs::File::create(dir.path().join(format!("{name}.png")))?;
//!     let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 3, 2);
//!     enc.set_color(png::ColorType::Grayscale);
//!     enc.set_depth(png::BitDepth::Eight);
//!     enc.write_header()?.write_image_data(&[base, base + 1, base + 2, base + 3, base + 4, base + 5])?;
//! }
//!
//! let seq = Sequence::open(dir.path())?;
//! assert_eq!(seq.kind(), SourceKind::Directory);
//! assert_eq!((seq.len(), seq.width(), seq.height(), seq.bits()), (2, 3, 2, 8));
//! assert_eq!(seq.epoch(1), "0002");
//! assert_eq!(seq.time_s(1), None); // a directory carries no times
//!
//! let mut frame = GreyFrame::default();
//! seq.read(1, &mut frame)?;
//! assert_eq!(frame.pixels, [20, 21, 22, 23, 24, 25]);
//! assert_eq!(frame.get(2, 1), Some(25)); // column 2, row 1
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod bytes;
mod cine;
mod dir;
mod error;
pub mod export;
mod mraw;

use std::path::{Path, PathBuf};

pub use error::{FramesError, Result};

/// One grey frame, row-major (top row first), the camera's values unscaled.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GreyFrame {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// The values lie in `0 .. 2^bits` (8 for 8-bit data; 10, 12 or 16 as the camera states).
    pub bits: u8,
    /// `width × height` values, row `v` at `v * width ..`.
    pub pixels: Vec<u16>,
}

impl GreyFrame {
    /// The value at column `u`, row `v` (0-based), or `None` outside the frame.
    pub fn get(&self, u: u32, v: u32) -> Option<u16> {
        if u >= self.width || v >= self.height {
            return None;
        }
        self.pixels
            .get(v as usize * self.width as usize + u as usize)
            .copied()
    }

    /// Sets the size and bit depth and resizes the pixel buffer, keeping its allocation.
    pub(crate) fn reshape(&mut self, width: u32, height: u32, bits: u8) -> &mut [u16] {
        self.width = width;
        self.height = height;
        self.bits = bits;
        self.pixels.resize(width as usize * height as usize, 0);
        &mut self.pixels
    }
}

/// What kind of file a [`Sequence`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceKind {
    /// A directory with one PNG or TIFF image per frame.
    Directory,
    /// A Phantom `.cine` file.
    Cine,
    /// A Photron `.cih`/`.cihx` header with its `.mraw`.
    Mraw,
}

impl SourceKind {
    /// The name used in summaries: `directory`, `cine`, `mraw`.
    pub fn name(self) -> &'static str {
        match self {
            SourceKind::Directory => "directory",
            SourceKind::Cine => "cine",
            SourceKind::Mraw => "mraw",
        }
    }
}

/// How a frame's values are stored in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelLayout {
    /// Image files (PNG or TIFF), decoded by their own decoders.
    ImageFiles,
    /// One byte per value.
    U8,
    /// Two bytes per value, little-endian.
    U16Le,
    /// 10-bit values packed big-endian, four values in five bytes (Phantom).
    Packed10,
    /// 12-bit values packed big-endian, two values in three bytes (Phantom, Photron).
    Packed12,
}

impl PixelLayout {
    /// A short name: `image files`, `8-bit`, `16-bit little-endian`, `packed 10-bit`, `packed 12-bit`.
    pub fn name(self) -> &'static str {
        match self {
            PixelLayout::ImageFiles => "image files",
            PixelLayout::U8 => "8-bit",
            PixelLayout::U16Le => "16-bit little-endian",
            PixelLayout::Packed10 => "packed 10-bit",
            PixelLayout::Packed12 => "packed 12-bit",
        }
    }

    /// Bytes of `n` values in this layout (`None` for image files or a count that does not
    /// fill whole bytes, or on overflow).
    pub(crate) fn bytes_for(self, n: u64) -> Option<u64> {
        match self {
            PixelLayout::ImageFiles => None,
            PixelLayout::U8 => Some(n),
            PixelLayout::U16Le => n.checked_mul(2),
            PixelLayout::Packed10 => (n % 4 == 0).then(|| n / 4 * 5),
            PixelLayout::Packed12 => (n % 2 == 0).then(|| n / 2 * 3),
        }
    }
}

/// Where a sequence's times come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeSource {
    /// No times (a directory of images).
    None,
    /// The camera's own per-frame timestamps (a `.cine`'s tagged time block) minus its trigger time.
    Timestamps,
    /// The frame's number relative to the trigger divided by the frame rate.
    FrameRate,
}

impl TimeSource {
    /// A short name: `none`, `timestamps`, `frame rate`.
    pub fn name(self) -> &'static str {
        match self {
            TimeSource::None => "none",
            TimeSource::Timestamps => "timestamps",
            TimeSource::FrameRate => "frame rate",
        }
    }
}

/// What a source's header states (`crashrig frames info` prints it). Fields a format does not
/// state are `None`.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceInfo {
    /// The path opened (the directory, `.cine`, `.cih` or `.cihx`).
    pub path: PathBuf,
    /// The kind of source.
    pub kind: SourceKind,
    /// Number of frames.
    pub frames: usize,
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Bits the values span (see [`GreyFrame::bits`]).
    pub bits: u8,
    /// How the values are stored.
    pub layout: PixelLayout,
    /// The frame rate the camera states (Hz).
    pub frame_rate_hz: Option<f64>,
    /// Exposure time the camera states (s).
    pub exposure_s: Option<f64>,
    /// `.cine`: the trigger's time as the camera states it, UTC, ISO 8601 with nanoseconds.
    pub trigger_utc: Option<String>,
    /// `.mraw`: the trigger's frame number in the camera's numbering (see docs/FRAMES.md).
    pub trigger_frame: Option<i64>,
    /// The camera's number of the first frame in the file (`.cine`: `FirstImageNo`, relative to
    /// the trigger; `.mraw`: `Start Frame`).
    pub first_image_number: Option<i64>,
    /// Recorded frames between two frames of the file (`.mraw`: `Save Step`; 1 otherwise).
    pub frame_step: Option<u32>,
    /// The camera model as stated.
    pub camera: Option<String>,
    /// Where [`Sequence::time_s`] comes from.
    pub time_source: TimeSource,
}

/// An opened frame source; frames are read one at a time with [`Sequence::read`].
#[derive(Debug)]
pub struct Sequence {
    info: SequenceInfo,
    epochs: Vec<String>,
    times_s: Option<Vec<f64>>,
    source: Source,
}

#[derive(Debug)]
enum Source {
    Dir(dir::DirSource),
    Cine(cine::CineSource),
    Mraw(mraw::MrawSource),
}

/// What an opened format hands to [`Sequence`].
pub(crate) struct Opened {
    info: SequenceInfo,
    epochs: Vec<String>,
    times_s: Option<Vec<f64>>,
    source: Source,
}

impl Sequence {
    /// Opens a directory of PNG/TIFF images, a `.cine`, or a `.cih`/`.cihx` (with the `.mraw`
    /// of the same name beside it). Reads and checks every header (for a directory: every
    /// image's header, so that frames of another size are found now); decodes no pixels.
    pub fn open(path: &Path) -> Result<Sequence> {
        let meta = std::fs::metadata(path).map_err(error::io_err(path, "cannot open"))?;
        let opened = if meta.is_dir() {
            dir::open(path)?
        } else {
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase);
            match ext.as_deref() {
                Some("cine") => cine::open(path)?,
                Some("cih") | Some("cihx") => mraw::open(path)?,
                _ => {
                    return Err(FramesError::NotASource {
                        path: path.to_path_buf(),
                    });
                }
            }
        };
        let Opened {
            info,
            epochs,
            times_s,
            source,
        } = opened;
        debug_assert_eq!(epochs.len(), info.frames);
        Ok(Sequence {
            info,
            epochs,
            times_s,
            source,
        })
    }

    /// The kind of source.
    pub fn kind(&self) -> SourceKind {
        self.info.kind
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.info.frames
    }

    /// Whether the sequence has no frame (never true for an opened sequence).
    pub fn is_empty(&self) -> bool {
        self.info.frames == 0
    }

    /// Width (px).
    pub fn width(&self) -> u32 {
        self.info.width
    }

    /// Height (px).
    pub fn height(&self) -> u32 {
        self.info.height
    }

    /// Bits the values span.
    pub fn bits(&self) -> u8 {
        self.info.bits
    }

    /// The path opened.
    pub fn path(&self) -> &Path {
        &self.info.path
    }

    /// Frame `index`'s epoch name (file stem, or six-digit index). Panics past the end, like
    /// slice indexing.
    pub fn epoch(&self, index: usize) -> &str {
        &self.epochs[index]
    }

    /// The index of the frame whose epoch name is `epoch`.
    pub fn index_of(&self, epoch: &str) -> Option<usize> {
        self.epochs.iter().position(|e| e == epoch)
    }

    /// Frame `index`'s time relative to the trigger (s); `None` for a directory or past the end.
    pub fn time_s(&self, index: usize) -> Option<f64> {
        self.times_s.as_ref().and_then(|t| t.get(index).copied())
    }

    /// The frame rate the camera states (Hz).
    pub fn frame_rate_hz(&self) -> Option<f64> {
        self.info.frame_rate_hz
    }

    /// What the header states.
    pub fn info(&self) -> &SequenceInfo {
        &self.info
    }

    /// Decodes frame `index` into `into`, reusing its buffer.
    pub fn read(&self, index: usize, into: &mut GreyFrame) -> Result<()> {
        if index >= self.info.frames {
            return Err(FramesError::NoSuchFrame {
                path: self.info.path.clone(),
                index,
                len: self.info.frames,
            });
        }
        match &self.source {
            Source::Dir(d) => d.read(index, &self.info, into),
            Source::Cine(c) => c.read(index, &self.info, into),
            Source::Mraw(m) => m.read(index, &self.info, into),
        }
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// Six-digit epoch names `000000`, `000001`, … for `n` frames (more digits past 999 999).
pub(crate) fn index_epochs(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("{i:06}")).collect()
}
