//! The one error type of the crate: every variant names the file, and the frame where one is concerned.

use std::path::PathBuf;

/// Everything that can go wrong while opening or reading a frame source or exporting it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FramesError {
    /// A file-system operation failed.
    #[error("{}: {what}: {source}", path.display())]
    Io {
        /// The file or directory concerned.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The path is neither a directory of images nor a `.cine`, `.cih` or `.cihx` file.
    #[error(
        "{}: not a frame source (a directory of PNG/TIFF images, a Phantom .cine, or a Photron .cih/.cihx with its .mraw)",
        path.display()
    )]
    NotASource {
        /// The path given.
        path: PathBuf,
    },
    /// A directory without a single PNG or TIFF file.
    #[error("{}: no PNG or TIFF frame in the directory", path.display())]
    NoFrames {
        /// The directory.
        path: PathBuf,
    },
    /// An image file that does not decode (a broken PNG/TIFF).
    #[error("{}: does not decode: {problem}", path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// The decoder's message.
        problem: String,
    },
    /// A frame whose size or bit depth differs from the first frame's.
    #[error(
        "{}: frame is {width}x{height} with {bits} bits, the first frame ({first}) is {first_width}x{first_height} with {first_bits} bits; all frames must have one size and bit depth",
        path.display()
    )]
    Mismatch {
        /// The frame's file.
        path: PathBuf,
        /// Its width (px).
        width: u32,
        /// Its height (px).
        height: u32,
        /// Its bits per sample.
        bits: u8,
        /// The first frame's file name.
        first: String,
        /// The first frame's width (px).
        first_width: u32,
        /// The first frame's height (px).
        first_height: u32,
        /// The first frame's bits per sample.
        first_bits: u8,
    },
    /// A layout, compression or bit depth this crate does not read (the message says which).
    #[error("{}: not supported: {what}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is not supported, e.g. `compression 1 (JPEG)` or `4-bit grey PNG`.
        what: String,
    },
    /// A header field that is missing, malformed or inconsistent.
    #[error("{}: header field `{field}`: {problem}", path.display())]
    Header {
        /// The header file (`.cine`, `.cih`, `.cihx`).
        path: PathBuf,
        /// The field concerned, as the format names it.
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// The file ends before the header or a frame does.
    #[error(
        "{}: truncated: {part} needs bytes up to {needed}, the file has {len}",
        path.display()
    )]
    Truncated {
        /// The file.
        path: PathBuf,
        /// What was cut off: `the header`, `the image offsets`, `frame 12`, …
        part: String,
        /// The end offset the part needs (bytes).
        needed: u64,
        /// The file's length (bytes).
        len: u64,
    },
    /// A `.cih`/`.cihx` header whose `.mraw` is not beside it.
    #[error("{}: the recording's .mraw file {} is missing", header.display(), mraw.display())]
    MissingMraw {
        /// The header file.
        header: PathBuf,
        /// The `.mraw` path looked for.
        mraw: PathBuf,
    },
    /// A frame index past the end of the sequence.
    #[error("{}: frame {index} asked for, the sequence has {len}", path.display())]
    NoSuchFrame {
        /// The source.
        path: PathBuf,
        /// The index asked for (0-based).
        index: usize,
        /// The number of frames.
        len: usize,
    },
    /// `--first`/`--last` name no frame of the sequence, or select none.
    #[error("{}: {problem}", path.display())]
    Range {
        /// The source.
        path: PathBuf,
        /// What is wrong with the range.
        problem: String,
    },
    /// Writing the output directory failed.
    #[error(transparent)]
    Out(#[from] crashrig_outdir::Error),
    /// Encoding an exported PNG failed.
    #[error("{}: cannot encode the PNG: {problem}", path.display())]
    Encode {
        /// The PNG's name in the output directory.
        path: PathBuf,
        /// The encoder's message.
        problem: String,
    },
}

/// The crate's result type.
pub type Result<T, E = FramesError> = std::result::Result<T, E>;

pub(crate) fn io_err<'a>(
    path: &'a std::path::Path,
    what: &'static str,
) -> impl FnOnce(std::io::Error) -> FramesError + 'a {
    move |source| FramesError::Io {
        path: path.to_path_buf(),
        what,
        source,
    }
}
