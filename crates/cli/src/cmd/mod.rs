//! One module per subcommand; each owns its clap `Args` and a `run` function.

pub mod bootstrap;
pub mod calibrate;
pub mod colmap;
pub mod grid;
pub mod paper;
pub mod propagate;

/// The error of a command that is specified but not built yet.
pub fn not_yet(what: &str) -> anyhow::Error {
    anyhow::anyhow!("`crashrig {what}` is not yet implemented")
}
