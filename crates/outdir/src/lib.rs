//! Crash-safe output directories: a command's files are written into a hidden **staging
//! directory** beside `OUT` (same parent, so renames stay on one file system) and swapped in as
//! a whole when the command has finished. A reader of `OUT` sees either the complete old result
//! or the complete new one, never a mix.
//!
//! # Guarantees
//! - **Whole swap.** [`Staged::commit`] replaces `OUT` by the staging directory. On Linux the two
//!   directories are exchanged atomically (`renameat2(RENAME_EXCHANGE)`); elsewhere, or on a file
//!   system without it, the old `OUT` is renamed aside, the staging directory renamed to `OUT`
//!   and the old one removed (between the two renames `OUT` is briefly absent, never mixed).
//! - **Nothing of a previous run survives** in a reused `OUT`: the new `OUT` holds exactly the
//!   files of this run.
//! - **User files are never replaced.** An existing `OUT` is only replaced when it is empty or
//!   every entry in it passes the command's `replaceable` test (names the command itself writes);
//!   otherwise [`Staged::new`] fails with [`Error::NotOurs`] before anything is written.
//! - **Errors and signals clean up.** Dropping an uncommitted [`Staged`] (an error, a panic)
//!   removes the staging directory; SIGINT, SIGTERM and SIGHUP remove every staging directory of
//!   the process (and an old result a finished swap has not removed yet), say on stderr what
//!   became of `OUT` (`removed the unfinished output; OUT keeps its previous content`, or, for a
//!   signal that came after the swap, `OUT holds the whole new result`) and exit with status
//!   128 + signal. Every change this crate makes to a staging directory or `OUT` holds a gate
//!   that the signal thread takes for good, so a signal is handled between two changes, never
//!   inside one (a signal during the swap is handled right after it), and nothing is created
//!   once the clean-up has begun. A writer that fills [`Staged::dir`] without
//!   [`Staged::write`] does so inside [`gated`]. A process killed with SIGKILL leaves its
//!   hidden directories behind; the next [`Staged::new`] for the same `OUT` cleans up (Linux:
//!   when their process is gone): it removes them, and when the kill came between the two
//!   renames of the fallback swap (`OUT` absent), it first puts the old result back.
//! - Files are flushed to disk (`fsync`) before the swap.
//!
//! # Fault injection (tests only, feature `fault-injection`)
//! With the cargo feature `fault-injection` (off by default; only tests turn it on, as
//! failpoint crates do), the environment variable `CRASHRIG_OUTDIR_FAULT` stops the process at
//! a deterministic point, so interruption tests need no timing. A build without the feature
//! (every shipping build: `cargo build --release`) reads no environment variable and holds no
//! hook. The variable holds `ACTION-POINT`, optionally with
//! `,no-exchange` (use the two-rename swap, as on a file system without an atomic exchange):
//! - points: `after-file:K` (right after the K-th [`Staged::write`], 1-based), `before-swap`
//!   (in [`Staged::commit`], before the swap), `between-renames` (two-rename swap only: the old
//!   `OUT` moved aside, the new one not yet in place), `after-swap` (the new result is `OUT`,
//!   the old one not removed yet);
//! - actions: `abort` (SIGABRT, no clean-up, like SIGKILL), `stop` (SIGSTOP: a test looks at
//!   `OUT`, sends the signal it wants to the process group, then SIGCONT), `sigint` (raise
//!   SIGINT: before the swap the process then waits for the signal thread; inside the swap it
//!   finishes the swap first).
//!
//! The CLI's integration tests get a binary with the hook through a dev-dependency on this
//! crate with the feature (`crates/cli/Cargo.toml`): cargo unifies it into the `crashrig`
//! binary it builds for `cargo test`, never into `cargo build`.
//!
//! # Features
//! - `fault-injection` (off by default): the test hook above. Without it the crate has no
//!   fault points at all.
//!
//! # Example
//! ```
//! use crashrig_outdir::Staged;
//!
//! let parent = tempfile::tempdir()?;
//! let out = parent.path().join("result");
//! // The command only ever writes these names, so an old result made of them may be replaced.
//! let ours = |name: &str| name == "table.csv" || name == "summary.json";
//!
//! let mut staged = Staged::new(&out, ours)?;
//! staged.write("table.csv", b"x,y\n1,2\n")?;
//! // Other writers can write straight into the staging directory:
//! std::fs::write(staged.dir().join("summary.json"), b"{}")?;
//! assert!(!out.exists(), "nothing is visible before the commit");
//! staged.commit()?;
//! assert_eq!(std::fs::read(out.join("table.csv"))?, b"x,y\n1,2\n");
//!
//! // A second run replaces the whole directory: files it does not write do not survive.
//! let mut staged = Staged::new(&out, ours)?;
//! staged.write("summary.json", b"{\"run\": 2}")?;
//! staged.commit()?;
//! assert!(!out.join("table.csv").exists());
//! // Only OUT is left in the parent: no staging or temporary directories.
//! assert_eq!(std::fs::read_dir(parent.path())?.count(), 1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod shard;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Once, RwLock, RwLockReadGuard, RwLockWriteGuard};

/// The environment variable of the fault-injection hook (feature `fault-injection`; see the
/// crate docs).
#[cfg(feature = "fault-injection")]
pub const FAULT_ENV: &str = "CRASHRIG_OUTDIR_FAULT";

/// Marker in the names of staging and set-aside directories: `.<OUT name>.crashrig-staging.<pid>.<n>`.
const STAGING_MARK: &str = ".crashrig-staging.";

/// Everything that can go wrong while staging or swapping an output directory.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file-system operation failed.
    #[error("{}: {what}", path.display())]
    Io {
        /// The path concerned.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// `OUT` cannot be an output directory (`.`, `..`, a path ending in `..`, a symbolic link or
    /// an existing non-directory).
    #[error("{}: cannot be used as an output directory: {why}", path.display())]
    BadOut {
        /// The output path.
        path: PathBuf,
        /// Why not.
        why: &'static str,
    },
    /// `OUT` exists and holds an entry the command does not write: it is not replaced.
    #[error(
        "{}: exists and holds `{entry}`, which this command does not write; remove it or choose a new or empty output directory",
        out.display()
    )]
    NotOurs {
        /// The output directory.
        out: PathBuf,
        /// The first foreign entry found.
        entry: String,
    },
    /// `--shard i/N` is not 1 ≤ i ≤ N ≤ [`shard::MAX_SHARDS`].
    #[error("--shard {value}: {problem}")]
    ShardSpec {
        /// The value as given.
        value: String,
        /// What is wrong.
        problem: String,
    },
    /// A directory given to `merge` is not a shard directory.
    #[error("{}: not a shard directory: {why}", dir.display())]
    NotAShard {
        /// The directory.
        dir: PathBuf,
        /// Why not.
        why: &'static str,
    },
    /// A `shard.json` that cannot be read as a shard manifest.
    #[error("{}: {problem}", path.display())]
    ShardManifest {
        /// The manifest file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The shard directories given to `merge` are not exactly the shards of one run (the
    /// message names the directory or the missing i/N).
    #[error("{problem}")]
    ShardSet {
        /// What is wrong, naming the shard.
        problem: String,
    },
    /// A file name given to [`Staged::write`] is empty, absolute or climbs out with `..`.
    #[error("`{name}`: not a relative file name inside the output directory")]
    BadName {
        /// The name.
        name: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

fn io<'a>(path: &'a Path, what: &'static str) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io {
        path: path.to_path_buf(),
        what,
        source,
    }
}

// ------------------------------------------------------------ signal clean-up ---

/// What a registered directory holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A staging directory: the unfinished new result.
    Staging,
    /// The old result, swapped out of `OUT` (or moved aside), to be removed.
    Old,
}

/// A directory the signal thread removes, and the output directory it belongs to.
#[derive(Debug)]
struct Entry {
    path: PathBuf,
    out: PathBuf,
    kind: Kind,
}

/// The directories to remove on a termination signal, and the last output swapped in.
#[derive(Debug)]
struct Registry {
    entries: Vec<Entry>,
    completed: Option<PathBuf>,
}

impl Registry {
    fn add(&mut self, path: &Path, out: &Path, kind: Kind) {
        self.entries.push(Entry {
            path: path.to_path_buf(),
            out: out.to_path_buf(),
            kind,
        });
    }

    fn remove(&mut self, path: &Path) {
        self.entries.retain(|e| e.path != path);
    }

    fn set_kind(&mut self, path: &Path, kind: Kind) {
        for e in self.entries.iter_mut().filter(|e| e.path == path) {
            e.kind = kind;
        }
    }

    /// The one line the signal thread prints: what became of the output. An output inside
    /// another staging directory (`place`'s `OUT/grid/`) is part of that one.
    fn interrupted_message(&self) -> String {
        let top = |kind: Kind| -> Vec<String> {
            let mut outs: Vec<String> = self
                .entries
                .iter()
                .filter(|e| e.kind == kind)
                .filter(|e| {
                    !self
                        .entries
                        .iter()
                        .any(|s| s.kind == Kind::Staging && e.out.starts_with(&s.path))
                })
                .map(|e| e.out.display().to_string())
                .collect();
            outs.dedup();
            outs
        };
        let unfinished = top(Kind::Staging);
        if !unfinished.is_empty() {
            return format!(
                "interrupted: removed the unfinished output; {} keeps its previous content",
                unfinished.join(", ")
            );
        }
        let swapped = top(Kind::Old);
        let done = swapped
            .first()
            .cloned()
            .or_else(|| self.completed.as_ref().map(|p| p.display().to_string()));
        match done {
            Some(out) => format!(
                "interrupted after the output was complete: {out} holds the whole new result"
            ),
            None => "interrupted".to_string(),
        }
    }
}

/// The **gate**: every file-system change to a staging directory or an output directory made
/// through this crate (creating a staging directory, [`Staged::write`], [`gated`], the swap,
/// the clean-up of a dropped [`Staged`]) holds it, shared for writes and exclusive for the rest;
/// the signal thread takes it exclusively and never gives it back. So a termination signal is
/// handled between two such changes, never inside one, and once the signal thread has removed
/// the registered directories nothing of this process can create or fill one again (every
/// writer then blocks on the gate until the process exits).
static GATE: RwLock<Registry> = RwLock::new(Registry {
    entries: Vec::new(),
    completed: None,
});
static HANDLER: Once = Once::new();

fn shared() -> RwLockReadGuard<'static, Registry> {
    GATE.read().unwrap_or_else(|e| e.into_inner())
}

fn exclusive() -> RwLockWriteGuard<'static, Registry> {
    GATE.write().unwrap_or_else(|e| e.into_inner())
}

/// Runs `f` — file-system writes into a staging directory that do not go through
/// [`Staged::write`] (a writer given [`Staged::dir`]) — so that a termination signal is handled
/// before or after it, never during it, and no write starts once the signal's clean-up has begun
/// (then `gated` blocks until the process exits). `f` must not call this crate.
pub fn gated<T>(f: impl FnOnce() -> T) -> T {
    let _gate = shared();
    f()
}

fn remove_tree(p: &Path) {
    // A writer may still be creating files while we remove: retry a few times.
    for _ in 0..5 {
        match std::fs::remove_dir_all(p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => continue,
            _ => return,
        }
    }
}

/// Removes every directory of `dirs` until none has come back for a few milliseconds (at most
/// about 2 s): a backstop for a writer that fills a staging directory outside the gate.
fn remove_until_gone(dirs: &[PathBuf]) {
    let mut quiet = 0;
    for _ in 0..400 {
        for d in dirs {
            remove_tree(d);
        }
        if dirs.iter().any(|d| std::fs::symlink_metadata(d).is_ok()) {
            quiet = 0;
            continue;
        }
        quiet += 1;
        if quiet >= 3 {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// Installs (once per process) a thread that, on SIGINT/SIGTERM/SIGHUP, takes the gate for good,
/// removes every registered directory (unfinished staging directories, and an old result that a
/// finished swap has not removed yet), says on stderr what became of the output and exits with
/// status 128 + signal.
fn install_handler() {
    HANDLER.call_once(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        let spawned = std::thread::Builder::new()
            .name("crashrig-outdir-signals".into())
            .spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    let registry = exclusive();
                    let dirs: Vec<PathBuf> =
                        registry.entries.iter().map(|e| e.path.clone()).collect();
                    remove_until_gone(&dirs);
                    eprintln!("{}", registry.interrupted_message());
                    std::process::exit(128 + sig);
                }
            });
        drop(spawned);
    });
}

/// For a host process that handles signals itself (the Python module `crashrig`, where Ctrl-C
/// is a `KeyboardInterrupt` that unwinds the call and drops its [`Staged`], which removes the
/// staging directory): the signal thread is never installed, so SIGINT/SIGTERM/SIGHUP keep the
/// host's handling. Call it before the first [`Staged::new`]; later it has no effect.
pub fn leave_signals_to_host() {
    HANDLER.call_once(|| {});
}

/// Writes one file atomically: a temporary file in the same directory, then a rename over
/// `path`, so a reader never sees a half-written file and a failure leaves the previous file
/// (for single files a front end writes, such as `--replicates` or `covariance --out`; a set
/// of files is a [`Staged`] directory). The file gets mode 0644, as `File::create` makes it.
/// It runs under the gate: a termination signal waits for the rename, so no temporary file is
/// left behind.
///
/// # Errors
/// [`Error::Io`] naming `path` (or its directory) and the step that failed.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let _gate = shared();
    let mut tmp =
        tempfile::NamedTempFile::new_in(dir).map_err(io(dir, "cannot create a temporary file"))?;
    tmp.write_all(bytes).map_err(io(path, "write failed"))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .map_err(io(path, "cannot set permissions"))?;
    }
    tmp.persist(path)
        .map_err(|e| io(path, "cannot rename into place")(e.error))?;
    Ok(())
}

/// Writes a set of files held in memory, `(name, bytes)`, as the directory `out`, replaced as a
/// whole ([`Staged`]): an existing `out` may hold only these names (empty, or an earlier run of
/// the same writer), anything else is refused before a file is written. For plot directories
/// such as `calibrate --plots` and `bootstrap --plots`.
///
/// # Errors
/// [`Staged::new`]'s (including [`Error::NotOurs`]), [`Staged::write`]'s and
/// [`Staged::commit`]'s.
pub fn write_dir(out: &Path, files: &[(String, Vec<u8>)]) -> Result<()> {
    let mut staged = Staged::new(out, |name| files.iter().any(|(n, _)| n == name))?;
    for (name, bytes) in files {
        staged.write(name, bytes)?;
    }
    staged.commit()
}

// ------------------------------------------------------------- fault hook ---

/// Where the fault hook can stop the process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Point {
    /// Right after the K-th [`Staged::write`] (1-based).
    AfterFile(usize),
    /// In [`Staged::commit`], after the staging tree is flushed, before the gate is taken.
    BeforeSwap,
    /// Without an atomic exchange: the old `OUT` is moved aside, the new one not yet in place
    /// (`OUT` is absent). Inside the gate.
    BetweenRenames,
    /// The new result is `OUT`; the old one is not removed yet. Inside the gate.
    AfterSwap,
}

/// Without the feature `fault-injection`: no fault point, the atomic exchange always tried.
#[cfg(not(feature = "fault-injection"))]
fn fault_spec() -> (Option<(&'static str, Point)>, bool) {
    (None, false)
}

/// The hook's instructions: the point and what to do there, and whether the atomic exchange is
/// to be skipped (to test the two-rename fallback).
#[cfg(feature = "fault-injection")]
fn fault_spec() -> (Option<(&'static str, Point)>, bool) {
    let Ok(spec) = std::env::var(FAULT_ENV) else {
        return (None, false);
    };
    let mut stop = None;
    let mut no_exchange = false;
    for item in spec.split(',') {
        if item == "no-exchange" {
            no_exchange = true;
            continue;
        }
        let (action, at) = item.split_once('-').unwrap_or(("", ""));
        let action = match action {
            "abort" => "abort",
            "sigint" => "sigint",
            "stop" => "stop",
            _ => continue,
        };
        let point = match at {
            "before-swap" => Some(Point::BeforeSwap),
            "between-renames" => Some(Point::BetweenRenames),
            "after-swap" => Some(Point::AfterSwap),
            _ => at
                .strip_prefix("after-file:")
                .and_then(|k| k.parse().ok())
                .map(Point::AfterFile),
        };
        if let Some(p) = point {
            stop = Some((action, p));
        }
    }
    (stop, no_exchange)
}

/// Acts at `point` if `CRASHRIG_OUTDIR_FAULT` asks for it (feature `fault-injection`): `abort` (SIGABRT, no
/// clean-up, like SIGKILL), `stop` (SIGSTOP: a test observes `OUT` and sends the signal it
/// wants, then SIGCONT), `sigint` (raise SIGINT; outside the gate the process then waits for
/// the signal thread, inside it goes on and the signal is handled once the gate is free).
fn fault(point: Point, inside_gate: bool) {
    let (Some((action, at)), _) = fault_spec() else {
        return;
    };
    if at != point {
        return;
    }
    match action {
        "abort" => std::process::abort(),
        "stop" => {
            let _ = signal_hook::low_level::raise(signal_hook::consts::SIGSTOP);
        }
        "sigint" => {
            let _ = signal_hook::low_level::raise(signal_hook::consts::SIGINT);
            if !inside_gate {
                // The signal thread removes the staging directory and exits the process.
                loop {
                    std::thread::park();
                }
            }
        }
        _ => {}
    }
}

// ---------------------------------------------------------------- Staged ---

/// An output directory being written: files go to a hidden staging directory until
/// [`Staged::commit`] swaps it in as `OUT`. Dropping it uncommitted removes the staging
/// directory (see the crate docs for the guarantees).
#[derive(Debug)]
pub struct Staged {
    out: PathBuf,
    staging: PathBuf,
    files: usize,
    committed: bool,
}

/// `(parent, file name)` of `out`, rejecting `.`/`..` and paths without a final name.
fn split_out(out: &Path) -> Result<(PathBuf, String)> {
    let bad = |why| Error::BadOut {
        path: out.to_path_buf(),
        why,
    };
    let name = out
        .file_name()
        .ok_or_else(|| bad("it has no final name (like `.` or `..`)"))?
        .to_str()
        .ok_or_else(|| bad("its name is not valid UTF-8"))?
        .to_string();
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((parent, name))
}

/// Whether the process with id `pid` is still running (Linux: `/proc/<pid>`; elsewhere assume
/// yes, so nothing of a live run is removed).
fn alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// The hidden directories of `name` in `parent` left by processes that are gone: `(path,
/// moved-aside old result?)`.
fn stale(parent: &Path, name: &str) -> Vec<(PathBuf, bool)> {
    let prefix = format!(".{name}{STAGING_MARK}");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for e in entries.flatten() {
        let file_name = e.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let pid = rest.split('.').next().and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|p| p != std::process::id() && !alive(p)) {
            found.push((e.path(), rest.ends_with(".old")));
        }
    }
    found.sort();
    found
}

/// Cleans up after killed runs into `out`: when `out` is absent and a killed run had moved the
/// old result aside (the two-rename swap, killed between its renames), that old result is put
/// back first; every other stale staging directory is removed.
fn recover_stale(parent: &Path, name: &str, out: &Path) {
    let found = stale(parent, name);
    if std::fs::symlink_metadata(out).is_err()
        && let Some((aside, _)) = found.iter().find(|(_, old)| *old)
    {
        let _ = std::fs::rename(aside, out);
    }
    for (p, _) in found {
        if p.exists() {
            remove_tree(&p);
        }
    }
}

/// Checks an existing `out`: a real directory whose entries all pass `replaceable`.
fn check_existing(out: &Path, replaceable: &impl Fn(&str) -> bool) -> Result<bool> {
    match std::fs::symlink_metadata(out) {
        Ok(m) if m.file_type().is_symlink() => Err(Error::BadOut {
            path: out.to_path_buf(),
            why: "it is a symbolic link (give the directory it points to)",
        }),
        Ok(m) if !m.is_dir() => Err(Error::BadOut {
            path: out.to_path_buf(),
            why: "it exists and is not a directory",
        }),
        Ok(_) => {
            let entries = std::fs::read_dir(out).map_err(io(out, "cannot list"))?;
            let mut names: Vec<String> = entries
                .map(|e| {
                    e.map(|e| {
                        let name = e.file_name().to_string_lossy().into_owned();
                        let dir = e.file_type().is_ok_and(|t| t.is_dir());
                        if dir { format!("{name}/") } else { name }
                    })
                    .map_err(io(out, "cannot list"))
                })
                .collect::<Result<_>>()?;
            names.sort();
            match names.into_iter().find(|n| !replaceable(n)) {
                Some(foreign) => Err(Error::NotOurs {
                    out: out.to_path_buf(),
                    entry: foreign,
                }),
                None => Ok(true),
            }
        }
        Err(_) => Ok(false),
    }
}

impl Staged {
    /// Starts writing the output directory `out`.
    ///
    /// `replaceable(name)` says whether a top-level entry `name` of an existing `out` is
    /// something this command writes (so the old result may be replaced as a whole); a
    /// directory is passed with a trailing `/` (`"grid/"`), so a directory where the command
    /// writes a file is foreign. An empty
    /// or absent `out` is always fine; an entry that fails the test is an [`Error::NotOurs`],
    /// reported before anything is written. The parent directory is created if needed.
    pub fn new(out: &Path, replaceable: impl Fn(&str) -> bool) -> Result<Staged> {
        let (parent, name) = split_out(out)?;
        install_handler();
        static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let staging = parent.join(format!(".{name}{STAGING_MARK}{}.{n}", std::process::id()));
        // Everything below changes the file system: inside the gate, so a signal comes before
        // (nothing is created) or after (the staging directory is registered and removed).
        let mut registry = exclusive();
        recover_stale(&parent, &name, out);
        if !check_existing(out, &replaceable)? {
            std::fs::create_dir_all(&parent)
                .map_err(io(&parent, "cannot create the parent directory"))?;
        }
        std::fs::create_dir(&staging)
            .map_err(io(&staging, "cannot create the staging directory"))?;
        registry.add(&staging, out, Kind::Staging);
        Ok(Staged {
            out: out.to_path_buf(),
            staging,
            files: 0,
            committed: false,
        })
    }

    /// The staging directory. Write files with [`Staged::write`]; a writer that fills it
    /// otherwise does so inside [`gated`], so that a termination signal cannot interleave.
    pub fn dir(&self) -> &Path {
        &self.staging
    }

    /// The final output directory.
    pub fn out(&self) -> &Path {
        &self.out
    }

    /// Writes `bytes` to `name` (relative, `/`-separated subdirectories are created) inside the
    /// staging directory, and flushes it to disk (inside the gate).
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<()> {
        let rel = Path::new(name);
        let ok = !name.is_empty()
            && rel
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
        if !ok {
            return Err(Error::BadName {
                name: name.to_string(),
            });
        }
        let path = self.staging.join(rel);
        {
            let _gate = shared();
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(io(dir, "cannot create directory"))?;
            }
            let mut f = std::fs::File::create(&path).map_err(io(&path, "cannot create"))?;
            f.write_all(bytes).map_err(io(&path, "write failed"))?;
            f.sync_all().map_err(io(&path, "write failed"))?;
        }
        self.files += 1;
        fault(Point::AfterFile(self.files), false);
        Ok(())
    }

    /// Swaps the staging directory in as `OUT` (see the crate docs) and removes the old `OUT`.
    pub fn commit(mut self) -> Result<()> {
        sync_tree(&self.staging);
        fault(Point::BeforeSwap, false);
        let no_exchange = fault_spec().1;
        let mut registry = exclusive();
        match std::fs::symlink_metadata(&self.out) {
            Err(_) => {
                std::fs::rename(&self.staging, &self.out).map_err(io(
                    &self.out,
                    "cannot rename the staging directory into place",
                ))?;
                registry.remove(&self.staging);
                self.committed = true;
                fault(Point::AfterSwap, true);
            }
            Ok(_) if !no_exchange && exchange(&self.staging, &self.out) => {
                // The staging path now holds the old result: removed below.
                registry.set_kind(&self.staging, Kind::Old);
                self.committed = true;
                fault(Point::AfterSwap, true);
            }
            Ok(_) => {
                let aside = self.staging.with_extension("old");
                registry.add(&aside, &self.out, Kind::Old);
                if let Err(e) = std::fs::rename(&self.out, &aside) {
                    registry.remove(&aside);
                    return Err(io(&self.out, "cannot move the old output aside")(e));
                }
                fault(Point::BetweenRenames, true);
                if let Err(e) = std::fs::rename(&self.staging, &self.out) {
                    let _ = std::fs::rename(&aside, &self.out);
                    registry.remove(&aside);
                    return Err(io(
                        &self.out,
                        "cannot rename the staging directory into place",
                    )(e));
                }
                registry.remove(&self.staging);
                self.staging = aside;
                self.committed = true;
                fault(Point::AfterSwap, true);
            }
        }
        sync_dir(self.out.parent().unwrap_or(Path::new(".")));
        registry.completed = Some(self.out.clone());
        drop(registry);
        // Remove the old result (now at `self.staging`, absent when OUT was new), then forget it.
        remove_tree(&self.staging);
        exclusive().remove(&self.staging);
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.committed {
            let mut registry = exclusive();
            remove_tree(&self.staging);
            registry.remove(&self.staging);
        }
    }
}

/// Atomically exchanges two directories (Linux `renameat2(RENAME_EXCHANGE)`); `false` when
/// unsupported, so the caller falls back to two renames.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> bool {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).is_ok()
}

#[cfg(not(target_os = "linux"))]
fn exchange(_a: &Path, _b: &Path) -> bool {
    false
}

/// `fsync` of every file and directory below `dir` (best effort).
fn sync_tree(dir: &Path) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            match e.file_type() {
                Ok(t) if t.is_dir() => sync_tree(&p),
                Ok(t) if t.is_file() => {
                    if let Ok(f) = std::fs::File::open(&p) {
                        let _ = f.sync_all();
                    }
                }
                _ => {}
            }
        }
    }
    sync_dir(dir);
}

fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn fresh_output_is_created_whole() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("a/b/out");
        let mut s = Staged::new(&out, |_| true).unwrap();
        s.write("x.csv", b"1").unwrap();
        s.write("sub/y.json", b"2").unwrap();
        assert!(!out.exists());
        s.commit().unwrap();
        assert_eq!(listing(&out), ["sub", "x.csv"]);
        assert_eq!(std::fs::read(out.join("sub/y.json")).unwrap(), b"2");
        assert_eq!(listing(&tmp.path().join("a/b")), ["out"]);
    }

    #[test]
    fn write_dir_replaces_its_own_names_and_refuses_others() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("plots");
        let files = |b: &[u8]| {
            vec![
                ("a.png".to_string(), b.to_vec()),
                ("b.svg".into(), b.into()),
            ]
        };
        write_dir(&out, &files(b"1")).unwrap();
        write_dir(&out, &files(b"2")).unwrap();
        assert_eq!(listing(&out), ["a.png", "b.svg"]);
        assert_eq!(std::fs::read(out.join("a.png")).unwrap(), b"2");
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        let e = write_dir(&out, &files(b"3")).unwrap_err();
        assert!(
            matches!(e, Error::NotOurs { ref entry, .. } if entry == "notes.txt"),
            "{e}"
        );
        assert_eq!(std::fs::read(out.join("a.png")).unwrap(), b"2");
        assert_eq!(listing(tmp.path()), ["plots"]);
    }

    #[test]
    fn reused_output_keeps_nothing_of_the_old_run() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("old_z07.png"), b"stale").unwrap();
        std::fs::write(out.join("summary.json"), b"old").unwrap();
        std::fs::create_dir(out.join("maps")).unwrap();
        let mut s = Staged::new(&out, |n| {
            n.ends_with(".png") || n.ends_with(".json") || n == "maps/"
        })
        .unwrap();
        s.write("summary.json", b"new").unwrap();
        s.commit().unwrap();
        assert_eq!(listing(&out), ["summary.json"]);
        assert_eq!(std::fs::read(out.join("summary.json")).unwrap(), b"new");
        assert_eq!(listing(tmp.path()), ["out"]);
    }

    #[test]
    fn foreign_files_are_never_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("scenario.toml"), b"mine").unwrap();
        let err = Staged::new(&out, |n| n.ends_with(".csv")).unwrap_err();
        assert!(
            matches!(&err, Error::NotOurs { entry, .. } if entry == "scenario.toml"),
            "{err}"
        );
        assert_eq!(listing(tmp.path()), ["out"], "no staging directory");
        assert_eq!(std::fs::read(out.join("scenario.toml")).unwrap(), b"mine");
    }

    #[test]
    fn dropped_uncommitted_leaves_old_output_and_no_staging() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("a.csv"), b"old").unwrap();
        {
            let mut s = Staged::new(&out, |_| true).unwrap();
            s.write("a.csv", b"new").unwrap();
            assert_eq!(listing(tmp.path()).len(), 2, "staging exists while writing");
        }
        assert_eq!(listing(tmp.path()), ["out"]);
        assert_eq!(std::fs::read(out.join("a.csv")).unwrap(), b"old");
    }

    #[test]
    fn bad_outputs_and_names_are_errors() {
        let tmp = tempfile::tempdir().unwrap();
        assert!(matches!(
            Staged::new(Path::new(".."), |_| true),
            Err(Error::BadOut { .. })
        ));
        let file = tmp.path().join("f");
        std::fs::write(&file, b"").unwrap();
        assert!(matches!(
            Staged::new(&file, |_| true),
            Err(Error::BadOut { .. })
        ));
        let mut s = Staged::new(&tmp.path().join("o"), |_| true).unwrap();
        for bad in ["", "/etc/x", "../x", "a/../../x"] {
            assert!(
                matches!(s.write(bad, b""), Err(Error::BadName { .. })),
                "{bad}"
            );
        }
    }

    #[test]
    fn signal_message_says_what_became_of_the_output() {
        let mut r = Registry {
            entries: Vec::new(),
            completed: None,
        };
        assert_eq!(r.interrupted_message(), "interrupted");
        r.add(
            Path::new("/p/.out.s.1.0"),
            Path::new("/p/out"),
            Kind::Staging,
        );
        // `place`: its grid output is staged inside its own staging directory.
        r.add(
            Path::new("/p/.out.s.1.0/.grid.s.1.1"),
            Path::new("/p/.out.s.1.0/grid"),
            Kind::Staging,
        );
        assert_eq!(
            r.interrupted_message(),
            "interrupted: removed the unfinished output; /p/out keeps its previous content"
        );
        r.remove(Path::new("/p/.out.s.1.0/.grid.s.1.1"));
        r.set_kind(Path::new("/p/.out.s.1.0"), Kind::Old);
        assert_eq!(
            r.interrupted_message(),
            "interrupted after the output was complete: /p/out holds the whole new result"
        );
        r.remove(Path::new("/p/.out.s.1.0"));
        r.completed = Some(PathBuf::from("/p/out"));
        assert_eq!(
            r.interrupted_message(),
            "interrupted after the output was complete: /p/out holds the whole new result"
        );
    }

    #[test]
    fn old_result_moved_aside_by_a_killed_run_is_put_back() {
        if !cfg!(target_os = "linux") {
            return;
        }
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        // A run killed between the two renames of the fallback swap: OUT absent, the old result
        // aside, the new one staged.
        let aside = tmp.path().join(format!(".out{STAGING_MARK}4000000000.old"));
        let staging = tmp.path().join(format!(".out{STAGING_MARK}4000000000.0"));
        std::fs::create_dir(&aside).unwrap();
        std::fs::write(aside.join("a.csv"), b"old").unwrap();
        std::fs::create_dir(&staging).unwrap();
        std::fs::write(staging.join("a.csv"), b"new, never committed").unwrap();
        let s = Staged::new(&out, |n| n == "a.csv").unwrap();
        assert_eq!(std::fs::read(out.join("a.csv")).unwrap(), b"old");
        drop(s);
        assert_eq!(listing(tmp.path()), ["out"]);
        assert_eq!(std::fs::read(out.join("a.csv")).unwrap(), b"old");
    }

    #[test]
    fn gated_runs_its_closure() {
        assert_eq!(gated(|| 2 + 2), 4);
    }

    #[test]
    fn stale_staging_of_a_dead_process_is_removed() {
        let tmp = tempfile::tempdir().unwrap();
        // No process has id 4 000 000 000 (Linux pids stay below 2²²).
        let stale = tmp.path().join(format!(".out{STAGING_MARK}4000000000.0"));
        std::fs::create_dir(&stale).unwrap();
        std::fs::write(stale.join("grid.csv"), b"half").unwrap();
        let s = Staged::new(&tmp.path().join("out"), |_| true).unwrap();
        if cfg!(target_os = "linux") {
            assert!(!stale.exists());
        }
        drop(s);
    }
}

/// The crate's README (its crates.io page), compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
