//! The report's 3-D view and the PLY files (docs/REFERENCE.md): the data blob
//! `<script type="application/json" id="crashrig-3d">` of a generated `report.html` holds, number
//! for number, what `results.json`, `grid/<layout>/grid.csv` and `measure/trajectories.csv` hold;
//! `grid.ply` and `trajectories.ply`, read back by an independent PLY reader (`ply-rs-bw`), hold
//! what `grid.csv` and `trajectories.csv` hold.

use crate::contract::common::{fixture, read_json, run};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Ply, Property};
use serde_json::Value;
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The rows of a CSV file: header, then cells (the files here quote nothing).
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines
        .next()
        .expect("header")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("column {name} in {header:?}"))
}

/// A CSV cell as a number; blank = None.
fn cell(c: &str) -> Option<f64> {
    (!c.is_empty()).then(|| c.parse().unwrap_or_else(|_| panic!("{c:?} is a number")))
}

/// The JSON number or null.
fn jnum(v: &Value) -> Option<f64> {
    if v.is_null() {
        None
    } else {
        Some(v.as_f64().unwrap_or_else(|| panic!("{v} is a number")))
    }
}

fn blob(html: &str) -> Value {
    let start = "<script type=\"application/json\" id=\"crashrig-3d\">";
    let from = html.find(start).expect("the data blob") + start.len();
    let len = html[from..].find("</script>").expect("its end");
    serde_json::from_str(&html[from..from + len]).expect("the blob is JSON")
}

fn read_ply(path: &Path) -> Ply<DefaultElement> {
    let mut f = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Parser::<DefaultElement>::new()
        .read_ply(&mut f)
        .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()))
}

fn double(e: &DefaultElement, k: &str) -> f64 {
    match e.get(k) {
        Some(Property::Double(v)) => *v,
        other => panic!("{k}: {other:?} is not a double"),
    }
}

fn float(e: &DefaultElement, k: &str) -> f32 {
    match e.get(k) {
        Some(Property::Float(v)) => *v,
        other => panic!("{k}: {other:?} is not a float"),
    }
}

fn int(e: &DefaultElement, k: &str) -> i32 {
    match e.get(k) {
        Some(Property::Int(v)) => *v,
        other => panic!("{k}: {other:?} is not an int"),
    }
}

/// A float property equals the CSV cell rounded to f32 (bit for bit), NaN where it is blank.
fn assert_float_is_cell(got: f32, c: &str, what: &str) {
    match cell(c) {
        Some(v) => assert_eq!(got.to_bits(), (v as f32).to_bits(), "{what}: {got} vs {c}"),
        None => assert!(got.is_nan(), "{what}: {got} where the CSV is blank"),
    }
}

/// The own project's study: every number of the blob against results.json and the CSV files.
#[test]
fn report_3d_blob_equals_results_json_and_the_csv_files() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let own = crate::contract::study::own_project(tmp.path());
    let out = tmp.path().join("out");
    let r = run([
        "study",
        s(&own.join("study.toml")),
        "--out",
        s(&out),
        "--samples",
        "40",
        "--no-sensitivity",
    ]);
    assert!(r.success, "{}", r.stderr);
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    let b = blob(&html);
    let results = read_json(&out.join("results.json"));
    let keys: Vec<&String> = b.as_object().expect("object").keys().collect();
    assert_eq!(keys, ["cameras", "layouts", "trajectories"]);

    // Layouts: name, threshold, every point of grid.csv, the observers of results.json.
    let layouts = results["layouts"].as_array().expect("layouts");
    let bl = b["layouts"].as_array().expect("blob layouts");
    assert_eq!(bl.len(), layouts.len());
    let mut nulls = 0;
    for (l, rl) in bl.iter().zip(layouts) {
        assert_eq!(l["name"], rl["name"]);
        assert_eq!(l["threshold_mm"], rl["summary"]["threshold_mm"]);
        let (h, rows) = csv(&out.join(rl["dir"].as_str().expect("dir")).join("grid.csv"));
        let pts = l["points"].as_array().expect("points");
        assert_eq!(pts.len(), rows.len(), "{}", l["name"]);
        let c = ["x_mm", "y_mm", "z_mm", "sigma_worst_mm"].map(|n| col(&h, n));
        for (p, row) in pts.iter().zip(&rows) {
            let p = p.as_array().expect("point");
            assert_eq!(p.len(), 4);
            for k in 0..4 {
                assert_eq!(
                    jnum(&p[k]),
                    cell(&row[c[k]]),
                    "{}: {p:?} vs {row:?}",
                    l["name"]
                );
            }
            nulls += usize::from(p[3].is_null());
        }
        let cams = l["cameras"].as_array().expect("cameras");
        let obs = rl["observers"].as_array().expect("observers");
        assert_eq!(cams.len(), obs.len());
        for (c, o) in cams.iter().zip(obs) {
            assert_eq!(c["name"], o["name"]);
            assert_eq!(c["world_from_cam"]["position_mm"], o["position_mm"]);
        }
    }
    assert!(nulls > 0, "the fixed layout has points no two cameras see");
    // The fixed layout's cameras carry the study file's angles; the aimed ones none.
    let fixed = &bl[2]["cameras"];
    let study = std::fs::read_to_string(own.join("study.toml")).expect("study.toml");
    assert!(study.contains("name = \"fixed_rear_and_side\""));
    for c in fixed.as_array().expect("cameras") {
        let a = c["world_from_cam"]["angles_deg"]
            .as_array()
            .expect("angles");
        assert_eq!(a.len(), 3);
    }
    assert!(bl[0]["cameras"][0]["world_from_cam"]["angles_deg"].is_null());

    // Cameras: the chain's world poses of results.json.
    let chain = results["propagation"]["cameras"]
        .as_array()
        .expect("chain cameras");
    let bc = b["cameras"].as_array().expect("blob cameras");
    assert_eq!(bc.len(), chain.len());
    for (c, rc) in bc.iter().zip(chain) {
        assert_eq!(c["name"], rc["name"]);
        assert_eq!(c["world_from_cam"]["position_mm"], rc["position_mm"]);
        assert_eq!(c["world_from_cam"]["angles_deg"], rc["angles_deg"]);
    }

    // Trajectories: every row of measure/trajectories.csv, null where not measured.
    // The study's measure/summary.json names no markers or epochs: trajectories.csv does
    // (epoch-major, markers sorted by name).
    let summary = read_json(&out.join("measure/summary.json"));
    let (h, rows) = csv(&out.join("measure/trajectories.csv"));
    let [ce, cm, cx, cy, cz, csx, csy, csz, csm] = [
        "epoch",
        "marker",
        "x_mm",
        "y_mm",
        "z_mm",
        "sigma_x_mm",
        "sigma_y_mm",
        "sigma_z_mm",
        "sigma_max_mm",
    ]
    .map(|n| col(&h, n));
    let mut markers: Vec<Value> = Vec::new();
    let mut epochs: Vec<Value> = Vec::new();
    for r in &rows {
        for (list, v) in [(&mut markers, &r[cm]), (&mut epochs, &r[ce])] {
            if !list.iter().any(|x| x == v.as_str()) {
                list.push(Value::from(v.as_str()));
            }
        }
    }
    markers.sort_by(|a, b| a.as_str().cmp(&b.as_str()));
    assert_eq!(summary["markers"], markers.len());
    assert_eq!(summary["epochs"], epochs.len());
    let bt = b["trajectories"].as_array().expect("trajectories");
    assert_eq!(bt.len(), markers.len());
    let mut measured = 0;
    for (t, name) in bt.iter().zip(markers) {
        assert_eq!(&t["marker"], &name);
        let te = t["epochs"].as_array().expect("epochs");
        assert_eq!(te.len(), epochs.len());
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| name == r[cm].as_str()).collect();
        for (k, e) in epochs.iter().enumerate() {
            let row = mine.iter().find(|r| r[ce] == e.as_str().unwrap());
            match row.and_then(|r| cell(&r[cx]).map(|x| (r, x))) {
                Some((r, x)) => {
                    let p = te[k].as_array().expect("a measured epoch");
                    let want = [Some(x), cell(&r[cy]), cell(&r[cz])];
                    assert_eq!(p.iter().map(jnum).collect::<Vec<_>>(), want);
                    measured += 1;
                }
                None => assert!(te[k].is_null(), "{name} {e}: not measured"),
            }
        }
        // The ellipsoids: at the reference epoch and at the row of largest σ_max, their semi-axes
        // give back the σ of trajectories.csv (√ of the covariance's diagonal).
        let el = t["ellipsoids"].as_array().expect("ellipsoids");
        let largest = mine
            .iter()
            .filter_map(|r| cell(&r[csm]).map(|v| (v, r[ce].clone())))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .expect("a measured row");
        let reference = &summary["reference_epoch"];
        assert!(!el.is_empty());
        for e in el {
            let row = mine
                .iter()
                .find(|r| r[ce] == e["epoch"].as_str().unwrap())
                .expect("the ellipsoid's row");
            match e["role"].as_str().unwrap() {
                "reference" => assert_eq!(&e["epoch"], reference),
                "largest" => assert_eq!(e["epoch"].as_str().unwrap(), largest.1),
                other => panic!("role {other}"),
            }
            let a: Vec<[f64; 3]> = e["semi_axes_mm"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| std::array::from_fn(|i| v[i].as_f64().unwrap()))
                .collect();
            for (i, c) in [csx, csy, csz].into_iter().enumerate() {
                let var: f64 = a.iter().map(|v| v[i] * v[i]).sum();
                let want = cell(&row[c]).expect("σ");
                assert!(
                    (var.sqrt() - want).abs() <= 1e-9 * want,
                    "{name}: σ {i} {} vs {want}",
                    var.sqrt()
                );
            }
            let p: Vec<Option<f64>> = e["position_mm"]
                .as_array()
                .unwrap()
                .iter()
                .map(jnum)
                .collect();
            assert_eq!(p, [cell(&row[cx]), cell(&row[cy]), cell(&row[cz])]);
        }
    }
    assert!(measured > 0);
}

/// `grid --out DIR`: DIR/grid.ply holds grid.csv's points and σ (NaN where blank) and the
/// worst-direction σ of grid_detail.csv; its header as docs/REFERENCE.md gives it.
#[test]
fn grid_ply_reads_back_as_grid_csv() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    let scen = fixture("scenarios/fixed_three_cameras.toml");
    let r = run([
        "grid",
        s(&scen),
        "--samples",
        "60",
        "--seed",
        "2",
        "--no-plots",
        "--out",
        s(&out),
    ]);
    assert!(r.success, "{}", r.stderr);
    let ply = read_ply(&out.join("grid.ply"));
    let props: Vec<&String> = ply.header.elements["vertex"].properties.keys().collect();
    assert_eq!(
        props,
        [
            "x",
            "y",
            "z",
            "sigma_x",
            "sigma_y",
            "sigma_z",
            "sigma_max",
            "sigma_worst"
        ]
    );
    let v = &ply.payload["vertex"];
    let (h, rows) = csv(&out.join("grid.csv"));
    let (hd, detail) = csv(&out.join("grid_detail.csv"));
    assert_eq!(v.len(), rows.len());
    let mut blank = 0;
    for ((e, row), d) in v.iter().zip(&rows).zip(&detail) {
        for (k, n) in [("x", "x_mm"), ("y", "y_mm"), ("z", "z_mm")] {
            assert_eq!(Some(double(e, k)), cell(&row[col(&h, n)]), "{k}");
        }
        for (k, n) in [
            ("sigma_x", "sigma_x_mm"),
            ("sigma_y", "sigma_y_mm"),
            ("sigma_z", "sigma_z_mm"),
            ("sigma_max", "sigma_max_mm"),
        ] {
            assert_float_is_cell(float(e, k), &row[col(&h, n)], k);
        }
        assert_float_is_cell(
            float(e, "sigma_worst"),
            &d[col(&hd, "sigma_worst_mm")],
            "worst",
        );
        blank += usize::from(row[col(&h, "sigma_max_mm")].is_empty());
    }
    assert!(
        blank > 0,
        "the fixed scenario has points no two cameras see"
    );
    let summary = read_json(&out.join("summary.json"));
    assert!(
        summary["files"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f == "grid.ply")
    );
}

/// `measure --out DIR`: DIR/trajectories.ply holds trajectories.csv's rows, the epoch and
/// marker indices, and names the markers in index order in a comment line.
#[test]
fn trajectories_ply_reads_back_as_trajectories_csv() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("out");
    let seq = fixture("measure/sequence");
    let r = run([
        "measure",
        s(&seq.join("model")),
        "--camera-a",
        "cam_out/",
        "--camera-b",
        "2",
        "--camera-c",
        "3",
        "--link",
        s(&seq.join("link.json")),
        "--tie",
        s(&seq.join("tie.json")),
        "--observations",
        s(&seq.join("observations.csv")),
        "--mm-per-unit",
        "1000",
        "--pixel-sigma-px",
        "0.1",
        "--frame-rate-hz",
        "1000",
        "--samples",
        "40",
        "--seed",
        "4",
        "--no-plots",
        "--out",
        s(&out),
    ]);
    assert!(r.success, "{}", r.stderr);
    let ply = read_ply(&out.join("trajectories.ply"));
    let summary = read_json(&out.join("summary.json"));
    let markers: Vec<String> = summary["marker_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap().to_string())
        .collect();
    let epochs: Vec<String> = summary["epoch_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap().to_string())
        .collect();
    let comment = |key: &str| -> Vec<String> {
        let c = ply
            .header
            .comments
            .iter()
            .find_map(|c| c.strip_prefix(&format!("{key} ")))
            .unwrap_or_else(|| panic!("comment {key} in {:?}", ply.header.comments));
        serde_json::from_str(c).expect("a JSON array of names")
    };
    assert_eq!(comment("markers"), markers);
    assert_eq!(comment("epochs"), epochs);
    let (h, rows) = csv(&out.join("trajectories.csv"));
    let v = &ply.payload["vertex"];
    assert_eq!(v.len(), rows.len());
    let mut blank = 0;
    for (e, row) in v.iter().zip(&rows) {
        assert_eq!(
            epochs[int(e, "epoch_index") as usize],
            row[col(&h, "epoch")]
        );
        assert_eq!(
            markers[int(e, "marker_index") as usize],
            row[col(&h, "marker")]
        );
        for (k, n) in [("x", "x_mm"), ("y", "y_mm"), ("z", "z_mm")] {
            match cell(&row[col(&h, n)]) {
                Some(want) => assert_eq!(double(e, k), want, "{k}"),
                None => assert!(double(e, k).is_nan()),
            }
        }
        for (k, n) in [
            ("sigma_x", "sigma_x_mm"),
            ("sigma_y", "sigma_y_mm"),
            ("sigma_z", "sigma_z_mm"),
            ("sigma_max", "sigma_max_mm"),
        ] {
            assert_float_is_cell(float(e, k), &row[col(&h, n)], k);
        }
        blank += usize::from(row[col(&h, "x_mm")].is_empty());
    }
    let _ = blank;
}
