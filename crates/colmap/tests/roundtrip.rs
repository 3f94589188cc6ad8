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

#[test]
fn roundtrip_failed_write_leaves_no_partial_model() {
    // Files are renamed in the order rigs, cameras, frames, images, points3D; a directory in
    // the place of images.bin makes the fourth rename fail after three succeeded.
    let m = Reconstruction::read(&fixture("simple_radial/bin")).expect("reads");
    let out = tempfile::tempdir().expect("tmp");
    std::fs::create_dir(out.path().join("images.bin")).expect("mkdir");
    let err = m
        .write(out.path(), ModelFormat::Binary)
        .expect_err("images.bin is a directory");
    assert!(err.to_string().contains("images.bin"), "{err}");
    let mut names: Vec<String> = std::fs::read_dir(out.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        vec!["images.bin".to_string()],
        "only the obstacle is left"
    );
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

/// SplitMix64 for the random-model round trip.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    /// Any finite double: random bit patterns (subnormals, huge exponents, −0) or plain values.
    fn f64(&mut self) -> f64 {
        match self.below(4) {
            0 => {
                // Any bit pattern, folded (exactly, by fmod) into the bound a model's numbers
                // have (`crashrig_colmap::bounds::MAX_MODEL_VALUE`).
                let v = f64::from_bits(self.next()) % crashrig_colmap::bounds::MAX_MODEL_VALUE;
                if v.is_finite() { v } else { -0.0 }
            }
            1 => (self.next() as f64 / u64::MAX as f64 - 0.5) * 2000.0,
            2 => (self.below(2001) as f64 - 1000.0) / 8.0,
            _ => f64::from_bits(self.below(1 << 52)), // subnormal or zero
        }
    }
}

fn random_model(rng: &mut Rng) -> Reconstruction {
    use crashrig_camera::{Camera, ModelId};
    use crashrig_colmap::{
        CameraRecord, Frame, Image, Point2D, Point3D, RawPose, Rig, RigSensor, SensorId,
        TrackElement,
    };
    let pose = |rng: &mut Rng| {
        // Any non-zero quaternion is valid; keep w away from 0 so the norm is never zero.
        RawPose {
            qvec: [
                1.0 + rng.below(5) as f64,
                rng.f64() % 4.0,
                rng.f64() % 4.0,
                rng.f64() % 4.0,
            ],
            tvec: [rng.f64(), rng.f64(), rng.f64()],
        }
    };
    let n_cams = 1 + rng.below(4) as u32;
    let cameras: Vec<CameraRecord> = (0..n_cams)
        .map(|c| {
            let model = ModelId::ALL[rng.below(18) as usize];
            let params = (0..model.num_params()).map(|_| rng.f64()).collect();
            CameraRecord {
                camera_id: 10 + 3 * c,
                camera: Camera {
                    model,
                    width: rng.next() >> 1,
                    height: rng.below(5000),
                    params,
                },
            }
        })
        .collect();
    // One rig holding every camera (first is the reference); some sensor poses unknown.
    let rig = Rig {
        rig_id: 7,
        ref_sensor: Some(SensorId::camera(cameras[0].camera_id)),
        sensors: cameras[1..]
            .iter()
            .map(|c| RigSensor {
                sensor: SensorId::camera(c.camera_id),
                sensor_from_rig: (rng.below(3) > 0).then(|| pose(rng)),
            })
            .collect(),
    };
    let n_frames = 1 + rng.below(3) as u32;
    let mut images = Vec::new();
    let mut frames = Vec::new();
    for f in 0..n_frames {
        let mut data_ids = Vec::new();
        for c in &cameras {
            let image_id = 100 * (f + 1) + c.camera_id;
            let n_pts = rng.below(6) as usize;
            let name: String = (0..1 + rng.below(12))
                .map(|_| {
                    ['a', 'b', ' ', 'c', '/', '_', '-', '.', 'x', 'y', 'z', 'é']
                        [rng.below(12) as usize]
                })
                .collect();
            let im = Image {
                image_id,
                stored_cam_from_world: pose(rng),
                camera_id: c.camera_id,
                name: format!("f{f}_{}", name.trim()),
                points2d: (0..n_pts)
                    .map(|_| Point2D {
                        xy: [rng.f64(), rng.f64()],
                        point3d_id: None,
                    })
                    .collect(),
            };
            data_ids.push(im.data_id());
            images.push(im);
        }
        frames.push(Frame {
            frame_id: 50 + f,
            rig_id: 7,
            rig_from_world: pose(rng),
            data_ids,
        });
    }
    // Points observed by random free 2-D points.
    let mut points = Vec::new();
    let mut pid = 1u64 << 40;
    for image in &mut images {
        let image_id = image.image_id;
        for (k, p2) in image.points2d.iter_mut().enumerate() {
            if rng.below(2) == 0 {
                continue;
            }
            pid += 1 + rng.below(1000);
            p2.point3d_id = Some(pid);
            points.push(Point3D {
                point3d_id: pid,
                xyz: [rng.f64(), rng.f64(), rng.f64()],
                rgb: [
                    rng.below(256) as u8,
                    rng.below(256) as u8,
                    rng.below(256) as u8,
                ],
                error: rng.f64(),
                track: vec![TrackElement {
                    image_id,
                    point2d_idx: k as u32,
                }],
            });
        }
    }
    Reconstruction::from_records(cameras, vec![rig], frames, images, points)
        .expect("consistent random model")
}

#[test]
fn roundtrip_random_models_bit_exact() {
    let mut rng = Rng(20261121);
    for case in 0..50 {
        let m = random_model(&mut rng);
        for format in [ModelFormat::Binary, ModelFormat::Text] {
            let out = tempfile::tempdir().expect("tmp");
            m.write(out.path(), format).expect("writes");
            let back = Reconstruction::read(out.path())
                .unwrap_or_else(|e| panic!("case {case} {format:?}: {e}"));
            // Bit-exact: compare the raw bits of every double through the Debug of to_bits.
            let bits = |r: &Reconstruction| {
                let mut v: Vec<u64> = Vec::new();
                for c in r.cameras() {
                    v.extend(c.camera.params.iter().map(|p| p.to_bits()));
                    v.extend([c.camera.width, c.camera.height, u64::from(c.camera_id)]);
                }
                for i in r.images() {
                    v.extend(i.stored_cam_from_world.to_array().map(f64::to_bits));
                    v.extend(i.points2d.iter().flat_map(|p| {
                        [
                            p.xy[0].to_bits(),
                            p.xy[1].to_bits(),
                            p.point3d_id.unwrap_or(0),
                        ]
                    }));
                }
                for p in r.points3d() {
                    v.extend(p.xyz.map(f64::to_bits));
                    v.push(p.error.to_bits());
                }
                for f in r.frames() {
                    v.extend(f.rig_from_world.to_array().map(f64::to_bits));
                }
                for rig in r.rigs() {
                    for s in &rig.sensors {
                        v.extend(
                            s.sensor_from_rig
                                .map_or([0; 7], |p| p.to_array().map(f64::to_bits)),
                        );
                    }
                }
                v
            };
            assert_eq!(bits(&back), bits(&m), "case {case} {format:?}");
            assert_eq!(
                back.images().iter().map(|i| &i.name).collect::<Vec<_>>(),
                m.images().iter().map(|i| &i.name).collect::<Vec<_>>()
            );
            assert_eq!(back.rigs(), m.rigs());
            assert_eq!(back.points3d().len(), m.points3d().len());
        }
    }
}
