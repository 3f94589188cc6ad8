//! Checks against independent implementations (OpenCV, pycolmap) stored in
//! `fixtures/geometry/goldens.json` (provenance in `fixtures/geometry/README.md`).

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_geometry::triangulate::{View, dlt, dlt_homogeneous};
use crashrig_geometry::umeyama::align;
use crashrig_geometry::{Mat3, Mat6, Rot3, Vec3, projection_center, quat, se3, so3};
use nalgebra::{Matrix3x4, Vector2};
use serde_json::Value;

fn goldens() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/geometry/goldens.json"
    );
    let text = std::fs::read_to_string(path).expect("fixtures/geometry/goldens.json is committed");
    serde_json::from_str(&text).expect("goldens.json is valid JSON")
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn vec3(v: &Value) -> Vec3 {
    Vec3::from_row_slice(&floats(v))
}

fn mat3(v: &Value) -> Mat3 {
    Mat3::from_row_slice(&floats(v))
}

fn mat34(v: &Value) -> Matrix3x4<f64> {
    Matrix3x4::from_row_slice(&floats(v))
}

fn mat6(v: &Value) -> Mat6 {
    Mat6::from_row_slice(&floats(v))
}

#[test]
fn goldens_rodrigues() {
    let g = goldens();
    for case in g["rodrigues"].as_array().unwrap() {
        let w = vec3(&case["w"]);
        let expected = mat3(&case["matrix"]);
        // Two independent Rodrigues implementations: a few ulps apart.
        assert_abs_diff_eq!(*so3::exp(&w).matrix(), expected, epsilon = 1e-15);
        // Log of OpenCV's matrix: ~ε/sin(θ/2)·… at most ~1e-15 for these angles (up to π − 1e-7).
        let back = so3::log(&Rot3::from_matrix_unchecked(expected));
        assert_abs_diff_eq!(back, w, epsilon = 1e-14);
    }
}

#[test]
fn goldens_rigid() {
    let g = goldens();
    for case in g["rigid"].as_array().unwrap() {
        let q = floats(&case["q_wxyz"]);
        let t = floats(&case["t"]);
        let pose = quat::rigid_from_colmap([q[0], q[1], q[2], q[3]], [t[0], t[1], t[2]]).unwrap();
        let m: Matrix3x4<f64> = pose.to_homogeneous().fixed_view::<3, 4>(0, 0).into_owned();
        // Translations up to 2e3 mm: entries agree to ε·2e3 ≈ 5e-13.
        assert_abs_diff_eq!(m, mat34(&case["matrix"]), epsilon = 1e-12);
        let inv: Matrix3x4<f64> = pose
            .inverse()
            .to_homogeneous()
            .fixed_view::<3, 4>(0, 0)
            .into_owned();
        assert_abs_diff_eq!(inv, mat34(&case["inverse"]), epsilon = 1e-12);
        // The projection centre is the translation of the inverse (world_from_cam).
        let c = projection_center(&pose);
        assert_abs_diff_eq!(
            c,
            mat34(&case["inverse"]).column(3).into_owned(),
            epsilon = 1e-12
        );
        assert_abs_diff_eq!(se3::adjoint(&pose), mat6(&case["adjoint"]), epsilon = 1e-12);
    }
}

#[test]
fn goldens_compose() {
    let g = goldens();
    let poses: Vec<_> = g["rigid"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let q = floats(&c["q_wxyz"]);
            let t = floats(&c["t"]);
            quat::rigid_from_colmap([q[0], q[1], q[2], q[3]], [t[0], t[1], t[2]]).unwrap()
        })
        .collect();
    for case in g["compose"].as_array().unwrap() {
        let a = poses[case["a"].as_u64().unwrap() as usize];
        let b = poses[case["b"].as_u64().unwrap() as usize];
        let m: Matrix3x4<f64> = (a * b)
            .to_homogeneous()
            .fixed_view::<3, 4>(0, 0)
            .into_owned();
        // |t| up to ~5e3 mm after composition: ε·5e3 ≈ 1e-12.
        assert_abs_diff_eq!(m, mat34(&case["matrix"]), epsilon = 5e-12);
    }
}

#[test]
fn goldens_covariance_inverse() {
    let g = goldens();
    let case = &g["covariance_inverse"];
    let r = &g["rigid"][case["rigid"].as_u64().unwrap() as usize];
    let q = floats(&r["q_wxyz"]);
    let t = floats(&r["t"]);
    let pose = quat::rigid_from_colmap([q[0], q[1], q[2], q[3]], [t[0], t[1], t[2]]).unwrap();
    let ad_inv = se3::adjoint(&pose.inverse());
    let ours = ad_inv * mat6(&case["covar"]) * ad_inv.transpose();
    // Entries up to ~1e7 (translations of 2e3 mm squared): relative 1e-12.
    assert_relative_eq!(
        ours,
        mat6(&case["inverse_covar"]),
        max_relative = 1e-12,
        epsilon = 1e-9
    );
}

#[test]
fn goldens_umeyama() {
    let g = goldens();
    let case = &g["umeyama"];
    let to_points =
        |v: &Value| -> Vec<Vec3> { floats(v).chunks(3).map(Vec3::from_row_slice).collect() };
    let src = to_points(&case["src"]);
    let dst = to_points(&case["dst"]);
    let sim = align(&src, &dst, true).unwrap();
    // Same least-squares optimum from two SVD implementations: ~1e-14 relative on a problem with
    // singular-value ratios ~1; translations ~1e3 mm.
    assert_relative_eq!(
        sim.scale,
        case["sim3_scale"].as_f64().unwrap(),
        max_relative = 1e-12
    );
    assert_abs_diff_eq!(
        *sim.rotation.matrix(),
        mat3(&case["sim3_rotation"]),
        epsilon = 1e-12
    );
    assert_abs_diff_eq!(
        sim.translation,
        vec3(&case["sim3_translation"]),
        epsilon = 1e-9
    );
    let rigid = align(&src, &dst, false).unwrap();
    assert_abs_diff_eq!(
        *rigid.rotation.matrix(),
        mat3(&case["rigid_rotation"]),
        epsilon = 1e-12
    );
    assert_abs_diff_eq!(
        rigid.translation,
        vec3(&case["rigid_translation"]),
        epsilon = 1e-9
    );
}

#[test]
fn goldens_triangulate() {
    let g = goldens();
    let case = &g["triangulate"];
    let views: Vec<View> = case["cams_from_world"]
        .as_array()
        .unwrap()
        .iter()
        .zip(case["normalized"].as_array().unwrap())
        .map(|(c, n)| {
            let m = mat34(c);
            let r = Rot3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
            let t = m.column(3).into_owned();
            let n = floats(n);
            View {
                cam_from_world: quat::rigid_from_rotation(&r, &t),
                normalized: Vector2::new(n[0], n[1]),
            }
        })
        .collect();
    let truth = vec3(&case["point_true"]);
    let pycolmap = vec3(&case["point_pycolmap"]);
    // Noise-free views 1–2 m away: ours is exact to ~1e-12 relative.
    assert_relative_eq!(dlt(&views).unwrap(), truth, max_relative = 1e-11);
    assert_relative_eq!(
        dlt_homogeneous(&views).unwrap(),
        truth,
        max_relative = 1e-10
    );
    // pycolmap's own answer is only ~5e-8 mm from the truth (see README).
    assert_abs_diff_eq!(dlt(&views).unwrap(), pycolmap, epsilon = 1e-6);
}
