//! `crashrig study STUDY.toml --out DIR` on an own project written by pycolmap
//! (`fixtures/study/own/`, generator `fixtures/gen/own_study.py`).

use crate::contract::common::{assert_clean_error, json_of, read_json, run};
use std::path::{Path, PathBuf};

/// Copies the own project into a temporary directory (so a run never writes into the repo).
pub fn own_project(tmp: &Path) -> PathBuf {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).expect("mkdir");
        for e in std::fs::read_dir(from).expect("read dir") {
            let p = e.expect("entry").path();
            let q = to.join(p.file_name().expect("name"));
            if p.is_dir() {
                copy(&p, &q);
            } else {
                std::fs::copy(&p, &q).expect("copy");
            }
        }
    }
    let dst = tmp.join("own");
    copy(&crate::contract::common::fixture("study/own"), &dst);
    dst
}

/// `results.json` holds `calibration` and `tie` exactly as `calibrate --json` and
/// `bootstrap --json` print them on the same inputs and seed; the layouts' grid files exist and
/// their summaries are the ones in results.json; the same seed on another thread count gives
/// the same bytes.
#[test]
fn study_own_project_matches_the_commands() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let study = own.join("study.toml");
    let out = tmp.path().join("out");
    let (s, o) = (study.display().to_string(), out.display().to_string());
    let r = run([
        "study",
        s.as_str(),
        "--out",
        o.as_str(),
        "--samples",
        "40",
        "--json",
    ]);
    let v = json_of(&r);
    let results = read_json(&out.join("results.json"));
    assert_eq!(v, results, "--json prints results.json");
    assert_eq!(results["seed"], 11);

    let m = own.join("calibration").display().to_string();
    let cal = json_of(&run([
        "calibrate",
        m.as_str(),
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "cam_in/",
        "--scale-points",
        "1",
        "2",
        "--scale-length-mm",
        "1500",
        "--json",
    ]));
    assert_eq!(
        results["calibration"], cal,
        "calibration = calibrate --json"
    );

    let db = own.join("tie/database.db").display().to_string();
    let tm = own.join("tie/model").display().to_string();
    let boot = json_of(&run([
        "bootstrap",
        db.as_str(),
        "--model",
        tm.as_str(),
        "--image-a",
        "in/0001.png",
        "--image-b",
        "side/0001.png",
        "--method",
        "absolute",
        "--iterations",
        "60",
        "--mm-per-unit",
        "1000",
        "--seed",
        "11",
        "--json",
    ]));
    assert_eq!(results["tie"], boot, "tie = bootstrap --json");

    let layouts = results["layouts"].as_array().expect("layouts");
    assert_eq!(layouts.len(), 3);
    for l in layouts {
        let dir = out.join(l["dir"].as_str().expect("dir"));
        assert_eq!(read_json(&dir.join("summary.json")), *l);
        let csv = std::fs::read_to_string(dir.join("grid.csv")).expect("grid.csv");
        let n = csv.lines().count() - 1;
        assert_eq!(n as u64, l["summary"]["points"].as_u64().expect("points"));
        assert_eq!(l["summary"]["samples_per_point"], 40);
    }
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    assert!(html.contains("Verdict per layout") && html.contains("rear_and_side"));

    // [measure]: DIR/measure/ holds what `crashrig measure` writes when given the study's own
    // calibrate/bootstrap results and the same settings and seed.
    assert!(html.contains("The measured test sequence"));
    let mdir = out.join("measure");
    let mout = tmp.path().join("measure_cmd");
    let (mm, obs) = (
        own.join("measure/model").display().to_string(),
        own.join("measure/observations.csv").display().to_string(),
    );
    // The study's link is the calibration's typed mean: the SO(3) mean rotation
    // (`mean_rotation_angles_deg`); `measure --link` reads `angles_deg` (the per-angle mean,
    // here 5e-6° away). The command gets the same link by naming the SO(3) mean angles.
    let mut cal_json = read_json(&out.join("calibration/calibrate.json"));
    cal_json["angles_deg"] = cal_json["mean_rotation_angles_deg"].clone();
    let link_path = tmp.path().join("link.json");
    std::fs::write(&link_path, serde_json::to_vec(&cal_json).expect("json")).expect("link");
    let (link, tie) = (
        link_path.display().to_string(),
        out.join("tie/bootstrap.json").display().to_string(),
    );
    let mo = mout.display().to_string();
    let cmd = json_of(&run([
        "measure",
        mm.as_str(),
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "2",
        "--camera-c",
        "3",
        "--link",
        link.as_str(),
        "--tie",
        tie.as_str(),
        "--observations",
        obs.as_str(),
        "--out",
        mo.as_str(),
        "--mm-per-unit",
        "1000",
        "--sigma-a-position-mm",
        "0.3",
        "0.3",
        "0.3",
        "--sigma-a-angles-deg",
        "0.004",
        "0.004",
        "0.004",
        "--pixel-sigma-px",
        "0.3",
        "--frame-rate-hz",
        "1000",
        "--threshold-mm",
        "3",
        "--samples",
        "40",
        "--seed",
        "11",
        "--json",
    ]));
    let ms = &results["measure"]["summary"];
    assert_eq!(read_json(&mdir.join("summary.json")), *ms);
    for k in [
        "epochs",
        "markers",
        "rows",
        "samples_per_point",
        "rows_measured",
        "rows_fewer_than_two_views",
        "rows_flagged",
        "reference_epoch",
        "cameras",
    ] {
        assert_eq!(ms[k], cmd[k], "measure summary {k}");
    }
    assert_eq!(
        ms["rows_fewer_than_two_views"], 2,
        "knee hidden from C twice"
    );
    // The command reads the link and tie back from JSON in degrees (rad → deg → rad), the
    // study passes the typed values: the same numbers up to that rounding (≤ 1e-9 relative).
    for file in ["trajectories.csv", "displacements.csv"] {
        let a = std::fs::read_to_string(mdir.join(file)).expect("study csv");
        let b = std::fs::read_to_string(mout.join(file)).expect("measure csv");
        assert_eq!(a.lines().count(), b.lines().count(), "{file}");
        assert_eq!(a.lines().next(), b.lines().next(), "{file} header");
        for (la, lb) in a.lines().zip(b.lines()).skip(1) {
            for (x, y) in la.split(',').zip(lb.split(',')) {
                match (x.parse::<f64>(), y.parse::<f64>()) {
                    (Ok(x), Ok(y)) => assert!(
                        (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1.0),
                        "{file}: {la} vs {lb}"
                    ),
                    _ => assert_eq!(x, y, "{file}: {la} vs {lb}"),
                }
            }
        }
    }
    for m in ["head", "chest", "shoulder", "knee"] {
        assert!(mdir.join(format!("plots/{m}.png")).is_file(), "plot {m}");
    }

    let out2 = tmp.path().join("out2");
    let o2 = out2.display().to_string();
    let r2 = run([
        "study",
        s.as_str(),
        "--out",
        o2.as_str(),
        "--samples",
        "40",
        "--threads",
        "1",
    ]);
    assert!(r2.success, "{}", r2.stderr);
    assert_eq!(
        std::fs::read(out.join("results.json")).expect("a"),
        std::fs::read(out2.join("results.json")).expect("b"),
        "same seed, one thread vs default: identical results.json"
    );
}

pub fn study_error(edit: impl Fn(&str) -> String, needles: &[&str]) {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let study = own.join("study.toml");
    let text = std::fs::read_to_string(&study).expect("study");
    std::fs::write(&study, edit(&text)).expect("write");
    let out = tmp.path().join("out");
    let (s, o) = (study.display().to_string(), out.display().to_string());
    let mut r = run(["study", s.as_str(), "--out", o.as_str(), "--samples", "4"]);
    // A step that fails after others ran (e.g. `[measure]` naming a camera the model lacks):
    // the finished steps' log lines (`crashrig study: [i/n] step: time`, printed when stderr is
    // not a terminal) come first; the failure itself is still exactly one `error:` line.
    r.stderr = r
        .stderr
        .lines()
        .filter(|l| !l.starts_with("crashrig study: ["))
        .map(|l| format!("{l}\n"))
        .collect();
    let mut all = vec!["study.toml"];
    all.extend_from_slice(needles);
    assert_clean_error(&r, &all);
    assert!(
        !out.join("results.json").exists(),
        "no results after an error"
    );
}

#[test]
fn study_missing_section_is_one_error_line() {
    study_error(
        |t| {
            let i = t.find("[outward]").expect("outward");
            let j = t.find("[[layout]]").expect("layout");
            format!("{}{}", &t[..i], &t[j..])
        },
        &["[outward]", "missing section"],
    );
}

#[test]
fn study_missing_path_names_key_and_line() {
    study_error(
        |t| t.replace("model = \"tie/model\"", "model = \"tie/nowhere\""),
        &["`tie.model`", "nowhere", "does not exist"],
    );
    // The line of the key: `study.toml:<line>:`.
    let line = std::fs::read_to_string(crate::contract::common::fixture("study/own/study.toml"))
        .expect("study")
        .lines()
        .position(|l| l.starts_with("model = \"tie/model\""))
        .expect("line")
        + 1;
    study_error(
        |t| t.replace("model = \"tie/model\"", "model = \"tie/nowhere\""),
        &[&format!("study.toml:{line}:")],
    );
}

#[test]
fn study_model_without_the_named_cameras() {
    study_error(
        // The calibration's camera only ([measure] has its own camera_a).
        |t| t.replacen("camera_a = \"cam_out/\"", "camera_a = \"cam_front/\"", 1),
        &["[calibration]", "cam_front/"],
    );
}

/// Every field `study` writes to `results.json` is documented: the study's own fields by their
/// full path in `docs/REFERENCE.md`, `calibration.*` (= `calibrate --json`) by name in
/// `docs/CALIBRATE.md`, `tie.*` (= `bootstrap --json`) by name in `docs/BOOTSTRAP.md`.
#[test]
fn study_results_fields_are_documented() {
    fn paths(v: &serde_json::Value, p: &str, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Object(m) => {
                for (k, x) in m {
                    let q = if p.is_empty() {
                        k.clone()
                    } else {
                        format!("{p}.{k}")
                    };
                    out.push(q.clone());
                    paths(x, &q, out);
                }
            }
            serde_json::Value::Array(a) => {
                for x in a.iter().filter(|x| x.is_object()) {
                    paths(x, &format!("{p}[]"), out);
                }
            }
            _ => {}
        }
    }
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let out = tmp.path().join("out");
    let (s, o) = (
        own.join("study.toml").display().to_string(),
        out.display().to_string(),
    );
    let r = run(["study", s.as_str(), "--out", o.as_str(), "--samples", "10"]);
    assert!(r.success, "{}", r.stderr);
    let results = read_json(&out.join("results.json"));
    let mut all = Vec::new();
    paths(&results, "", &mut all);
    let doc = |name: &str| {
        std::fs::read_to_string(crate::contract::common::root().join("docs").join(name))
            .expect("doc")
    };
    let (reference, calibrate, tie_doc) = (
        doc("REFERENCE.md"),
        doc("CALIBRATE.md"),
        doc("BOOTSTRAP.md"),
    );
    let mut missing = Vec::new();
    for p in &all {
        let leaf = p.rsplit(['.', ']']).next().expect("leaf");
        let ok = if p.starts_with("calibration.") {
            calibrate.contains(&format!("`{leaf}")) || calibrate.contains(&format!(".{leaf}`"))
        } else if p.starts_with("tie.") {
            tie_doc.contains(&format!("`{leaf}")) || tie_doc.contains(&format!(".{leaf}`"))
        } else {
            // A row documents the field itself, or its object / array of objects.
            reference.contains(&format!("`{p}`"))
                || reference.contains(&format!("`{p}."))
                || reference.contains(&format!("`{p}[]."))
        };
        if !ok {
            missing.push(p.clone());
        }
    }
    assert!(
        missing.is_empty(),
        "results.json fields not documented: {missing:?}"
    );
}

/// `colmap points`: the point a pixel of an image observes comes first, at distance 0, and every
/// hit lies within the radius, nearest first; `--point` gives that point's track.
#[test]
fn colmap_points_finds_the_point_at_a_pixel() {
    let dir = crate::contract::common::fixture("study/own/tie/model");
    let model = crashrig_colmap::Reconstruction::read(&dir).expect("model");
    let image = model.image_by_name("side/0001.png").expect("image");
    let (xy, id) = image
        .points2d
        .iter()
        .find_map(|p| p.point3d_id.map(|id| (p.xy, id)))
        .expect("an observation");
    let d = dir.display().to_string();
    let (x, y) = (xy[0].to_string(), xy[1].to_string());
    let v = json_of(&run([
        "colmap",
        "points",
        d.as_str(),
        "--image",
        "side/0001.png",
        "--near",
        x.as_str(),
        y.as_str(),
        "--radius",
        "80",
        "--json",
    ]));
    let hits = v.as_array().expect("array");
    assert_eq!(hits[0]["point3D_id"], id);
    assert_eq!(hits[0]["distance_px"], 0.0);
    let dist: Vec<f64> = hits
        .iter()
        .map(|h| h["distance_px"].as_f64().expect("d"))
        .collect();
    assert!(dist.windows(2).all(|w| w[0] <= w[1]) && dist.iter().all(|d| *d <= 80.0));
    let idarg = id.to_string();
    let one = json_of(&run([
        "colmap",
        "points",
        d.as_str(),
        "--point",
        idarg.as_str(),
        "--json",
    ]));
    assert_eq!(one[0]["track_length"], 2);
    // Text mode: the point's coordinates (never NaN) and one line per observation of its track.
    let text = run(["colmap", "points", d.as_str(), "--point", idarg.as_str()]);
    assert!(text.success, "{}", text.stderr);
    assert!(!text.stdout.contains("NaN"), "{}", text.stdout);
    let x = format!("{:.4}", one[0]["xyz"][0].as_f64().expect("x"));
    assert!(text.stdout.contains(&x), "{x} missing:\n{}", text.stdout);
    for t in one[0]["track"].as_array().expect("track") {
        let name = t["image"].as_str().expect("image");
        let u = format!("{:.2}", t["pixel"][0].as_f64().expect("u"));
        assert!(
            text.stdout
                .lines()
                .any(|l| l.contains(name) && l.contains(&u)),
            "track line {name} {u} missing:\n{}",
            text.stdout
        );
    }
    let r = run([
        "colmap",
        "points",
        d.as_str(),
        "--image",
        "nope.png",
        "--near",
        "1",
        "2",
    ]);
    assert_clean_error(&r, &["nope.png"]);
}

/// OUT is replaced as a whole: a second run into the same OUT succeeds and leaves only the new
/// result; an OUT holding a file `study` does not write is refused before any work, untouched.
#[test]
fn study_out_is_staged_and_foreign_files_are_refused() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let out = tmp.path().join("out");
    let (s, o) = (
        own.join("study.toml").display().to_string(),
        out.display().to_string(),
    );
    let args = [
        "study",
        s.as_str(),
        "--out",
        o.as_str(),
        "--samples",
        "4",
        "--no-sensitivity",
    ];
    assert!(run(args).success);
    std::fs::write(out.join("grid/old_layout.csv"), b"old").expect("write");
    assert!(run(args).success);
    assert!(
        !out.join("grid/old_layout.csv").exists(),
        "nothing old survives"
    );
    std::fs::write(out.join("notes.txt"), b"mine").expect("write");
    assert_clean_error(&run(args), &["notes.txt"]);
    assert_eq!(std::fs::read(out.join("notes.txt")).expect("kept"), b"mine");
}

/// A study layout with fixed observers runs the same grid as `crashrig grid` on the scenario
/// with the same observers (fixtures/scenarios/fixed_four_cameras.toml: look_at_mm, OPENCV
/// lens, given σ), seed and draws: identical `grid.csv` σ and `observers_seen` cells.
#[test]
fn study_fixed_layout_equals_grid_on_the_scenario() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let study = own.join("study.toml");
    let text = std::fs::read_to_string(&study).expect("study");
    let cut = text.find("[[layout]]").expect("layout");
    let scen = crate::contract::common::fixture("scenarios/fixed_four_cameras.toml");
    let stext = std::fs::read_to_string(&scen).expect("scenario");
    // The scenario's [grid] and observers as a study layout (same keys, other table names).
    let grid = &stext[stext.find("[grid]").expect("grid")..];
    let layout = grid
        .replace("[grid]", "[[layout]]\nname = \"fixed_four\"")
        .replace("[[grid.observer]]", "[[layout.observer]]");
    let body = text[..cut].replace("seed = 11", "seed = 20261121");
    std::fs::write(&study, format!("{body}{layout}")).expect("write");
    let out = tmp.path().join("out");
    let (s, o) = (study.display().to_string(), out.display().to_string());
    let r = run([
        "study",
        s.as_str(),
        "--out",
        o.as_str(),
        "--samples",
        "40",
        "--no-sensitivity",
    ]);
    assert!(r.success, "{}", r.stderr);
    let gout = tmp.path().join("grid");
    let (sc, go) = (scen.display().to_string(), gout.display().to_string());
    let g = run(["grid", sc.as_str(), "--out", go.as_str(), "--samples", "40"]);
    assert!(g.success, "{}", g.stderr);
    let table = |p: &Path| -> Vec<std::collections::HashMap<String, String>> {
        let t = std::fs::read_to_string(p).expect("csv");
        let mut lines = t.lines();
        let head: Vec<String> = lines
            .next()
            .expect("header")
            .split(',')
            .map(String::from)
            .collect();
        lines
            .map(|l| {
                head.iter()
                    .cloned()
                    .zip(l.split(',').map(String::from))
                    .collect()
            })
            .collect()
    };
    let a = table(&out.join("grid/fixed_four/grid.csv"));
    let b = table(&gout.join("grid.csv"));
    assert_eq!(a.len(), 442);
    assert_eq!(a.len(), b.len());
    let mut measurable = 0;
    for (ra, rb) in a.iter().zip(&b) {
        for k in [
            "x_mm",
            "y_mm",
            "z_mm",
            "sigma_x_mm",
            "sigma_y_mm",
            "sigma_z_mm",
            "sigma_max_mm",
            "observers_seen",
        ] {
            assert_eq!(
                ra[k], rb[k],
                "{k} at ({}, {}, {})",
                ra["x_mm"], ra["y_mm"], ra["z_mm"]
            );
        }
        measurable += usize::from(ra["observers_seen"] == "2" && !ra["sigma_max_mm"].is_empty());
    }
    assert!(
        measurable > 100 && measurable < 442,
        "{measurable} measurable"
    );
    let results = read_json(&out.join("results.json"));
    let fixed = &results["layouts"][0]["summary"]["fixed"];
    let gsum = read_json(&gout.join("summary.json"));
    assert_eq!(fixed["fraction_measurable"], gsum["fraction_measurable"]);
    assert_eq!(fixed["observer_coverage"], gsum["observer_coverage"]);
}

/// Bad fixed observers and `[measure]` sections in a study: one error line naming the study
/// file and the key (or the section whose step failed).
#[test]
fn study_bad_fixed_observer_names_the_key() {
    study_error(
        |t| {
            t.replace(
                "model = \"OPENCV\", width = 1920",
                "model = \"OPENCVX\", width = 1920",
            )
        },
        &["layout[2].observer[1].camera", "OPENCVX"],
    );
    study_error(
        |t| {
            t.replace(
                "width = 1920, height = 1200, params",
                "width = 0, height = 1200, params",
            )
        },
        &["layout[2].observer[1].camera", "width and height"],
    );
    study_error(
        |t| {
            t.replace(
                "params = [1400.0, 1400.0, 960.0, 600.0, -0.05, 0.01, 0.0, 0.0] }",
                "params = [1400.0, 1400.0, 960.0] }",
            )
        },
        &["layout[2].observer[1].camera"],
    );
    study_error(
        |t| t.replace("look_at_mm = [900.0, 0.0, 0.0]\n", ""),
        &["layout[2].observer[1].angles_deg", "look_at_mm"],
    );
    study_error(
        |t| {
            t.replace(
                "camera_from = \"tie/model:1\"",
                "camera_from = \"tie/model:9\"",
            )
        },
        &["layout[2].observer[0].camera_from", "no camera 9"],
    );
    study_error(
        |t| t.replace("camera_c = \"3\"", "camera_c = \"3\"\nbogus = 1"),
        &["bogus"],
    );
    study_error(
        |t| t.replace("measure/observations.csv", "measure/nothing.csv"),
        &["measure.observations", "nothing.csv"],
    );
    // A step failure names [measure] and the library's message (camera 7 is not in the model).
    study_error(
        |t| t.replace("camera_b = \"2\"", "camera_b = \"7\""),
        &["[measure]"],
    );
}

/// A fixed layout where no two cameras see a common point: the study still runs, the layout
/// is all not measurable, and one `warning:` line names the study file and the layout.
#[test]
fn study_fixed_layout_nothing_measurable_warns() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = own_project(tmp.path());
    let study = own.join("study.toml");
    let text = std::fs::read_to_string(&study).expect("study");
    let turned = text.replace(
        "look_at_mm = [900.0, 0.0, 0.0]",
        "look_at_mm = [1200.0, 3000.0, 100.0]",
    );
    assert_ne!(turned, text);
    std::fs::write(&study, turned).expect("write");
    let out = tmp.path().join("out");
    let (s, o) = (study.display().to_string(), out.display().to_string());
    let r = run([
        "study",
        s.as_str(),
        "--out",
        o.as_str(),
        "--samples",
        "4",
        "--no-sensitivity",
    ]);
    assert!(r.success, "{}", r.stderr);
    let warnings: Vec<&str> = r
        .stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", r.stderr);
    assert!(
        warnings[0].contains("study.toml") && warnings[0].contains("fixed_rear_and_side"),
        "{}",
        warnings[0]
    );
    let results = read_json(&out.join("results.json"));
    let l = &results["layouts"][2]["summary"];
    assert_eq!(l["fixed"]["fraction_measurable"], 0.0);
    assert_eq!(l["fraction_below_threshold"], 0.0);
    assert!(
        out.join("grid/fixed_rear_and_side/sigma_max_z00_0mm.png")
            .is_file()
    );
    // The verdict says so in words, never "max NaN mm".
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    assert!(html.contains("the whole grid is not measurable"));
    // (base64 images may contain the letters "NaN"; text, attributes and numbers may not)
    for pat in [">NaN", "\"NaN", "NaN mm", "NaN /", "NaN<"] {
        assert!(!html.contains(pat), "a NaN reached the report: {pat}");
    }
}
