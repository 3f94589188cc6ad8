//! `crashrig place --shard i/N` and the place half of `crashrig merge` (docs/SCALE.md).
//!
//! The search dominates a placement (on the 40-candidate example, K = 4, the search alone
//! takes as long as the whole run: `docs/performance.md`), so the shards split **the search**:
//! its work items are the C(n, K) subsets in lexicographic order when it is exhaustive (shard i
//! scores the ranks `Shard::range(C(n, K))`), or one item, the whole greedy + swap search
//! (sequential rounds; one shard runs it, the others write an empty board). Each shard
//! keeps the board of its best layouts, and confirms by the Monte Carlo, **on every grid
//! point**, the layouts of its board within [`crate::CONFIRM_MARGIN`] of its own best
//! ([`crashrig_grid::shard::write_scenario_rows`]; each point's draws come from its own
//! streams, so the rows are the unsharded run's bit for bit). The board's order is total
//! (score, then the candidate set), so the best layouts of the union of the shards' boards are
//! the unsharded search's; and every layout the unsharded run confirms was confirmed by the
//! shard that scored it (its share is within the margin of the global best, hence of its
//! shard's best, and fewer than [`crate::MAX_CONFIRMED`] layouts of its shard beat it).
//! The shard directory holds `shard.json`, its board (`place_shard.json`) and the rows of the
//! layouts it confirmed (`layout<k>_points.csv`, with `layout<k>_points_independent.csv` in
//! correlated mode).
//!
//! [`merge`] merges the boards, takes the confirmed layouts' rows from the shards that hold
//! them, scores them as the unsharded run does, picks the same winner, and writes
//! `placement.json` and the winner's `grid/` through the code of `crashrig grid` — no draw is
//! repeated.
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
//! let r = merge(&read_set(&dirs)?, "place_out".as_ref(), true, None)?;
//! println!("mount {:?}", r.placement.chosen);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::approx::Score;
use crate::{
    Error, Inputs, PlaceConfig, PlaceRun, Shortlist, commit, replaceable, score_of, search,
};
use crashrig_grid::shard::{fingerprint_inputs, read_scenario_rows, write_scenario_rows};
use crashrig_outdir::shard::{MANIFEST, Manifest, Shard};
use crashrig_stats::progress::{Counter, Monitor, Reporter};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `command` of a place shard's manifest.
pub const COMMAND: &str = "place";

/// The board of a place shard (`place_shard.json`).
pub const SEARCH_FILE: &str = "place_shard.json";

/// Largest `place_shard.json` read (a board of at most [`crate::MAX_CONFIRMED`] layouts
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

/// `place_shard.json`: the candidates file and K the shard ran with, and the board of its
/// share of the search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SearchFile {
    /// The candidates file (absolute when it could be resolved).
    candidates: PathBuf,
    choose: usize,
    method: String,
    /// Layouts the shard scored to first order.
    evaluated: u64,
    board: Vec<BoardEntry>,
}

/// One layout of a shard's board: names (in pick order when the shard confirmed it, else in
/// file order), its approximate score (the sum in Rust's shortest round-trip decimal form, so
/// it parses back to the same bits) and, when the shard confirmed it, the k of its
/// `layout<k>_points.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BoardEntry {
    chosen: Vec<String>,
    below: usize,
    points: usize,
    with_sigma: usize,
    sum_sigma_max_mm: String,
    rows: Option<usize>,
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
/// (`config.plots` is ignored: maps are drawn by the merge). The shard scores its share of the
/// search ([`crate::search::search_share`]) and confirms the best layouts of its board on every
/// grid point.
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
    let table = inputs.table(config, progress)?;
    let n = inputs.candidates.len();
    let total = search::items(n, inputs.k);
    let range = shard.range(total);
    let found = search::search_share(&table, inputs.k, crate::MAX_CONFIRMED, range.clone());
    let local = Shortlist::of(&table, &found);
    drop(table);
    let mut files = 2;
    let mut board = Vec::with_capacity(found.board.entries.len());
    for (i, (score, set)) in found.board.entries.iter().enumerate() {
        // The shortlist is the board's first entries (the margin filter keeps its order).
        let (order, rows) = match local.layouts.get(i) {
            Some((_, order)) => {
                files += write_scenario_rows(
                    &inputs.layout(order),
                    &config.scenario,
                    inputs.samples,
                    inputs.seed,
                    0..inputs.points,
                    &prefix(i),
                    &mut staged,
                    progress,
                )?;
                (order.clone(), Some(i + 1))
            }
            None => (set.clone(), None),
        };
        board.push(BoardEntry {
            chosen: inputs.names(&order),
            below: score.below,
            points: score.points,
            with_sigma: score.with_sigma,
            sum_sigma_max_mm: score.sum_sigma_max_mm.to_string(),
            rows,
        });
    }
    let absolute = |p: &Path| std::fs::canonicalize(p).unwrap_or(p.to_path_buf());
    let search = SearchFile {
        candidates: absolute(&config.candidates),
        choose: inputs.k,
        method: found.method.to_string(),
        evaluated: found.evaluated,
        board,
    };
    let mut manifest = Manifest::new(
        COMMAND,
        shard,
        total,
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

/// A board entry of one shard in terms of the candidates: its set (sorted), pick order and
/// score, the shard (position in the set) and the k of its rows.
struct Owned {
    set: Vec<usize>,
    order: Vec<usize>,
    score: Score,
    shard: usize,
    rows: Option<usize>,
}

impl SearchFile {
    /// The board's entries in terms of `inputs`' candidates.
    fn entries(&self, inputs: &Inputs, shard: usize, path: &Path) -> Result<Vec<Owned>, Error> {
        let bad = |problem: String| Error::Shard {
            path: path.to_path_buf(),
            problem,
        };
        if self.board.len() > crate::MAX_CONFIRMED {
            return Err(bad(format!(
                "`board`: {} layouts, at most {}",
                self.board.len(),
                crate::MAX_CONFIRMED
            )));
        }
        let mut out = Vec::with_capacity(self.board.len());
        for e in &self.board {
            let order = e
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
            let sum = e.sum_sigma_max_mm.parse::<f64>().map_err(|_| {
                bad(format!(
                    "`sum_sigma_max_mm`: `{}` is not a number",
                    e.sum_sigma_max_mm
                ))
            })?;
            let mut set = order.clone();
            set.sort_unstable();
            out.push(Owned {
                set,
                order,
                score: Score {
                    below: e.below,
                    points: e.points,
                    sum_sigma_max_mm: sum,
                    with_sigma: e.with_sigma,
                },
                shard,
                rows: e.rows,
            });
        }
        Ok(out)
    }
}

/// Merges the shards of one placement (`shards` as [`crashrig_outdir::shard::read_set`]
/// returns them: checked, in shard order) into `out`: exactly what `crashrig place` writes
/// (`placement.json` byte for byte; `grid/` as `crashrig grid` writes it, `summary.json` equal
/// except its timings). The scenario and the candidates are read again from the paths the
/// shards recorded and must have the fingerprint they recorded. Nothing is written on an error.
///
/// `monitor` (optional) gets `(done, shards + 1)`: one unit per shard's board read, one for
/// the chosen layouts' rows; it may cancel between them and before writing
/// ([`Error::Cancelled`], nothing written).
///
/// # Errors
/// [`Error::Shard`] for a shard that is not a place shard, a board that names other
/// candidates, K or method than the first shard's, or inputs that changed; the errors of [`crate::run`] and of
/// [`crashrig_grid::shard::read_scenario_rows`] (a shard's rows, with file and line).
pub fn merge(
    shards: &[(PathBuf, Manifest)],
    out: &Path,
    plots: bool,
    monitor: Option<&dyn Monitor>,
) -> Result<PlaceRun, Error> {
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
    let read = Counter::monitored(monitor, shards.len() + 1);
    let searches = shards
        .iter()
        .map(|(dir, _)| {
            read.check()?;
            let s = read_search(dir);
            read.add(1);
            s
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let search = &searches[0];
    for ((dir, _), other) in shards.iter().zip(&searches).skip(1) {
        if (&other.candidates, other.choose, &other.method)
            != (&search.candidates, search.choose, &search.method)
        {
            return Err(Error::Shard {
                path: dir.join(SEARCH_FILE),
                problem: format!(
                    "a shard of another run: its candidates, K or search method differ from {}'s",
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
    let method = match search.method.as_str() {
        m if m == search::EXHAUSTIVE => search::EXHAUSTIVE,
        m if m == search::GREEDY_SWAP => search::GREEDY_SWAP,
        other => {
            return Err(Error::Shard {
                path: dir0.join(SEARCH_FILE),
                problem: format!("`method`: `{other}` is not a search method"),
            });
        }
    };
    // The union of the boards: the unsharded search's board.
    let mut owned = Vec::new();
    for (k, ((dir, _), sf)) in shards.iter().zip(&searches).enumerate() {
        owned.extend(sf.entries(&inputs, k, &dir.join(SEARCH_FILE))?);
    }
    let mut board = search::Board::new(crate::MAX_CONFIRMED);
    for o in &owned {
        board.offer(o.score, &o.set);
    }
    let found = search::Found {
        method,
        evaluated: searches.iter().map(|s| s.evaluated).sum(),
        board,
    };
    let best_share = found.board.entries.first().map_or(0.0, |(s, _)| s.share());
    let mut layouts = Vec::new();
    let mut sources = Vec::new();
    for (score, set) in &found.board.entries {
        if score.share() < best_share - crate::CONFIRM_MARGIN {
            continue;
        }
        // Every board entry was offered from a shard's board.
        let Some((o, Some(rows))) = owned.iter().find(|o| o.set == *set).map(|o| (o, o.rows))
        else {
            let o = owned.iter().find(|o| o.set == *set);
            let shard = o.map_or(0, |o| o.shard);
            return Err(Error::Shard {
                path: shards[shard].0.join(SEARCH_FILE),
                problem: format!(
                    "layout {:?} is among the best but its shard has no Monte Carlo rows for it",
                    inputs.names(set)
                ),
            });
        };
        layouts.push((*score, o.order.clone()));
        sources.push((o.shard, rows));
    }
    let shortlist = Shortlist {
        method,
        evaluated: found.evaluated,
        layouts,
    };
    let mut rows = Vec::with_capacity(shortlist.layouts.len());
    let mut scores = Vec::with_capacity(shortlist.layouts.len());
    for ((_, order), (shard, k)) in shortlist.layouts.iter().zip(&sources) {
        // The rows hold every grid point.
        let (dir, m) = &shards[*shard];
        let mut whole = m.clone();
        whole.items = crashrig_outdir::shard::Items {
            start: 0,
            end: inputs.points,
            total: inputs.points,
        };
        let r = read_scenario_rows(
            inputs.layout(order),
            &config.scenario,
            inputs.samples,
            inputs.seed,
            &[(dir.clone(), whole)],
            &prefix(k - 1),
        )?;
        scores.push(score_of(r.result().clone(), r.grid()));
        rows.push(r);
    }
    read.add(1);
    read.check()?;
    let (winner, placement) = shortlist.decide(&inputs, &scores);
    let staged = crashrig_outdir::Staged::new(out, replaceable)?;
    let grid = rows
        .swap_remove(winner)
        .write(&staged.dir().join("grid"), plots)?;
    commit(&placement, staged, out)?;
    Ok(PlaceRun { placement, grid })
}
