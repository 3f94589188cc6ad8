//! A study whose `[measure]` names a CFC class and a trigger offset: the sequence is measured
//! with the filter (typed values from `crashrig_measure::run`), `DIR/measure/` gets
//! `kinematics.csv` and the kinematics plots, and the report its kinematics subsection with
//! numbers that are those of the written `kinematics.csv`.

use super::{Provenance, write_outputs};
use crate::html::Report;
use crate::kinematics_report::{MarkerKinematics, Spread, per_marker, section};
use crate::{Options, Study, run_study};
use std::collections::BTreeMap;
use std::path::Path;

/// Per marker: the largest σ over the three axes of each row of `kinematics.csv` columns
/// `first..first + 3` (rows with kinematics only).
fn csv_sigma(csv: &str, first: usize) -> BTreeMap<String, Vec<f64>> {
    let mut out: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for line in csv.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        if c[first].is_empty() {
            continue;
        }
        let s = (first..first + 3)
            .map(|i| c[i].parse::<f64>().expect("σ"))
            .fold(f64::NEG_INFINITY, f64::max);
        out.entry(c[1].to_string()).or_default().push(s);
    }
    out
}

#[test]
fn study_with_cfc_reports_its_kinematics() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "pixel_sigma_px = 0.3\n",
        "pixel_sigma_px = 0.3\ncfc = 60\ncfc_standard = \"iso6487\"\nsync_sigma_ms = 0.5\n",
    );
    let study = Study::from_toml_str(&text, &path).expect("study");
    let options = Options {
        samples: Some(60),
        no_sensitivity: true,
        ..Options::default()
    };
    let r = run_study(&study, &options).expect("study runs");
    let m = r.measure.as_ref().expect("[measure]");
    let k = m.measurement.kinematics.as_ref().expect("kinematics");
    assert_eq!(k.filter.class(), 60);
    assert_eq!(k.filter.standard().name(), "iso6487");
    assert!(k.rows_with_kinematics > 0);
    let ks = m.summary.kinematics.as_ref().expect("summary.kinematics");
    let sync = m.summary.sync_offset.as_ref().expect("summary.sync_offset");
    assert_eq!(sync.sigma_ms, 0.5);
    assert!(sync.variance_share.contains_key("filtered_displacement"));

    let tmp = tempfile::tempdir().unwrap();
    write_outputs(tmp.path(), &study, &r, &Provenance::default()).expect("outputs");
    let d = tmp.path().join("measure");
    let csv = std::fs::read_to_string(d.join("kinematics.csv")).expect("kinematics.csv");
    assert_eq!(
        csv.lines().next().unwrap(),
        crashrig_measure::output::KINEMATICS_HEADER
    );
    let markers = per_marker(&m.measurement);
    assert_eq!(markers.len(), m.measurement.markers.len());
    // The report's σ per marker are the written file's: σ_d columns 6–8, σ_v 12–14, σ_a 18–20.
    let check = |first: usize, pick: fn(&MarkerKinematics) -> Option<Spread>| {
        let from_csv = csv_sigma(&csv, first);
        for mk in &markers {
            let s = pick(mk).expect("σ");
            let v = &from_csv[&mk.marker];
            assert_eq!(v.len(), mk.rows, "{}", mk.marker);
            assert_eq!(s.max, v.iter().copied().fold(f64::NEG_INFINITY, f64::max));
            assert_eq!(
                s.median,
                crashrig_stats::summary::median(v).unwrap_or(f64::NAN)
            );
        }
    };
    check(6, |x| x.displacement_sigma_mm);
    check(12, |x| x.velocity_sigma_m_s);
    check(18, |x| x.acceleration_sigma_m_s2);
    // The largest σ over the markers is the summary's.
    let max_d = markers
        .iter()
        .map(|x| x.displacement_sigma_mm.unwrap().max)
        .fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(Some(max_d), ks.max_displacement_sigma_mm);

    for mk in &markers {
        let stem = mk.marker.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
        for ext in ["png", "svg"] {
            assert!(
                d.join(format!("plots/{stem}_kinematics.{ext}")).is_file(),
                "{stem}"
            );
        }
    }
    let html = std::fs::read_to_string(tmp.path().join("report.html")).unwrap();
    for needle in [
        "Kinematics: CFC 60 (ISO 6487)",
        "ISO 6487 Annex A",
        "σ of the filtered kinematics per marker",
        "How much of each σ comes from camera A&#39;s trigger offset (σ 0.5 ms",
        "filtered displacement",
        "±2σ bands",
        "--cfc 60 --cfc-standard iso6487 --sync-sigma-ms 0.5 --seed",
    ] {
        assert!(html.contains(needle), "report.html lacks {needle:?}");
    }
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tmp.path().join("results.json")).unwrap()).unwrap();
    assert_eq!(results["measure"]["summary"]["kinematics"]["cfc"], 60);

    // Without a filter the subsection is left out.
    let mut plain = m.clone();
    plain.measurement.kinematics = None;
    plain.summary.kinematics = None;
    let mut rep = Report::default();
    section(&mut rep, &plain, &[]);
    assert!(rep.blocks.is_empty());
}
