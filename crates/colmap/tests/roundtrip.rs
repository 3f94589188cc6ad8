//! Writer round trips: bin→bin byte-identical, bin→txt→bin byte-identical, and our text output
//! byte-identical to pycolmap's for the same model.

use crashrig_colmap::{ModelFormat, Reconstruction};

use crate::common::fixture;

const STEMS: [&str; 5] = ["cameras", "images", "points3D", "rigs", "frames"];

fn bytes(dir: &std::path::Path, stem: &str, ext: &str) -> Vec<u8> {
    std::fs::read(dir.join(format!("{stem}.{ext}"))).expect("file written")
}

#[test]
fn roundtrip_nominal() {
    let src = fixture("rig_opencv/bin");
    let m = Reconstruction::read(&src).expect("reads");
    let out = tempfile::tempdir().expect("tmp");
    m.write(out.path(), ModelFormat::Binary).expect("writes");
    for stem in STEMS {
        assert_eq!(
            bytes(&src, stem, "bin"),
            bytes(out.path(), stem, "bin"),
            "{stem}.bin"
        );
    }
}

#[test]
fn roundtrip_bin_txt_bin_is_bit_exact() {
    for name in [
        "rig_opencv/bin",
        "full_opencv/bin",
        "opencv_fisheye/bin",
        "simple_radial/bin",
        "all_models/bin",
    ] {
        let src = fixture(name);
        let m = Reconstruction::read(&src).expect("reads");
        let txt = tempfile::tempdir().expect("tmp");
        m.write(txt.path(), ModelFormat::Text).expect("writes text");
        let t = Reconstruction::read(txt.path()).expect("reads text");
        assert_eq!(t.format(), ModelFormat::Text);
        let bin = tempfile::tempdir().expect("tmp");
        t.write(bin.path(), ModelFormat::Binary)
            .expect("writes bin");
        for stem in STEMS {
            assert_eq!(
                bytes(&src, stem, "bin"),
                bytes(bin.path(), stem, "bin"),
                "{name}: {stem}.bin"
            );
        }
    }
}

#[test]
fn roundtrip_text_matches_pycolmap_bytes() {
    for name in ["rig_opencv", "full_opencv", "simple_radial"] {
        let m = Reconstruction::read(&fixture(&format!("{name}/bin"))).expect("reads");
        let out = tempfile::tempdir().expect("tmp");
        m.write(out.path(), ModelFormat::Text).expect("writes");
        let theirs = fixture(&format!("{name}/txt"));
        for stem in STEMS {
            let a = String::from_utf8(bytes(&theirs, stem, "txt")).expect("utf8");
            let b = String::from_utf8(bytes(out.path(), stem, "txt")).expect("utf8");
            assert_eq!(a, b, "{name}: {stem}.txt");
        }
    }
}

#[test]
fn roundtrip_text_to_bin_matches_pycolmap_bytes() {
    for name in ["rig_opencv", "full_opencv", "simple_radial"] {
        let m = Reconstruction::read(&fixture(&format!("{name}/txt"))).expect("reads");
        let out = tempfile::tempdir().expect("tmp");
        m.write(out.path(), ModelFormat::Binary).expect("writes");
        for stem in STEMS {
            assert_eq!(
                bytes(&fixture(&format!("{name}/bin")), stem, "bin"),
                bytes(out.path(), stem, "bin"),
                "{name}: {stem}.bin"
            );
        }
    }
}

#[test]
fn roundtrip_legacy_gains_rigs_and_frames() {
    let m = Reconstruction::read(&fixture("rig_opencv/legacy_txt")).expect("reads");
    assert!(m.is_legacy());
    let out = tempfile::tempdir().expect("tmp");
    m.write(out.path(), ModelFormat::Binary).expect("writes");
    let back = Reconstruction::read(out.path()).expect("reads back");
    assert!(!back.is_legacy());
    assert_eq!(back.rigs(), m.rigs());
    assert_eq!(back.frames(), m.frames());
    assert_eq!(back.images(), m.images());
    // The three legacy files are reproduced exactly.
    let legacy_bin = fixture("rig_opencv/legacy_bin");
    for stem in ["cameras", "images", "points3D"] {
        assert_eq!(
            bytes(&legacy_bin, stem, "bin"),
            bytes(out.path(), stem, "bin"),
            "{stem}.bin"
        );
    }
}

#[test]
fn roundtrip_handwritten_text() {
    let m = Reconstruction::read(&fixture("handwritten_txt")).expect("reads");
    let nine = m.image(9).expect("image 9");
    assert!(
        nine.points2d.is_empty(),
        "empty POINTS2D line gives no points"
    );
    let out = tempfile::tempdir().expect("tmp");
    m.write(out.path(), ModelFormat::Text).expect("writes");
    let back = Reconstruction::read(out.path()).expect("reads back");
    assert_eq!(back.images(), m.images());
    assert_eq!(back.points3d(), m.points3d());
    assert_eq!(back.cameras(), m.cameras());
    // "-0" survives as negative zero.
    assert!(back.image(3).expect("image 3").stored_cam_from_world.tvec[1].is_sign_negative());
}

#[test]
fn roundtrip_write_replaces_files_atomically() {
    let m = Reconstruction::read(&fixture("simple_radial/bin")).expect("reads");
    let out = tempfile::tempdir().expect("tmp");
    m.write(out.path(), ModelFormat::Binary)
        .expect("first write");
    m.write(out.path(), ModelFormat::Binary).expect("overwrite");
    let names: Vec<String> = std::fs::read_dir(out.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 5, "no temporary files left: {names:?}");
}

fn one_image_model(name: &str, sensor_pose: Option<crashrig_colmap::RawPose>) -> Reconstruction {
    use crashrig_camera::{Camera, ModelId};
    use crashrig_colmap::{CameraRecord, Frame, Image, RawPose, Rig, RigSensor, SensorId};
    let cam = |id| CameraRecord {
        camera_id: id,
        camera: Camera::new(ModelId::SimplePinhole, 10, 10, vec![5.0, 5.0, 5.0]).expect("valid"),
    };
    let image = |id, camera_id| Image {
        image_id: id,
        stored_cam_from_world: RawPose::IDENTITY,
        camera_id,
        name: format!("{name}{id}"),
        points2d: vec![],
    };
    let rig = Rig {
        rig_id: 1,
        ref_sensor: Some(SensorId::camera(1)),
        sensors: vec![RigSensor {
            sensor: SensorId::camera(2),
            sensor_from_rig: sensor_pose,
        }],
    };
    let frame = Frame {
        frame_id: 1,
        rig_id: 1,
        rig_from_world: RawPose {
            qvec: [0.0, 1.0, 0.0, 0.0],
            tvec: [1.0, 2.0, 3.0],
        },
        data_ids: vec![image(1, 1).data_id(), image(2, 2).data_id()],
    };
    Reconstruction::from_records(
        vec![cam(1), cam(2)],
        vec![rig],
        vec![frame],
        vec![image(1, 1), image(2, 2)],
        vec![],
    )
    .expect("consistent model")
}

#[test]
fn roundtrip_rig_composition_and_unknown_sensor_pose() {
    use approx::assert_abs_diff_eq;
    // sensor_from_rig = 180° about z with t = (0, 0, 1); rig_from_world = 180° about x, t = (1, 2, 3).
    let m = one_image_model(
        "img",
        Some(crashrig_colmap::RawPose {
            qvec: [0.0, 0.0, 0.0, 1.0],
            tvec: [0.0, 0.0, 1.0],
        }),
    );
    let reference = m.image_cam_from_world(1).expect("reference camera pose");
    let other = m.image_cam_from_world(2).expect("composed pose");
    let x = nalgebra::Point3::new(1.0, 1.0, 1.0);
    // Rx(180)·x + (1,2,3) = (2, 1, 2); then Rz(180)·(2,1,2) + (0,0,1) = (−2, −1, 3). Exact in f64.
    assert_abs_diff_eq!(
        (reference * x).coords,
        nalgebra::Vector3::new(2.0, 1.0, 2.0),
        epsilon = 1e-15
    );
    assert_abs_diff_eq!(
        (other * x).coords,
        nalgebra::Vector3::new(-2.0, -1.0, 3.0),
        epsilon = 1e-15
    );
    let unknown = one_image_model("img", None);
    assert!(unknown.image_cam_from_world(1).is_some());
    assert!(
        unknown.image_cam_from_world(2).is_none(),
        "unknown sensor_from_rig gives no pose"
    );
    assert!(unknown.image_cam_from_world(3).is_none(), "missing image");
}

#[test]
fn roundtrip_text_rejects_unwritable_names() {
    let m = one_image_model("bad\nname", None);
    let out = tempfile::tempdir().expect("tmp");
    let target = out.path().join("model");
    match m.write(&target, ModelFormat::Text) {
        Err(crashrig_colmap::Error::Unwritable { path, record, .. }) => {
            assert_eq!(path, target.join("images.txt"));
            assert_eq!(record, 0);
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(!target.exists(), "nothing written");
    // Binary holds any name except NUL bytes.
    m.write(&target, ModelFormat::Binary)
        .expect("binary writes");
    let back = Reconstruction::read(&target).expect("reads");
    assert_eq!(back.image(2).map(|i| i.name.as_str()), Some("bad\nname2"));
}
