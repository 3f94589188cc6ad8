//! The one error type of `crashrig-colmap`: every variant names the file and the record.

use std::path::PathBuf;

/// Everything that can go wrong while reading or writing COLMAP files.
///
/// Every variant carries the `path` of the file involved, and where it applies the text `line`
/// (1-based), the binary byte `offset` or the 0-based `record` index in its file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused to read or write a file.
    #[error("{}: cannot read or write", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying IO error.
        #[source]
        source: std::io::Error,
    },
    /// The path does not exist (a model directory or a database was expected).
    #[error("{}: does not exist", path.display())]
    Missing {
        /// The path as given.
        path: PathBuf,
    },
    /// The directory holds neither the three binary nor the three text model files.
    #[error("{}: not a COLMAP model (needs cameras, images and points3D as .bin or .txt)", path.display())]
    NotAModel {
        /// The directory.
        path: PathBuf,
    },
    /// An SQLite file without COLMAP's tables.
    #[error("{}: not a COLMAP database (no `{table}` table)", path.display())]
    NotADatabase {
        /// The file.
        path: PathBuf,
        /// The first required table that is missing.
        table: &'static str,
    },
    /// Exactly one of `rigs.*` and `frames.*` exists (COLMAP refuses such a model too).
    #[error("{}: rigs and frames files must both exist or both be absent", path.display())]
    RigsWithoutFrames {
        /// The model directory.
        path: PathBuf,
    },
    /// A binary file ends before a record is complete, or a count announces more records
    /// than the remaining bytes can hold.
    #[error("{}: truncated at byte {offset}: {needed} more bytes needed", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Byte offset where the missing data should start.
        offset: u64,
        /// Bytes needed from that offset.
        needed: u64,
    },
    /// A binary file has bytes left after its last record.
    #[error("{}: {extra} unexpected bytes after the last record (at byte {offset})", path.display())]
    TrailingBytes {
        /// The file.
        path: PathBuf,
        /// Offset of the first unexpected byte.
        offset: u64,
        /// How many bytes are left.
        extra: u64,
    },
    /// A text line could not be parsed.
    #[error("{}:{line}: {what}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong (static description).
        what: &'static str,
    },
    /// A binary record holds an invalid value (bad sensor type, bad flag, non-UTF-8 name).
    #[error("{}: record {record} (byte {offset}): {what}", path.display())]
    BadValue {
        /// The file.
        path: PathBuf,
        /// 0-based record index.
        record: usize,
        /// Byte offset of the bad value.
        offset: u64,
        /// What is wrong.
        what: &'static str,
    },
    /// A camera model id outside 0–17 (binary: the parameter count is then unknown).
    #[error("{}: record {record}: unknown camera model id {id}", path.display())]
    UnknownModelId {
        /// The file.
        path: PathBuf,
        /// 0-based record index (binary) or 1-based line (text).
        record: usize,
        /// The id found.
        id: i64,
    },
    /// A camera model name not known to COLMAP 4.2 (text).
    #[error("{}:{line}: unknown camera model {name:?}", path.display())]
    UnknownModelName {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// The name found.
        name: String,
    },
    /// A text camera line whose parameter count does not match its model.
    #[error("{}:{line}: camera model {model} takes {expected} parameters, found {found}", path.display())]
    WrongParamCount {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Model name.
        model: &'static str,
        /// Expected count.
        expected: usize,
        /// Count found.
        found: usize,
    },
    /// A cross-file consistency rule is violated (e.g. a track names a missing image).
    #[error("{}{}: {what} (id {id})", path.display(), location(*record, *line))]
    Invariant {
        /// The file holding the offending record.
        path: PathBuf,
        /// 0-based record index in that file.
        record: usize,
        /// 1-based line of the record, for text files.
        line: Option<usize>,
        /// The rule that failed.
        what: &'static str,
        /// The id involved (image, point, camera, rig or frame id, as `what` says).
        id: u64,
    },
    /// A record cannot be written in the requested format (e.g. an image name with a line
    /// break, which text files cannot hold).
    #[error("{}: record {record}: cannot be written: {what}", path.display())]
    Unwritable {
        /// The file that was to be written.
        path: PathBuf,
        /// 0-based record index.
        record: usize,
        /// Why.
        what: &'static str,
    },
    /// The SQLite library reported an error.
    #[cfg(feature = "database")]
    #[error("{}: SQLite error", path.display())]
    Sqlite {
        /// The database file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: rusqlite::Error,
    },
    /// A database row holds an invalid value (bad blob size, bad column count, ...).
    #[error("{}: table {table}, row id {row}: {what}", path.display())]
    BadRow {
        /// The database file.
        path: PathBuf,
        /// The table.
        table: &'static str,
        /// The row's key (image id, pair id, camera id, ...).
        row: i64,
        /// What is wrong.
        what: &'static str,
    },
    /// `colmap convert` was asked to write into its input directory.
    #[error("{}: is the input model directory; converting in place would replace the input, choose another output directory", path.display())]
    ConvertInPlace {
        /// The output (= input) directory.
        path: PathBuf,
    },
    /// The output directory of `colmap convert` cannot be staged (it holds other files, ...).
    #[cfg(feature = "commands")]
    #[error("{problem}")]
    Staging {
        /// The output directory.
        path: PathBuf,
        /// What is wrong: the message of the output-directory writer, which names the
        /// directory (shown as this error's message, not returned as its source).
        problem: crashrig_outdir::Error,
    },
    /// Writing the converted model failed.
    #[error("writing {}", path.display())]
    Writing {
        /// The output directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: Box<Error>,
    },
    /// Swapping the converted model into the output directory failed.
    #[cfg(feature = "commands")]
    #[error("writing {}", path.display())]
    Commit {
        /// The output directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: crashrig_outdir::Error,
    },
    /// The model has no 3-D point with this id.
    #[error("{}: no point3D with id {id}", path.display())]
    NoPoint3D {
        /// The model directory.
        path: PathBuf,
        /// The id asked for.
        id: u64,
    },
    /// The model has no image of this name (compared in Unicode normal form C).
    #[error("{}: image {name:?} is not in the model{}", path.display(), nearest_text(nearest))]
    NoImage {
        /// The model directory.
        path: PathBuf,
        /// The name asked for.
        name: String,
        /// The model's image names nearest to it ([`crate::Reconstruction::nearest_image_names`]).
        nearest: Vec<String>,
    },
}

/// `; nearest: a, b` (empty without names).
fn nearest_text(nearest: &[String]) -> String {
    if nearest.is_empty() {
        String::new()
    } else {
        format!("; nearest: {}", nearest.join(", "))
    }
}

/// Shorthand for `Result<T, crashrig_colmap::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// The file (or directory) the error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Error::Io { path, .. }
            | Error::Missing { path }
            | Error::NotAModel { path }
            | Error::NotADatabase { path, .. }
            | Error::RigsWithoutFrames { path }
            | Error::Truncated { path, .. }
            | Error::TrailingBytes { path, .. }
            | Error::Parse { path, .. }
            | Error::BadValue { path, .. }
            | Error::UnknownModelId { path, .. }
            | Error::UnknownModelName { path, .. }
            | Error::WrongParamCount { path, .. }
            | Error::Invariant { path, .. }
            | Error::Unwritable { path, .. }
            | Error::BadRow { path, .. }
            | Error::ConvertInPlace { path }
            | Error::Writing { path, .. }
            | Error::NoPoint3D { path, .. }
            | Error::NoImage { path, .. } => path,
            #[cfg(feature = "database")]
            Error::Sqlite { path, .. } => path,
            #[cfg(feature = "commands")]
            Error::Staging { path, .. } | Error::Commit { path, .. } => path,
        }
    }
}

/// `":LINE"` for a text record (the `file:line` form of parse errors), `": record N"` otherwise.
fn location(record: usize, line: Option<usize>) -> String {
    match line {
        Some(l) => format!(":{l}"),
        None => format!(": record {record}"),
    }
}
