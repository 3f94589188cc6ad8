//! Our reader equals pycolmap 4.2.1's reading of the same files (golden JSON next to each model).

use approx::assert_abs_diff_eq;
use crashrig_colmap::{RawPose, Reconstruction, SensorType};
use crashrig_geometry::{Rigid3, Vec3, projection_center};

use crate::common::{f, fv, golden_models, json, u};

/// Parsed numbers are bit-identical to pycolmap's (same decimal/binary source, both exact).
fn assert_same(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: length");
    for (x, y) in a.iter().zip(b) {
        assert!(x.to_bits() == y.to_bits() || x == y, "{what}: {x} != {y}");
    }
}

/// pycolmap normalizes quaternions too; the two normalisations may differ in the last ulps, so
/// rotation matrices agree to 1e-15 and translations are copied unchanged (1e-15 absolute
/// covers the −0/+0 of a copied zero).
fn assert_pose(ours: &Rigid3, golden: &serde_json::Value, what: &str) {
    let g = fv(golden);
    let theirs = RawPose::from_array([g[0], g[1], g[2], g[3], g[4], g[5], g[6]])
        .to_rigid()
        .expect("golden pose is valid");
    let r1 = ours.rotation.to_rotation_matrix();
    let r2 = theirs.rotation.to_rotation_matrix();
    assert_abs_diff_eq!(r1.matrix(), r2.matrix(), epsilon = 1e-15);
    assert_abs_diff_eq!(
        ours.translation.vector,
        theirs.translation.vector,
        epsilon = 1e-15
    );
    let _ = what;
}

fn sensor_code(t: SensorType) -> i64 {
    i64::from(t.code())
}

fn check_model(dir: &std::path::Path) {
    let g = json(&dir.join("golden.json"));
    let m = Reconstruction::read(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    assert_eq!(
        m.num_observations() as u64,
        u(&g["num_observations"]),
        "{}",
        dir.display()
    );

    let gc = g["cameras"].as_array().expect("cameras");
    let mut cams: Vec<_> = m.cameras().iter().collect();
    cams.sort_by_key(|c| c.camera_id);
    assert_eq!(cams.len(), gc.len());
    for (c, j) in cams.iter().zip(gc) {
        assert_eq!(u64::from(c.camera_id), u(&j["id"]));
        assert_eq!(c.camera.model.name(), j["model"].as_str().expect("name"));
        assert_eq!(c.camera.width, u(&j["width"]));
        assert_eq!(c.camera.height, u(&j["height"]));
        assert_same(&c.camera.params, &fv(&j["params"]), "camera params");
    }

    let gr = g["rigs"].as_array().expect("rigs");
    let mut rigs: Vec<_> = m.rigs().iter().collect();
    rigs.sort_by_key(|r| r.rig_id);
    assert_eq!(rigs.len(), gr.len());
    for (r, j) in rigs.iter().zip(gr) {
        assert_eq!(u64::from(r.rig_id), u(&j["id"]));
        let reference = r.ref_sensor.expect("ref sensor");
        assert_eq!(
            sensor_code(reference.sensor_type),
            j["ref_sensor"][0].as_i64().expect("type")
        );
        assert_eq!(u64::from(reference.id), u(&j["ref_sensor"][1]));
        let js = j["sensors"].as_array().expect("sensors");
        let mut sensors: Vec<_> = r.sensors.iter().collect();
        sensors.sort_by_key(|s| s.sensor);
        assert_eq!(sensors.len(), js.len());
        for (s, k) in sensors.iter().zip(js) {
            assert_eq!(
                sensor_code(s.sensor.sensor_type),
                k["type"].as_i64().expect("type")
            );
            assert_eq!(u64::from(s.sensor.id), u(&k["id"]));
            match s.sensor_from_rig {
                Some(p) => {
                    assert_pose(&p.to_rigid().expect("valid"), &k["pose"], "sensor_from_rig")
                }
                None => assert!(k["pose"].is_null()),
            }
        }
    }

    let gf = g["frames"].as_array().expect("frames");
    let mut frames: Vec<_> = m.frames().iter().collect();
    frames.sort_by_key(|f| f.frame_id);
    assert_eq!(frames.len(), gf.len());
    for (fr, j) in frames.iter().zip(gf) {
        assert_eq!(u64::from(fr.frame_id), u(&j["id"]));
        assert_eq!(u64::from(fr.rig_id), u(&j["rig_id"]));
        assert_pose(
            &fr.rig_from_world.to_rigid().expect("valid"),
            &j["rig_from_world"],
            "rig_from_world",
        );
        let mut ours: Vec<[i64; 3]> = fr
            .data_ids
            .iter()
            .map(|d| {
                [
                    sensor_code(d.sensor.sensor_type),
                    i64::from(d.sensor.id),
                    d.id as i64,
                ]
            })
            .collect();
        ours.sort();
        let theirs: Vec<[i64; 3]> = j["data_ids"]
            .as_array()
            .expect("data ids")
            .iter()
            .map(|d| [0, 1, 2].map(|k| d[k].as_i64().expect("int")))
            .collect();
        assert_eq!(ours, theirs);
    }

    let gi = g["images"].as_array().expect("images");
    let mut images: Vec<_> = m.images().iter().collect();
    images.sort_by_key(|i| i.image_id);
    assert_eq!(images.len(), gi.len());
    for (im, j) in images.iter().zip(gi) {
        assert_eq!(u64::from(im.image_id), u(&j["id"]));
        assert_eq!(im.name, j["name"].as_str().expect("name"));
        assert_eq!(u64::from(im.camera_id), u(&j["camera_id"]));
        let frame = m.image_frame(im.image_id).expect("image has a frame");
        assert_eq!(u64::from(frame.frame_id), u(&j["frame_id"]));
        let pose = m
            .image_cam_from_world(im.image_id)
            .expect("image has a pose");
        // Composition sensor_from_rig ∘ rig_from_world: a few ulps of a unit-scale product.
        let g7 = fv(&j["cam_from_world"]);
        let theirs = RawPose::from_array([g7[0], g7[1], g7[2], g7[3], g7[4], g7[5], g7[6]])
            .to_rigid()
            .expect("valid");
        assert_abs_diff_eq!(
            pose.rotation.to_rotation_matrix().matrix(),
            theirs.rotation.to_rotation_matrix().matrix(),
            epsilon = 1e-14
        );
        assert_abs_diff_eq!(
            pose.translation.vector,
            theirs.translation.vector,
            epsilon = 1e-13
        );
        let c = fv(&j["center"]);
        assert_abs_diff_eq!(
            projection_center(&pose),
            Vec3::new(c[0], c[1], c[2]),
            epsilon = 1e-13
        );
        let gp = j["points2D"].as_array().expect("points2D");
        assert_eq!(im.points2d.len(), gp.len(), "image {}", im.image_id);
        for (p, k) in im.points2d.iter().zip(gp) {
            assert_same(&p.xy, &[f(&k[0]), f(&k[1])], "point2D xy");
            let id = k[2].as_i64().expect("id");
            assert_eq!(p.point3d_id.map_or(-1, |v| v as i64), id);
        }
    }

    let gp = g["points3D"].as_array().expect("points3D");
    let mut points: Vec<_> = m.points3d().iter().collect();
    points.sort_by_key(|p| p.point3d_id);
    assert_eq!(points.len(), gp.len());
    for (p, j) in points.iter().zip(gp) {
        assert_eq!(p.point3d_id, u(&j["id"]));
        assert_same(&p.xyz, &fv(&j["xyz"]), "xyz");
        let rgb: Vec<u64> = j["color"].as_array().expect("rgb").iter().map(u).collect();
        assert_eq!(p.rgb.map(u64::from).to_vec(), rgb);
        assert_same(&[p.error], &[f(&j["error"])], "error");
        let track: Vec<[u64; 2]> = p
            .track
            .iter()
            .map(|t| [t.image_id.into(), t.point2d_idx.into()])
            .collect();
        let theirs: Vec<[u64; 2]> = j["track"]
            .as_array()
            .expect("track")
            .iter()
            .map(|t| [u(&t[0]), u(&t[1])])
            .collect();
        assert_eq!(track, theirs);
    }
}

#[test]
fn golden_nominal() {
    check_model(&crate::common::fixture("rig_opencv/bin"));
}

#[test]
fn golden_all_models() {
    for dir in golden_models() {
        check_model(&dir);
    }
}

#[test]
fn golden_every_camera_model_id() {
    let m = Reconstruction::read(&crate::common::fixture("all_models/bin")).expect("reads");
    let mut ids: Vec<i32> = m.cameras().iter().map(|c| c.camera.model.id()).collect();
    ids.sort();
    assert_eq!(ids, (0..18).collect::<Vec<_>>());
    // A name with spaces survives binary IO in full.
    assert_eq!(
        m.image_by_name("image with spaces.png").map(|i| i.image_id),
        Some(3)
    );
    // Issue 36: a name typed in another Unicode normal form finds it; none is suggested.
    assert_eq!(
        m.image_by_name("image with spaces.png\u{301}")
            .map(|i| i.image_id),
        None
    );
    assert_eq!(
        m.nearest_image_names("image with space.png", 1),
        vec!["image with spaces.png"]
    );
    // ... but not COLMAP's text format: it is flagged, and only it.
    assert_eq!(m.names_unsafe_for_text(), vec!["image with spaces.png"]);
    let w = m.text_format_warning().expect("a warning");
    assert!(
        w.starts_with("1 image name(s)") && w.contains("\"image with spaces.png\""),
        "{w}"
    );
    let clean = Reconstruction::read(&crate::common::fixture("rig_opencv/bin")).expect("reads");
    assert!(clean.names_unsafe_for_text().is_empty());
    assert_eq!(clean.text_format_warning(), None);
}

#[test]
fn golden_text_equals_binary() {
    for name in ["rig_opencv", "full_opencv", "simple_radial"] {
        let b = Reconstruction::read(&crate::common::fixture(&format!("{name}/bin"))).expect("bin");
        let t = Reconstruction::read(&crate::common::fixture(&format!("{name}/txt"))).expect("txt");
        assert_eq!(b.cameras(), t.cameras());
        assert_eq!(b.rigs(), t.rigs());
        assert_eq!(b.frames(), t.frames());
        assert_eq!(b.images(), t.images());
        assert_eq!(b.points3d(), t.points3d());
    }
}

#[test]
fn golden_legacy_builds_trivial_rigs_and_frames() {
    let m = Reconstruction::read(&crate::common::fixture("rig_opencv/legacy_bin")).expect("reads");
    assert!(m.is_legacy());
    assert_eq!(m.rigs().len(), m.cameras().len());
    for r in m.rigs() {
        assert!(r.sensors.is_empty());
        assert_eq!(r.ref_sensor.map(|s| s.id), Some(r.rig_id));
    }
    assert_eq!(m.frames().len(), m.images().len());
    // The poses agree with the five-file model, where they are composed from the rig.
    let five = Reconstruction::read(&crate::common::fixture("rig_opencv/bin")).expect("reads");
    assert!(!five.is_legacy());
    for im in five.images() {
        let a = five.image_cam_from_world(im.image_id).expect("pose");
        let b = m.image_cam_from_world(im.image_id).expect("pose");
        // images.bin stores the composed pose pycolmap computed: equal to rounding.
        assert_abs_diff_eq!(
            a.rotation.to_rotation_matrix().matrix(),
            b.rotation.to_rotation_matrix().matrix(),
            epsilon = 1e-14
        );
        assert_abs_diff_eq!(a.translation.vector, b.translation.vector, epsilon = 1e-13);
    }
}

#[test]
fn golden_stored_pose_matches_composed_pose() {
    let m = Reconstruction::read(&crate::common::fixture("rig_opencv/bin")).expect("reads");
    for im in m.images() {
        let (angle, dt) = m.stored_pose_deviation(im.image_id).expect("both poses");
        // pycolmap wrote the composed pose into images.bin: equal to rounding.
        assert_abs_diff_eq!(angle, 0.0, epsilon = 1e-7); // angle_to of nearly equal unit quaternions: ~sqrt(ulp)
        assert_abs_diff_eq!(dt, 0.0, epsilon = 1e-13);
    }
    // A deliberately inconsistent images.txt pose is reported, and ignored for the used pose.
    let tmp = crate::common::copy_dir(&crate::common::fixture("rig_opencv/txt"));
    let p = tmp.path().join("images.txt");
    let text = std::fs::read_to_string(&p).expect("read");
    let mut lines: Vec<String> = text.split('\n').map(str::to_owned).collect();
    let mut toks: Vec<String> = lines[4].split(' ').map(str::to_owned).collect();
    toks[7] = "100".into(); // TZ of the first image
    lines[4] = toks.join(" ");
    std::fs::write(&p, lines.join("\n")).expect("write");
    let bad = Reconstruction::read(tmp.path()).expect("reads");
    let id = bad.images()[0].image_id;
    let (_, dt) = bad.stored_pose_deviation(id).expect("both poses");
    assert!(dt > 90.0, "deviation {dt}");
    let used = bad.image_cam_from_world(id).expect("pose");
    let reference = m.image_cam_from_world(id).expect("pose");
    assert_abs_diff_eq!(
        used.translation.vector,
        reference.translation.vector,
        epsilon = 0.0
    );
}
