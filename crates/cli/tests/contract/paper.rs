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
    check_first_screen(&html, &read_json(&out.join("results.json")));
    // The fixed-lens layouts have points no two cameras see: counted apart, not as above.
    let fixed = &r["layouts"][10]["verdict"];
    assert!(
        fixed["points_seen_by_fewer_than_two"]
            .as_u64()
            .expect("count")
            > 0
    );
    assert!(fixed["fraction_measurable"].as_f64().expect("share") < 1.0);
    assert!(html.contains("What differs from the paper"));
    assert!(html.contains("verified inliers only"));
    assert!(
        html.contains("pixel pitch 5.0 µm"),
        "the report states the assumed lens"
    );
}

/// The cells of the report's first-screen answer table: (layout, [(data-key, text)]) per row.
fn answer_table(html: &str) -> Vec<(String, Vec<(String, String)>)> {
    let start = html
        .find("<table class=\"answer\" id=\"answer\">")
        .expect("the answer table");
    let table = &html[start..start + html[start..].find("</table>").expect("its end")];
    let unescape = |s: &str| {
        s.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&#39;", "'")
            .replace("&amp;", "&")
    };
    table
        .split("<tr class=")
        .skip(1)
        .map(|row| {
            let layout = row
                .split("data-layout=\"")
                .nth(1)
                .and_then(|s| s.split('"').next())
                .expect("data-layout");
            let cells = row
                .split("<td data-key=\"")
                .skip(1)
                .map(|c| {
                    let (key, rest) = c.split_once("\">").expect("a cell");
                    let text = rest.split("</td>").next().expect("cell end");
                    (key.to_string(), unescape(text))
                })
                .collect();
            (unescape(layout), cells)
        })
        .collect()
}

/// The report's first screen answers per layout with `results.json`'s numbers: the answer
/// table comes before every other block, has one row per layout in order, and each cell is the
/// `layouts[].verdict` value it names (formatted as the report formats it). The verdict agrees
/// with the grid summary computed apart (`crashrig_grid`'s worst-direction summary): the hot
/// spot's σ is the summary's largest worst-direction σ, and the shares add up.
pub fn check_first_screen(html: &str, results: &serde_json::Value) {
    let answer = html.find("id=\"answer\"").expect("answer table");
    for later in ["class=\"verdict ", "<nav class=\"toc\"", "class=\"meta\""] {
        let at = html.find(later).unwrap_or(usize::MAX);
        assert!(answer < at, "the answer table comes before {later}");
    }
    let rows = answer_table(html);
    let layouts = results["layouts"].as_array().expect("layouts");
    assert_eq!(rows.len(), layouts.len(), "one row per layout");
    let pct = |v: &serde_json::Value| format!("{:.1} %", 100.0 * v.as_f64().expect("a share"));
    let mm = |v: &serde_json::Value| v.as_f64().map_or("—".to_string(), |v| format!("{v:.2}"));
    for ((layout, cells), l) in rows.iter().zip(layouts) {
        let v = &l["verdict"];
        let name = l["name"].as_str().expect("name");
        assert_eq!(layout, name);
        let cell = |key: &str| -> &str {
            &cells
                .iter()
                .find(|(k, _)| k == key)
                .unwrap_or_else(|| panic!("{name}: no cell {key}"))
                .1
        };
        assert_eq!(v["sigma"], "worst_direction");
        assert_eq!(cell("name"), name);
        let reached = v["reached"].as_bool().expect("reached");
        assert_eq!(
            cell("reached"),
            if reached { "yes" } else { "no" },
            "{name}"
        );
        assert_eq!(
            cell("fraction_measurable"),
            pct(&v["fraction_measurable"]),
            "{name}"
        );
        let measurable = v["points_measurable"].as_u64().expect("count");
        if measurable > 0 {
            assert_eq!(
                cell("fraction_below_threshold_of_measurable"),
                pct(&v["fraction_below_threshold_of_measurable"]),
                "{name}"
            );
        }
        let hot = &v["hot_spot"];
        assert_eq!(
            cell("median_sigma_worst_mm"),
            format!(
                "{} / {}",
                mm(&v["median_sigma_worst_mm"]),
                mm(&hot["sigma_worst_mm"])
            ),
            "{name}"
        );
        if hot.is_object() {
            let p: Vec<f64> = hot["point_mm"]
                .as_array()
                .expect("point")
                .iter()
                .map(|x| x.as_f64().expect("mm"))
                .collect();
            assert_eq!(
                cell("hot_spot.point_mm"),
                format!("({:.0}, {:.0}, {:.0})", p[0], p[1], p[2]),
                "{name}"
            );
            let angle = hot["intersection_angle_deg"].as_f64().expect("angle");
            assert!(
                cell("hot_spot").contains(&format!("{angle:.1}°")),
                "{name}: the reason names the angle {angle:.1}°: {}",
                cell("hot_spot")
            );
            // The largest worst-direction σ as the grid summary computes it apart.
            let max = l["summary"]["max_sigma_worst_mm"].as_f64().expect("max");
            let hs = hot["sigma_worst_mm"].as_f64().expect("σ");
            assert!(
                (hs - max).abs() <= 1e-12 * max,
                "{name}: hot spot {hs} vs summary {max}"
            );
        }
        if let Some(d) = v["dominant_input"].as_object() {
            let c = cell("dominant_input");
            assert!(
                c.starts_with(d["input"].as_str().expect("input")),
                "{name}: {c}"
            );
            assert!(
                c.contains(&format!(
                    "{} → {}",
                    mm(&d["sigma_worst_mm"]),
                    mm(&d["sigma_worst_halved_mm"])
                )),
                "{name}: {c}"
            );
        }
        // Counts add up; "not measurable" is never counted as above the threshold.
        let n = v["points"].as_u64().expect("points");
        let count = |k: &str| v[k].as_u64().expect(k);
        assert_eq!(
            count("points_measurable")
                + count("points_seen_by_fewer_than_two")
                + count("points_degenerate"),
            n
        );
        assert_eq!(
            count("points_below_threshold") + count("points_above_threshold"),
            measurable
        );
        // Below the threshold in every direction over the whole grid = below of measurable ×
        // measurable share (the summary's own count, over all points).
        let all = l["summary"]["fraction_worst_below_threshold"]
            .as_f64()
            .expect("share");
        assert!(
            (all - count("points_below_threshold") as f64 / n as f64).abs() < 1e-12,
            "{name}"
        );
        assert_eq!(reached, count("points_below_threshold") == n, "{name}");
    }
}
