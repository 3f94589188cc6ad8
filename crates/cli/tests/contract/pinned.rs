//! Every output byte pinned to today's main before the issue-23 move of the command logic into
//! the libraries (`crashrig_measure::run`, `crashrig_grid::run_grid`, one heat-map renderer):
//! the commands of `fixtures/gen/pinned_outputs.py`, run by the built binary, must reproduce
//! the FNV-1a hash of every file in `fixtures/pinned/manifest.txt` (written by the release
//! binary of main at 90b8f76; timing lines of JSON left out).

use super::common::root;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

const SEQ: &str = "fixtures/measure/sequence";

/// The runs of the generator, in its order: name, arguments (`OUT`: the output directory).
fn runs() -> Vec<(&'static str, Vec<String>)> {
    let s = |v: &[&str]| v.iter().map(|a| a.replace("SEQ", SEQ)).collect::<Vec<_>>();
    vec![
        (
            "measure",
            s(&[
                "measure",
                "SEQ/model",
                "--camera-a",
                "cam_out/",
                "--camera-b",
                "2",
                "--camera-c",
                "3",
                "--link",
                "SEQ/link.json",
                "--tie",
                "SEQ/tie.json",
                "--observations",
                "SEQ/observations.csv",
                "--a-covariance",
                "SEQ/a_covariance.json",
                "--mm-per-unit",
                "1000",
                "--pixel-sigma-px",
                "0.1",
                "--frame-rate-hz",
                "1000",
                "--samples",
                "300",
                "--seed",
                "4",
                "--out",
                "OUT",
            ]),
        ),
        (
            "grid_fixed",
            s(&[
                "grid",
                "fixtures/scenarios/fixed_three_cameras.toml",
                "--samples",
                "300",
                "--seed",
                "2",
                "--out",
                "OUT",
            ]),
        ),
        (
            "grid_correlated",
            s(&[
                "--json",
                "grid",
                "fixtures/scenarios/three_cameras_correlated.toml",
                "--samples",
                "300",
                "--seed",
                "2",
                "--no-plots",
                "--out",
                "OUT",
            ]),
        ),
        (
            "propagate",
            s(&[
                "--json",
                "propagate",
                "fixtures/scenarios/paper_chain.toml",
                "--samples",
                "2000",
                "--seed",
                "3",
            ]),
        ),
        (
            "study",
            s(&[
                "study",
                "fixtures/study/own/study.toml",
                "--samples",
                "100",
                "--no-sensitivity",
                "--seed",
                "5",
                "--out",
                "OUT",
            ]),
        ),
    ]
}

fn fnv1a64(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// JSON (and stdout) without the lines of timing fields, without the lines of the
/// `"pixel_sigma_check"` object (issue 44 added it to every measure summary with B and C) and
/// without the names of the PLY files added after the pin (issue 46: `grid.ply`,
/// `trajectories.ply`, checked in `view3d.rs`) in a `files` list — every other byte as pinned.
fn normalise(name: &str, data: Vec<u8>) -> Vec<u8> {
    if !(name.ends_with(".json") || name.ends_with("stdout")) {
        return data;
    }
    let timing: [&[u8]; 5] = [
        b"\"elapsed_s\"",
        b"\"samples_per_second\"",
        b"\"threads\"",
        b"\"grid.ply\",",
        b"\"trajectories.ply\",",
    ];
    let check: &[u8] = b"\"pixel_sigma_check\": ";
    let mut depth = 0_i64;
    data.split(|b| *b == b'\n')
        .filter(|l| {
            let opens = l.iter().filter(|&&b| b == b'{' || b == b'[').count() as i64;
            let closes = l.iter().filter(|&&b| b == b'}' || b == b']').count() as i64;
            if depth > 0 {
                depth += opens - closes;
                return false;
            }
            if l.windows(check.len()).any(|w| w == check) {
                depth = opens - closes;
                return false;
            }
            !timing.iter().any(|t| l.windows(t.len()).any(|w| w == *t))
        })
        .collect::<Vec<_>>()
        .join(&b'\n')
}

fn hash_dir(run: &str, dir: &Path, rel: &Path, out: &mut BTreeMap<String, String>) {
    for e in std::fs::read_dir(dir.join(rel)).unwrap() {
        let e = e.unwrap();
        let r = rel.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            hash_dir(run, dir, &r, out);
            continue;
        }
        let name = r.to_string_lossy().replace('\\', "/");
        if run == "study" && !(name.starts_with("grid/") || name.starts_with("measure/")) {
            continue;
        }
        if name.ends_with(".ply") {
            continue;
        }
        let data = normalise(&name, std::fs::read(e.path()).unwrap());
        out.insert(format!("{run}/{name}"), format!("{:016x}", fnv1a64(&data)));
    }
}

#[test]
fn pinned_outputs_are_byte_identical_to_main_before_the_move() {
    let tmp = tempfile::tempdir().unwrap();
    let mut got = BTreeMap::new();
    for (run, args) in runs() {
        let out = tmp.path().join(run);
        let argv: Vec<String> = args
            .iter()
            .map(|a| {
                if a == "OUT" {
                    out.display().to_string()
                } else {
                    a.clone()
                }
            })
            .collect();
        let o = Command::new(env!("CARGO_BIN_EXE_crashrig"))
            .args(&argv)
            .current_dir(root())
            .env_remove("RAYON_NUM_THREADS")
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{run}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        if args.iter().any(|a| a == "OUT") {
            hash_dir(run, &out, Path::new(""), &mut got);
        } else {
            let data = normalise("stdout", o.stdout);
            got.insert(format!("{run}/stdout"), format!("{:016x}", fnv1a64(&data)));
        }
    }
    // CRASHRIG_PINNED_GOT=FILE writes the hashes of this run (to update the manifest after an
    // intended change of an output).
    if let Some(f) = std::env::var_os("CRASHRIG_PINNED_GOT") {
        let text: String = got.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
        std::fs::write(f, text).unwrap();
    }
    let manifest = std::fs::read_to_string(root().join("fixtures/pinned/manifest.txt")).unwrap();
    let want: BTreeMap<String, String> = manifest
        .lines()
        .map(|l| {
            let (k, v) = l.rsplit_once(' ').unwrap();
            (k.to_string(), v.to_string())
        })
        .collect();
    assert_eq!(want.len(), 91, "the manifest lists every pinned file");
    for (k, v) in &want {
        assert_eq!(got.get(k), Some(v), "{k} differs from main before the move");
    }
    assert_eq!(got.len(), want.len(), "extra output files: {got:?}");
}
