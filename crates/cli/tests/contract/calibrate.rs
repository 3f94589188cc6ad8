//! `crashrig calibrate`: JSON shape and the numpy statistics of `fixtures/rig/*/expected.json`.

use crate::contract::common::{
    angle_diff_deg, arr3, assert_clean_error, boolean, field, fixture, json_of, matrix, num,
    numbers, read_json, run, string, uint,
};
use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::{Rot3, Vec3, opk::rotation_from_opk, so3};
use serde_json::Value;

/// Runs `calibrate --json` on `fixtures/rig/<name>` with extra arguments; checks every field
/// the contract names, with its type and shape.
fn calibrate(name: &str, extra: &[&str]) -> Value {
    let dir = fixture(&format!("rig/{name}"));
    let mut args: Vec<String> = vec![
        "calibrate".into(),
        dir.display().to_string(),
        "--camera-a".into(),
        "cam_out/".into(),
        "--camera-b".into(),
        "cam_in/".into(),
        "--json".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let v = json_of(&run(&args));
    let n = uint(&v, "n_epochs");
    for k in [
        "base_mm",
        "base_sigma_mm",
        "base_sem_mm",
        "angles_deg",
        "angles_sigma_deg",
        "angles_sem_deg",
    ] {
        arr3(&v, k);
    }
    num(&v, "mm_per_unit");
    matrix(&v, "covariance", 6);
    matrix(&v, "covariance_tangent", 6);
    matrix(&v, "sem_covariance_tangent", 6);
    string(&v, "sem_rule");
    let epochs = field(&v, "epochs").as_array().expect("epochs is an array");
    assert_eq!(epochs.len() as u64, n, "one entry per epoch");
    for e in epochs {
        string(e, "name");
        arr3(e, "base_mm");
        arr3(e, "angles_deg");
        boolean(e, "outlier");
    }
    v
}

/// Checks base/angles mean, σ and SEM against the numpy `stats` of an expected.json.
/// Tolerance 1e-6 mm / 1e-6 deg: the brief's acceptance bound; both sides are computed in
/// f64 from the same links, which the generator checked to < 1e-9 after the model round trip.
fn assert_stats(v: &Value, stats: &Value) {
    for k in [
        "base_mm",
        "base_sigma_mm",
        "base_sem_mm",
        "angles_sigma_deg",
        "angles_sem_deg",
    ] {
        let (a, b) = (arr3(v, k), arr3(stats, k));
        for i in 0..3 {
            assert_abs_diff_eq!(a[i], b[i], epsilon = 1e-6);
        }
    }
    // Mean angles: compared modulo 360° (the contract does not fix the output range).
    let (a, b) = (arr3(v, "angles_deg"), arr3(stats, "angles_deg"));
    for i in 0..3 {
        assert_abs_diff_eq!(angle_diff_deg(a[i], b[i]), 0.0, epsilon = 1e-6);
    }
}

#[test]
fn calibrate_nominal() {
    let v = calibrate(
        "paper",
        &["--scale-points", "1", "2", "--scale-length-mm", "2000"],
    );
    let e = read_json(&fixture("rig/paper/expected.json"));
    let stats = field(&e, "stats");
    assert_eq!(uint(&v, "n_epochs"), uint(stats, "n"));
    assert_stats(&v, stats);
    // The scale bar gives the generator's model unit (1/2.7 m); 1e-9 relative: a ratio of
    // two f64 lengths.
    assert_relative_eq!(
        num(&v, "mm_per_unit"),
        num(&e, "mm_per_unit"),
        max_relative = 1e-9
    );
    // Covariance: numpy's 6×6 (ddof = 1), x y z mm and ω φ κ deg; 1e-6 absolute as above.
    let (c, ce) = (matrix(&v, "covariance", 6), matrix(stats, "covariance", 6));
    for i in 0..6 {
        for j in 0..6 {
            assert_abs_diff_eq!(c[i][j], ce[i][j], epsilon = 1e-6);
        }
    }
}

#[test]
fn calibrate_epochs_match_injected_links() {
    let v = calibrate(
        "paper",
        &["--scale-points", "1", "2", "--scale-length-mm", "2000"],
    );
    let e = read_json(&fixture("rig/paper/expected.json"));
    let got = field(&v, "epochs").as_array().expect("array");
    let want = field(&e, "epochs").as_array().expect("array");
    assert_eq!(got.len(), want.len());
    let outliers: Vec<u64> = field(&e, "outliers")
        .as_array()
        .expect("outliers")
        .iter()
        .map(|x| x.as_u64().expect("index"))
        .collect();
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(string(g, "name"), string(w, "name"), "epoch {i}");
        // 1e-6 mm / deg: per-epoch links survive the pycolmap model round trip to < 1e-9.
        let (a, b) = (arr3(g, "base_mm"), arr3(w, "base_mm"));
        for k in 0..3 {
            assert_abs_diff_eq!(a[k], b[k], epsilon = 1e-6);
        }
        let (a, b) = (arr3(g, "angles_deg"), arr3(w, "angles_deg"));
        for k in 0..3 {
            assert_abs_diff_eq!(angle_diff_deg(a[k], b[k]), 0.0, epsilon = 1e-6);
        }
        assert_eq!(
            boolean(g, "outlier"),
            outliers.contains(&(i as u64)),
            "epoch {i} outlier flag"
        );
    }
}

#[test]
fn calibrate_sem_is_sigma_over_sqrt_n() {
    // Contract: σ is the n−1 sample standard deviation, SEM = σ/√n; the covariance diagonal
    // is σ². 1e-12 relative: the same f64 quantities, one division or product apart.
    let v = calibrate("wrap", &["--mm-per-unit", "1"]);
    let n = uint(&v, "n_epochs") as f64;
    let c = matrix(&v, "covariance", 6);
    for (k, (s, sem)) in [
        ("base_sigma_mm", "base_sem_mm"),
        ("angles_sigma_deg", "angles_sem_deg"),
    ]
    .into_iter()
    .enumerate()
    {
        let (s, sem) = (arr3(&v, s), arr3(&v, sem));
        for i in 0..3 {
            assert_relative_eq!(sem[i], s[i] / n.sqrt(), max_relative = 1e-12);
            assert_relative_eq!(c[3 * k + i][3 * k + i], s[i] * s[i], max_relative = 1e-9);
        }
    }
}

#[test]
fn calibrate_wrap_safe_angles() {
    // ω and κ straddle ±180°: the contract requires the small spread (σ ≈ 0.04°), never ~100°.
    let v = calibrate("wrap", &["--mm-per-unit", "1"]);
    let e = read_json(&fixture("rig/wrap/expected.json"));
    assert_stats(&v, field(&e, "stats"));
}

#[test]
fn calibrate_flags_injected_outliers() {
    // fixtures/rig/outliers has gross errors injected at epochs 9, 29 and 44.
    let v = calibrate("outliers", &["--mm-per-unit", "1000"]);
    let epochs = field(&v, "epochs").as_array().expect("array");
    for i in [9usize, 29, 44] {
        assert!(boolean(&epochs[i], "outlier"), "epoch {i} must be flagged");
    }
    // Statistics are over all epochs (outliers included).
    let e = read_json(&fixture("rig/outliers/expected.json"));
    assert_stats(&v, field(&e, "stats"));
}

#[test]
fn calibrate_mm_per_unit_equals_scale_bar() {
    // `--mm-per-unit F` with the generator's model unit gives the scale-bar result.
    let e = read_json(&fixture("rig/paper/expected.json"));
    let f = num(&e, "mm_per_unit").to_string();
    let v = calibrate("paper", &["--mm-per-unit", f.as_str()]);
    assert_stats(&v, field(&e, "stats"));
}

/// `calibrate --json` on the rig-constrained `shared_frame` model with camera ids 1 and 2.
fn shared_frame(extra: &[&str]) -> crate::contract::common::Run {
    let dir = fixture("rig/shared_frame");
    let mut args = vec![
        "calibrate".to_string(),
        dir.display().to_string(),
        "--camera-a".into(),
        "1".into(),
        "--camera-b".into(),
        "2".into(),
        "--json".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    run(&args)
}

#[test]
fn calibrate_rig_constrained_model_is_refused() {
    // Every epoch of `shared_frame` has exactly the nominal link (a bundle adjusted with a rig
    // constraint): one error line that names the model, says why and what to do (issue 12).
    let r = shared_frame(&[]);
    assert_clean_error(
        &r,
        &[
            "shared_frame",
            "rig constraint",
            "without rig constraints",
            "--accept-rig-constrained",
        ],
    );
}

#[test]
fn calibrate_camera_ids_and_shared_frames() {
    // Images `left_*`/`right_*` do not pair by name; epochs come from shared frames, and A/B
    // are given as camera ids. Every epoch has exactly the nominal link (expected.json);
    // accepted for inspection only with the flag, and then marked so.
    let dir = fixture("rig/shared_frame");
    let r = shared_frame(&["--accept-rig-constrained"]);
    assert!(r.stderr.contains("rig-constrained"), "{}", r.stderr);
    let v = json_of(&r);
    let e = read_json(&dir.join("expected.json"));
    assert_eq!(uint(&v, "n_epochs"), uint(&e, "n_epochs"));
    assert!(boolean(&v, "rig_constrained"));
    assert_eq!(string(&v, "sem_rule"), "covariance_over_n");
    assert!(field(&v, "autocorrelation").is_null());
    // 1e-6 mm / deg: the generator checked the links to < 1e-9 after the model round trip.
    let (b, be) = (arr3(&v, "base_mm"), arr3(&e, "base_mm"));
    let (a, ae) = (arr3(&v, "angles_deg"), arr3(&e, "angles_deg"));
    for i in 0..3 {
        assert_abs_diff_eq!(b[i], be[i], epsilon = 1e-6);
        assert_abs_diff_eq!(angle_diff_deg(a[i], ae[i]), 0.0, epsilon = 1e-6);
    }
}

fn rotation_deg(a: [f64; 3]) -> Rot3 {
    rotation_from_opk(a[0].to_radians(), a[1].to_radians(), a[2].to_radians())
}

#[test]
fn calibrate_covariance_tangent_recomputed_from_epochs() {
    // Issue 10: `covariance_tangent` equals the covariance (n − 1) recomputed from the printed
    // per-epoch base and ω φ κ: residuals (base − link base, log(R̄ᵀ·R) in deg about B's axes)
    // about the printed mean link `link`.
    let v = calibrate(
        "paper",
        &["--scale-points", "1", "2", "--scale-length-mm", "2000"],
    );
    let link = field(&v, "link");
    let c_bar = Vec3::from(arr3(link, "base_mm"));
    let r_bar = rotation_deg(arr3(link, "angles_deg"));
    let epochs = field(&v, "epochs").as_array().expect("array");
    let n = epochs.len() as f64;
    let res: Vec<[f64; 6]> = epochs
        .iter()
        .map(|e| {
            let dc = Vec3::from(arr3(e, "base_mm")) - c_bar;
            let r = rotation_deg(arr3(e, "angles_deg"));
            let dr = so3::log(&(r_bar.inverse() * r)).map(f64::to_degrees);
            [dc.x, dc.y, dc.z, dr.x, dr.y, dr.z]
        })
        .collect();
    let mean: [f64; 6] = std::array::from_fn(|j| res.iter().map(|r| r[j]).sum::<f64>() / n);
    let got = matrix(&v, "covariance_tangent", 6);
    let sem = matrix(&v, "sem_covariance_tangent", 6);
    for i in 0..6 {
        for j in 0..6 {
            let want = res
                .iter()
                .map(|r| (r[i] - mean[i]) * (r[j] - mean[j]))
                .sum::<f64>()
                / (n - 1.0);
            // The per-epoch values pass through ω φ κ (1e-13 deg of rounding): 1e-9 relative
            // to the scale of the entry.
            let scale = (got[i][i] * got[j][j]).sqrt();
            assert_abs_diff_eq!(got[i][j], want, epsilon = 1e-9 * scale);
        }
    }
    // The mean of the residuals about the mean link is zero (it is their mean): 1e-9 σ.
    for j in 0..6 {
        assert_abs_diff_eq!(mean[j], 0.0, epsilon = 1e-9 * got[j][j].sqrt());
    }
    // The uncertainty of the mean is covariance_tangent / n scaled by √(f_i f_j), f the
    // rule's variance factors (1e-12 relative: a few roundings).
    assert_eq!(string(&v, "sem_rule"), "ar1_noise_fit_bound_pooled");
    let f = numbers(
        field(field(&v, "sem_detail"), "variance_inflation"),
        "variance_inflation",
        6,
    );
    // effective_n = n / (f / q), q the small-sample factor folded into f.
    let q = numbers(
        field(field(&v, "sem_detail"), "small_sample_factor"),
        "small_sample_factor",
        6,
    );
    let eff = numbers(field(&v, "effective_n"), "effective_n", 6);
    for j in 0..6 {
        assert!(
            f[j] >= q[j] && q[j] >= 1.0 && f[j] <= (n - 1.0) * 1.69,
            "f = {f:?}"
        );
        assert_abs_diff_eq!(eff[j], n * q[j] / f[j], epsilon = 1e-9 * n);
    }
    for i in 0..6 {
        for j in 0..6 {
            assert_abs_diff_eq!(
                sem[i][j],
                got[i][j] / n * (f[i] * f[j]).sqrt(),
                epsilon = 1e-12 * (got[i][i] * got[j][j] * f[i] * f[j]).sqrt() / n
            );
        }
    }
}

#[test]
fn calibrate_unpaired_images_are_skipped() {
    // Two images without a partner are left out; points 1 and 3 are a 2000 mm scale bar.
    let v = calibrate(
        "unpaired",
        &["--scale-points", "1", "3", "--scale-length-mm", "2000"],
    );
    let e = read_json(&fixture("rig/unpaired/expected.json"));
    let stats = field(&e, "stats");
    assert_eq!(uint(&v, "n_epochs"), uint(stats, "n"));
    assert_stats(&v, stats);
}
