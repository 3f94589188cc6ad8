//! The generators: hostile inputs for every command, by class.

use super::harness::{Case, Expect, args};
use std::path::{Path, PathBuf};

/// The repository's fixtures.
fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(rel)
}

/// All files of a fixture directory (relative to it), sorted.
fn files_of(rel: &str) -> Vec<(String, Vec<u8>)> {
    let dir = fixture(rel);
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// Files of a case: (relative path, bytes).
type Files = Vec<(String, Vec<u8>)>;

/// SplitMix64: a tiny seeded generator for bit flips (no dependency needed).
struct Mix(u64);
impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// The base scenario: a two-camera chain (for `propagate`) and a small grid (for `grid`).
pub const BASE: &str = r#"seed = 3
samples = 40
rotation_noise = "tangent"

[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]

[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [61.98, -1.71, 179.76]
angles_deg = [179.92, -0.09, 179.76]
sigma_position_mm = [0.19, 0.26, 0.13]
sigma_angles_deg = [0.004, 0.005, 0.008]

[grid]
x_mm = [400.0, 800.0, 3]
y_mm = [-200.0, 200.0, 2]
z_mm = [0.0, 0.0, 1]
threshold_mm = 5.0

[[grid.observer]]
name = "rear"
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]

[[grid.observer]]
name = "door"
position_mm = [1300.0, -700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

/// `propagate` and `grid` on scenario `text` (named `name`), both expected to do `expect`.
fn scenario_cases(
    class: &'static str,
    name: &str,
    text: &[u8],
    expect: impl Fn(&str) -> Expect,
) -> Vec<Case> {
    let path = format!("{{in}}/{name}");
    let inputs = vec![(name.to_string(), text.to_vec())];
    vec![
        Case {
            class,
            inputs: inputs.clone(),
            old_out: vec![],
            args: args(&["propagate", &path, "--json"]),
            env: vec![],
            expect: expect("propagate"),
        },
        Case {
            class,
            inputs,
            old_out: vec![],
            args: args(&["grid", &path, "--out", "{out}", "--no-plots"]),
            env: vec![],
            expect: expect("grid"),
        },
    ]
}

fn err(needles: &[&str]) -> Expect {
    Expect::Error(needles.iter().map(|s| s.to_string()).collect())
}

/// Byte offsets and lengths of the numbers of `text` (values after `=`, outside strings).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut v = Vec::new();
    let mut i = 0;
    let mut in_value = false;
    let mut in_str = false;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            in_value = false;
        } else if c == b'"' {
            in_str = !in_str;
        } else if c == b'=' && !in_str {
            in_value = true;
        } else if in_value && !in_str && (c == b'-' || c.is_ascii_digit()) {
            let start = i;
            while i < b.len() && (b[i] == b'-' || b[i] == b'.' || b[i].is_ascii_digit()) {
                i += 1;
            }
            v.push((start, i - start));
            continue;
        }
        i += 1;
    }
    v
}

/// Hostile scenario files: wrong lengths, huge counts, extreme and non-finite values, control
/// bytes, non-UTF-8, truncation, deep nesting, degenerate geometry, gimbal lock.
pub fn scenarios() -> Vec<Case> {
    let mut out = Vec::new();
    // Wrong-length arrays at every 3-vector and axis.
    let vec_lines: Vec<(usize, &str)> = BASE
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains("= ["))
        .collect();
    for (ln, line) in &vec_lines {
        let key = line.split('=').next().unwrap().trim();
        for n in [0usize, 1, 2, 4, 5] {
            let items: Vec<String> = (0..n).map(|i| format!("{}.0", i + 1)).collect();
            let new_line = format!("{key} = [{}]", items.join(", "));
            let text: String = BASE
                .lines()
                .enumerate()
                .map(|(i, l)| {
                    if i == *ln {
                        new_line.clone()
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n");
            let line_no = format!("s.toml:{}:", ln + 1);
            out.extend(scenario_cases(
                "wrong-length array",
                "s.toml",
                text.as_bytes(),
                |_| err(&[&line_no, key]),
            ));
        }
    }
    // Huge and invalid counts.
    for v in [
        "10000001",
        "1000000000000000",
        "18446744073709551615",
        "4611686018427387904",
        "9223372036854775807",
        "0",
        "1",
        "-1",
    ] {
        let text = BASE.replacen("samples = 40", &format!("samples = {v}"), 1);
        out.extend(scenario_cases(
            "huge count",
            "s.toml",
            text.as_bytes(),
            |_| err(&["s.toml:2", "samples"]),
        ));
    }
    for (axis, line) in [
        ("x_mm = [400.0, 800.0, 3]", 21),
        ("y_mm = [-200.0, 200.0, 2]", 22),
        ("z_mm = [0.0, 0.0, 1]", 23),
    ] {
        let key = &axis[..4];
        let head = axis.rsplit_once(',').unwrap().0;
        for c in [
            "10001",
            "1000000000",
            "4611686018427387904",
            "0",
            "-5",
            "1.5",
        ] {
            let text = BASE.replacen(axis, &format!("{head}, {c}]"), 1);
            let l = format!("s.toml:{line}");
            out.extend(scenario_cases(
                "huge count",
                "s.toml",
                text.as_bytes(),
                |_| err(&[&l, key]),
            ));
        }
    }
    let big_grid = BASE
        .replacen(
            "x_mm = [400.0, 800.0, 3]",
            "x_mm = [400.0, 800.0, 10000]",
            1,
        )
        .replacen(
            "y_mm = [-200.0, 200.0, 2]",
            "y_mm = [-200.0, 200.0, 10000]",
            1,
        );
    out.extend(scenario_cases(
        "huge count",
        "s.toml",
        big_grid.as_bytes(),
        |_| err(&["s.toml:20", "grid points exceed"]),
    ));
    for (extra, needle) in [
        (
            "[grid.adaptive]\ntolerance_mm = 1e-12\nmax_samples = 1000\n",
            "tolerance_mm",
        ),
        (
            "[grid.adaptive]\ntolerance_mm = 0.01\nmax_samples = 1000000000000000\n",
            "max_samples",
        ),
        (
            "[grid.adaptive]\ntolerance_mm = 0.01\nbatch = 1000000000000\n",
            "batch",
        ),
    ] {
        let text = BASE.replacen(
            "threshold_mm = 5.0\n",
            &format!("threshold_mm = 5.0\n{extra}"),
            1,
        );
        out.extend(scenario_cases(
            "huge count",
            "s.toml",
            text.as_bytes(),
            |_| err(&["s.toml:", needle]),
        ));
    }
    // Extreme and non-finite values at every number.
    for (start, len) in numbers(BASE) {
        for v in ["1e300", "-1e308", "1e308", "nan", "inf", "-inf"] {
            let text = format!("{}{v}{}", &BASE[..start], &BASE[start + len..]);
            let line = format!("s.toml:{}", BASE[..start].matches('\n').count() + 1);
            out.extend(scenario_cases(
                "extreme value",
                "s.toml",
                text.as_bytes(),
                |_| err(&[&line]),
            ));
        }
    }
    // Control bytes in names, unknown references, and in the file name itself.
    for (i, bad) in [
        "\\u001b[31mred\\u0007",
        "\\u001b]0;title\\u0007",
        "a\\u009bb",
        "\\r\\u001b[2K",
    ]
    .iter()
    .enumerate()
    {
        let text = BASE.replacen("parent = \"cam1\"", &format!("parent = \"{bad}\""), 1);
        out.extend(scenario_cases(
            "control bytes",
            "s.toml",
            text.as_bytes(),
            |c| {
                if c == "propagate" {
                    err(&["s.toml:14", "unknown camera"])
                } else {
                    err(&["s.toml:14"])
                }
            },
        ));
        let name = format!("s{}\u{1b}[2J{i}.toml", ["", "\u{7}", "\u{9b}", "\r"][i]);
        let text = BASE.replacen("samples = 40", "samples = -3", 1);
        out.extend(scenario_cases(
            "control bytes",
            &name,
            text.as_bytes(),
            |_| err(&["\\u{1b}[2J", "samples"]),
        ));
    }
    // Non-UTF-8 bytes at several places.
    for at in (0..BASE.len()).step_by(97) {
        let mut bytes = BASE.as_bytes().to_vec();
        bytes.insert(at, 0xff);
        let line = format!("s.toml:{}:", BASE[..at].matches('\n').count() + 1);
        out.extend(scenario_cases("non-UTF-8", "s.toml", &bytes, |_| {
            err(&[&line, "UTF-8"])
        }));
    }
    // Truncation at every 11th byte: valid or a clean located error.
    for cut in (1..BASE.len()).step_by(11) {
        out.extend(scenario_cases(
            "truncated scenario",
            "s.toml",
            &BASE.as_bytes()[..cut],
            |_| Expect::Either("s.toml".into()),
        ));
    }
    // Deep nesting (the parser's recursion limit) must still give a line.
    for depth in [40usize, 200, 5000] {
        let text = format!(
            "{BASE}extra = {}1{}\n",
            "[".repeat(depth),
            "]".repeat(depth)
        );
        out.extend(scenario_cases(
            "deep nesting",
            "s.toml",
            text.as_bytes(),
            |_| err(&["s.toml:37:"]),
        ));
    }
    // Degenerate geometry: every point degenerate is an error (grid); gimbal-lock input is valid (propagate).
    for (what, pos) in [
        ("coincident", "200.0, 0.0, 0.0"),
        ("1e-6 mm apart", "200.000001, 0.0, 0.0"),
    ] {
        let _ = what;
        let text = BASE.replacen("1300.0, -700.0, 0.0", pos, 1);
        out.push(Case {
            class: "degenerate geometry",
            inputs: vec![("s.toml".into(), text.into_bytes())],
            old_out: vec![],
            args: args(&["grid", "{in}/s.toml", "--out", "{out}", "--no-plots"]),
            env: vec![],
            expect: err(&["s.toml:", "intersection angle"]),
        });
    }
    // Parallel lines of sight: grid on the x axis, both observers on it too.
    let parallel = BASE
        .replacen("y_mm = [-200.0, 200.0, 2]", "y_mm = [0.0, 0.0, 1]", 1)
        .replacen("1300.0, -700.0, 0.0", "100.0, 0.0, 0.0", 1);
    out.push(Case {
        class: "degenerate geometry",
        inputs: vec![("s.toml".into(), parallel.into_bytes())],
        old_out: vec![],
        args: args(&["grid", "{in}/s.toml", "--out", "{out}", "--no-plots"]),
        env: vec![],
        expect: err(&["s.toml:", "intersection angle"]),
    });
    // Some points degenerate: they are flagged, blanked and left out of the median.
    let mixed = BASE
        .replacen("x_mm = [400.0, 800.0, 3]", "x_mm = [0.0, 2000.0, 21]", 1)
        .replacen("y_mm = [-200.0, 200.0, 2]", "y_mm = [-700.0, 700.0, 15]", 1)
        .replacen("200.0, 0.0, 0.0", "2200.0, 0.0, 0.0", 1)
        .replacen("1300.0, -700.0, 0.0", "1000.0, 800.0, 0.0", 1);
    out.push(Case {
        class: "degenerate geometry",
        inputs: vec![("s.toml".into(), mixed.into_bytes())],
        old_out: vec![],
        args: args(&["grid", "{in}/s.toml", "--out", "{out}", "--no-plots"]),
        env: vec![],
        expect: Expect::Ok(check_mixed_degenerate),
    });
    let gimbal = BASE.replacen(
        "angles_deg = [0.0, 0.0, 0.0]",
        "angles_deg = [0.0, 90.0, 0.0]",
        1,
    );
    out.push(Case {
        class: "degenerate geometry",
        inputs: vec![("s.toml".into(), gimbal.into_bytes())],
        old_out: vec![],
        args: args(&["propagate", "{in}/s.toml"]),
        env: vec![],
        // Any ω φ κ input is a valid rotation (issue 10 item 8): φ = 90° propagates, with a
        // warning that the output ω φ κ σ are undefined there.
        expect: Expect::Ok(|_| Ok(())),
    });
    out
}

/// The interface example's layout has three grid points on the line through both observers.
fn check_mixed_degenerate(out: &Path) -> Result<(), String> {
    let csv = std::fs::read_to_string(out.join("grid.csv")).map_err(|e| e.to_string())?;
    let mut lines = csv.lines();
    let header = lines.next().unwrap_or("");
    if !header.ends_with(",sigma_max_mm,intersection_angle_deg,degenerate") {
        return Err(format!("header {header}"));
    }
    let flagged: Vec<&str> = lines.filter(|l| l.ends_with(",true")).collect();
    if flagged.len() != 3 || !flagged.iter().all(|l| l.contains(",,,,")) {
        return Err(format!(
            "expected 3 blanked degenerate rows, got {flagged:?}"
        ));
    }
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
            .map_err(|e| e.to_string())?;
    let med = s["median_sigma_max_mm"].as_f64().unwrap_or(f64::NAN);
    let max = s["max_sigma_mm"].as_f64().unwrap_or(f64::NAN);
    if !(med > 0.5 && med < 10.0 && max < 100.0) || s["degenerate_points"] != 3 {
        return Err(format!("median {med}, max {max}, summary {s}"));
    }
    Ok(())
}

/// Truncated and bit-flipped COLMAP models, through `colmap info`, `colmap convert` and
/// `calibrate`.
pub fn models() -> Vec<Case> {
    let mut out = Vec::new();
    let mut rng = Mix(13);
    for (k, model) in [
        "colmap/simple_radial/bin",
        "colmap/rig_opencv/bin",
        "colmap/simple_radial/txt",
        "colmap/rig_opencv/txt",
        "rig/paper",
    ]
    .iter()
    .enumerate()
    {
        let files = files_of(model);
        let model_files: Vec<usize> = (0..files.len())
            .filter(|&i| files[i].0.ends_with(".bin") || files[i].0.ends_with(".txt"))
            .collect();
        let mut variants: Vec<(&'static str, Files)> = Vec::new();
        for &i in &model_files {
            let len = files[i].1.len();
            for num in [0usize, 1, 2, 3, 5, 7, 9, 11, 13, 15] {
                let cut = len * num / 16;
                let mut f = files.clone();
                f[i].1.truncate(cut);
                variants.push(("truncated model", f));
            }
            for _ in 0..6 {
                let mut f = files.clone();
                if len == 0 {
                    continue;
                }
                for _ in 0..1 + rng.next() % 3 {
                    let at = (rng.next() % len as u64) as usize;
                    f[i].1[at] ^= 1 << (rng.next() % 8);
                }
                variants.push(("bit-flipped model", f));
            }
        }
        for (j, (class, f)) in variants.into_iter().enumerate() {
            let inputs: Vec<(String, Vec<u8>)> = f
                .into_iter()
                .map(|(n, b)| (format!("model/{n}"), b))
                .collect();
            let cmd: Vec<&str> = if *model == "rig/paper" {
                vec![
                    "calibrate",
                    "{in}/model",
                    "--camera-a",
                    "cam_out/",
                    "--camera-b",
                    "cam_in/",
                    "--mm-per-unit",
                    "1",
                    "--json",
                ]
            } else {
                match (j + k) % 3 {
                    0 => vec!["colmap", "info", "{in}/model", "--json"],
                    1 => vec!["colmap", "convert", "{in}/model", "{out}", "--to", "txt"],
                    _ => vec!["colmap", "convert", "{in}/model", "{out}", "--to", "bin"],
                }
            };
            out.push(Case {
                class,
                inputs,
                old_out: vec![],
                args: args(&cmd),
                env: vec![],
                expect: Expect::Either("{in}/model".into()),
            });
        }
    }
    out
}

/// Truncated and bit-flipped databases through `colmap info` and `bootstrap`.
pub fn databases() -> Vec<Case> {
    let mut out = Vec::new();
    let mut rng = Mix(7);
    let twoview_model = files_of("paper/twoview/model");
    for db in ["colmap/rig_opencv/database.db", "paper/twoview/database.db"] {
        let bytes = std::fs::read(fixture(db)).unwrap();
        let mut variants: Vec<(&'static str, Vec<u8>)> = Vec::new();
        for num in [0usize, 1, 2, 4, 8, 12, 16, 20, 24, 28, 31] {
            let mut b = bytes.clone();
            b.truncate(bytes.len() * num / 32);
            variants.push(("truncated database", b));
        }
        for _ in 0..24 {
            let mut b = bytes.clone();
            for _ in 0..1 + rng.next() % 4 {
                let at = (rng.next() % b.len() as u64) as usize;
                b[at] ^= 1 << (rng.next() % 8);
            }
            variants.push(("bit-flipped database", b));
        }
        for (j, (class, b)) in variants.into_iter().enumerate() {
            let mut inputs = vec![("database.db".to_string(), b)];
            let boot = db.starts_with("paper") && j % 2 == 1;
            let cmd: Vec<&str> = if boot {
                inputs.extend(
                    twoview_model
                        .iter()
                        .map(|(n, b)| (format!("model/{n}"), b.clone())),
                );
                vec![
                    "bootstrap",
                    "{in}/database.db",
                    "--model",
                    "{in}/model",
                    "--image-a",
                    "cam_in/000001.png",
                    "--image-b",
                    "cam_door/000001.png",
                    "--iterations",
                    "20",
                    "--mm-per-unit",
                    "1000",
                    "--json",
                ]
            } else {
                vec!["colmap", "info", "{in}/database.db", "--json"]
            };
            out.push(Case {
                class,
                inputs,
                old_out: vec![],
                args: args(&cmd),
                env: vec![],
                expect: Expect::Either("{in}/".into()),
            });
        }
    }
    out
}

/// Huge and invalid command-line values: each error names the option (or variable).
pub fn arguments() -> Vec<Case> {
    let mut out = Vec::new();
    let scen = vec![("s.toml".to_string(), BASE.as_bytes().to_vec())];
    let model = files_of("paper/twoview/model");
    let mut boot_inputs = vec![(
        "database.db".to_string(),
        std::fs::read(fixture("paper/twoview/database.db")).unwrap(),
    )];
    boot_inputs.extend(model.iter().map(|(n, b)| (format!("model/{n}"), b.clone())));
    let boot = |extra: &[&str]| {
        let mut v = vec![
            "bootstrap",
            "{in}/database.db",
            "--model",
            "{in}/model",
            "--image-a",
            "cam_in/000001.png",
            "--image-b",
            "cam_door/000001.png",
        ];
        v.extend_from_slice(extra);
        args(&v)
    };
    let rig: Vec<(String, Vec<u8>)> = files_of("rig/paper")
        .into_iter()
        .map(|(n, b)| (format!("model/{n}"), b))
        .collect();
    let mut push = |inputs: &Vec<(String, Vec<u8>)>,
                    a: Vec<std::ffi::OsString>,
                    env: Vec<(String, String)>,
                    needle: &str| {
        // clap reports a negative number as an unexpected argument, naming the value.
        let value = a.last().and_then(|l| l.to_str()).unwrap_or("").to_string();
        let negative = value.len() > 1
            && value.starts_with('-')
            && value.as_bytes()[1].is_ascii_digit()
            && needle.starts_with("--");
        let needle = if negative { value.as_str() } else { needle };
        out.push(Case {
            class: "huge argument",
            inputs: inputs.clone(),
            old_out: vec![],
            args: a,
            env,
            expect: err(&[needle]),
        });
    };
    for v in [
        "1000000000000000",
        "18446744073709551615",
        "4611686018427387904",
        "10000001",
        "1",
        "-1",
    ] {
        push(
            &scen,
            args(&["propagate", "{in}/s.toml", "--samples", v]),
            vec![],
            "--samples",
        );
        push(
            &scen,
            args(&["grid", "{in}/s.toml", "--out", "{out}", "--samples", v]),
            vec![],
            "--samples",
        );
    }
    for v in [
        "1000000000000",
        "18446744073709551615",
        "1000001",
        "0",
        "1",
        "-3",
        "1e3",
    ] {
        push(
            &boot_inputs,
            boot(&["--iterations", v]),
            vec![],
            "--iterations",
        );
    }
    for v in ["1e308", "inf", "nan", "-1", "0", "1e-300"] {
        push(
            &boot_inputs,
            boot(&["--mm-per-unit", v]),
            vec![],
            "--mm-per-unit",
        );
        push(
            &rig,
            args(&[
                "calibrate",
                "{in}/model",
                "--camera-a",
                "cam_out/",
                "--camera-b",
                "cam_in/",
                "--mm-per-unit",
                v,
            ]),
            vec![],
            "--mm-per-unit",
        );
    }
    for v in ["100000", "0", "18446744073709551616", "1025"] {
        push(
            &scen,
            args(&["--threads", v, "propagate", "{in}/s.toml"]),
            vec![],
            "--threads",
        );
        push(
            &scen,
            args(&["grid", "{in}/s.toml", "--out", "{out}", "--threads", v]),
            vec![],
            "--threads",
        );
    }
    for v in ["100000", "1000000000000000000000000", "1025"] {
        let env = vec![("RAYON_NUM_THREADS".to_string(), v.to_string())];
        push(
            &scen,
            args(&["propagate", "{in}/s.toml"]),
            env.clone(),
            "RAYON_NUM_THREADS",
        );
        push(
            &scen,
            args(&["grid", "{in}/s.toml", "--out", "{out}"]),
            env,
            "RAYON_NUM_THREADS",
        );
    }
    out
}

/// Interrupted writes at deterministic points (the `CRASHRIG_OUTDIR_FAULT` hook) over an
/// older result holding a stale file.
pub fn interruptions() -> Vec<Case> {
    let mut out = Vec::new();
    let scen = vec![("s.toml".to_string(), BASE.as_bytes().to_vec())];
    let old_grid = vec![
        ("grid.csv".to_string(), b"old".to_vec()),
        ("summary.json".to_string(), b"{\"old\": true}".to_vec()),
        (
            "sigma_max_z07_999mm_stale.png".to_string(),
            b"stale".to_vec(),
        ),
    ];
    // grid writes 2 CSVs, 6 heat maps (one z level) and summary.json: 9 files.
    let mut points: Vec<String> = (1..=9).map(|k| format!("after-file:{k}")).collect();
    points.push("before-swap".into());
    for p in &points {
        for sigint in [false, true] {
            let spec = format!("{}-{p}", if sigint { "sigint" } else { "abort" });
            out.push(Case {
                class: "interrupted write",
                inputs: scen.clone(),
                old_out: old_grid.clone(),
                args: args(&["grid", "{in}/s.toml", "--out", "{out}"]),
                env: vec![("CRASHRIG_OUTDIR_FAULT".into(), spec)],
                expect: Expect::Interrupted { sigint },
            });
        }
    }
    let model: Vec<(String, Vec<u8>)> = files_of("colmap/rig_opencv/bin")
        .into_iter()
        .map(|(n, b)| (format!("model/{n}"), b))
        .collect();
    // An older model of another rig in OUT: none of its files may survive beside the new one.
    let old_model: Vec<(String, Vec<u8>)> = files_of("colmap/simple_radial/bin")
        .into_iter()
        .filter(|(n, _)| n.ends_with(".bin"))
        .collect();
    for to in ["txt", "bin"] {
        for sigint in [false, true] {
            let spec = format!("{}-before-swap", if sigint { "sigint" } else { "abort" });
            out.push(Case {
                class: "interrupted write",
                inputs: model.clone(),
                old_out: old_model.clone(),
                args: args(&["colmap", "convert", "{in}/model", "{out}", "--to", to]),
                env: vec![("CRASHRIG_OUTDIR_FAULT".into(), spec)],
                expect: Expect::Interrupted { sigint },
            });
        }
    }
    out
}
