//! `crashrig bootstrap`: JSON shape and bit-identical output for any thread count.

use crate::contract::common::{
    angle_diff_deg, arr3, field, fixture, intervals3, json_of, read_json, run, run_env, string,
    uint,
};
use approx::assert_abs_diff_eq;
use serde_json::Value;

const IMAGE_A: &str = "cam_in/000001.png";
const IMAGE_B: &str = "cam_door/000001.png";

/// Arguments of a small bootstrap run on `fixtures/paper/twoview` (model in metres).
fn args(method: &str, iterations: usize, seed: u64, threads: Option<usize>) -> Vec<String> {
    let mut a = vec![
        "bootstrap".to_string(),
        fixture("paper/twoview/database.db").display().to_string(),
        "--model".into(),
        fixture("paper/twoview/model").display().to_string(),
        "--image-a".into(),
        IMAGE_A.into(),
        "--image-b".into(),
        IMAGE_B.into(),
        "--method".into(),
        method.into(),
        "--iterations".into(),
        iterations.to_string(),
        "--seed".into(),
        seed.to_string(),
        "--mm-per-unit".into(),
        "1000".into(),
        "--json".into(),
    ];
    if let Some(t) = threads {
        a.push("--threads".into());
        a.push(t.to_string());
    }
    a
}

/// Checks every field the contract names, with its type and shape.
fn check_shape(v: &Value, method: &str, iterations: u64) {
    assert_eq!(string(v, "method"), method);
    assert_eq!(uint(v, "iterations"), iterations);
    let n = uint(v, "n_correspondences");
    assert!(n > 0, "n_correspondences must be positive");
    assert!(uint(v, "failed_iterations") <= iterations);
    for k in ["base_mm", "base_sigma_mm", "angles_deg", "angles_sigma_deg"] {
        arr3(v, k);
    }
    for k in ["base_sigma_mm", "angles_sigma_deg"] {
        assert!(arr3(v, k).iter().all(|s| *s >= 0.0), "{k} must be ≥ 0");
    }
    let ci = field(v, "ci95");
    intervals3(ci, "base_mm");
    intervals3(ci, "angles_deg");
    // Extensions: which items were resampled, and the 6×6 tangent covariance (symmetric,
    // non-negative diagonal).
    assert!(["inliers", "matches"].contains(&string(v, "resampled")));
    assert!(uint(v, "n_resampled") > 0);
    let c = field(v, "covariance_tangent");
    let c: Vec<Vec<f64>> = (0..6)
        .map(|i| {
            (0..6)
                .map(|j| c[i][j].as_f64().expect("a number"))
                .collect()
        })
        .collect();
    for i in 0..6 {
        assert!(c[i][i] >= 0.0);
        for j in 0..6 {
            assert!((c[i][j] - c[j][i]).abs() <= 1e-12 * (c[i][i] * c[j][j]).sqrt());
        }
    }
}

#[test]
fn bootstrap_resample_matches_and_replicates_csv() {
    // The relative method on all 262 raw matches (12 gross mismatches): each replicate re-runs
    // LO-RANSAC; every replicate is written to the CSV.
    let tmp = tempfile::tempdir().expect("temp dir");
    let csv = tmp.path().join("replicates.csv");
    let mut a = args("relative", 6, 3, None);
    a.extend([
        "--resample".into(),
        "matches".into(),
        "--replicates".into(),
        csv.display().to_string(),
    ]);
    let v = json_of(&run(a));
    check_shape(&v, "relative", 6);
    assert_eq!(string(&v, "resampled"), "matches");
    assert_eq!(uint(&v, "n_candidates"), 262);
    assert_eq!(uint(&v, "n_resampled"), 262);
    let text = std::fs::read_to_string(&csv).expect("replicates written");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("replicate,x_mm,y_mm,z_mm,omega_deg,phi_deg,kappa_deg,tx_deg,ty_deg,tz_deg")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len() as u64, 6 - uint(&v, "failed_iterations"));
    assert!(rows.iter().all(|r| r.split(',').count() == 10));
    // The default is inlier resampling, and the text report says which was used.
    let v = json_of(&run(args("absolute", 4, 3, None)));
    assert_eq!(string(&v, "resampled"), "inliers");
    let mut a = args("absolute", 4, 3, None);
    a.retain(|s| s != "--json");
    let r = run(a);
    assert!(r.stdout.contains("resampled: the "), "{}", r.stdout);
}

#[test]
fn bootstrap_nominal() {
    let v = json_of(&run(args("absolute", 20, 7, None)));
    check_shape(&v, "absolute", 20);
    // Known value: truth.json holds the generator's `A_from_B` (mm). The fixture README gives
    // a bootstrap spread of about 0.1 mm and 0.03°, so 1 mm and 0.3° are ~10σ bounds.
    let truth = read_json(&fixture("paper/twoview/truth.json"));
    let t = field(&truth, "a_from_b");
    let base_true = arr3(t, "translation_mm");
    let base = arr3(&v, "base_mm");
    for i in 0..3 {
        assert_abs_diff_eq!(base[i], base_true[i], epsilon = 1.0);
    }
    let r = field(t, "rotation_matrix");
    let m = |i: usize, j: usize| r[i][j].as_f64().expect("matrix entry");
    // R = Rx(ω)·Ry(φ)·Rz(κ): r02 = sin φ, r12 = −sin ω cos φ, r22 = cos ω cos φ,
    // r01 = −cos φ sin κ, r00 = cos φ cos κ (the contract's convention, cos φ > 0 here).
    let opk_true = [
        (-m(1, 2)).atan2(m(2, 2)).to_degrees(),
        m(0, 2).asin().to_degrees(),
        (-m(0, 1)).atan2(m(0, 0)).to_degrees(),
    ];
    let opk = arr3(&v, "angles_deg");
    for i in 0..3 {
        assert_abs_diff_eq!(angle_diff_deg(opk[i], opk_true[i]), 0.0, epsilon = 0.3);
    }
    // Wrap-safe statistics: ω and κ sit at ±180°; their σ and 95 % intervals must be the
    // small spread (≈ 0.03°), never ~100° (1° is a > 30σ bound).
    let sig = arr3(&v, "angles_sigma_deg");
    let ci = intervals3(field(&v, "ci95"), "angles_deg");
    for i in 0..3 {
        assert!(sig[i] < 1.0, "angle σ {i} = {}° is not wrap-safe", sig[i]);
        assert!(
            ci[i][1] - ci[i][0] < 1.0,
            "angle interval {i} {:?} is not wrap-safe",
            ci[i]
        );
    }
}

#[test]
fn bootstrap_relative_shape() {
    let v = json_of(&run(args("relative", 20, 7, None)));
    check_shape(&v, "relative", 20);
}

#[test]
fn bootstrap_same_seed_any_thread_count() {
    // Contract: the same seed gives bit-identical output whatever the thread count
    // (`--threads N` or RAYON_NUM_THREADS). The bootstrap JSON has no timing fields, so the
    // whole stdout must be byte-identical.
    for method in ["absolute", "relative"] {
        let one = run(args(method, 24, 11, Some(1)));
        let two = run(args(method, 24, 11, Some(2)));
        let env = run_env(args(method, 24, 11, None), &[("RAYON_NUM_THREADS", "2")]);
        json_of(&one);
        assert!(
            one.stdout == two.stdout,
            "{method}: --threads 1 vs 2 differ"
        );
        assert!(
            one.stdout == env.stdout,
            "{method}: --threads 1 vs RAYON_NUM_THREADS=2 differ"
        );
    }
}

/// `--plots DIR` is replaced as a whole: a second run over the first run's plots succeeds (with
/// the replicates file kept inside `DIR`, which is the command's own too), and a directory
/// holding another file is refused with one `error:` line and left as it was.
#[test]
fn bootstrap_plots_directory_is_replaced_whole_or_refused() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let plots = tmp.path().join("plots");
    let mut a = args("absolute", 4, 3, None);
    a.extend([
        "--plots".into(),
        plots.display().to_string(),
        "--replicates".into(),
        plots.join("replicates.csv").display().to_string(),
    ]);
    for _ in 0..2 {
        json_of(&run(&a));
        assert_eq!(std::fs::read_dir(&plots).expect("plots").count(), 13);
    }
    std::fs::write(plots.join("notes.txt"), b"mine").expect("a foreign file");
    let r = run(&a);
    crate::contract::common::assert_clean_error(&r, &["notes.txt"]);
    assert_eq!(
        std::fs::read(plots.join("notes.txt")).expect("kept"),
        b"mine"
    );
    assert_eq!(std::fs::read_dir(&plots).expect("plots").count(), 14);
}
