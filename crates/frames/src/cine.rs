//! Phantom `.cine` files: uncompressed grey, 8 and 16 bits, and the packed 10- and 12-bit
//! layouts; per-frame times from the tagged time block and the trigger time.
//!
//! Layout (little-endian): the file header (44 bytes) | BITMAPINFOHEADER (40 bytes) | SETUP
//! (`Length` bytes) | tagged blocks | `ImageCount` image offsets (i64) | per image:
//! `AnnotationSize` (u32), the annotation, `ImageSize` (u32, the annotation's last 4 bytes),
//! the pixels. docs/FRAMES.md lists the fields read.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::bytes::{Le, read_at, unpack};
use crate::error::io_err;
use crate::{
    FramesError, GreyFrame, Opened, PixelLayout, Result, SequenceInfo, Source, SourceKind,
    TimeSource, index_epochs,
};

/// `biCompression` of 10-bit packed data (`BI_PACKED`).
const BI_PACKED: u32 = 256;
/// `biCompression` of 12-bit packed data (`BI_PACKED_12L`).
const BI_PACKED_12L: u32 = 1024;
/// Tagged block of per-image times (TIME64 each), and its older twin.
const TAG_TIME_ONLY: u16 = 1002;
const TAG_IMAGE_TIME: u16 = 1001;
/// Largest width or height accepted (px); Phantom sensors are far smaller.
const MAX_SIDE: i32 = 1 << 16;
/// Offsets inside SETUP (bytes from its start).
/// `Mark` (`ST`) at 140, followed by the block's `Length` (u16) at 142.
const SETUP_MARK: usize = 140;
const SETUP_FRAME_RATE: usize = 768;
const SETUP_CFA: usize = 808;
const SETUP_REAL_BPP: usize = 896;
const SETUP_SHUTTER_NS: usize = 1568;

#[derive(Debug)]
pub(crate) struct CineSource {
    file: File,
    path: PathBuf,
    file_len: u64,
    offsets: Vec<u64>,
    layout: PixelLayout,
    /// Bytes of one stored row (unpacked layouts), or of the whole image (packed ones, which
    /// are one bit stream).
    image_bytes: u64,
    row_bytes: u64,
    bottom_up: bool,
}

fn header_err(path: &Path, field: &'static str, problem: impl Into<String>) -> FramesError {
    FramesError::Header {
        path: path.to_path_buf(),
        field,
        problem: problem.into(),
    }
}

fn unsupported(path: &Path, what: impl Into<String>) -> FramesError {
    FramesError::Unsupported {
        path: path.to_path_buf(),
        what: what.into(),
    }
}

fn truncated(path: &Path, part: impl Into<String>, needed: u64, len: u64) -> FramesError {
    FramesError::Truncated {
        path: path.to_path_buf(),
        part: part.into(),
        needed,
        len,
    }
}

/// Reads `n` bytes at `at`, or reports the part as truncated.
fn read_part(
    file: &File,
    path: &Path,
    len: u64,
    at: u64,
    n: usize,
    part: &'static str,
) -> Result<Vec<u8>> {
    let end = at.checked_add(n as u64).unwrap_or(u64::MAX);
    if end > len {
        return Err(truncated(path, part, end, len));
    }
    let mut buf = vec![0u8; n];
    read_at(file, path, at, &mut buf)?;
    Ok(buf)
}

/// A TIME64: seconds since 1970-01-01 UTC and a 32-bit binary fraction of a second.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Time64 {
    pub seconds: u32,
    pub fraction: u32,
}

impl Time64 {
    fn from_le(b: &[u8]) -> Time64 {
        Time64 {
            fraction: u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            seconds: u32::from_le_bytes([b[4], b[5], b[6], b[7]]),
        }
    }

    /// `self − other` in seconds, exact to one rounding (the difference is formed in integers).
    pub fn minus_s(self, other: Time64) -> f64 {
        let a = (i128::from(self.seconds) << 32) + i128::from(self.fraction);
        let b = (i128::from(other.seconds) << 32) + i128::from(other.fraction);
        (a - b) as f64 / 4_294_967_296.0
    }

    /// ISO 8601 UTC with nanoseconds (rounded down), e.g. `2019-02-26T22:17:25.923956285Z`.
    pub fn utc(self) -> String {
        let days = i64::from(self.seconds / 86_400);
        let secs = self.seconds % 86_400;
        let (y, m, d) = civil_from_days(days);
        let nanos = (u64::from(self.fraction) * 1_000_000_000) >> 32;
        format!(
            "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{nanos:09}Z",
            secs / 3600,
            secs / 60 % 60,
            secs % 60
        )
    }
}

/// Proleptic Gregorian date of `days` since 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

pub(crate) fn open(path: &Path) -> Result<Opened> {
    let file = File::open(path).map_err(io_err(path, "cannot open"))?;
    let len = file.metadata().map_err(io_err(path, "cannot open"))?.len();
    let head = read_part(&file, path, len, 0, 44, "the file header")?;
    let h = Le {
        bytes: &head,
        path,
        file_len: len,
        base: 0,
        part: "the file header",
    };
    if &head[0..2] != b"CI" {
        return Err(header_err(
            path,
            "Type",
            "not a Phantom cine file (it does not start with `CI`)",
        ));
    }
    match h.u16(4)? {
        0 => {}
        1 => return Err(unsupported(path, "compression 1 (JPEG-compressed cine)")),
        2 => {
            return Err(unsupported(
                path,
                "compression 2 (uninterpolated colour-filter-array raw)",
            ));
        }
        c => return Err(unsupported(path, format!("compression {c}"))),
    }
    let first_image_no = h.i32(16)?;
    let image_count = h.u32(20)?;
    let off_image_header = u64::from(h.u32(24)?);
    let off_setup = u64::from(h.u32(28)?);
    let off_image_offsets = u64::from(h.u32(32)?);
    let trigger = Time64::from_le(&head[36..44]);
    if image_count == 0 {
        return Err(header_err(path, "ImageCount", "the file holds no image"));
    }

    // BITMAPINFOHEADER.
    let bmp = read_part(&file, path, len, off_image_header, 40, "the bitmap header")?;
    let b = Le {
        bytes: &bmp,
        path,
        file_len: len,
        base: off_image_header,
        part: "the bitmap header",
    };
    let width = b.i32(4)?;
    let height = b.i32(8)?;
    let bit_count = b.u16(14)?;
    let bi_compression = b.u32(16)?;
    let bi_size_image = u64::from(b.u32(20)?);
    if !(1..=MAX_SIDE).contains(&width) {
        return Err(header_err(
            path,
            "biWidth",
            format!("{width} is not a width in 1..={MAX_SIDE}"),
        ));
    }
    if height < 0 {
        return Err(unsupported(
            path,
            format!("biHeight {height} (top-down rows stated by a negative height)"),
        ));
    }
    if !(1..=MAX_SIDE).contains(&height) {
        return Err(header_err(
            path,
            "biHeight",
            format!("{height} is not a height in 1..={MAX_SIDE}"),
        ));
    }
    let (width, height) = (width as u32, height as u32);

    // SETUP: the fields lying inside its own Length.
    let mark = read_part(
        &file,
        path,
        len,
        off_setup + SETUP_MARK as u64,
        4,
        "the setup",
    )?;
    if &mark[0..2] != b"ST" {
        return Err(header_err(
            path,
            "Setup.Mark",
            "the setup block has no `ST` mark (cine files before 1999 are not read)",
        ));
    }
    let setup_len = u16::from_le_bytes([mark[2], mark[3]]) as usize;
    let setup = read_part(&file, path, len, off_setup, setup_len, "the setup")?;
    let s = Le {
        bytes: &setup,
        path,
        file_len: len,
        base: off_setup,
        part: "the setup",
    };
    let field = |at: usize| -> Result<Option<u32>> {
        if at + 4 <= setup_len {
            s.u32(at).map(Some)
        } else {
            Ok(None)
        }
    };
    let frame_rate = field(SETUP_FRAME_RATE)?.filter(|&r| r > 0);
    let cfa = field(SETUP_CFA)?.unwrap_or(0);
    let real_bpp = field(SETUP_REAL_BPP)?;
    let shutter_ns = field(SETUP_SHUTTER_NS)?.filter(|&t| t > 0);
    if cfa != 0 || matches!(bit_count, 24 | 48) {
        return Err(unsupported(
            path,
            format!("colour cine (CFA {cfa}, biBitCount {bit_count}); grey cines are read"),
        ));
    }
    let layout = match (bi_compression, bit_count) {
        (0, 8) => PixelLayout::U8,
        (0, 16) => PixelLayout::U16Le,
        (BI_PACKED, _) => PixelLayout::Packed10,
        (BI_PACKED_12L, _) => PixelLayout::Packed12,
        (c, b) => {
            return Err(unsupported(
                path,
                format!(
                    "biCompression {c} with biBitCount {b} (read: 8 or 16 bits uncompressed, packed 10-bit (256), packed 12-bit (1024))"
                ),
            ));
        }
    };
    let bits = match layout {
        PixelLayout::U8 => 8,
        PixelLayout::U16Le => match real_bpp {
            Some(r @ 9..=16) => r as u8,
            _ => 16,
        },
        PixelLayout::Packed10 => 10,
        _ => 12,
    };
    let pixels = u64::from(width) * u64::from(height);
    let (image_bytes, row_bytes) = match layout {
        PixelLayout::U8 | PixelLayout::U16Le => {
            let min_row = u64::from(width) * if layout == PixelLayout::U8 { 1 } else { 2 };
            // Rows may be padded: biSizeImage / height when it divides evenly and is large enough.
            let row = if bi_size_image > 0
                && bi_size_image % u64::from(height) == 0
                && bi_size_image / u64::from(height) >= min_row
            {
                bi_size_image / u64::from(height)
            } else {
                min_row
            };
            (row * u64::from(height), row)
        }
        _ => {
            let Some(n) = layout.bytes_for(pixels) else {
                return Err(unsupported(
                    path,
                    format!(
                        "{} with {width}x{height} pixels (not a whole number of bytes)",
                        layout.name()
                    ),
                ));
            };
            (n, 0)
        }
    };

    // Tagged blocks between SETUP and the image offsets.
    let mut times_block: Option<(u64, u64)> = None;
    let mut old_times_block: Option<(u64, u64)> = None;
    let mut pos = off_setup + setup_len as u64;
    while pos + 8 <= off_image_offsets && pos + 8 <= len {
        let mut tag = [0u8; 8];
        read_at(&file, path, pos, &mut tag)?;
        let size = u64::from(u32::from_le_bytes([tag[0], tag[1], tag[2], tag[3]]));
        let kind = u16::from_le_bytes([tag[4], tag[5]]);
        if size < 8 || pos + size > off_image_offsets {
            break;
        }
        match kind {
            TAG_TIME_ONLY => times_block = Some((pos + 8, size - 8)),
            TAG_IMAGE_TIME => old_times_block = Some((pos + 8, size - 8)),
            _ => {}
        }
        pos += size;
    }

    // The image offsets, checked against the file's length before they are allocated.
    let n = image_count as usize;
    let table_end = off_image_offsets + 8 * u64::from(image_count);
    if table_end > len {
        return Err(truncated(path, "the image offsets", table_end, len));
    }
    let mut table = vec![0u8; 8 * n];
    read_at(&file, path, off_image_offsets, &mut table)?;
    let mut offsets = Vec::with_capacity(n);
    for (i, o) in table.chunks_exact(8).enumerate() {
        let o = i64::from_le_bytes(o.try_into().expect("8 bytes"));
        // Each image needs at least its two size fields and its pixels.
        let end = u64::try_from(o)
            .ok()
            .and_then(|o| o.checked_add(8 + image_bytes));
        match end {
            Some(end) if end <= len => offsets.push(o as u64),
            Some(end) => return Err(truncated(path, format!("frame {i}"), end, len)),
            None => {
                return Err(header_err(
                    path,
                    "ImageOffsets",
                    format!("frame {i}: offset {o} lies outside the file"),
                ));
            }
        }
    }
    drop(table);

    // Times: the camera's per-image stamps minus the trigger; else image number / frame rate.
    let stamps = times_block
        .into_iter()
        .chain(old_times_block)
        .find(|&(_, size)| size >= 8 * u64::from(image_count));
    let (times_s, time_source) = match stamps {
        Some((at, _)) => {
            let raw = read_part(&file, path, len, at, 8 * n, "the time block")?;
            let t = raw
                .chunks_exact(8)
                .map(|b| Time64::from_le(b).minus_s(trigger))
                .collect::<Vec<_>>();
            (Some(t), TimeSource::Timestamps)
        }
        None => match frame_rate {
            Some(rate) => (
                Some(
                    (0..n)
                        .map(|i| (i64::from(first_image_no) + i as i64) as f64 / f64::from(rate))
                        .collect(),
                ),
                TimeSource::FrameRate,
            ),
            None => (None, TimeSource::None),
        },
    };

    let info = SequenceInfo {
        path: path.to_path_buf(),
        kind: SourceKind::Cine,
        frames: n,
        width,
        height,
        bits,
        layout,
        frame_rate_hz: frame_rate.map(f64::from),
        exposure_s: shutter_ns.map(|t| f64::from(t) * 1e-9),
        trigger_utc: Some(trigger.utc()),
        trigger_frame: None,
        first_image_number: Some(i64::from(first_image_no)),
        frame_step: None,
        camera: None,
        time_source,
    };
    Ok(Opened {
        info,
        epochs: index_epochs(n),
        times_s,
        source: Source::Cine(CineSource {
            file,
            path: path.to_path_buf(),
            file_len: len,
            offsets,
            layout,
            image_bytes,
            row_bytes,
            // Uncompressed images are stored bottom-up (BMP convention), packed ones top-down.
            bottom_up: matches!(layout, PixelLayout::U8 | PixelLayout::U16Le),
        }),
    })
}

impl CineSource {
    pub(crate) fn read(
        &self,
        index: usize,
        info: &SequenceInfo,
        into: &mut GreyFrame,
    ) -> Result<()> {
        let (path, len) = (&self.path, self.file_len);
        let start = self.offsets[index];
        let frame = || format!("frame {index}");
        let mut four = [0u8; 4];
        read_at(&self.file, path, start, &mut four)?;
        let annotation = u64::from(u32::from_le_bytes(four));
        if annotation < 8 {
            return Err(header_err(
                path,
                "AnnotationSize",
                format!("frame {index}: {annotation} (at least 8)"),
            ));
        }
        let pixels_at = start + annotation;
        let end = pixels_at.saturating_add(self.image_bytes);
        if end > len {
            return Err(truncated(path, frame(), end, len));
        }
        read_at(&self.file, path, pixels_at - 4, &mut four)?;
        let image_size = u64::from(u32::from_le_bytes(four));
        if image_size < self.image_bytes {
            return Err(header_err(
                path,
                "ImageSize",
                format!(
                    "frame {index}: {image_size} bytes, a {}x{} {} image needs {}",
                    info.width,
                    info.height,
                    self.layout.name(),
                    self.image_bytes
                ),
            ));
        }
        let mut raw = vec![0u8; self.image_bytes as usize];
        read_at(&self.file, path, pixels_at, &mut raw)?;
        let (w, h) = (info.width as usize, info.height as usize);
        let out = into.reshape(info.width, info.height, info.bits);
        if self.bottom_up {
            for r in 0..h {
                let src = &raw[r * self.row_bytes as usize..];
                let dst = &mut out[(h - 1 - r) * w..(h - r) * w];
                unpack(self.layout, src, dst);
            }
        } else {
            unpack(self.layout, &raw, out);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time64_utc_nominal() {
        // 2019-02-26T22:17:25Z is 1551219445 s after the epoch; fraction 2^31 = 0.5 s.
        let t = Time64 {
            seconds: 1_551_219_445,
            fraction: 1 << 31,
        };
        assert_eq!(t.utc(), "2019-02-26T22:17:25.500000000Z");
        let epoch = Time64 {
            seconds: 0,
            fraction: 0,
        };
        assert_eq!(epoch.utc(), "1970-01-01T00:00:00.000000000Z");
        // 2000-02-29 (a leap day of a century divisible by 400): 951782400 s.
        let leap = Time64 {
            seconds: 951_782_400,
            fraction: 0,
        };
        assert_eq!(leap.utc(), "2000-02-29T00:00:00.000000000Z");
    }

    #[test]
    fn time64_minus_nominal() {
        let a = Time64 {
            seconds: 10,
            fraction: 0,
        };
        let b = Time64 {
            seconds: 9,
            fraction: 3 << 30,
        };
        // 10 − 9.75 = 0.25 exactly (binary fractions).
        assert_eq!(a.minus_s(b), 0.25);
        assert_eq!(b.minus_s(a), -0.25);
    }
}
