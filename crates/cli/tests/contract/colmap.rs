//! `crashrig colmap info` (model and database) and `crashrig colmap convert`.

use crate::contract::common::{boolean, field, fixture, json_of, read_json, run, string, uint};
use serde_json::Value;
use std::path::Path;

/// Every model folder under `fixtures/colmap/` that has a pycolmap `golden.json`.
const MODELS: &[&str] = &[
    "rig_opencv/bin",
    "rig_opencv/txt",
    "rig_opencv/legacy_bin",
    "rig_opencv/legacy_txt",
    "full_opencv/bin",
    "full_opencv/txt",
    "opencv_fisheye/bin",
    "simple_radial/bin",
    "simple_radial/txt",
    "simple_radial/legacy_txt",
    "all_models/bin",
    "handwritten_txt",
];

const MODEL_FIELDS: &[&str] = &[
    "format",
    "legacy",
    "cameras",
    "rigs",
    "frames",
    "images",
    "points3D",
    "observations",
];

/// `colmap info --json` of a model directory, with the contract's fields and types checked.
fn model_info(dir: &Path) -> Value {
    let v = json_of(&run([
        "colmap".as_ref(),
        "info".as_ref(),
        dir.as_os_str(),
        "--json".as_ref(),
    ]));
    let format = string(&v, "format");
    assert!(
        format == "binary" || format == "text",
        "format must be binary|text, got {format}"
    );
    boolean(&v, "legacy");
    for k in &MODEL_FIELDS[2..] {
        uint(&v, k);
    }
    v
}

/// The golden counts of a model folder, as pycolmap reports them.
fn golden_counts(dir: &Path) -> [u64; 6] {
    let g = read_json(&dir.join("golden.json"));
    let len = |k: &str| {
        field(&g, k)
            .as_array()
            .unwrap_or_else(|| panic!("golden {k} is a list"))
            .len() as u64
    };
    [
        len("cameras"),
        len("rigs"),
        len("frames"),
        len("images"),
        len("points3D"),
        uint(&g, "num_observations"),
    ]
}

fn counts(v: &Value) -> [u64; 6] {
    [
        uint(v, "cameras"),
        uint(v, "rigs"),
        uint(v, "frames"),
        uint(v, "images"),
        uint(v, "points3D"),
        uint(v, "observations"),
    ]
}

#[test]
fn colmap_info_model_nominal() {
    let dir = fixture("colmap/rig_opencv/bin");
    let v = model_info(&dir);
    assert_eq!(string(&v, "format"), "binary");
    assert!(!boolean(&v, "legacy"));
    assert_eq!(counts(&v), golden_counts(&dir));
}

#[test]
fn colmap_info_model_every_fixture_matches_pycolmap() {
    for rel in MODELS {
        let dir = fixture(&format!("colmap/{rel}"));
        let v = model_info(&dir);
        assert_eq!(counts(&v), golden_counts(&dir), "{rel}");
        let binary = dir.join("cameras.bin").exists();
        assert_eq!(
            string(&v, "format"),
            if binary { "binary" } else { "text" },
            "{rel}"
        );
        let legacy = !dir.join("rigs.bin").exists() && !dir.join("rigs.txt").exists();
        assert_eq!(boolean(&v, "legacy"), legacy, "{rel}");
    }
}

#[test]
fn colmap_info_database_nominal() {
    let db = fixture("colmap/rig_opencv/database.db");
    let v = json_of(&run([
        "colmap".as_ref(),
        "info".as_ref(),
        db.as_os_str(),
        "--json".as_ref(),
    ]));
    for k in [
        "user_version",
        "cameras",
        "images",
        "rigs",
        "frames",
        "keypoints",
        "matched_pairs",
        "verified_pairs",
    ] {
        uint(&v, k);
    }
    let g = read_json(&fixture("colmap/rig_opencv/database_golden.json"));
    assert_eq!(uint(&v, "user_version"), uint(&g, "user_version"));
    assert_eq!(uint(&v, "cameras"), uint(&g, "num_cameras"));
    assert_eq!(uint(&v, "images"), uint(&g, "num_images"));
    assert_eq!(uint(&v, "rigs"), uint(&g, "num_rigs"));
    assert_eq!(uint(&v, "frames"), uint(&g, "num_frames"));
    assert_eq!(
        uint(&v, "matched_pairs"),
        uint(&g, "num_matched_image_pairs")
    );
    assert_eq!(
        uint(&v, "verified_pairs"),
        uint(&g, "num_verified_image_pairs")
    );
    // `keypoints` = images with a keypoints row: the golden lists `<image id>_rows` per image.
    let heads = field(&g, "keypoints_head")
        .as_object()
        .expect("keypoints_head is an object");
    let with_rows = heads
        .iter()
        .filter(|(k, v)| k.ends_with("_rows") && v.as_u64().is_some_and(|n| n > 0))
        .count() as u64;
    assert_eq!(uint(&v, "keypoints"), with_rows);
}

/// Runs `colmap convert IN OUT --to FMT` and expects success.
fn convert(input: &Path, output: &Path, to: &str) {
    let r = run([
        "colmap".as_ref(),
        "convert".as_ref(),
        input.as_os_str(),
        output.as_os_str(),
        "--to".as_ref(),
        to.as_ref(),
    ]);
    assert!(r.success, "convert failed: {}", r.stderr);
}

const FIVE: [&str; 5] = ["cameras", "images", "points3D", "rigs", "frames"];

#[test]
fn colmap_convert_txt_warns_about_names_with_whitespace() {
    // Issue 12 item 6: COLMAP's text format cannot hold "image with spaces.png".
    let tmp = tempfile::tempdir().expect("temp dir");
    let args = |src: &Path, out: &Path| {
        [
            "colmap".into(),
            "convert".into(),
            src.as_os_str().to_owned(),
            out.as_os_str().to_owned(),
            "--to".into(),
            "txt".into(),
        ]
    };
    let out = tmp.path().join("txt");
    let r = run(args(&fixture("colmap/all_models/bin"), &out));
    assert!(r.success, "{}", r.stderr);
    assert!(
        r.stderr
            .contains("warning: 1 image name(s) contain whitespace")
            && r.stderr.contains("\"image with spaces.png\""),
        "{}",
        r.stderr
    );
    let out = tmp.path().join("clean");
    let r = run(args(&fixture("colmap/rig_opencv/bin"), &out));
    assert!(
        r.success && !r.stderr.contains("whitespace"),
        "{}",
        r.stderr
    );
}

#[test]
fn colmap_convert_nominal() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let src = fixture("colmap/rig_opencv/bin");
    let txt = tmp.path().join("txt");
    convert(&src, &txt, "txt");
    for s in FIVE {
        assert!(txt.join(format!("{s}.txt")).is_file(), "{s}.txt written");
    }
    let v = model_info(&txt);
    assert_eq!(string(&v, "format"), "text");
    assert_eq!(counts(&v), golden_counts(&src));
}

#[test]
fn colmap_convert_bin_txt_bin_is_bit_exact() {
    // Contract: doubles survive bin→txt→bin bit-exactly. bin→txt→bin must give the same
    // bytes as writing the binary model directly (bin→bin).
    let tmp = tempfile::tempdir().expect("temp dir");
    for rel in ["rig_opencv/bin", "all_models/bin", "opencv_fisheye/bin"] {
        let src = fixture(&format!("colmap/{rel}"));
        let base = tmp.path().join(rel.replace('/', "_"));
        let (direct, txt, back) = (base.join("direct"), base.join("txt"), base.join("back"));
        convert(&src, &direct, "bin");
        convert(&src, &txt, "txt");
        convert(&txt, &back, "bin");
        for s in FIVE {
            let a = std::fs::read(direct.join(format!("{s}.bin"))).expect("direct file");
            let b = std::fs::read(back.join(format!("{s}.bin"))).expect("round-trip file");
            assert!(a == b, "{rel}: {s}.bin differs after bin→txt→bin");
        }
    }
}

#[test]
fn colmap_convert_legacy_writes_five_files() {
    // A 3.x three-file model comes out in the current five-file layout, with COLMAP's
    // trivial rigs and frames.
    let tmp = tempfile::tempdir().expect("temp dir");
    let src = fixture("colmap/rig_opencv/legacy_txt");
    let out = tmp.path().join("out");
    convert(&src, &out, "bin");
    for s in FIVE {
        assert!(out.join(format!("{s}.bin")).is_file(), "{s}.bin written");
    }
    let v = model_info(&out);
    assert!(!boolean(&v, "legacy"));
    assert_eq!(counts(&v), golden_counts(&src));
}

#[test]
fn colmap_convert_json_is_one_document() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let src = fixture("colmap/simple_radial/txt");
    let out = tmp.path().join("out");
    let r = run([
        "colmap".as_ref(),
        "convert".as_ref(),
        src.as_os_str(),
        out.as_os_str(),
        "--to".as_ref(),
        "bin".as_ref(),
        "--json".as_ref(),
    ]);
    let v = json_of(&r);
    assert!(v.is_object(), "convert --json prints an object, got {v}");
}
