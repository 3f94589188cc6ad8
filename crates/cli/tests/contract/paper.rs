//! `crashrig paper --out DIR`: report.html, JSON, figures (a tiny run: few draws/iterations).

use crate::contract::common::{json_of, read_json, run};
use std::path::{Path, PathBuf};

/// Every file under `dir` (recursively) whose extension is `ext`.
fn files_with_ext(dir: &Path, ext: &str, found: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read dir") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            files_with_ext(&p, ext, found);
        } else if p.extension().is_some_and(|x| x == ext) {
            found.push(p);
        }
    }
}

#[test]
fn paper_nominal() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("paper");
    let o = out.display().to_string();
    let r = run([
        "paper",
        "--out",
        o.as_str(),
        "--samples",
        "4",
        "--chain-samples",
        "50",
        "--iterations",
        "4",
        "--seed",
        "3",
        "--json",
    ]);
    // `--json`: one JSON document on stdout, progress on stderr.
    let v = json_of(&r);
    assert!(v.is_object(), "paper --json prints an object");
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html written");
    assert!(
        html.to_ascii_lowercase().contains("<html"),
        "report.html is HTML"
    );
    // The report sets the paper's published values beside the result: Table 1's base
    // (61.98, −1.71, 179.76) mm.
    for published in ["61.98", "179.76"] {
        assert!(
            html.contains(published),
            "report quotes the paper's {published}"
        );
    }
    let mut jsons = Vec::new();
    files_with_ext(&out, "json", &mut jsons);
    assert!(!jsons.is_empty(), "the report's JSON is written");
    for j in &jsons {
        read_json(j);
    }
    // Figures 10–13: at least four heat maps, each as PNG and SVG.
    let mut pngs = Vec::new();
    files_with_ext(&out.join("grid"), "png", &mut pngs);
    assert!(pngs.len() >= 4, "four heat maps, got {}", pngs.len());
    for p in &pngs {
        let bytes = std::fs::read(p).expect("png");
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{} is a PNG",
            p.display()
        );
        assert!(
            p.with_extension("svg").is_file(),
            "{} has an SVG twin",
            p.display()
        );
    }
}

/// `paper` is `study` on the bundled study file: running `study` on `DIR/inputs/study.toml`
/// into another directory gives the same results.json, byte for byte (moved here from the
/// command module, which now only writes the inputs and runs the study).
#[test]
fn paper_equals_study_on_its_study_file() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("paper");
    let again = tmp.path().join("again");
    let (o, a) = (out.display().to_string(), again.display().to_string());
    let r = json_of(&run([
        "paper",
        "--out",
        o.as_str(),
        "--samples",
        "20",
        "--chain-samples",
        "2000",
        "--iterations",
        "20",
        "--seed",
        "7",
        "--json",
    ]));
    let study = out.join("inputs/study.toml").display().to_string();
    let r2 = json_of(&run([
        "study",
        study.as_str(),
        "--out",
        a.as_str(),
        "--json",
    ]));
    assert_eq!(r, r2);
    assert_eq!(
        std::fs::read(out.join("results.json")).expect("results.json"),
        std::fs::read(again.join("results.json")).expect("results.json")
    );
    assert_eq!(r["seed"], 7);
    assert_eq!(r["layouts"].as_array().expect("layouts").len(), 11);
    assert!(
        r["layouts"][10]["summary"]["fixed"]["fraction_measurable"]
            .as_f64()
            .expect("fraction")
            < 1.0
    );
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    assert!(html.contains("What differs from the paper"));
    assert!(html.contains("verified inliers only"));
    assert!(
        html.contains("pixel pitch 5.0 µm"),
        "the report states the assumed lens"
    );
}
