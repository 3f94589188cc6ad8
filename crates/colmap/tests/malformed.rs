//! Malformed inputs give typed errors naming the file and the line, record or offset.

use std::path::Path;

use crashrig_colmap::{Error, Reconstruction};

use crate::common::{copy_dir, fixture};

fn edit_text(dir: &Path, file: &str, f: impl FnOnce(&mut Vec<String>)) {
    let p = dir.join(file);
    let text = std::fs::read_to_string(&p).expect("readable");
    let mut lines: Vec<String> = text.split('\n').map(str::to_owned).collect();
    f(&mut lines);
    std::fs::write(&p, lines.join("\n")).expect("writable");
}

fn edit_bytes(dir: &Path, file: &str, f: impl FnOnce(&mut Vec<u8>)) {
    let p = dir.join(file);
    let mut b = std::fs::read(&p).expect("readable");
    f(&mut b);
    std::fs::write(&p, b).expect("writable");
}

#[test]
fn malformed_nominal_bad_number_names_file_and_line() {
    let tmp = copy_dir(&fixture("rig_opencv/txt"));
    // Line 6 of points3D.txt is the third point; break its Y coordinate.
    edit_text(tmp.path(), "points3D.txt", |l| {
        let mut toks: Vec<&str> = l[5].split(' ').collect();
        toks[2] = "0.1.2";
        l[5] = toks.join(" ");
    });
    let err = Reconstruction::read(tmp.path()).expect_err("must fail");
    match &err {
        Error::Parse { path, line, .. } => {
            assert_eq!(path, &tmp.path().join("points3D.txt"));
            assert_eq!(*line, 6);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("points3D.txt:6"), "{msg}");
}

#[test]
fn malformed_text_cases() {
    type Case = (&'static str, fn(&mut Vec<String>), usize);
    let cases: [Case; 6] = [
        (
            "cameras.txt",
            |l| l[3] = l[3].replace("OPENCV", "OPENCVX"),
            4,
        ),
        ("cameras.txt", |l| l[4] = format!("{} 0.5", l[4]), 5),
        ("images.txt", |l| l[4] = l[4].replacen(' ', " x", 1), 5),
        (
            "images.txt",
            |l| l[5] = format!("{} 1.0", l[5].trim_end()),
            6,
        ),
        (
            "rigs.txt",
            |l| l[3] = l[3].replace("CAMERA 2", "LIDAR 2"),
            4,
        ),
        ("frames.txt", |l| l[3] = format!("{} CAMERA", l[3]), 4),
    ];
    for (file, edit, expect_line) in cases {
        let tmp = copy_dir(&fixture("rig_opencv/txt"));
        edit_text(tmp.path(), file, edit);
        let err = Reconstruction::read(tmp.path()).expect_err("must fail");
        assert_eq!(err.path(), tmp.path().join(file), "{err}");
        let line = match &err {
            Error::Parse { line, .. }
            | Error::UnknownModelName { line, .. }
            | Error::WrongParamCount { line, .. } => *line,
            other => panic!("{file}: unexpected error {other:?}"),
        };
        assert_eq!(line, expect_line, "{file}: {err}");
    }
}

#[test]
fn malformed_binary_unknown_model_id() {
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    // Record 1 of cameras.bin starts at 8 + 88; its model id follows the u32 camera id.
    edit_bytes(tmp.path(), "cameras.bin", |b| {
        b[8 + 88 + 4..8 + 88 + 8].copy_from_slice(&18i32.to_le_bytes())
    });
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::UnknownModelId { path, record, id } => {
            assert_eq!(path, tmp.path().join("cameras.bin"));
            assert_eq!((record, id), (1, 18));
        }
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn malformed_binary_truncated_and_huge_counts() {
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    edit_bytes(tmp.path(), "images.bin", |b| b.truncate(b.len() - 3));
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::Truncated { path, needed, .. } => {
            assert_eq!(path, tmp.path().join("images.bin"));
            assert_eq!(needed, 3);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    // A count of 2^62 points must not allocate; it is a truncation at byte 0.
    edit_bytes(tmp.path(), "points3D.bin", |b| {
        b[0..8].copy_from_slice(&(1u64 << 62).to_le_bytes())
    });
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::Truncated { path, offset, .. } => {
            assert_eq!(path, tmp.path().join("points3D.bin"));
            assert_eq!(offset, 8);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    edit_bytes(tmp.path(), "rigs.bin", |b| b.push(0));
    assert!(matches!(
        Reconstruction::read(tmp.path()),
        Err(Error::TrailingBytes { extra: 1, .. })
    ));
}

#[test]
fn malformed_invariants() {
    // A track element pointing at a missing image.
    let tmp = copy_dir(&fixture("handwritten_txt"));
    edit_text(tmp.path(), "points3D.txt", |l| {
        l[1] = l[1].replace(" 7 0 3 1", " 8 0 3 1")
    });
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::Invariant {
            path,
            record,
            line,
            id,
            ..
        } => {
            assert_eq!(path, tmp.path().join("points3D.txt"));
            assert_eq!((record, id), (0, 8));
            // Text models name the line (the edited l[1] is line 2).
            assert_eq!(line, Some(2));
        }
        other => panic!("unexpected error {other:?}"),
    }
    // A point2D index beyond the image's points.
    let tmp = copy_dir(&fixture("handwritten_txt"));
    edit_text(tmp.path(), "points3D.txt", |l| {
        l[1] = l[1].replace(" 7 0 3 1", " 7 0 3 5")
    });
    assert!(matches!(
        Reconstruction::read(tmp.path()),
        Err(Error::Invariant { record: 0, .. })
    ));
    // An observation whose point's track does not list it.
    let tmp = copy_dir(&fixture("handwritten_txt"));
    edit_text(tmp.path(), "points3D.txt", |l| {
        l[1] = l[1].replace(" 7 0 3 1", " 7 0")
    });
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::Invariant { path, id, .. } => {
            assert_eq!(path, tmp.path().join("images.txt"));
            assert_eq!(id, 11);
        }
        other => panic!("unexpected error {other:?}"),
    }
    // An image whose camera does not exist.
    let tmp = copy_dir(&fixture("handwritten_txt"));
    edit_text(tmp.path(), "images.txt", |l| {
        l[3] = l[3].replace(" 1 left", " 5 left")
    });
    let err = Reconstruction::read(tmp.path()).expect_err("must fail");
    assert!(
        matches!(
            err,
            Error::Invariant {
                id: 5,
                line: Some(4),
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("images.txt:4: "), "{err}");
    // A frame naming a missing image.
    let tmp = copy_dir(&fixture("rig_opencv/txt"));
    edit_text(tmp.path(), "frames.txt", |l| {
        l[3] = l[3].replace("CAMERA 2 2", "CAMERA 2 99")
    });
    match Reconstruction::read(tmp.path()).expect_err("must fail") {
        Error::Invariant {
            path,
            record,
            line,
            id,
            ..
        } => {
            assert_eq!(path, tmp.path().join("frames.txt"));
            assert_eq!((record, id), (0, 99));
            assert_eq!(line, Some(4));
        }
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn malformed_directory_layouts() {
    let empty = tempfile::tempdir().expect("tmp");
    assert!(matches!(
        Reconstruction::read(empty.path()),
        Err(Error::NotAModel { .. })
    ));
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    std::fs::remove_file(tmp.path().join("frames.bin")).expect("rm");
    assert!(matches!(
        Reconstruction::read(tmp.path()),
        Err(Error::RigsWithoutFrames { .. })
    ));
    // Binary wins when both exist: a broken text model next to a good binary one is ignored.
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    for f in ["cameras.txt", "images.txt", "points3D.txt"] {
        std::fs::write(tmp.path().join(f), "garbage").expect("write");
    }
    let m = Reconstruction::read(tmp.path()).expect("binary wins");
    assert_eq!(m.format(), crashrig_colmap::ModelFormat::Binary);
}

#[test]
fn malformed_images_txt_pairs_lines_positionally() {
    // A comment in place of POINTS2D means no points (COLMAP's rule), and the next image line
    // is still read as an image.
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::write(
        tmp.path().join("cameras.txt"),
        "1 SIMPLE_PINHOLE 10 10 5 5 5\n",
    )
    .expect("w");
    std::fs::write(
        tmp.path().join("images.txt"),
        "# header\n1 1 0 0 0 0 0 0 1 a.png\n# not points\n2 1 0 0 0 0 0 1 1 b c.png\n\n",
    )
    .expect("w");
    std::fs::write(tmp.path().join("points3D.txt"), "").expect("w");
    let m = Reconstruction::read(tmp.path()).expect("reads");
    assert_eq!(m.images().len(), 2);
    assert!(m.images().iter().all(|i| i.points2d.is_empty()));
    assert_eq!(m.image(2).map(|i| i.name.as_str()), Some("b c.png"));
}

#[test]
fn malformed_empty_rigs_and_frames_files_mean_legacy() {
    // COLMAP takes the legacy path when no rig and no frame was loaded, even if the files exist.
    let tmp = copy_dir(&fixture("handwritten_txt"));
    std::fs::write(tmp.path().join("rigs.txt"), "# Number of rigs: 0\n").expect("w");
    std::fs::write(tmp.path().join("frames.txt"), "").expect("w");
    let m = Reconstruction::read(tmp.path()).expect("reads as legacy");
    assert!(m.is_legacy());
    assert_eq!(m.rigs().len(), 2);
    assert_eq!(m.frames().len(), 3);
}

/// Every number of a model is finite and within ±[`crashrig_colmap::bounds::MAX_MODEL_VALUE`]
/// (issue 36 §4: a pose translation of 1e308 made `calibrate` print `null` with exit 0): each
/// file's numbers, text (named by line) and binary (named by record).
#[test]
fn malformed_values_beyond_the_bound_name_file_and_record() {
    // (file, 0-based line, 0-based token, the record's 1-based line, what the error says); a
    // point2D is named by its image's line.
    let cases = [
        ("cameras.txt", 4, 4, 5, "a camera parameter"),
        ("rigs.txt", 4, 12, 5, "a sensor_from_rig number"),
        ("frames.txt", 3, 7, 4, "a rig_from_world number"),
        ("images.txt", 4, 5, 5, "a cam_from_world number"),
        ("images.txt", 5, 1, 5, "a point2D coordinate"),
        ("points3D.txt", 4, 2, 5, "a point3D coordinate"),
        ("points3D.txt", 4, 7, 5, "a point3D coordinate or error"),
    ];
    for (file, line, token, record_line, what) in cases {
        for value in ["1e308", "1.0000001e12", "inf", "nan"] {
            let tmp = copy_dir(&fixture("rig_opencv/txt"));
            edit_text(tmp.path(), file, |l| {
                let mut toks: Vec<String> = l[line].split(' ').map(str::to_owned).collect();
                toks[token] = value.to_string();
                l[line] = toks.join(" ");
            });
            let err = Reconstruction::read(tmp.path()).expect_err(file);
            let text = err.to_string();
            assert!(
                text.starts_with(&format!(
                    "{}:{}: {what}",
                    tmp.path().join(file).display(),
                    record_line
                )) && text.contains("beyond ±1e12"),
                "{file} {value}: {text}"
            );
        }
        // Within the bound (1e11; COLMAP's error -1) the value is no bound error.
        let tmp = copy_dir(&fixture("rig_opencv/txt"));
        edit_text(tmp.path(), file, |l| {
            let mut toks: Vec<String> = l[line].split(' ').map(str::to_owned).collect();
            toks[token] = if token == 7 && file == "points3D.txt" {
                "-1".into()
            } else {
                "1e11".into()
            };
            l[line] = toks.join(" ");
        });
        if let Err(e) = Reconstruction::read(tmp.path()) {
            assert!(!e.to_string().contains("beyond ±1e12"), "{file}: {e}");
        }
    }
    // Binary: the record of frames.bin (the first frame's TY, byte 8 + 8 + 5 × 8).
    let tmp = copy_dir(&fixture("rig_opencv/bin"));
    edit_bytes(tmp.path(), "frames.bin", |b| {
        b[56..64].copy_from_slice(&1e308f64.to_le_bytes());
    });
    let err = Reconstruction::read(tmp.path()).expect_err("1e308 in frames.bin");
    assert_eq!(
        err.to_string(),
        format!(
            "{}: record 0: a rig_from_world number is not finite or beyond ±1e12 model units (docs/LIMITS.md) (id 1)",
            tmp.path().join("frames.bin").display()
        )
    );
}
