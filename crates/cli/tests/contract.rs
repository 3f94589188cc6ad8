//! End-to-end contract tests of the `crashrig` binary against its reference (`docs/REFERENCE.md`,
//! the contract users and scripts read).
//!
//! Every test runs the built binary (`CARGO_BIN_EXE_crashrig`) on committed fixtures and checks
//! what the contract promises: `--help`, the exact JSON fields and shapes under `--json`,
//! the files of `grid --out`, bit-identical results for any thread count, known values from
//! the pycolmap/numpy goldens, and clean one-line errors on bad input (no panic, no
//! backtrace, no half-written output). Runs are kept tiny so the file stays fast in debug mode.

#[path = "contract/common.rs"]
mod common;

#[path = "contract/help.rs"]
mod help;

#[path = "contract/colmap.rs"]
mod colmap;

#[path = "contract/calibrate.rs"]
mod calibrate;

#[path = "contract/bootstrap.rs"]
mod bootstrap;

#[path = "contract/propagate.rs"]
mod propagate;

#[path = "contract/grid.rs"]
mod grid;

#[path = "contract/adaptive.rs"]
mod adaptive;

#[path = "contract/errors.rs"]
mod errors;

#[path = "contract/paper.rs"]
mod paper;

#[path = "contract/regressions.rs"]
mod regressions;

#[path = "contract/defects.rs"]
mod defects;

#[path = "contract/study.rs"]
mod study;

#[path = "contract/study_lines.rs"]
mod study_lines;

#[path = "contract/uncertain.rs"]
mod uncertain;

#[path = "contract/sim.rs"]
mod sim;

#[path = "contract/acceptance.rs"]
mod acceptance;

#[path = "contract/covariance.rs"]
mod covariance;

#[path = "contract/pinned.rs"]
mod pinned;
#[path = "contract/place.rs"]
mod place;
#[path = "contract/units.rs"]
mod units;
#[path = "contract/view3d.rs"]
mod view3d;

mod shard;

#[path = "contract/frames.rs"]
mod frames;
/// `crashrig track`: its files, `--json` and bad input.
#[path = "contract/track.rs"]
mod track;
/// `cargo xtask shards` (std + anyhow only), run here with the built binary.
#[path = "../../../xtask/src/shards.rs"]
#[allow(dead_code)]
mod xtask_shards;
