//! Positioned reads (several threads may read one file at once), bounds-checked little-endian
//! fields, and the unpacking of 8-, 16-, packed 10- and packed 12-bit pixel data.

use std::fs::File;
use std::path::Path;

use crate::error::io_err;
use crate::{FramesError, PixelLayout, Result};

/// Reads exactly `buf.len()` bytes at `offset` without moving a shared cursor.
pub(crate) fn read_at(file: &File, path: &Path, offset: u64, buf: &mut [u8]) -> Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileExt;
        file.read_exact_at(buf, offset)
            .map_err(io_err(path, "read failed"))
    }
    #[cfg(windows)]
    {
        use std::os::windows::fs::FileExt;
        let mut done = 0;
        while done < buf.len() {
            let n = file
                .seek_read(&mut buf[done..], offset + done as u64)
                .map_err(io_err(path, "read failed"))?;
            if n == 0 {
                return Err(io_err(path, "read failed")(std::io::Error::from(
                    std::io::ErrorKind::UnexpectedEof,
                )));
            }
            done += n;
        }
        Ok(())
    }
}

/// A little-endian view of a header held in memory; every read is bounds-checked and a short
/// header is [`FramesError::Truncated`].
pub(crate) struct Le<'a> {
    pub bytes: &'a [u8],
    pub path: &'a Path,
    /// The file's length, for the error message.
    pub file_len: u64,
    /// Offset of `bytes[0]` in the file.
    pub base: u64,
    pub part: &'static str,
}

impl Le<'_> {
    fn take<const N: usize>(&self, at: usize) -> Result<[u8; N]> {
        at.checked_add(N)
            .and_then(|end| self.bytes.get(at..end))
            .map(|s| s.try_into().expect("slice of length N"))
            .ok_or_else(|| FramesError::Truncated {
                path: self.path.to_path_buf(),
                part: self.part.to_string(),
                needed: self.base.saturating_add(at as u64).saturating_add(N as u64),
                len: self.file_len,
            })
    }
    pub fn u16(&self, at: usize) -> Result<u16> {
        Ok(u16::from_le_bytes(self.take(at)?))
    }
    pub fn u32(&self, at: usize) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(at)?))
    }
    pub fn i32(&self, at: usize) -> Result<i32> {
        Ok(i32::from_le_bytes(self.take(at)?))
    }
}

/// Unpacks `raw` (exactly `layout.bytes_for(out.len())` bytes) into `out`.
pub(crate) fn unpack(layout: PixelLayout, raw: &[u8], out: &mut [u16]) {
    match layout {
        PixelLayout::U8 => {
            for (o, &b) in out.iter_mut().zip(raw) {
                *o = u16::from(b);
            }
        }
        PixelLayout::U16Le => {
            for (o, b) in out.iter_mut().zip(raw.chunks_exact(2)) {
                *o = u16::from_le_bytes([b[0], b[1]]);
            }
        }
        PixelLayout::Packed10 => {
            // Four values in five bytes, most significant bit first.
            for (o, b) in out.chunks_exact_mut(4).zip(raw.chunks_exact(5)) {
                let b: [u16; 5] = [b[0], b[1], b[2], b[3], b[4]].map(u16::from);
                o[0] = (b[0] << 2) | (b[1] >> 6);
                o[1] = ((b[1] & 0x3f) << 4) | (b[2] >> 4);
                o[2] = ((b[2] & 0x0f) << 6) | (b[3] >> 2);
                o[3] = ((b[3] & 0x03) << 8) | b[4];
            }
        }
        PixelLayout::Packed12 => {
            // Two values in three bytes, most significant bit first.
            for (o, b) in out.chunks_exact_mut(2).zip(raw.chunks_exact(3)) {
                let b: [u16; 3] = [b[0], b[1], b[2]].map(u16::from);
                o[0] = (b[0] << 4) | (b[1] >> 4);
                o[1] = ((b[1] & 0x0f) << 8) | b[2];
            }
        }
        PixelLayout::ImageFiles => unreachable!("image files are decoded by their decoders"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unpack_packed10_nominal() {
        // 0x3ff, 0x001, 0x2aa, 0x155 → bits 1111111111 0000000001 1010101010 0101010101
        let raw = [0xff, 0xc0, 0x1a, 0xa9, 0x55];
        let mut out = [0u16; 4];
        unpack(PixelLayout::Packed10, &raw, &mut out);
        assert_eq!(out, [0x3ff, 0x001, 0x2aa, 0x155]);
    }

    #[test]
    fn unpack_packed12_nominal() {
        let raw = [0xab, 0xcd, 0xef];
        let mut out = [0u16; 2];
        unpack(PixelLayout::Packed12, &raw, &mut out);
        assert_eq!(out, [0xabc, 0xdef]);
    }

    #[test]
    fn unpack_u16le_nominal() {
        let raw = [0x34, 0x12, 0xff, 0x0f];
        let mut out = [0u16; 2];
        unpack(PixelLayout::U16Le, &raw, &mut out);
        assert_eq!(out, [0x1234, 0x0fff]);
    }

    #[test]
    fn le_short_header_is_truncated() {
        let le = Le {
            bytes: &[1, 2, 3],
            path: Path::new("x.cine"),
            file_len: 3,
            base: 0,
            part: "the file header",
        };
        assert_eq!(le.u16(0).unwrap(), 0x0201);
        assert!(matches!(
            le.u32(0),
            Err(FramesError::Truncated { needed: 4, .. })
        ));
        assert!(matches!(
            le.u16(usize::MAX),
            Err(FramesError::Truncated { .. })
        ));
    }
}
