//! The typed documents of `crashrig_study::contract` print exactly the bytes of the `json!`
//! builders they replaced (issue 23): `calibrate --json` ([`CalibrationResult::to_json`]) on
//! the rig fixtures (with outliers, drift, refinement, both scale sources) and a study's
//! `results.json` ([`StudyResult::to_json`], propagation, fixed and given observers, `[tie]`,
//! `[measure]`). The oracle is main's `json!` code before the change (commit 86e7aee), kept
//! here verbatim: the pinned manifest does not hash these documents. Serialising the
//! calibration struct directly gives the same bytes too (its fields are in key order).

use crashrig_calibrate::{CalibrationConfig, CalibrationResult, ResolvedScale, Scale, calibrate};
use crashrig_geometry::{Mat6, UncertainPose, Vec3, opk};
use crashrig_rig::robust::outlier_rule_description;
use crashrig_rig::stats::LinkStatistics;
use crashrig_rig::{DriftReport, Refinement};
use crashrig_study::Study;
use crashrig_study::contract::covariance_deg_rows;
use crashrig_study::study_file::ObserverNoise;
use crashrig_study::{Options, StudyResult, run_study};
use crashrig_tie::TieResult;
use nalgebra::Vector3;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

const PARAMS: [&str; 6] = ["x", "y", "z", "omega", "phi", "kappa"];
const TANGENT: [&str; 6] = ["x", "y", "z", "theta_x", "theta_y", "theta_z"];
const REFINED_LABEL: &str = "a weighted mean of the same per-epoch poses (not independent \
evidence); covariance from the normal equations, which treat the epochs as independent, \
raised on each tangent axis to at least sem_covariance_tangent";

fn deg3(v: &Vec3) -> [f64; 3] {
    [v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees()]
}

fn arr3(v: &Vec3) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

fn cov_deg(c: &Mat6) -> Vec<Vec<f64>> {
    let f = |k: usize| if k < 3 { 1.0 } else { 1f64.to_degrees() };
    (0..6)
        .map(|i| (0..6).map(|j| c[(i, j)] * f(i) * f(j)).collect())
        .collect()
}

fn stats_json(s: &LinkStatistics) -> Value {
    json!({
        "n_epochs": s.n,
        "base_mm": arr3(&s.base_mm),
        "base_sigma_mm": arr3(&s.base_sigma_mm),
        "base_sem_mm": arr3(&s.base_sem_mm),
        "angles_deg": deg3(&s.angles),
        "angles_sigma_deg": deg3(&s.angles_sigma),
        "angles_sem_deg": deg3(&s.angles_sem),
        "mean_rotation_angles_deg": deg3(&s.mean_rotation_angles),
        "covariance": cov_deg(&s.covariance),
    })
}

fn refined_json(r: &Refinement) -> Value {
    json!({
        "base_mm": arr3(&r.base_mm),
        "base_sigma_mm": arr3(&r.base_sigma_mm),
        "angles_deg": deg3(&r.angles),
        "angles_sigma_deg": deg3(&r.angles_sigma),
        "covariance": cov_deg(&r.covariance),
        "covariance_tangent": cov_deg(&r.tangent_covariance),
        "covariance_tangent_independent": cov_deg(&r.tangent_covariance_independent),
        "floor_factors": r.floor_factors,
        "what": REFINED_LABEL,
        "sigma_rotation_deg": deg3(&r.sigma_rotation),
        "sigma_position_mm": arr3(&r.sigma_position_mm),
        "variance_factor": r.variance_factor,
        "n_unknowns": r.n_unknowns,
        "redundancy": r.redundancy,
        "iterations": r.iterations,
    })
}

fn opk_deg(u: &UncertainPose) -> [f64; 3] {
    let a = opk::opk_from_rotation(&u.rotation());
    [
        a.omega.to_degrees(),
        a.phi.to_degrees(),
        a.kappa.to_degrees(),
    ]
}

fn drift_json(d: &DriftReport) -> Value {
    json!({
        "order": PARAMS,
        "lags": d.autocorrelation,
        "effective_n": d.effective_n,
        "sem_inflation": d.sem_inflation,
        "white_noise_band": d.white_noise_band,
        "sem_optimistic": d.optimistic,
        "warning": d.any_optimistic(),
    })
}

/// Main's `CalibrationResult::to_json` before the change.
fn calibration_before(r: &CalibrationResult) -> Value {
    let c = &r.calibration;
    let epochs: Vec<Value> = c
        .links
        .iter()
        .zip(&c.outliers.outlier)
        .zip(&c.outliers.z_scores)
        .map(|((l, o), z)| {
            json!({
                "name": l.name,
                "base_mm": arr3(&l.base_mm),
                "angles_deg": deg3(&l.angles),
                "outlier": o,
                "z_scores": z,
            })
        })
        .collect();
    let scale_json = match &r.scale {
        ResolvedScale::Bar(b) => json!({
            "source": "scale_bar", "point_ids": [b.point_1, b.point_2],
            "length_mm": b.length_mm, "distance_units": b.distance_units,
        }),
        ResolvedScale::Given(_) => json!({"source": "mm_per_unit"}),
        ResolvedScale::Default => json!({"source": "default"}),
    };
    let set = &r.pairing;
    let mut out = stats_json(&c.all);
    let extra = json!({
        "model": r.config.model.display().to_string(),
        "camera_a": r.config.camera_a,
        "camera_b": r.config.camera_b,
        "mm_per_unit": c.mm_per_unit,
        "scale_factor": c.mm_per_unit,
        "scale": scale_json,
        "link": {
            "base_mm": arr3(&r.link.center()),
            "angles_deg": opk_deg(&r.link),
        },
        "covariance_tangent": cov_deg(&r.epoch_covariance),
        "sem_covariance_tangent": cov_deg(&r.link.covariance),
        "sem_rule": r.sem_rule,
        "effective_n": r.effective_n,
        "sem_reliable": r.sem_reliable,
        "sem_detail": {
            "order": TANGENT,
            "lag1": c.sem.lag1,
            "drift_rho": c.sem.drift_rho,
            "drift_share": c.sem.drift_share,
            "small_sample_factor": c.sem.small_sample_factor,
            "autocorrelated": c.sem.autocorrelated,
            "variance_inflation": c.sem.inflation,
        },
        "rig_constrained": c.rig_constrained,
        "outlier_rule": outlier_rule_description(c.links.len()),
        "outlier_threshold": c.outliers.threshold,
        "outlier_thresholds": c.outliers.thresholds,
        "n_outliers": c.outliers.indices().len(),
        "without_outliers": c.without_outliers.as_ref().map(stats_json),
        "autocorrelation": c.drift.as_ref().map(drift_json),
        "refined": c.refined.as_ref().map(refined_json),
        "refined_without_outliers": c.refined_without_outliers.as_ref().map(refined_json),
        "pairing": {
            "by_name": set.paired_by_name,
            "by_frame": set.paired_by_frame,
            "unpaired_a": set.unpaired_a,
            "unpaired_b": set.unpaired_b,
            "without_pose": set.without_pose,
        },
        "warnings": r.warnings,
        "epochs": epochs,
    });
    if let (Some(o), Value::Object(e)) = (out.as_object_mut(), extra) {
        o.extend(e);
    }
    out
}

fn v3deg(v: Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

fn sigma_parts(c: &Mat6) -> (Vector3<f64>, Vector3<f64>) {
    (
        Vector3::new(c[(0, 0)], c[(1, 1)], c[(2, 2)]).map(|v| v.max(0.0).sqrt()),
        Vector3::new(c[(3, 3)], c[(4, 4)], c[(5, 5)]).map(|v| v.max(0.0).sqrt()),
    )
}

/// Main's `StudyResult::to_json` before the change.
fn results_before(r: &StudyResult) -> Value {
    let cameras: Vec<Value> = r
        .chain
        .iter()
        .map(|c| {
            let m = &c.mc;
            json!({
                "name": c.camera.name(),
                "position_mm": <[f64; 3]>::from(m.nominal.position_mm),
                "angles_deg": v3deg(m.nominal.angles_rad()),
                "position_sigma_mm": <[f64; 3]>::from(m.position_sigma_mm),
                "angles_sigma_deg": v3deg(m.angles_sigma_rad),
                "tangent_sigma_deg": v3deg(m.tangent_sigma_rad),
                "covariance_tangent": covariance_deg_rows(&m.covariance_tangent),
                "angles_singular": m.angles_singular,
                "linear": {
                    "position_sigma_mm": <[f64; 3]>::from(c.linear.position_sigma_mm),
                    "angles_sigma_deg": c.linear.angles_sigma_rad.map(v3deg),
                    "tangent_sigma_deg": v3deg(c.linear.tangent_sigma_rad),
                    "covariance_tangent": covariance_deg_rows(&c.linear.covariance_tangent),
                },
            })
        })
        .collect();
    let layouts: Vec<Value> = r
        .layouts
        .iter()
        .map(|l| {
            json!({
                "name": l.layout.name,
                "dir": format!("grid/{}", l.layout.slug()),
                "description": l.layout.description,
                "correlated": l.result.correlated,
                "observers": l.grid.observers.iter().zip(&l.layout.observers).zip(&l.result.observer_covariance).map(|((o, lo), c)| {
                    let (p, a) = sigma_parts(c);
                    json!({
                        "name": o.name,
                        "position_mm": <[f64; 3]>::from(o.position_mm),
                        "from": match lo.noise { ObserverNoise::From(c) => Some(c.name()), ObserverNoise::Given(_) => None },
                        "sigma_position_mm": <[f64; 3]>::from(p),
                        "sigma_angles_deg": v3deg(a),
                        "covariance_tangent": covariance_deg_rows(c),
                    })
                }).collect::<Vec<_>>(),
                "summary": l.summary,
                "sensitivity": l.sensitivity,
            })
        })
        .collect();
    let mut v = json!({
        "seed": r.seed,
        "samples": r.samples,
        "calibration": calibration_before(&r.calibration),
        "tie": r.tie.as_ref().map(TieResult::to_json),
        "propagation": {"samples": r.chain_samples, "seed": r.seed, "rotation_noise": "tangent", "cameras": cameras},
        "layouts": layouts,
    });
    if let Some(m) = &r.measure {
        v["measure"] = json!({"dir": "measure", "summary": m.summary});
        if let Some(a) = &m.a_covariance {
            let mut j = a.to_json();
            if let Some(o) = j.as_object_mut() {
                o.remove("epochs");
                o.remove("joint");
            }
            j["file"] = json!("measure/a_covariance.json");
            v["measure"]["a_covariance"] = j;
        }
    }
    v
}

fn pretty(v: &Value) -> String {
    serde_json::to_string_pretty(v).unwrap()
}

fn rig_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/rig")
        .join(name)
}

fn calibrated(name: &str, scale: Scale) -> CalibrationResult {
    calibrate(
        &CalibrationConfig {
            model: rig_fixture(name),
            camera_a: "cam_out/".into(),
            camera_b: "cam_in/".into(),
            scale,
            ..CalibrationConfig::default()
        },
        None,
    )
    .unwrap()
}

#[test]
fn calibration_document_prints_the_bytes_of_the_json_builder_it_replaced() {
    let cases = [
        (
            "paper",
            Scale::ScaleBar {
                points: [1, 2],
                length_mm: 2000.0,
            },
        ),
        ("outliers", Scale::MmPerUnit(1000.0)),
        ("unpaired", Scale::Default),
    ];
    for (name, scale) in cases {
        let r = calibrated(name, scale);
        let want = pretty(&calibration_before(&r));
        assert_eq!(pretty(&r.to_json()), want, "{name}");
        // The struct's fields are declared in key order: direct serialisation agrees.
        assert_eq!(
            serde_json::to_string_pretty(&r.document()).unwrap(),
            want,
            "{name}"
        );
    }
    // The cases reach every optional part of the document.
    let outliers = calibrated("outliers", Scale::MmPerUnit(1000.0)).to_json();
    assert!(outliers["n_outliers"].as_u64().unwrap() > 0);
    for key in [
        "without_outliers",
        "autocorrelation",
        "refined",
        "refined_without_outliers",
    ] {
        assert!(!outliers[key].is_null(), "{key}");
    }
}

#[test]
fn results_document_prints_the_bytes_of_the_json_builder_it_replaced() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/study/own/study.toml");
    let study = Study::from_path(&path).expect("study");
    let r = run_study(
        &study,
        &Options {
            samples: Some(100),
            no_sensitivity: false,
            seed: Some(5),
            ..Options::default()
        },
    )
    .expect("study");
    assert!(r.tie.is_some() && r.measure.is_some());
    assert!(r.layouts.iter().any(|l| !l.sensitivity.is_empty()));
    // Issue 38 extended the document (never removed or renamed a field): without its new
    // fields it is byte for byte the builder's.
    let now = r.to_json();
    for l in now["layouts"].as_array().expect("layouts") {
        assert!(l["verdict"].is_object(), "layouts[].verdict");
    }
    assert!(now["calibration_quality"].is_object());
    assert_eq!(
        pretty(&without_issue_38_fields(now)),
        pretty(&without_issue_38_fields(results_before(&r)))
    );
}

/// `v` without the fields issue 38 added: `calibration_quality`, `layouts[].verdict` and
/// `layouts[].sensitivity[].{median_sigma_worst_mm, hot_spot_sigma_worst_mm}`.
fn without_issue_38_fields(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("calibration_quality");
    }
    for l in v["layouts"].as_array_mut().into_iter().flatten() {
        if let Some(o) = l.as_object_mut() {
            o.remove("verdict");
        }
        for s in l["sensitivity"].as_array_mut().into_iter().flatten() {
            if let Some(o) = s.as_object_mut() {
                o.remove("median_sigma_worst_mm");
                o.remove("hot_spot_sigma_worst_mm");
            }
        }
    }
    v
}
