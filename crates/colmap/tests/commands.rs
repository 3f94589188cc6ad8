//! The entries of `crashrig colmap info|convert|points` against the pycolmap goldens: counts,
//! tracks and pixels as pycolmap reports them, the JSON documents' keys in their order, and the
//! refusals (converting in place, an output holding foreign files, unknown ids and names).

use crate::common::{fixture, golden_models, json, u};
use crashrig_colmap::convert::{ConvertConfig, convert};
use crashrig_colmap::info::{database_info, model_info};
use crashrig_colmap::lookup::{Points, PointsQuery, TrackPixel, points};
use crashrig_colmap::{Error, ModelFormat, Reconstruction};

/// The length of a golden list.
fn len(v: &serde_json::Value) -> usize {
    v.as_array().expect("array").len()
}

#[test]
fn model_info_counts_are_pycolmaps() {
    for dir in golden_models() {
        let g = json(&dir.join("golden.json"));
        let info = model_info(&dir).unwrap();
        let name = dir.file_name().unwrap().to_str().unwrap();
        assert_eq!(info.cameras, len(&g["cameras"]), "{name}");
        assert_eq!(info.rigs, len(&g["rigs"]), "{name}");
        assert_eq!(info.frames, len(&g["frames"]), "{name}");
        assert_eq!(info.images, len(&g["images"]), "{name}");
        assert_eq!(info.points3d, len(&g["points3D"]), "{name}");
        assert_eq!(
            info.observations as u64,
            u(&g["num_observations"]),
            "{name}"
        );
        let rigs_file = dir.join("rigs.bin").exists() || dir.join("rigs.txt").exists();
        assert_eq!(info.legacy, !rigs_file, "{name}");
        let format = if name.ends_with("bin") {
            ModelFormat::Binary
        } else {
            ModelFormat::Text
        };
        assert_eq!(info.format, format, "{name}");
        assert!(info.warnings.is_empty(), "{name}: {:?}", info.warnings);
    }
}

#[test]
fn model_info_document_and_text() {
    let dir = fixture("rig_opencv/legacy_txt");
    let info = model_info(&dir).unwrap();
    // pycolmap: 4 cameras (one trivial rig each), 8 images (one frame each), 40 points, 320
    // observations; keys in alphabetical order, as the command has always printed them.
    assert_eq!(
        serde_json::to_string(&info).unwrap(),
        r#"{"cameras":4,"format":"text","frames":8,"images":8,"legacy":true,"observations":320,"points3D":40,"rigs":4}"#
    );
    let text = format!(
        "COLMAP model {}\n  format        text (legacy three-file model: trivial rigs and frames)\n  \
         cameras       4\n  rigs          4\n  frames        8\n  images        8\n  \
         points3D      40\n  observations  320\n",
        dir.display()
    );
    assert_eq!(info.text_report(), text);
}

#[test]
fn model_info_warns_when_images_store_another_pose() {
    let tmp = crate::common::copy_dir(&fixture("rig_opencv/txt"));
    let path = tmp.path().join("images.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    // Shift the stored translation of the first image record by 1 model unit along z: COLMAP
    // ignores it (the rig/frame pose is used), other tools would not.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let k = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let mut f: Vec<String> = lines[k].split(' ').map(str::to_string).collect();
    f[7] = (f[7].parse::<f64>().unwrap() + 1.0).to_string();
    lines[k] = f.join(" ");
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let info = model_info(tmp.path()).unwrap();
    let [w] = &info.warnings[..] else {
        panic!("one warning expected: {:?}", info.warnings)
    };
    assert!(
        w.starts_with("1 image(s) store a pose in images.* that differs")
            && w.contains("0.000e0 deg, 1.000e0 model units"),
        "{w}"
    );
}

#[test]
fn database_info_counts_are_pycolmaps() {
    let path = fixture("rig_opencv/database.db");
    let g = json(&fixture("rig_opencv/database_golden.json"));
    let info = database_info(&path).unwrap();
    let c = info.counts;
    assert_eq!(c.user_version, g["user_version"].as_i64().unwrap());
    assert_eq!(c.cameras, u(&g["num_cameras"]));
    assert_eq!(c.images, u(&g["num_images"]));
    assert_eq!(c.rigs, u(&g["num_rigs"]));
    assert_eq!(c.frames, u(&g["num_frames"]));
    assert_eq!(c.matched_pairs, u(&g["num_matched_image_pairs"]));
    assert_eq!(c.verified_pairs, u(&g["num_verified_image_pairs"]));
    // Every image of the fixture has a keypoints row (400 keypoints in all, 50 each).
    assert_eq!(c.keypoints, c.images);
    assert_eq!(
        serde_json::to_string(&info).unwrap(),
        r#"{"cameras":4,"frames":4,"images":8,"keypoints":8,"matched_pairs":28,"rigs":2,"user_version":4020100,"verified_pairs":28}"#
    );
    assert!(
        info.text_report()
            .ends_with("  keypoints       8 images\n  matched pairs   28\n  verified pairs  28 (with at least one inlier)\n")
    );
}

#[test]
fn convert_writes_the_model_in_the_asked_format() {
    let input = fixture("rig_opencv/legacy_txt");
    let out = tempfile::tempdir().unwrap();
    let output = out.path().join("model");
    let config = ConvertConfig {
        input: input.clone(),
        output: output.clone(),
        format: ModelFormat::Binary,
    };
    let done = convert(&config).unwrap();
    assert!(done.legacy_input && done.warnings.is_empty());
    assert_eq!((done.cameras, done.rigs, done.frames), (4, 4, 8));
    assert_eq!((done.images, done.points3d), (8, 40));
    let back = Reconstruction::read(&output).unwrap();
    assert_eq!(back.format(), ModelFormat::Binary);
    assert!(!back.is_legacy());
    assert_eq!(back.num_observations(), 320);
    let doc = serde_json::to_value(&done).unwrap();
    let keys: Vec<&str> = doc
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    let expected = [
        "cameras",
        "format",
        "frames",
        "images",
        "input",
        "legacy_input",
        "output",
        "points3D",
        "rigs",
    ];
    assert_eq!(keys, expected);
    assert_eq!(doc["format"], "binary");
    assert_eq!(
        done.text_report(),
        format!(
            "wrote binary model to {} (4 cameras, 8 images, 40 points3D)\n",
            output.display()
        )
    );
    // Again, as text, over the binary model: no binary file survives beside the new one.
    let again = ConvertConfig {
        format: ModelFormat::Text,
        ..config
    };
    convert(&again).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&output)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "cameras.txt",
            "frames.txt",
            "images.txt",
            "points3D.txt",
            "rigs.txt"
        ]
    );
}

#[test]
fn convert_refuses_its_input_and_foreign_files() {
    let tmp = crate::common::copy_dir(&fixture("rig_opencv/bin"));
    let in_place = ConvertConfig {
        input: tmp.path().to_path_buf(),
        output: tmp.path().join("."),
        format: ModelFormat::Text,
    };
    assert!(matches!(
        convert(&in_place),
        Err(Error::ConvertInPlace { .. })
    ));
    assert!(!tmp.path().join("cameras.txt").exists());
    let out = tempfile::tempdir().unwrap();
    std::fs::write(out.path().join("notes.csv"), "keep").unwrap();
    let foreign = ConvertConfig {
        output: out.path().to_path_buf(),
        ..in_place
    };
    let e = convert(&foreign).unwrap_err();
    assert!(matches!(e, Error::Staging { .. }), "{e}");
    assert!(e.to_string().contains("notes.csv"), "{e}");
    assert_eq!(std::fs::read_dir(out.path()).unwrap().count(), 1);
}

#[test]
fn points_by_id_gives_pycolmaps_track() {
    let dir = fixture("rig_opencv/bin");
    let g = json(&dir.join("golden.json"));
    let images = g["images"].as_array().unwrap();
    for gp in g["points3D"].as_array().unwrap().iter().take(5) {
        let id = u(&gp["id"]);
        let Points::Id([p]) = points(&dir, &PointsQuery::Id(id)).unwrap() else {
            panic!("one point expected")
        };
        assert_eq!(p.point3d_id, id);
        assert_eq!(p.xyz.to_vec(), crate::common::fv(&gp["xyz"]));
        assert_eq!(p.error_px, crate::common::f(&gp["error"]));
        let track: Vec<TrackPixel> = gp["track"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                let im = images.iter().find(|i| i["id"] == t[0]).unwrap();
                let xy = &im["points2D"][u(&t[1]) as usize];
                TrackPixel {
                    image: im["name"].as_str().unwrap().to_string(),
                    pixel: [crate::common::f(&xy[0]), crate::common::f(&xy[1])],
                }
            })
            .collect();
        assert_eq!(p.track_length, track.len());
        assert_eq!(p.track, track);
    }
    let e = points(&dir, &PointsQuery::Id(1 << 40)).unwrap_err();
    assert!(
        matches!(e, Error::NoPoint3D { id, .. } if id == 1 << 40),
        "{e}"
    );
}

#[test]
fn points_near_a_pixel_nearest_first() {
    let dir = fixture("rig_opencv/bin");
    let g = json(&dir.join("golden.json"));
    let im = &g["images"][0];
    let name = im["name"].as_str().unwrap().to_string();
    // pycolmap's first observation of the first image: found at distance 0, first.
    let xy = &im["points2D"][0];
    let pixel = [crate::common::f(&xy[0]), crate::common::f(&xy[1])];
    let query = PointsQuery::Near {
        image: name.clone(),
        pixel,
        radius_px: 300.0,
    };
    let Points::Near(rows) = points(&dir, &query).unwrap() else {
        panic!("rows expected")
    };
    assert_eq!(rows[0].point3d_id, u(&xy[2]));
    assert_eq!((rows[0].pixel, rows[0].distance_px), (pixel, 0.0));
    assert!(
        rows.windows(2)
            .all(|w| w[0].distance_px <= w[1].distance_px)
    );
    assert!(rows.iter().all(|r| r.distance_px <= 300.0));
    let doc = serde_json::to_string(&Points::Near(rows[..1].to_vec())).unwrap();
    assert!(
        doc.starts_with(r#"[{"distance_px":0.0,"error_px":"#),
        "{doc}"
    );
    let text = Points::Near(rows[..1].to_vec()).text_report();
    let head = format!(
        "{:>10} {:>12} {:>12} {:>12} {:>9} {:>9} {:>6}\n{} ",
        "point3D_id", "x", "y", "z", "u", "v", "track", rows[0].point3d_id
    );
    assert!(text.starts_with(&head), "{text}");
    // A name that is not in the model: the error names the model's nearest names (issue 36),
    // the nearest first (one letter off).
    let typo = format!("{name}x");
    let missing = PointsQuery::Near {
        image: typo.clone(),
        pixel,
        radius_px: 1.0,
    };
    let e = points(&dir, &missing).unwrap_err();
    let e = e.to_string();
    assert!(
        e.starts_with(&format!(
            "{}: image {typo:?} is not in the model; nearest: {name:?}, \"",
            dir.display()
        )),
        "{e}"
    );
    assert_eq!(e.matches(", \"").count(), 2, "three names: {e}");
}
