//! Reading a user's input file with a size limit: the one reader of every input file
//! (COLMAP model files, scenario and study TOML, CSV, JSON results).
//!
//! An input that is not a regular file — a directory, a FIFO (reading it would wait for a
//! writer for ever), a device such as `/dev/zero` (it never ends) — is refused before it is
//! opened, and a regular file larger than the caller's limit is refused before anything is
//! allocated (its size is taken from the file system), so that no input can hang the program
//! or exhaust its memory. `docs/LIMITS.md` lists the limits of each kind of file.
//!
//! ```
//! use crashrig_input::file;
//! let dir = std::env::temp_dir().join(format!("crashrig-input-file-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! std::fs::write(dir.join("a.csv"), b"x\n1\n")?;
//! assert_eq!(file::read_limited(&dir.join("a.csv"), 16)?, b"x\n1\n");
//! // Too large for a 3-byte limit, and a directory is not a file.
//! assert!(file::read_limited(&dir.join("a.csv"), 3).is_err());
//! let e = file::read_limited(&dir, 16).unwrap_err();
//! assert!(e.to_string().contains("not a regular file"));
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), std::io::Error>(())
//! ```

use std::io::Read;
use std::path::Path;

/// Size limit of a COLMAP model file (`cameras`, `images`, `points3D`, `rigs`, `frames`):
/// 4 GiB.
pub const MAX_MODEL_FILE_BYTES: u64 = 4 << 30;
/// Size limit of a CSV input (observations, control points): 1 GiB.
pub const MAX_CSV_BYTES: u64 = 1 << 30;
/// Size limit of a JSON input (`calibrate`/`bootstrap`/`covariance` results): 256 MiB.
pub const MAX_JSON_BYTES: u64 = 256 << 20;
/// Size limit of a scenario or study file (TOML): 16 MiB.
pub const MAX_TOML_BYTES: u64 = 16 << 20;

/// Human form of a byte count (`16 MiB`, `4 GiB`, `12 bytes`).
pub fn human_bytes(n: u64) -> String {
    if n >= 1 << 30 && n.is_multiple_of(1 << 30) {
        format!("{} GiB", n >> 30)
    } else if n >= 1 << 20 && n.is_multiple_of(1 << 20) {
        format!("{} MiB", n >> 20)
    } else if n >= 1 << 20 {
        format!("{:.1} MiB", n as f64 / (1u64 << 20) as f64)
    } else {
        format!("{n} bytes")
    }
}

/// Checks that `path` is a regular file (symbolic links followed) of at most `limit` bytes,
/// without opening it.
///
/// # Errors
/// The file system's error, or [`std::io::ErrorKind::InvalidInput`] saying that the path is a
/// directory / not a regular file, or that it is larger than `limit`.
pub fn check_regular(path: &Path, limit: u64) -> std::io::Result<u64> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "is a directory, not a regular file",
        ));
    }
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a device, FIFO or socket is not read)",
        ));
    }
    if meta.len() > limit {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{} is larger than the limit of {} for this kind of file",
                human_bytes(meta.len()),
                human_bytes(limit)
            ),
        ));
    }
    Ok(meta.len())
}

/// Reads the regular file `path` whole, refusing anything that is not a regular file or is
/// larger than `limit` bytes ([`check_regular`]); the read itself stops at `limit` + 1 bytes
/// (a file that grows while it is read is refused too).
///
/// # Errors
/// As [`check_regular`], and the read's error.
pub fn read_limited(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let len = check_regular(path, limit)?;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "grew beyond the limit of {} while it was read",
                human_bytes(limit)
            ),
        ));
    }
    Ok(bytes)
}

/// The first byte of a text file that is not UTF-8, by its 1-based line and column (the
/// column counts bytes from the start of the line, as the TOML and CSV errors of every reader
/// do). Readers report it as `FILE:LINE:COLUMN: not valid UTF-8 text`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, column {column}: not valid UTF-8 text")]
pub struct NotUtf8 {
    /// 1-based line of the first invalid byte.
    pub line: usize,
    /// 1-based column (in bytes) of the first invalid byte.
    pub column: usize,
}

impl NotUtf8 {
    /// The position of `e`, the error of decoding `bytes`.
    pub fn of(bytes: &[u8], e: &std::str::Utf8Error) -> NotUtf8 {
        let (line, column) = crate::location::line_col_of(bytes, e.valid_up_to());
        NotUtf8 { line, column }
    }

    /// The [`NotUtf8`] inside an error of [`read_text_limited`], if that is what it is.
    pub fn in_io(e: &std::io::Error) -> Option<NotUtf8> {
        e.get_ref()?.downcast_ref::<NotUtf8>().copied()
    }
}

/// `bytes` as UTF-8 text, or the line and column of the first byte that is not.
///
/// ```
/// use crashrig_input::file::{NotUtf8, text_from_bytes};
/// assert_eq!(text_from_bytes(b"a = 1\n".to_vec()).unwrap(), "a = 1\n");
/// let e = text_from_bytes(b"a = 1\nb = \"\xff\"\n".to_vec()).unwrap_err();
/// assert_eq!(e, NotUtf8 { line: 2, column: 6 });
/// ```
///
/// # Errors
/// [`NotUtf8`] for bytes that are not UTF-8.
pub fn text_from_bytes(bytes: Vec<u8>) -> Result<String, NotUtf8> {
    String::from_utf8(bytes).map_err(|e| NotUtf8::of(e.as_bytes(), &e.utf8_error()))
}

/// [`read_limited`], then UTF-8.
///
/// # Errors
/// As [`read_limited`], and [`std::io::ErrorKind::InvalidData`] holding a [`NotUtf8`] (the
/// line and column of the first invalid byte; [`NotUtf8::in_io`]) for text that is not UTF-8.
pub fn read_text_limited(path: &Path, limit: u64) -> std::io::Result<String> {
    text_from_bytes(read_limited(path, limit)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_file_refuses_directories_devices_and_large_files() {
        let dir = std::env::temp_dir().join(format!("crashrig-input-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("x.txt");
        std::fs::write(&f, b"12345").unwrap();
        assert_eq!(read_limited(&f, 5).unwrap(), b"12345");
        let e = read_limited(&f, 4).unwrap_err().to_string();
        assert!(e.contains("5 bytes") && e.contains("4 bytes"), "{e}");
        assert!(
            read_limited(&dir, 100)
                .unwrap_err()
                .to_string()
                .contains("directory")
        );
        #[cfg(unix)]
        {
            let e = read_limited(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
        std::fs::write(&f, b"ab\ncd\xff\xfe").unwrap();
        let e = read_text_limited(&f, 10).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert_eq!(e.to_string(), "line 2, column 3: not valid UTF-8 text");
        assert_eq!(NotUtf8::in_io(&e), Some(NotUtf8 { line: 2, column: 3 }));
        assert_eq!(NotUtf8::in_io(&std::io::Error::other("x")), None);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(human_bytes(16 << 20), "16 MiB");
        assert_eq!(human_bytes(4 << 30), "4 GiB");
    }
}
