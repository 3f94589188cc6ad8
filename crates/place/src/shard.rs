//! `crashrig place --shard i/N` and the place half of `crashrig merge` (docs/SCALE.md).
//!
//! Every shard runs the whole first-order search — it is deterministic (the search's board
//! ranks ties by the candidate sets, not by the evaluation order), so every shard finds the
//! same shortlist — and then the Monte Carlo confirmation of **every** shortlisted layout on
//! its share of the grid points (`Shard::range(points)`), as a grid shard runs them
//! ([`crashrig_study::grid_shard::write_scenario_rows`]: each point's draws come from its own
//! streams, so the rows are bit-identical to the unsharded run's). The shard directory holds
//! `shard.json`, the search's shortlist (`place_shard.json`) and the rows of layout k
//! (`layout<k>_points.csv`, with `layout<k>_points_independent.csv` in correlated mode).
//!
//! [`merge`] reads every layout's rows back, scores them as the unsharded run does, picks the
//! same winner, and writes `placement.json` and the winner's `grid/` through the code of
//! `crashrig grid` — no draw is repeated (the unsharded run draws the winner twice, once to
//! confirm it and once for `grid/`; both give the same bits).
//!
//! # Example
//! ```no_run
//! use crashrig_outdir::shard::{Shard, read_set};
//! use crashrig_place::PlaceConfig;
//! use crashrig_place::shard::{merge, run_shard};
//!
//! let mut dirs = Vec::new();
//! for i in 1..=2 {
//!     let config = PlaceConfig {
//!         scenario: "examples/place/scenario.toml".into(),
//!         candidates: "examples/place/candidates.toml".into(),
//!         choose: 2,
//!         out: format!("place.shards/{i}").into(),
//!         samples: Some(2000),
//!         seed: Some(1),
//!         plots: false,
//!     };
//!     run_shard(&config, Shard::new(i, 2)?, None)?;
//!     dirs.push(config.out);
//! }
//! let r = merge(&read_set(&dirs)?, "place_out".as_ref(), true)?;
//! println!("mount {:?}", r.placement.chosen);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::approx::Score;
use crate::{Error, Inputs, PlaceConfig, PlaceRun, Shortlist, commit, replaceable, score_of};
use crashrig_outdir::shard::{MANIFEST, Manifest, Shard};
use crashrig_stats::progress::Reporter;
use crashrig_study::grid_shard::{fingerprint_inputs, read_scenario_rows, write_scenario_rows};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `command` of a place shard's manifest.
pub const COMMAND: &str = "place";

/// The search's shortlist in a place shard directory.
pub const SEARCH_FILE: &str = "place_shard.json";

/// Largest `place_shard.json` read (a shortlist of at most [`crate::MAX_CONFIRMED`] layouts
/// of at most 1000 names is far smaller).
const MAX_SEARCH_BYTES: u64 = 4 << 20;

/// What a place shard run wrote.
#[derive(Debug, Clone)]
pub struct ShardRun {
    /// Its `shard.json`.
    pub manifest: Manifest,
    /// Files written (`shard.json` included).
    pub files: usize,
}

/// `place_shard.json`: the candidates file and K the shard ran with, and the search's
/// shortlist (every shard of one run holds the same).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SearchFile {
    /// The candidates file (absolute when it could be resolved).
    candidates: PathBuf,
    choose: usize,
    method: String,
    evaluated: u64,
    layouts: Vec<LayoutEntry>,
}

/// One shortlisted layout: names in pick order and its approximate score (the sum in Rust's
/// shortest round-trip decimal form, so it parses back to the same bits).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LayoutEntry {
    chosen: Vec<String>,
    below: usize,
    points: usize,
    with_sigma: usize,
    sum_sigma_max_mm: String,
}

/// The file-name prefix of layout `i`'s rows (0-based `i`; `layout1_` first).
fn prefix(i: usize) -> String {
    format!("layout{}_", i + 1)
}

/// Whether a top-level entry of an existing shard directory is something a place shard writes.
pub fn shard_replaceable(name: &str) -> bool {
    name == MANIFEST
        || name == SEARCH_FILE
        || (name.starts_with("layout") && name.ends_with(".csv"))
        || name.starts_with(".tmp")
}

/// The fingerprint of a placement's inputs: both files' bytes, both as read, and K.
fn input_fingerprint(config: &PlaceConfig, inputs: &Inputs) -> Result<String, Error> {
    Ok(fingerprint_inputs(
        COMMAND,
        &[&config.scenario, &config.candidates],
        &[
            format!("{:?}", inputs.scenario),
            format!("{:?}", inputs.candidates),
            format!("choose {}", inputs.k),
        ],
    )?)
}

/// Runs shard `shard` of `config`'s placement and writes the shard directory `config.out`
/// (`config.plots` is ignored: maps are drawn by the merge). The shard runs the whole search
/// and its share of the grid points of every layout the search shortlists.
///
/// # Errors
/// As [`crate::run`].
pub fn run_shard(
    config: &PlaceConfig,
    shard: Shard,
    progress: Option<&dyn Reporter>,
) -> Result<ShardRun, Error> {
    let inputs = Inputs::read(config)?;
    // Fails before any work when OUT holds files a place shard does not write.
    let mut staged = crashrig_outdir::Staged::new(&config.out, shard_replaceable)?;
    let fingerprint = input_fingerprint(config, &inputs)?;
    let start = std::time::Instant::now();
    let shortlist = Shortlist::find(&inputs, config, progress)?;
    let range = shard.range(inputs.points);
    let mut files = 2;
    for (i, (_, order)) in shortlist.layouts.iter().enumerate() {
        files += write_scenario_rows(
            &inputs.layout(order),
            &config.scenario,
            inputs.samples,
            inputs.seed,
            range.clone(),
            &prefix(i),
            &mut staged,
            progress,
        )?;
    }
    let absolute = |p: &Path| std::fs::canonicalize(p).unwrap_or(p.to_path_buf());
    let search = SearchFile {
        candidates: absolute(&config.candidates),
        choose: inputs.k,
        method: shortlist.method.to_string(),
        evaluated: shortlist.evaluated,
        layouts: shortlist
            .layouts
            .iter()
            .map(|(s, order)| LayoutEntry {
                chosen: inputs.names(order),
                below: s.below,
                points: s.points,
                with_sigma: s.with_sigma,
                sum_sigma_max_mm: s.sum_sigma_max_mm.to_string(),
            })
            .collect(),
    };
    let mut manifest = Manifest::new(
        COMMAND,
        shard,
        inputs.points,
        range,
        fingerprint,
        inputs.seed,
        inputs.samples as u64,
        absolute(&config.scenario),
    );
    manifest.elapsed_s = start.elapsed().as_secs_f64();
    manifest.threads = rayon::current_num_threads();
    let json = serde_json::to_vec_pretty(&search).map_err(|e| Error::Output {
        out: config.out.clone(),
        problem: e.to_string(),
    })?;
    staged.write(SEARCH_FILE, &json)?;
    staged.write(MANIFEST, &manifest.to_json())?;
    staged.commit()?;
    Ok(ShardRun { manifest, files })
}

/// Reads `DIR/place_shard.json`.
fn read_search(dir: &Path) -> Result<SearchFile, Error> {
    let path = dir.join(SEARCH_FILE);
    let bad = |problem: String| Error::Shard {
        path: path.clone(),
        problem,
    };
    let meta = std::fs::metadata(&path)
        .map_err(|e| bad(format!("cannot read ({e}); is this a place shard?")))?;
    if !meta.is_file() || meta.len() > MAX_SEARCH_BYTES {
        return Err(bad(format!(
            "not a regular file of at most {} MiB",
            MAX_SEARCH_BYTES >> 20
        )));
    }
    let bytes = std::fs::read(&path).map_err(|e| bad(format!("cannot read: {e}")))?;
    serde_json::from_slice(&bytes).map_err(|e| bad(format!("line {}: {e}", e.line())))
}

impl SearchFile {
    /// The shortlist in terms of `inputs`' candidates.
    fn shortlist(&self, inputs: &Inputs, path: &Path) -> Result<Shortlist, Error> {
        let bad = |problem: String| Error::Shard {
            path: path.to_path_buf(),
            problem,
        };
        let method = match self.method.as_str() {
            m if m == crate::search::EXHAUSTIVE => crate::search::EXHAUSTIVE,
            m if m == crate::search::GREEDY_SWAP => crate::search::GREEDY_SWAP,
            other => return Err(bad(format!("`method`: `{other}` is not a search method"))),
        };
        if self.layouts.is_empty() || self.layouts.len() > crate::MAX_CONFIRMED {
            return Err(bad(format!(
                "`layouts`: {} layouts, expected 1 to {}",
                self.layouts.len(),
                crate::MAX_CONFIRMED
            )));
        }
        let mut layouts = Vec::with_capacity(self.layouts.len());
        for l in &self.layouts {
            let order = l
                .chosen
                .iter()
                .map(|name| {
                    inputs
                        .candidates
                        .iter()
                        .position(|c| c.name == *name)
                        .ok_or_else(|| bad(format!("`chosen`: no candidate is named `{name}`")))
                })
                .collect::<Result<Vec<usize>, Error>>()?;
            let sum = l.sum_sigma_max_mm.parse::<f64>().map_err(|_| {
                bad(format!(
                    "`sum_sigma_max_mm`: `{}` is not a number",
                    l.sum_sigma_max_mm
                ))
            })?;
            let score = Score {
                below: l.below,
                points: l.points,
                sum_sigma_max_mm: sum,
                with_sigma: l.with_sigma,
            };
            layouts.push((score, order));
        }
        Ok(Shortlist {
            method,
            evaluated: self.evaluated,
            layouts,
        })
    }
}

/// Merges the shards of one placement (`shards` as [`crashrig_outdir::shard::read_set`]
/// returns them: checked, in shard order) into `out`: exactly what `crashrig place` writes
/// (`placement.json` byte for byte; `grid/` as `crashrig grid` writes it, `summary.json` equal
/// except its timings). The scenario and the candidates are read again from the paths the
/// shards recorded and must have the fingerprint they recorded. Nothing is written on an error.
///
/// # Errors
/// [`Error::Shard`] for a shard that is not a place shard, a shortlist that differs between
/// shards, or inputs that changed; the errors of [`crate::run`] and of
/// [`crashrig_study::grid_shard::read_scenario_rows`] (a shard's rows, with file and line).
pub fn merge(shards: &[(PathBuf, Manifest)], out: &Path, plots: bool) -> Result<PlaceRun, Error> {
    let Some((dir0, m0)) = shards.first() else {
        return Err(Error::Shard {
            path: PathBuf::from("merge"),
            problem: "no shard directory given".into(),
        });
    };
    if m0.command != COMMAND {
        return Err(Error::Shard {
            path: dir0.join(MANIFEST),
            problem: format!("a `{}` shard, not a place shard", m0.command),
        });
    }
    let search = read_search(dir0)?;
    for (dir, _) in &shards[1..] {
        if read_search(dir)? != search {
            return Err(Error::Shard {
                path: dir.join(SEARCH_FILE),
                problem: format!(
                    "a shard of another run: its candidates, K or search result differ from {}'s",
                    dir0.display()
                ),
            });
        }
    }
    let config = PlaceConfig {
        scenario: m0.input.clone(),
        candidates: search.candidates.clone(),
        choose: search.choose,
        out: out.to_path_buf(),
        samples: Some(m0.samples as usize),
        seed: Some(m0.seed),
        plots,
    };
    let inputs = Inputs::read(&config)?;
    if input_fingerprint(&config, &inputs)? != m0.fingerprint {
        return Err(Error::Shard {
            path: dir0.join(MANIFEST),
            problem: format!(
                "the scenario {} or the candidates {} (or a file they name) changed since the shards ran: the fingerprint differs",
                config.scenario.display(),
                config.candidates.display()
            ),
        });
    }
    let shortlist = search.shortlist(&inputs, &dir0.join(SEARCH_FILE))?;
    let mut rows = Vec::with_capacity(shortlist.layouts.len());
    let mut scores = Vec::with_capacity(shortlist.layouts.len());
    for (i, (_, order)) in shortlist.layouts.iter().enumerate() {
        let r = read_scenario_rows(
            inputs.layout(order),
            &config.scenario,
            inputs.samples,
            inputs.seed,
            shards,
            &prefix(i),
        )?;
        scores.push(score_of(r.result().clone(), r.grid()));
        rows.push(r);
    }
    let (winner, placement) = shortlist.decide(&inputs, &scores);
    let staged = crashrig_outdir::Staged::new(out, replaceable)?;
    let grid = rows
        .swap_remove(winner)
        .write(&staged.dir().join("grid"), plots)?;
    commit(&placement, staged, out)?;
    Ok(PlaceRun { placement, grid })
}
