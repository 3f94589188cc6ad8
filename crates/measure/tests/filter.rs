//! The CFC filter against the goldens of `fixtures/gen/kinematics_goldens.py`
//! (`fixtures/kinematics/cfc_goldens.json`): an independent NumPy/SciPy implementation of both
//! standards from their formulas, and pyisomme's `Channel.cfc(..., method="ISO-6487")` for the
//! ISO variant, on a step, a chirp and two crash pulses.

use crashrig_measure::filter::{Cfc, Standard};
use serde_json::Value;
use std::path::Path;

#[test]
fn cfc_matches_numpy_and_pyisomme_goldens() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/kinematics/cfc_goldens.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let cases = doc["cases"].as_array().unwrap();
    assert_eq!(
        cases.len(),
        24,
        "every signal × class × standard the rate carries"
    );
    let nums = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let mut standards = [0usize; 2];
    for case in cases {
        let standard = Standard::parse(case["standard"].as_str().unwrap()).unwrap();
        standards[usize::from(standard == Standard::Iso6487)] += 1;
        let class = u32::try_from(case["cfc"].as_u64().unwrap()).unwrap();
        let f = Cfc::new(class, standard, case["frame_rate_hz"].as_f64().unwrap()).unwrap();
        let x = nums(&case["input"]);
        let expected = nums(&case["expected"]);
        let got = f.filter(&x);
        // Relative to the record's scale (a pointwise relative error is meaningless at zero
        // crossings): 1e-9 of the largest |expected|.
        let scale = expected.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let worst = got
            .iter()
            .zip(&expected)
            .fold(0.0_f64, |m, (g, e)| m.max((g - e).abs()));
        assert!(
            worst <= 1e-9 * scale,
            "{} CFC {class} {}: worst deviation {worst:e} of scale {scale}",
            case["signal"],
            standard.name()
        );
    }
    assert!(standards[0] >= 8 && standards[1] >= 8, "{standards:?}");
}

#[test]
fn the_two_standards_differ_at_the_ends_and_in_the_corner() {
    // A ramp that still moves at the end: ISO's point reflection keeps the slope, J211's
    // start at rest does not; in the middle both agree closely (corners 0.28 % apart).
    let x: Vec<f64> = (0..400).map(|i| 0.1 * f64::from(i)).collect();
    let j = Cfc::new(60, Standard::J211, 1000.0).unwrap().filter(&x);
    let iso = Cfc::new(60, Standard::Iso6487, 1000.0).unwrap().filter(&x);
    assert!((iso[399] - x[399]).abs() < 1e-6, "{}", iso[399]);
    assert!((j[399] - x[399]).abs() > 0.1, "{}", j[399]);
    assert!((j[200] - iso[200]).abs() < 1e-6);
}
