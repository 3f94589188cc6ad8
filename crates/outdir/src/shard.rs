//! Sharded runs: the typed `--shard i/N` ([`Shard`]), the deterministic partition of a work
//! list into N contiguous shares ([`Shard::range`], [`Shard::block_range`]), and the shard
//! manifest `shard.json` ([`Manifest`]) that `crashrig merge` checks before it merges
//! ([`check_set`]: no shard missing, none repeated, none from another run).
//!
//! A shard is an ordinary process: it reads the same inputs as the unsharded run, does only
//! its share of the work and writes a shard directory (its rows and `shard.json`). Because
//! every random stream of the engines is keyed by the work item (grid point, block of
//! replicates), never by the process that computes it, the merged result is the unsharded one
//! bit for bit.
//!
//! # Example
//! ```
//! use crashrig_outdir::shard::{Manifest, Shard, check_set, fingerprint};
//!
//! let shard: Shard = "2/3".parse()?;
//! assert_eq!((shard.index(), shard.count()), (2, 3));
//! // 10 work items over 3 shards: 0..3, 3..6, 6..10 (contiguous, together all of them).
//! assert_eq!(shard.range(10), 3..6);
//! // Whole blocks of 4 items (the last block is short): blocks 0..1, 1..2, 2..3.
//! assert_eq!(shard.block_range(10, 4), 4..8);
//! assert!("0/3".parse::<Shard>().is_err() && "4/3".parse::<Shard>().is_err());
//!
//! let fp = fingerprint(&[b"seed = 1\n"]);
//! let manifests: Vec<_> = (1..=3)
//!     .map(|i| {
//!         let s = Shard::new(i, 3).unwrap();
//!         let m = Manifest::new("grid", s, 10, s.range(10), fp.clone(), 1, 2000, "scenario.toml");
//!         (format!("shard{i}").into(), m)
//!     })
//!     .collect();
//! // All three, in any order: merged in shard order.
//! let order = check_set(&[manifests[2].clone(), manifests[0].clone(), manifests[1].clone()])?;
//! assert_eq!(order, [1, 2, 0]);
//! // One missing: refused, naming it.
//! let e = check_set(&manifests[..2]).unwrap_err();
//! assert!(e.to_string().contains("3/3"), "{e}");
//! # Ok::<(), crashrig_outdir::Error>(())
//! ```

use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use sha2::Digest;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The largest shard count `--shard i/N` accepts (a bound checked before anything is
/// allocated per shard).
pub const MAX_SHARDS: usize = 100_000;

/// The file name of the manifest in a shard directory.
pub const MANIFEST: &str = "shard.json";

/// The value of `"format"` in every `shard.json`.
pub const FORMAT: &str = "crashrig-shard";

/// Version of the shard-directory layout (bumped when a shard's files change meaning).
pub const FORMAT_VERSION: u32 = 1;

/// One share of a run: shard `index` of `count` (1 ≤ index ≤ count ≤ [`MAX_SHARDS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "ShardRepr", into = "ShardRepr")]
pub struct Shard {
    index: usize,
    count: usize,
}

#[derive(Serialize, Deserialize)]
struct ShardRepr {
    index: usize,
    count: usize,
}

impl TryFrom<ShardRepr> for Shard {
    type Error = Error;
    fn try_from(r: ShardRepr) -> Result<Shard> {
        Shard::new(r.index, r.count)
    }
}

impl From<Shard> for ShardRepr {
    fn from(s: Shard) -> ShardRepr {
        ShardRepr {
            index: s.index,
            count: s.count,
        }
    }
}

impl Shard {
    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`Error::ShardSpec`] unless 1 ≤ `index` ≤ `count` ≤ [`MAX_SHARDS`].
    pub fn new(index: usize, count: usize) -> Result<Shard> {
        let bad = |problem: String| {
            Err(Error::ShardSpec {
                value: format!("{index}/{count}"),
                problem,
            })
        };
        if count == 0 {
            return bad("the shard count N must be at least 1".into());
        }
        if count > MAX_SHARDS {
            return bad(format!("the shard count N is at most {MAX_SHARDS}"));
        }
        if index == 0 || index > count {
            return bad(format!(
                "the shard index i must be between 1 and N = {count}"
            ));
        }
        Ok(Shard { index, count })
    }

    /// The whole run as one shard (`1/1`).
    pub fn whole() -> Shard {
        Shard { index: 1, count: 1 }
    }

    /// The 1-based index i.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The number of shards N.
    pub fn count(&self) -> usize {
        self.count
    }

    /// This shard's contiguous share of `total` work items:
    /// `⌊(i−1)·total/N⌋ .. ⌊i·total/N⌋`. The N shares are disjoint, in order, cover
    /// `0..total`, and differ in length by at most one.
    pub fn range(&self, total: usize) -> Range<usize> {
        let cut = |k: usize| (k as u128 * total as u128 / self.count as u128) as usize;
        cut(self.index - 1)..cut(self.index)
    }

    /// This shard's share of `total` items grouped in blocks of `block` items (the last block
    /// may be short) that must not be split: the items of the blocks [`Shard::range`] gives
    /// this shard out of `⌈total/block⌉`.
    pub fn block_range(&self, total: usize, block: usize) -> Range<usize> {
        let block = block.max(1);
        let blocks = self.range(total.div_ceil(block));
        (blocks.start * block).min(total)..(blocks.end * block).min(total)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = Error;

    /// Parses `i/N` (decimal integers, no spaces).
    fn from_str(s: &str) -> Result<Shard> {
        let bad = |problem: &str| Error::ShardSpec {
            value: s.to_string(),
            problem: problem.to_string(),
        };
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected i/N, e.g. 2/8 (shard 2 of 8)"))?;
        let num = |t: &str| -> Result<usize> {
            if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) || t.len() > 12 {
                return Err(bad(
                    "expected i/N with whole numbers, e.g. 2/8 (shard 2 of 8)",
                ));
            }
            t.parse::<usize>()
                .map_err(|_| bad("expected i/N with whole numbers"))
        };
        Shard::new(num(i)?, num(n)?).map_err(|e| match e {
            Error::ShardSpec { problem, .. } => Error::ShardSpec {
                value: s.to_string(),
                problem,
            },
            other => other,
        })
    }
}

/// `sha256:<hex>` of the parts, each prefixed by its length (so the split between parts
/// counts). Shards of one run have the same fingerprint of their inputs.
pub fn fingerprint(parts: &[&[u8]]) -> String {
    let mut h = sha2::Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    let digest = h.finalize();
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

/// Which items of the whole run a shard holds.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Items {
    /// First item (0-based).
    pub start: usize,
    /// One past the last item.
    pub end: usize,
    /// Items of the whole run.
    pub total: usize,
}

/// `shard.json`: what a shard directory holds and which run it belongs to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// [`FORMAT_VERSION`] when written.
    pub format_version: u32,
    /// The command that wrote it (`grid`, `measure`, `place`).
    pub command: String,
    /// Shard i of N.
    pub shard: Shard,
    /// The items of the whole run this shard holds (`shard.range(total)` or its block form).
    pub items: Items,
    /// [`fingerprint`] of the inputs (equal for every shard of one run).
    pub fingerprint: String,
    /// Seed of the run.
    pub seed: u64,
    /// Draws (per point, or replicates) of the run.
    pub samples: u64,
    /// The crashrig version that wrote it (shards of different versions are not merged).
    pub crashrig_version: String,
    /// The main input file (scenario, …) as the shard saw it (absolute when it could be
    /// resolved): `merge` reads it again and checks its fingerprint.
    pub input: PathBuf,
    /// Wall-clock seconds of the shard's work.
    pub elapsed_s: f64,
    /// Worker threads of the shard.
    pub threads: usize,
}

impl Manifest {
    /// A manifest for shard `shard` of a `command` run over `total` items, holding `items`
    /// (time and threads zero; set them when the work is done).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        command: &str,
        shard: Shard,
        total: usize,
        items: Range<usize>,
        fingerprint: String,
        seed: u64,
        samples: u64,
        input: impl Into<PathBuf>,
    ) -> Manifest {
        Manifest {
            format: FORMAT.to_string(),
            format_version: FORMAT_VERSION,
            command: command.to_string(),
            shard,
            items: Items {
                start: items.start,
                end: items.end,
                total,
            },
            fingerprint,
            seed,
            samples,
            crashrig_version: env!("CARGO_PKG_VERSION").to_string(),
            input: input.into(),
            elapsed_s: 0.0,
            threads: 0,
        }
    }

    /// The items as a range.
    pub fn range(&self) -> Range<usize> {
        self.items.start..self.items.end
    }

    /// The manifest as pretty JSON (what [`Manifest::read`] reads).
    pub fn to_json(&self) -> Vec<u8> {
        let mut v = serde_json::to_vec_pretty(self).unwrap_or_default();
        v.push(b'\n');
        v
    }

    /// Reads `DIR/shard.json`.
    ///
    /// # Errors
    /// [`Error::NotAShard`] when `dir` is not a directory or has no `shard.json`;
    /// [`Error::ShardManifest`] when the file is not a shard manifest of this layout version.
    pub fn read(dir: &Path) -> Result<Manifest> {
        if !dir.is_dir() {
            return Err(Error::NotAShard {
                dir: dir.to_path_buf(),
                why: "not a directory",
            });
        }
        let path = dir.join(MANIFEST);
        let meta = match std::fs::symlink_metadata(&path) {
            Ok(m) => m,
            Err(_) => {
                return Err(Error::NotAShard {
                    dir: dir.to_path_buf(),
                    why: "it has no shard.json (write one with --shard i/N)",
                });
            }
        };
        // A manifest is a few hundred bytes; anything large is not one.
        if !meta.is_file() || meta.len() > 1 << 20 {
            return Err(Error::ShardManifest {
                path,
                problem: "not a regular file of at most 1 MiB".into(),
            });
        }
        let bytes = std::fs::read(&path).map_err(|e| Error::Io {
            path: path.clone(),
            what: "cannot read",
            source: e,
        })?;
        let m: Manifest = serde_json::from_slice(&bytes).map_err(|e| Error::ShardManifest {
            path: path.clone(),
            problem: format!("line {}: {e}", e.line()),
        })?;
        if m.format != FORMAT || m.format_version != FORMAT_VERSION {
            return Err(Error::ShardManifest {
                path,
                problem: format!(
                    "format `{}` version {} is not `{FORMAT}` version {FORMAT_VERSION}",
                    m.format, m.format_version
                ),
            });
        }
        if m.items.start > m.items.end || m.items.end > m.items.total {
            return Err(Error::ShardManifest {
                path,
                problem: format!(
                    "`items` {}..{} is not inside 0..{}",
                    m.items.start, m.items.end, m.items.total
                ),
            });
        }
        Ok(m)
    }
}

/// Checks that `shards` (directory, manifest) are exactly the N shards of one run and
/// returns their positions in shard order (1/N first).
///
/// # Errors
/// [`Error::ShardSet`] naming the directory at fault: a shard of another run (command,
/// fingerprint of the inputs, seed, samples, N, item count or crashrig version differ from the
/// first shard's), a shard given twice (both directories), shards whose items do not tile the
/// run, or missing shards (their i/N).
pub fn check_set(shards: &[(PathBuf, Manifest)]) -> Result<Vec<usize>> {
    let Some((dir0, first)) = shards.first() else {
        return Err(Error::ShardSet {
            problem: "no shard directory given".into(),
        });
    };
    for (dir, m) in &shards[1..] {
        let differ = |what: &str, a: String, b: String| {
            Err(Error::ShardSet {
                problem: format!(
                    "{}: a shard of another run: its {what} is {b}, but {} has {a}",
                    dir.display(),
                    dir0.display()
                ),
            })
        };
        if m.command != first.command {
            return differ("command", first.command.clone(), m.command.clone());
        }
        if m.fingerprint != first.fingerprint {
            return differ(
                "input fingerprint",
                first.fingerprint.clone(),
                m.fingerprint.clone(),
            );
        }
        if m.seed != first.seed {
            return differ("seed", first.seed.to_string(), m.seed.to_string());
        }
        if m.samples != first.samples {
            return differ("samples", first.samples.to_string(), m.samples.to_string());
        }
        if m.shard.count != first.shard.count {
            return differ(
                "shard count N",
                first.shard.count.to_string(),
                m.shard.count.to_string(),
            );
        }
        if m.items.total != first.items.total {
            return differ(
                "item count",
                first.items.total.to_string(),
                m.items.total.to_string(),
            );
        }
        if m.crashrig_version != first.crashrig_version {
            return differ(
                "crashrig version",
                first.crashrig_version.clone(),
                m.crashrig_version.clone(),
            );
        }
    }
    let n = first.shard.count;
    let mut slot: Vec<Option<usize>> = vec![None; n];
    for (k, (dir, m)) in shards.iter().enumerate() {
        let s = &mut slot[m.shard.index - 1];
        if let Some(other) = *s {
            return Err(Error::ShardSet {
                problem: format!(
                    "shard {} is given twice: {} and {}",
                    m.shard,
                    shards[other].0.display(),
                    dir.display()
                ),
            });
        }
        *s = Some(k);
    }
    let missing: Vec<String> = slot
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(i, _)| format!("{}/{n}", i + 1))
        .collect();
    if !missing.is_empty() {
        let shown = if missing.len() > 10 {
            format!("{} … ({} in all)", missing[..10].join(", "), missing.len())
        } else {
            missing.join(", ")
        };
        return Err(Error::ShardSet {
            problem: format!("missing shard(s) {shown} of the run of {}", dir0.display()),
        });
    }
    let order: Vec<usize> = slot.into_iter().flatten().collect();
    // The shares must tile 0..total in order.
    let mut next = 0;
    for &k in &order {
        let (dir, m) = &shards[k];
        if m.items.start != next {
            return Err(Error::ShardSet {
                problem: format!(
                    "{}: shard {} holds items {}..{}, expected to start at {next}",
                    dir.display(),
                    m.shard,
                    m.items.start,
                    m.items.end
                ),
            });
        }
        next = m.items.end;
    }
    if next != first.items.total {
        return Err(Error::ShardSet {
            problem: format!("the shards hold items 0..{next} of {}", first.items.total),
        });
    }
    Ok(order)
}

/// Reads the manifests of `dirs` and checks them ([`check_set`]); returns (directory,
/// manifest) in shard order.
///
/// # Errors
/// As [`Manifest::read`] and [`check_set`].
pub fn read_set(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, Manifest)>> {
    if dirs.len() > MAX_SHARDS {
        return Err(Error::ShardSet {
            problem: format!(
                "{} shard directories given, at most {MAX_SHARDS}",
                dirs.len()
            ),
        });
    }
    let shards: Vec<(PathBuf, Manifest)> = dirs
        .iter()
        .map(|d| Manifest::read(d).map(|m| (d.clone(), m)))
        .collect::<Result<_>>()?;
    let order = check_set(&shards)?;
    Ok(order.into_iter().map(|k| shards[k].clone()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_nominal() {
        let s: Shard = "3/8".parse().unwrap();
        assert_eq!((s.index(), s.count()), (3, 8));
        assert_eq!(s.to_string(), "3/8");
        assert_eq!("1/1".parse::<Shard>().unwrap(), Shard::whole());
    }

    #[test]
    fn parse_rejects_bad_values() {
        for bad in [
            "0/3",
            "4/3",
            "a/b",
            "1/0",
            "0/0",
            "",
            "/",
            "1/",
            "/3",
            "1 /3",
            "+1/3",
            "-1/3",
            "1/3/4",
            "1.0/3",
            "1/100001",
            "99999999999999999999/3",
        ] {
            let e = bad.parse::<Shard>().unwrap_err();
            assert!(
                matches!(e, Error::ShardSpec { ref value, .. } if value == bad),
                "{bad}: {e}"
            );
        }
        assert!("100000/100000".parse::<Shard>().is_ok());
    }

    #[test]
    fn ranges_tile_the_work() {
        for total in [0usize, 1, 2, 7, 10, 100, 1001] {
            for n in [1usize, 2, 3, 7, 16] {
                let mut next = 0;
                for i in 1..=n {
                    let r = Shard::new(i, n).unwrap().range(total);
                    assert_eq!(r.start, next, "total {total}, {i}/{n}");
                    let len = r.len();
                    assert!(len == total / n || len == total / n + 1, "{total} {i}/{n}");
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
    }

    #[test]
    fn block_ranges_never_split_a_block() {
        for (total, block) in [(10usize, 4usize), (1000, 256), (1, 256), (0, 3), (512, 256)] {
            for n in [1usize, 2, 3, 5] {
                let mut next = 0;
                for i in 1..=n {
                    let r = Shard::new(i, n).unwrap().block_range(total, block);
                    assert_eq!(r.start, next);
                    assert!(r.start.is_multiple_of(block) || r.start == total);
                    assert!(r.end.is_multiple_of(block) || r.end == total);
                    next = r.end;
                }
                assert_eq!(next, total, "{total} {block} {n}");
            }
        }
    }

    #[test]
    fn fingerprint_known_answer() {
        // sha256 of 8 zero bytes (the length prefix of an empty part), from `printf
        // '\0\0\0\0\0\0\0\0' | sha256sum`.
        assert_eq!(
            fingerprint(&[b""]),
            "sha256:af5570f5a1810b7af78caf4bc70a660f0df51e42baf91d4de5b2328de0e83dfc"
        );
        assert_ne!(fingerprint(&[b"ab", b"c"]), fingerprint(&[b"a", b"bc"]));
    }

    fn set(n: usize) -> Vec<(PathBuf, Manifest)> {
        (1..=n)
            .map(|i| {
                let s = Shard::new(i, n).unwrap();
                let m = Manifest::new("grid", s, 10, s.range(10), "fp".into(), 1, 100, "x");
                (PathBuf::from(format!("s{i}")), m)
            })
            .collect()
    }

    #[test]
    fn check_set_refusals_name_the_shard() {
        let good = set(3);
        assert_eq!(check_set(&good).unwrap(), [0, 1, 2]);
        let msg = |s: &[(PathBuf, Manifest)]| check_set(s).unwrap_err().to_string();
        // Missing.
        let m = msg(&[good[0].clone(), good[2].clone()]);
        assert!(m.contains("missing shard(s) 2/3"), "{m}");
        // Repeated.
        let mut rep = good.clone();
        rep.push((PathBuf::from("again"), good[1].1.clone()));
        let m = msg(&rep);
        assert!(m.contains("shard 2/3 is given twice: s2 and again"), "{m}");
        // Foreign: seed, samples, fingerprint, N, command.
        for (what, change) in [
            ("seed", (|m: &mut Manifest| m.seed = 2) as fn(&mut Manifest)),
            ("samples", |m| m.samples = 7),
            ("input fingerprint", |m| m.fingerprint = "other".into()),
            ("command", |m| m.command = "measure".into()),
            ("crashrig version", |m| m.crashrig_version = "0.0.1".into()),
        ] {
            let mut f = good.clone();
            change(&mut f[2].1);
            let m = msg(&f);
            assert!(m.starts_with("s3: a shard of another run"), "{m}");
            assert!(m.contains(what), "{what}: {m}");
        }
        let mut other_n = good.clone();
        let s = Shard::new(3, 4).unwrap();
        other_n[2].1 = Manifest::new("grid", s, 10, s.range(10), "fp".into(), 1, 100, "x");
        assert!(msg(&other_n).contains("shard count N is 4"));
        // Items that do not tile the run.
        let mut gap = good.clone();
        gap[1].1.items.end = 5;
        assert!(
            msg(&gap).contains("expected to start at 5"),
            "{}",
            msg(&gap)
        );
        assert!(msg(&[]).contains("no shard directory"));
    }

    #[test]
    fn manifest_round_trip_and_refusals() {
        let dir = tempfile::tempdir().unwrap();
        let m = set(2).remove(1).1;
        std::fs::write(dir.path().join(MANIFEST), m.to_json()).unwrap();
        assert_eq!(Manifest::read(dir.path()).unwrap(), m);
        // Not a shard directory.
        let empty = tempfile::tempdir().unwrap();
        let e = Manifest::read(empty.path()).unwrap_err();
        assert!(matches!(e, Error::NotAShard { .. }), "{e}");
        // Broken JSON names the file and line.
        std::fs::write(dir.path().join(MANIFEST), b"{\n\"format\": 3\n}").unwrap();
        let e = Manifest::read(dir.path()).unwrap_err().to_string();
        assert!(e.contains("shard.json: line 2"), "{e}");
        // A manifest whose shard index is out of range is refused by its own parse.
        let bad = String::from_utf8(m.to_json())
            .unwrap()
            .replace("\"index\": 2", "\"index\": 5");
        std::fs::write(dir.path().join(MANIFEST), bad).unwrap();
        assert!(Manifest::read(dir.path()).is_err());
    }
}
