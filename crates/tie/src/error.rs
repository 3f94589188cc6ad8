//! The one error type of `crashrig-tie`: [`Error`], why a tie bootstrap failed. Every message
//! names the file or option at fault; the errors of [`crate::bootstrap_link`] (the resampling
//! of correspondences already read) name the step that failed.

use crashrig_bootstrap as boot;
use crashrig_stats::progress::Cancelled;
use std::path::PathBuf;

/// Why a tie bootstrap failed. Every message names the file or option at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is out of range.
    #[error("{message}")]
    Option {
        /// The option (CLI spelling, e.g. `--mm-per-unit`).
        option: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The COLMAP model cannot be read or lacks what the tie needs.
    #[error("{}: {message}", path.display())]
    Model {
        /// The model directory.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The COLMAP database cannot be read or lacks what the tie needs.
    #[error("{}: {message}", path.display())]
    Database {
        /// The database file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The pose estimation on the full sample failed (the file holding the correspondences).
    #[error("{}: {message}", path.display())]
    Estimation {
        /// The model (absolute) or database (relative) the correspondences came from.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// Too few replicates succeeded, or the replicate summary is undefined.
    #[error("{message}")]
    Replicates {
        /// What is wrong.
        message: String,
    },
    /// The full-sample resection of B failed ([`crate::bootstrap_link`]).
    #[error("resection of image B failed")]
    Resection(#[source] crashrig_pose::Error),
    /// The matched keypoints of image `image` (`'A'` or `'B'`) cannot be undistorted
    /// ([`crate::bootstrap_link`]).
    #[error("undistorting the matched keypoints of image {image}")]
    Undistort {
        /// `'A'` or `'B'`.
        image: char,
        /// What failed.
        #[source]
        source: crashrig_pose::Error,
    },
    /// The full-sample relative orientation failed ([`crate::bootstrap_link`]).
    #[error("relative orientation A-B failed")]
    RelativeOrientation(#[source] crashrig_pose::Error),
    /// The bootstrap engine refused the run (no items, no replicates, too few for the
    /// jackknife).
    #[error(transparent)]
    Bootstrap(boot::Error),
    /// The caller's monitor cancelled the run.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// A plot or the replicates file could not be written ([`crate::TieResult::write_files`]).
    #[error(transparent)]
    Write(#[from] crashrig_outdir::Error),
}

impl From<boot::Error> for Error {
    fn from(e: boot::Error) -> Self {
        match e {
            boot::Error::Cancelled(c) => Self::Cancelled(c),
            e => Self::Bootstrap(e),
        }
    }
}
