//! `cargo xtask shards N [-P JOBS] [--bin PATH] --out DIR -- [grid|measure|place] <arguments>`:
//! runs the N shards of a `crashrig grid` (the default), `measure` or `place` locally as plain processes with `xargs -P` (the same shard
//! commands a Slurm job array or a Kubernetes Indexed Job runs, `examples/scale/`) into
//! `DIR.shards/1 … N`, then `crashrig merge` into `DIR`. docs/SCALE.md.
//!
//! Only std and anyhow: the contract tests of `crashrig-cli` include this file and run it with
//! the built binary (`crates/cli/tests/contract/shard.rs`), so the verb is tested without a
//! nested cargo.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// What `cargo xtask shards` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Shard count N.
    pub count: usize,
    /// Shards run at the same time (`xargs -P`).
    pub parallel: usize,
    /// The merged output directory; the shards go to `<out>.shards/<i>`.
    pub out: PathBuf,
    /// The command that shards: `grid`, `measure` or `place`.
    pub command: String,
    /// The command's arguments without `--out` and `--shard` (its input first).
    pub grid_args: Vec<String>,
    /// Capture the shards' and the merge's output and the commands run, shown only when one
    /// fails (the tests set it, so a passing test prints nothing); `parse` gives `false`.
    pub quiet: bool,
}

/// The commands that shard (the first argument after `--` names one; default `grid`).
pub const COMMANDS: [&str; 3] = ["grid", "measure", "place"];

/// The usage line.
pub const USAGE: &str =
    "cargo xtask shards N [-P JOBS] [--bin PATH] --out DIR -- [grid|measure|place] INPUT [options]";

/// Parses `N [-P JOBS] [--bin PATH] --out DIR -- <grid args>`; returns the plan and `--bin`.
pub fn parse(args: &[String]) -> Result<(Plan, Option<PathBuf>)> {
    let split = args
        .iter()
        .position(|a| a == "--")
        .with_context(|| format!("missing `--` before the grid arguments; usage: {USAGE}"))?;
    let (own, grid_args) = (&args[..split], &args[split + 1..]);
    let (command, grid_args) = match grid_args.first() {
        Some(c) if COMMANDS.contains(&c.as_str()) => (c.clone(), &grid_args[1..]),
        _ => ("grid".to_string(), grid_args),
    };
    let mut count = None;
    let mut parallel = None;
    let mut out = None;
    let mut bin = None;
    let mut it = own.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| {
            it.next()
                .cloned()
                .with_context(|| format!("{name} needs a value; usage: {USAGE}"))
        };
        match a.as_str() {
            "-P" | "--parallel" => parallel = Some(value("-P")?),
            "--out" => out = Some(PathBuf::from(value("--out")?)),
            "--bin" => bin = Some(PathBuf::from(value("--bin")?)),
            n if count.is_none() && !n.starts_with('-') => count = Some(n.to_string()),
            other => bail!("unexpected `{other}`; usage: {USAGE}"),
        }
    }
    let number = |name: &str, v: &str| -> Result<usize> {
        match v.parse::<usize>() {
            Ok(n) if (1..=1024).contains(&n) => Ok(n),
            _ => bail!("{name}: `{v}` is not a whole number from 1 to 1024"),
        }
    };
    let count = number(
        "N",
        &count.with_context(|| format!("missing N; usage: {USAGE}"))?,
    )?;
    let parallel = match parallel {
        Some(p) => number("-P", &p)?,
        None => count,
    };
    let out = out.with_context(|| format!("missing --out DIR; usage: {USAGE}"))?;
    if grid_args.is_empty() {
        bail!("no {command} arguments after `--`; usage: {USAGE}");
    }
    if let Some(bad) = grid_args.iter().find(|a| {
        *a == "--out" || *a == "--shard" || a.starts_with("--out=") || a.starts_with("--shard=")
    }) {
        bail!("`{bad}` after `--`: the shards' --out and --shard are set by xtask");
    }
    Ok((
        Plan {
            count,
            parallel,
            out,
            command,
            grid_args: grid_args.to_vec(),
            quiet: false,
        },
        bin,
    ))
}

/// The directory of shard `i` of `plan`.
pub fn shard_dir(plan: &Plan, i: usize) -> PathBuf {
    let mut root = plan.out.clone().into_os_string();
    root.push(".shards");
    PathBuf::from(root).join(i.to_string())
}

/// The captured stderr of a failed process (with `quiet`), else `inherited` (it was printed).
fn captured(out: &std::process::Output, inherited: &str) -> String {
    if out.stderr.is_empty() {
        inherited.to_string()
    } else {
        String::from_utf8_lossy(&out.stderr).trim().to_string()
    }
}

/// Runs the N shards with `xargs -P` (one `crashrig <command> … --shard i/N` process per shard),
/// then `crashrig merge`. Returns the shard directories.
pub fn run(plan: &Plan, bin: &Path) -> Result<Vec<PathBuf>> {
    let n = plan.count;
    let dirs: Vec<PathBuf> = (1..=n).map(|i| shard_dir(plan, i)).collect();
    let template = shard_dir(plan, 0).with_file_name("{}");
    let mut xargs = Command::new("xargs");
    xargs
        .args(["-P", &plan.parallel.to_string(), "-I", "{}"])
        .arg(bin)
        .arg(&plan.command)
        .args(&plan.grid_args)
        .arg("--out")
        .arg(&template)
        .args(["--shard", &format!("{{}}/{n}")])
        .stdin(Stdio::piped());
    if plan.quiet {
        xargs.stdout(Stdio::piped()).stderr(Stdio::piped());
    } else {
        eprintln!("xtask shards: {xargs:?} <<< 1..{n}");
    }
    let mut child = xargs.spawn().context("cannot start `xargs` (findutils)")?;
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().context("xargs stdin")?;
        for i in 1..=n {
            writeln!(stdin, "{i}")?;
        }
    }
    let out = child.wait_with_output()?;
    if !out.status.success() {
        bail!(
            "a shard failed (xargs: {}); its error line is {}",
            out.status,
            captured(&out, "above")
        );
    }
    let mut merge = Command::new(bin);
    merge.arg("merge").args(&dirs).arg("--out").arg(&plan.out);
    if plan.grid_args.iter().any(|a| a == "--no-plots") {
        merge.arg("--no-plots");
    }
    let out = if plan.quiet {
        merge.output().context("cannot start crashrig merge")?
    } else {
        eprintln!("xtask shards: {merge:?}");
        let status = merge.status().context("cannot start crashrig merge")?;
        std::process::Output {
            status,
            stdout: Vec::new(),
            stderr: Vec::new(),
        }
    };
    if !out.status.success() {
        bail!(
            "crashrig merge failed ({}): {}",
            out.status,
            captured(&out, "above")
        );
    }
    Ok(dirs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn parse_nominal() {
        let (p, bin) = parse(&args("3 -P 2 --out o -- s.toml --samples 10")).unwrap();
        assert_eq!(p.count, 3);
        assert_eq!(p.parallel, 2);
        assert_eq!(p.out, PathBuf::from("o"));
        assert_eq!(p.grid_args, ["s.toml", "--samples", "10"]);
        assert_eq!(p.command, "grid");
        let (p, _) = parse(&args("2 --out o -- measure seq/model --camera-a a/")).unwrap();
        assert_eq!(
            (p.command.as_str(), &p.grid_args[..]),
            ("measure", &args("seq/model --camera-a a/")[..])
        );
        let (p, _) = parse(&args("2 --out o -- place s.toml --choose 2")).unwrap();
        assert_eq!(p.command, "place");
        assert_eq!(bin, None);
        assert_eq!(shard_dir(&p, 2), PathBuf::from("o.shards/2"));
        let (p, bin) = parse(&args("2 --bin b --out o -- s.toml")).unwrap();
        assert_eq!((p.parallel, bin), (2, Some(PathBuf::from("b"))));
    }

    /// The shell scripts of `examples/scale/` parse (`bash -n`), and the Kubernetes manifests
    /// hold the keys docs/SCALE.md relies on.
    #[test]
    fn scale_examples_are_valid() {
        let here = Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = here
            .ancestors()
            .map(|a| a.join("examples/scale"))
            .find(|d| d.is_dir())
            .expect("examples/scale above the manifest directory");
        for f in ["slurm-grid-array.sh", "slurm-merge.sh", "slurm-submit.sh"] {
            let st = Command::new("bash")
                .arg("-n")
                .arg(dir.join(f))
                .status()
                .unwrap();
            assert!(st.success(), "{f}: bash -n failed");
        }
        let job = std::fs::read_to_string(dir.join("k8s-grid-indexed-job.yaml")).unwrap();
        for key in [
            "completionMode: Indexed",
            "completions: 8",
            "JOB_COMPLETION_INDEX",
            "--shard",
        ] {
            assert!(job.contains(key), "k8s-grid-indexed-job.yaml lacks {key}");
        }
        let merge = std::fs::read_to_string(dir.join("k8s-merge-job.yaml")).unwrap();
        assert!(merge.contains("crashrig merge"));
    }

    #[test]
    fn parse_refusals() {
        for bad in [
            "3 --out o",
            "--out o -- s.toml",
            "0 --out o -- s.toml",
            "3 -- s.toml",
            "3 --out o --",
            "3 --out o -- s.toml --shard 1/2",
            "3 --out o -- s.toml --out x",
            "3 --out o -- measure",
            "3 --out o -- place s.toml --shard 1/3",
            "x --out o -- s.toml",
        ] {
            assert!(parse(&args(bad)).is_err(), "{bad}");
        }
    }
}
