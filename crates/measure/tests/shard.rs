//! `measure --shard i/N` and its merge: the merged directory is the unsharded run's, byte for
//! byte (every CSV and plot; `summary.json` except `elapsed_s`), for N = 1, 2, 3 and N above
//! the number of markers, with velocities, with `--cfc` and a trigger offset, with A's poses
//! drawn jointly, and with scale bars (`length_check.csv`, `summary.json`'s `length_check`);
//! and the merge refuses missing, repeated and foreign shards, naming them, without writing
//! anything.

use crashrig_input::options::Spelling;
use crashrig_measure::{MeasureOptions, OutputDir, shard};
use crashrig_outdir::shard::{Shard, read_set};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence")
}

/// The bundled sequence (51 epochs, 8 markers, cameras B and C) with 300 replicates (two
/// blocks of the streams, the second one short).
fn options() -> MeasureOptions {
    let f = fixture();
    MeasureOptions {
        camera_c: Some("3".into()),
        tie: Some(f.join("tie.json")),
        mm_per_unit: Some(1000.0),
        sigma_a_position_mm: Some([0.3, 0.4, 0.5]),
        sigma_a_angles_deg: Some([0.01, 0.02, 0.01]),
        samples: 300,
        seed: Some(11),
        frame_rate_hz: Some(1000.0),
        ..MeasureOptions::new(
            f.join("model"),
            "cam_out/",
            "2",
            f.join("link.json"),
            f.join("observations.csv"),
        )
    }
}

/// Every file under `dir` (relative path → bytes).
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

fn summary_without_time(bytes: &[u8]) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(bytes).unwrap();
    let t = v.as_object_mut().unwrap().remove("elapsed_s");
    assert!(t.is_some_and(|t| t.as_f64().is_some_and(|t| t >= 0.0)));
    v
}

/// Runs `o` whole into `tmp/whole` and in `n` shards merged into `tmp/merged<n>`, and
/// checks that the two directories hold the same files, byte for byte.
fn assert_merge_is_whole(o: &MeasureOptions, ns: &[usize], plots: bool, expect: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    let whole_dir = tmp.path().join("whole");
    let whole = MeasureOptions {
        out: Some(OutputDir {
            dir: whole_dir.clone(),
            plots,
        }),
        ..o.clone()
    };
    let markers = crashrig_measure::run(&whole.config(Spelling::Flag).unwrap(), None)
        .unwrap()
        .measurement
        .markers
        .len();
    let want = files(&whole_dir);
    for f in ["displacements.csv", "trajectories.csv"]
        .iter()
        .chain(expect)
    {
        assert!(want.contains_key(Path::new(f)), "{f}");
    }
    let summary = String::from_utf8(want[Path::new("summary.json")].clone()).unwrap();
    assert_eq!(
        o.sync_sigma_ms > 0.0,
        summary.contains("\"sync_offset\": {"),
        "{summary}"
    );
    for &n in ns {
        let dirs: Vec<PathBuf> = (1..=n)
            .map(|i| tmp.path().join(format!("n{n}/s{i}")))
            .collect();
        // Shards in reverse order: the order of the runs does not matter.
        for (i, dir) in dirs.iter().enumerate().rev() {
            let r = shard::run(o, Shard::new(i + 1, n).unwrap(), dir, None).unwrap();
            assert_eq!(r.manifest.items.total, markers);
        }
        let merged_dir = tmp.path().join(format!("merged{n}"));
        let mut given = dirs.clone();
        given.rotate_left(n / 2);
        shard::merge(&read_set(&given).unwrap(), &merged_dir, plots, None).unwrap();
        let got = files(&merged_dir);
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            want.keys().collect::<Vec<_>>(),
            "N = {n}"
        );
        for (name, bytes) in &want {
            if name == Path::new("summary.json") {
                assert_eq!(
                    summary_without_time(&got[name]),
                    summary_without_time(bytes),
                    "N = {n}"
                );
            } else {
                assert!(got[name] == *bytes, "N = {n}: {} differs", name.display());
            }
        }
    }
}

#[test]
fn merged_shards_are_the_unsharded_run_with_velocities_and_plots() {
    assert_merge_is_whole(&options(), &[1, 2, 3], true, &["plots/head_l.png"]);
}

#[test]
fn more_shards_than_markers_leave_some_empty_and_still_merge() {
    assert_merge_is_whole(&options(), &[11], false, &[]);
}

#[test]
fn merged_shards_are_the_unsharded_run_with_kinematics_and_a_trigger_offset() {
    let o = MeasureOptions {
        cfc: Some(180),
        sync_sigma_ms: 0.5,
        reference_epoch: Some("000005".into()),
        ..options()
    };
    assert_merge_is_whole(&o, &[2, 3], true, &["kinematics.csv"]);
}

/// The bundled sequence with its three scale bars (14 markers: the eight and two per bar).
fn with_scale_bars() -> MeasureOptions {
    let f = fixture();
    MeasureOptions {
        observations: f.join("observations_scale_bars.csv"),
        scale_bars: Some(f.join("scale_bars.csv")),
        mpe_mm: Some(1.0),
        ..options()
    }
}

#[test]
fn merged_shards_are_the_unsharded_run_with_scale_bars() {
    // N = 2: the bars split 1 + 2, and bar 1's markers (sorted: bar_door_* before bar_roof_*,
    // bar_seat_*) are owned by shard 1 while shard 2 owns bar_roof; N = 5: two shards without
    // a bar, and bars whose markers another shard owns.
    assert_merge_is_whole(
        &with_scale_bars(),
        &[2, 5],
        true,
        &["length_check.csv", "length_check.png", "length_check.svg"],
    );
}

#[test]
fn merged_shards_are_the_unsharded_run_with_scale_bars_kinematics_and_an_offset() {
    // The run without the offset (pass 1) has no scale bars: the shards' moments say so.
    let o = MeasureOptions {
        cfc: Some(180),
        sync_sigma_ms: 0.5,
        ..with_scale_bars()
    };
    assert_merge_is_whole(&o, &[3], false, &["length_check.csv", "kinematics.csv"]);
}

#[test]
fn merged_shards_are_the_unsharded_run_with_a_joints_draws() {
    // A's poses of every epoch drawn jointly: AR(1) correlation 0.7^|i−j| between the 51
    // epochs, 0.3 mm and 0.01° per axis.
    let tmp = tempfile::tempdir().unwrap();
    let n = 51;
    let epochs: Vec<String> = (1..=n).map(|i| format!("{i:06}")).collect();
    let cov: Vec<Vec<f64>> = (0..6 * n)
        .map(|a| {
            (0..6 * n)
                .map(|b| {
                    let s2 = if a % 6 < 3 { 0.09 } else { 1e-4 };
                    let rho = 0.7_f64.powi((a / 6_usize).abs_diff(b / 6) as i32);
                    if a % 6 == b % 6 { rho * s2 } else { 0.0 }
                })
                .collect()
        })
        .collect();
    let path = tmp.path().join("joint.json");
    let doc = serde_json::json!({
        "mm_per_unit": 1000.0,
        "covariance_tangent": cov[..6].iter().map(|r| &r[..6]).collect::<Vec<_>>(),
        "joint": {"epochs": epochs, "covariance_tangent": cov},
    });
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let o = MeasureOptions {
        sigma_a_position_mm: None,
        sigma_a_angles_deg: None,
        a_covariance: Some(path),
        mm_per_unit: None,
        ..options()
    };
    assert_merge_is_whole(&o, &[3], false, &[]);
}

/// Three shards of `o` in `tmp/s1..3`.
fn three_shards(o: &MeasureOptions, tmp: &Path) -> Vec<PathBuf> {
    (1..=3)
        .map(|i| {
            let dir = tmp.join(format!("s{i}"));
            shard::run(o, Shard::new(i, 3).unwrap(), &dir, None).unwrap();
            dir
        })
        .collect()
}

fn refusal(dirs: &[PathBuf], out: &Path) -> String {
    let e = match read_set(dirs) {
        Err(e) => crashrig_input::message::error_line(&e),
        Ok(set) => {
            crashrig_input::message::error_line(&shard::merge(&set, out, false, None).unwrap_err())
        }
    };
    assert!(!out.exists(), "{e}: wrote {}", out.display());
    e
}

#[test]
fn merge_refuses_missing_repeated_and_foreign_shards_naming_them() {
    let tmp = tempfile::tempdir().unwrap();
    let o = MeasureOptions {
        samples: 20,
        ..options()
    };
    let dirs = three_shards(&o, tmp.path());
    let out = tmp.path().join("out");
    // Missing.
    let e = refusal(&dirs[..2], &out);
    assert!(e.contains("missing shard(s) 3/3"), "{e}");
    // Repeated.
    let e = refusal(&[dirs[0].clone(), dirs[1].clone(), dirs[1].clone()], &out);
    assert!(e.contains("given twice"), "{e}");
    // Foreign: another seed, another sample count, another N, another option.
    let foreign = |o: MeasureOptions, shard: Shard, what: &str| {
        let dir = tmp.path().join(format!("foreign{}", what.len()));
        shard::run(&o, shard, &dir, None).unwrap();
        let mut set = dirs.clone();
        set[shard.index() - 1] = dir.clone();
        if shard.count() != 3 {
            set.truncate(shard.count());
        }
        let e = refusal(&set, &out);
        assert!(e.contains("a shard of another run"), "{what}: {e}");
        assert!(e.contains(&*dir.to_string_lossy()), "{what}: {e}");
        assert!(e.contains(&format!("its {what} is")), "{what}: {e}");
    };
    let s2 = Shard::new(2, 3).unwrap();
    foreign(
        MeasureOptions {
            seed: Some(12),
            ..o.clone()
        },
        s2,
        "seed",
    );
    foreign(
        MeasureOptions {
            samples: 21,
            ..o.clone()
        },
        s2,
        "samples",
    );
    foreign(o.clone(), Shard::new(2, 2).unwrap(), "shard count N");
    let other = MeasureOptions {
        pixel_sigma_px: 0.25,
        ..o.clone()
    };
    foreign(other, s2, "input fingerprint");
    // The inputs changed since the shards ran: the observations file, copied and edited.
    let obs = tmp.path().join("observations.csv");
    std::fs::copy(fixture().join("observations.csv"), &obs).unwrap();
    let o2 = MeasureOptions {
        observations: obs.clone(),
        ..o.clone()
    };
    let dirs2: Vec<PathBuf> = (1..=2)
        .map(|i| {
            let dir = tmp.path().join(format!("t{i}"));
            shard::run(&o2, Shard::new(i, 2).unwrap(), &dir, None).unwrap();
            dir
        })
        .collect();
    let text = std::fs::read_to_string(&obs).unwrap();
    std::fs::write(
        &obs,
        text.replacen("000001,B,head_l,1132.97", "000001,B,head_l,1132.96", 1),
    )
    .unwrap();
    let e = refusal(&dirs2, &out);
    assert!(e.contains("t1") && e.contains("measure_shard.json"), "{e}");
    assert!(e.contains("rerun the shards"), "{e}");
    // A truncated moments file: its path and line.
    let moments = dirs[1].join(shard::MOMENTS);
    let text = std::fs::read_to_string(&moments).unwrap();
    let cut = text.lines().take(3).collect::<Vec<_>>().join("\n") + "\n0,row,1,";
    std::fs::write(&moments, cut).unwrap();
    let e = refusal(&dirs, &out);
    assert!(e.contains(&format!("{}:4", moments.display())), "{e}");
    // Missing rows (a line removed): the merge names what no shard holds.
    std::fs::write(
        &moments,
        text.lines().take(3).collect::<Vec<_>>().join("\n") + "\n",
    )
    .unwrap();
    let e = refusal(&dirs, &out);
    assert!(e.contains("no shard holds the moments"), "{e}");
    // A row of another shard's marker: its line.
    let row_of_shard_1 = std::fs::read_to_string(dirs[0].join(shard::MOMENTS))
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .to_string();
    std::fs::write(&moments, format!("{text}{row_of_shard_1}\n")).unwrap();
    let e = refusal(&dirs, &out);
    assert!(e.contains("is not one of this shard's markers"), "{e}");
    // A directory that is no shard.
    let e = refusal(&[tmp.path().join("nothing")], &out);
    assert!(e.contains("nothing"), "{e}");
}

#[test]
fn a_shard_replaces_its_previous_directory_but_no_other() {
    let tmp = tempfile::tempdir().unwrap();
    let o = MeasureOptions {
        samples: 20,
        ..options()
    };
    let dir = tmp.path().join("s");
    let s = Shard::new(1, 2).unwrap();
    shard::run(&o, s, &dir, None).unwrap();
    shard::run(&o, s, &dir, None).unwrap();
    let other = tmp.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("notes.txt"), b"mine").unwrap();
    let e = shard::run(&o, s, &other, None).unwrap_err().to_string();
    assert!(e.contains("not a previous `measure` output"), "{e}");
    assert_eq!(std::fs::read(other.join("notes.txt")).unwrap(), b"mine");
}
