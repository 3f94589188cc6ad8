//! Test support: the repository's bundled scenarios as text (the tests read them at run time,
//! so the crate's own build never needs files outside it).

use std::path::Path;

/// A file of the repository, e.g. `benches/real_map.toml`.
pub(crate) fn repo_file(rel: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The real-study map (`benches/real_map.toml`) on a 5 × 5 grid: a chain with full
/// covariances, fixed OPENCV cameras with pixel noise and aimed observers, all drawn jointly
/// from the chain.
pub(crate) fn real_map_small() -> String {
    repo_file("benches/real_map.toml")
        .replace("x_mm = [400.0, 2000.0, 17]", "x_mm = [800.0, 1600.0, 5]")
        .replace("y_mm = [-600.0, 600.0, 13]", "y_mm = [-300.0, 300.0, 5]")
}
