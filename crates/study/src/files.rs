//! Writing the study's output files into its (staged) output directory.

use crate::Error;
use std::path::Path;

/// Writes `bytes` to `dir/name` (creating `dir`).
pub(crate) fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), Error> {
    // Into a staging directory: inside the gate, so a termination signal never interleaves
    // (`crashrig_outdir::gated`).
    crashrig_outdir::gated(|| {
        std::fs::create_dir_all(dir).map_err(|source| Error::Write {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(name);
        std::fs::write(&path, bytes).map_err(|source| Error::Write { path, source })
    })
}
