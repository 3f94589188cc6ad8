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
