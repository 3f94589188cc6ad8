//! Output helpers shared by the commands: JSON and text on stdout, atomic file writes.

use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// `text` with every control character (ESC, BEL, CR, …; also DEL and the C1 range) written as
/// `\u{XX}`, so input echoed in a message cannot drive the terminal. Newlines are escaped too:
/// an error stays one line.
pub fn escape_controls(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

/// Prints `value` as one pretty JSON document on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    serde_json::to_writer_pretty(&mut lock, value).context("writing JSON to stdout")?;
    writeln!(lock).context("writing JSON to stdout")?;
    Ok(())
}

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, then a rename,
/// so a reader never sees a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    Ok(crashrig_outdir::write_file(path, bytes)?)
}

/// Writes several files into `dir` as one unit: every file goes to a temporary file first, then
/// all are renamed into place in order; if any step fails, the files already renamed are
/// removed again, so a failed run leaves no partial set presented as complete. Put the file
/// that marks completion (e.g. `summary.json`) last.
#[allow(dead_code)] // kept for commands not yet on crashrig-outdir
pub fn write_all_or_none(dir: &Path, files: &[(String, Vec<u8>)]) -> anyhow::Result<()> {
    let mut temps = Vec::with_capacity(files.len());
    for (name, bytes) in files {
        let path = dir.join(name);
        let mut tmp = tempfile::NamedTempFile::new_in(dir)
            .with_context(|| format!("{}: cannot create a temporary file", dir.display()))?;
        tmp.write_all(bytes)
            .with_context(|| format!("{}: write failed", path.display()))?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))
                .with_context(|| format!("{}: cannot set permissions", path.display()))?;
        }
        temps.push((tmp, path));
    }
    let mut done: Vec<std::path::PathBuf> = Vec::with_capacity(temps.len());
    for (tmp, path) in temps {
        if let Err(e) = tmp.persist(&path) {
            for p in &done {
                let _ = std::fs::remove_file(p);
            }
            return Err(anyhow::Error::new(e.error)
                .context(format!("{}: cannot rename into place", path.display())));
        }
        done.push(path);
    }
    Ok(())
}

/// Treats a closed stdout pipe as success (the reader went away), other errors as errors.
pub fn quiet_pipe(r: std::io::Result<()>) -> anyhow::Result<()> {
    match r {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other.context("writing to stdout"),
    }
}

/// Prints what a shard run (`grid`, `measure`, `place` with `--shard i/N`) wrote: with `json`
/// its `shard.json`, else one line.
pub fn print_shard(
    m: &crashrig_outdir::shard::Manifest,
    files: usize,
    out: &Path,
    json: bool,
) -> anyhow::Result<()> {
    if json {
        return print_json(m);
    }
    let print = || -> std::io::Result<()> {
        let mut w = std::io::stdout().lock();
        writeln!(
            w,
            "shard {}: items {}..{} of {} in {:.3} s; wrote {files} files to {} (merge all {} with `crashrig merge`)",
            m.shard,
            m.items.start,
            m.items.end,
            m.items.total,
            m.elapsed_s,
            out.display(),
            m.shard.count()
        )
    };
    quiet_pipe(print())
}

/// Prints each of a library's warnings as one `warning: …` line on stderr.
pub fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Prints a measure run (`crashrig measure`, and `crashrig merge` of measure shards).
pub fn print_measure(
    r: &crashrig_measure::MeasureRun,
    warnings: &[String],
    out: &std::path::Path,
    g: &crate::Global,
) -> anyhow::Result<()> {
    warn_all(warnings);
    let s = &r.summary;
    if g.json {
        return print_json(s);
    }
    println!(
        "measured {} rows ({} epochs × {} markers seen), {} draws each; {:.1} % below {} mm; {} flagged; written to {}",
        s.numbers.rows,
        s.numbers.epochs,
        s.numbers.markers,
        s.numbers.samples_per_point,
        100.0 * s.numbers.fraction_below_threshold,
        s.numbers.threshold_mm,
        s.numbers.rows_flagged,
        out.display()
    );
    if let Some(sync) = &s.numbers.sync_offset {
        println!("{}", sync.line());
    }
    for bar in s.numbers.length_check.iter().flatten() {
        println!("{}", bar.line());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_controls_leaves_text_and_escapes_bytes() {
        assert_eq!(escape_controls("s.toml:3: `σ` ok"), "s.toml:3: `σ` ok");
        assert_eq!(
            escape_controls("name \u{1b}[31mred\u{7}\r\n"),
            "name \\u{1b}[31mred\\u{7}\\u{d}\\u{a}"
        );
        assert_eq!(escape_controls("\u{9b}\u{7f}"), "\\u{9b}\\u{7f}");
    }

    #[test]
    fn write_all_or_none_nominal() {
        let tmp = tempfile::tempdir().unwrap();
        let files = vec![
            ("a.csv".to_string(), b"1".to_vec()),
            ("summary.json".to_string(), b"{}".to_vec()),
        ];
        write_all_or_none(tmp.path(), &files).unwrap();
        assert_eq!(std::fs::read(tmp.path().join("a.csv")).unwrap(), b"1");
        assert_eq!(
            std::fs::read(tmp.path().join("summary.json")).unwrap(),
            b"{}"
        );
    }

    #[test]
    fn write_all_or_none_failure_leaves_nothing() {
        // The last target is a directory, so its rename fails after the first succeeded.
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir(tmp.path().join("summary.json")).unwrap();
        let files = vec![
            ("grid.csv".to_string(), b"x".to_vec()),
            ("summary.json".to_string(), b"{}".to_vec()),
        ];
        let err = write_all_or_none(tmp.path(), &files).unwrap_err();
        assert!(format!("{err:#}").contains("summary.json"), "{err:#}");
        assert!(
            !tmp.path().join("grid.csv").exists(),
            "grid.csv must be removed again"
        );
        let left: Vec<_> = std::fs::read_dir(tmp.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(
            left,
            vec![std::ffi::OsString::from("summary.json")],
            "no temporary files left"
        );
    }
}
