//! The pooled step of `ar1_noise_fit_bound_pooled` against its numpy twin (external truth,
//! `fixtures/gen/sem_pooled_refusal.py` → `fixtures/rig/sem_pooled/expected.json`): the same
//! tangent residuals through `SemModel::estimate` give numpy's factor, variance factor and
//! refusal on every axis — a common slow drift that refuses all six axes, three drifting axes
//! beside three white ones, a resolved drift over 300 epochs, and white noise.

use crashrig_geometry::{Mat6, Vec6};
use crashrig_rig::sem::{RULE, SemModel};

#[test]
fn pooled_step_matches_numpy_including_refusals() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/rig/sem_pooled/expected.json"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(doc["rule"], RULE);
    let mut refused_somewhere = false;
    for s in doc["sequences"].as_array().unwrap() {
        let name = s["name"].as_str().unwrap();
        let n = s["n"].as_u64().unwrap() as usize;
        let residuals: Vec<Vec6> = s["residuals"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| Vec6::from_fn(|j, _| r[j].as_f64().unwrap()))
            .collect();
        assert_eq!(residuals.len(), n, "{name}");
        let covariance = residuals
            .iter()
            .fold(Mat6::zeros(), |c, r| c + r * r.transpose())
            / (n as f64 - 1.0);
        let est = SemModel::new(n).estimate(&residuals, &covariance);
        let numbers = |key: &str| -> Vec<f64> {
            s[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let (factor, inflation) = (numbers("factor"), numbers("inflation"));
        for j in 0..6 {
            let refused = s["refused"][j].as_bool().unwrap();
            refused_somewhere |= refused;
            assert_eq!(est.reliable[j], !refused, "{name} axis {j}: {est:?}");
            let f = n as f64 / est.effective_n[j];
            assert!(
                (f - factor[j]).abs() <= 1e-9 * factor[j],
                "{name} axis {j}: factor {f} against numpy's {}",
                factor[j]
            );
            assert!(
                (est.inflation[j] - inflation[j]).abs() <= 1e-9 * inflation[j],
                "{name} axis {j}: F·q {} against numpy's {}",
                est.inflation[j],
                inflation[j]
            );
        }
    }
    assert!(refused_somewhere, "the goldens must exercise the refusal");
}
