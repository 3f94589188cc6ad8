//! `crashrig track` (docs/TRACK.md, docs/REFERENCE.md): the files and fields of a run on the
//! rendered sharp sequence, `--json` the same document as `summary.json`, `observations.csv`
//! in the form `measure` reads, and bad input — one `error:` line naming the file and line (or
//! the flag), nothing written.

use crate::contract::common::{assert_clean_error, fixture, json_of, read_json, run};
use std::path::{Path, PathBuf};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn sharp(rel: &str) -> PathBuf {
    fixture(&format!("track/sharp/{rel}"))
}

#[test]
fn track_writes_observations_frames_and_summary() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("t");
    let frames = sharp("frames");
    let seeds = sharp("seeds.csv");
    let r = run([
        "track",
        s(&frames),
        "--seeds",
        s(&seeds),
        "--camera",
        "B",
        "--out",
        s(&out),
        "--json",
    ]);
    let printed = json_of(&r);
    let written = read_json(&out.join("summary.json"));
    let strip = |mut v: serde_json::Value| {
        let o = v.as_object_mut().unwrap();
        for k in ["elapsed_s", "observations_per_second"] {
            assert!(o.remove(k).and_then(|x| x.as_f64()).is_some(), "{k}");
        }
        v
    };
    assert_eq!(strip(printed.clone()), strip(written));
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["frames.csv", "observations.csv", "summary.json"]);
    assert_eq!(printed["source"], "directory");
    assert_eq!(printed["camera"], "B");
    assert_eq!(printed["marker_kind"], "quadrant");
    assert_eq!(printed["frames"], 10);
    assert_eq!(
        (
            printed["first_epoch"].as_str(),
            printed["last_epoch"].as_str()
        ),
        (Some("0000"), Some("0009"))
    );
    let seeds_n = std::fs::read_to_string(&seeds).unwrap().lines().count() - 1;
    let markers = printed["markers"].as_array().unwrap();
    assert_eq!(markers.len(), seeds_n);
    let obs = std::fs::read_to_string(out.join("observations.csv")).unwrap();
    let mut lines = obs.lines();
    assert_eq!(
        lines.next(),
        Some("epoch,camera,marker,u_px,v_px,sigma_u_px,sigma_v_px,rho_uv")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len() as u64, printed["observations"].as_u64().unwrap());
    let found: u64 = markers.iter().map(|m| m["found"].as_u64().unwrap()).sum();
    assert_eq!(found, rows.len() as u64);
    for row in &rows {
        assert_eq!(row.len(), 8);
        assert_eq!(row[1], "B");
        let v: Vec<f64> = row[3..].iter().map(|x| x.parse().unwrap()).collect();
        assert!(v[2] > 0.0 && v[3] > 0.0 && v[4].abs() < 1.0, "{row:?}");
    }
    // A directory of PNGs has no clock: every time empty.
    let times = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let mut t = times.lines();
    assert_eq!(t.next(), Some("epoch,time_s"));
    let t: Vec<&str> = t.collect();
    assert_eq!(t.len(), 10);
    assert!(t.iter().all(|l| l.ends_with(',')), "{t:?}");
}

#[test]
fn track_bad_input_is_one_error_line_and_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let frames = sharp("frames");
    let seeds = |name: &str, text: &str| {
        let p = tmp.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let good = std::fs::read_to_string(sharp("seeds.csv")).unwrap();
    let first_seed = good.lines().nth(1).unwrap().to_string();
    let cases: Vec<(PathBuf, PathBuf, Vec<&str>, Vec<String>)> = vec![
        (
            tmp.path().join("no_frames"),
            sharp("seeds.csv"),
            vec![],
            vec!["no_frames".into()],
        ),
        (
            frames.clone(),
            seeds("number.csv", "marker,u_px,v_px\nQ1,fifty,38\n"),
            vec![],
            vec!["number.csv:2".into()],
        ),
        (
            frames.clone(),
            seeds(
                "twice.csv",
                &format!("marker,u_px,v_px\n{first_seed}\n{first_seed}\n"),
            ),
            vec![],
            vec!["twice.csv:3".into()],
        ),
        (
            frames.clone(),
            seeds("outside.csv", "marker,u_px,v_px\nQ1,50000,38\n"),
            vec![],
            vec!["outside.csv:2".into()],
        ),
        (
            frames.clone(),
            seeds("header.csv", "name,u,v\nQ1,50,38\n"),
            vec![],
            vec!["header.csv".into()],
        ),
        (
            frames.clone(),
            sharp("seeds.csv"),
            vec!["--first", "9999"],
            vec!["9999".into()],
        ),
    ];
    for (i, (frames, seeds, extra, needles)) in cases.into_iter().enumerate() {
        let out = tmp.path().join(format!("out{i}"));
        let mut args = vec![
            "track".to_string(),
            s(&frames).into(),
            "--seeds".into(),
            s(&seeds).into(),
            "--camera".into(),
            "C".into(),
            "--out".into(),
            s(&out).into(),
        ];
        args.extend(extra.iter().map(|x| x.to_string()));
        let r = run(&args);
        let n: Vec<&str> = needles.iter().map(String::as_str).collect();
        assert_clean_error(&r, &n);
        assert!(!out.exists(), "case {i}: {out:?} written");
    }
}
