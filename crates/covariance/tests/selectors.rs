//! Issue 36: camera A's selector as a user types it — empty, in another Unicode normal form
//! than the model's names, or matching nothing.

use crashrig_colmap::{CameraSelector, Reconstruction};
use crashrig_covariance::synthetic::ring_scene;
use crashrig_covariance::{ControlPoints, Error, Intrinsics, Options, covariance};

fn options(camera: &str) -> Options {
    Options {
        camera_a: CameraSelector::parse(camera),
        mm_per_unit: 1000.0,
        pixel_sigma_px: Some(0.5),
        intrinsics: Intrinsics::All,
    }
}

/// The scene with every image renamed `Cópia de <name>`, the `ó` stored decomposed (`o` +
/// U+0301, as macOS writes file names).
fn renamed(model: &Reconstruction) -> Reconstruction {
    let images = model
        .images()
        .iter()
        .map(|im| {
            let mut im = im.clone();
            im.name = format!("Co\u{301}pia de {}", im.name);
            im
        })
        .collect();
    Reconstruction::from_records(
        model.cameras().to_vec(),
        Vec::new(),
        Vec::new(),
        images,
        model.points3d().to_vec(),
    )
    .unwrap()
}

#[test]
fn an_empty_camera_is_refused_naming_the_flag() {
    let scene = ring_scene(4, 0.3);
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    for blank in ["", "  "] {
        let e = covariance(&scene.model, &control, &options(blank)).unwrap_err();
        assert!(
            matches!(
                e,
                Error::Setting {
                    name: "--camera",
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .starts_with("invalid setting --camera: is empty"),
            "{e}"
        );
    }
}

#[test]
fn a_prefix_in_another_normal_form_finds_the_images() {
    let scene = ring_scene(4, 0.3);
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let want = covariance(&scene.model, &control, &options("cam_out/")).unwrap();
    let model = renamed(&scene.model);
    // Typed composed (U+00F3), and typed as stored.
    for typed in ["C\u{f3}pia de cam_out/", "Co\u{301}pia de cam_out/"] {
        let r = covariance(&model, &control, &options(typed)).unwrap();
        let names: Vec<&str> = r.epochs.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["0000", "0001", "0002", "0003"]);
        // The image keeps the model's own name.
        assert_eq!(r.epochs[0].image, "Co\u{301}pia de cam_out/0000.png");
        assert_eq!(r.joint_deg, want.joint_deg);
    }
}

#[test]
fn a_camera_matching_nothing_names_the_nearest() {
    let scene = ring_scene(4, 0.3);
    let control = ControlPoints::from_ids("t", &scene.control_ids, 0.0);
    let model = renamed(&scene.model);
    let e = covariance(&model, &control, &options("Copia de cam_out/"))
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with(
            "camera A (Copia de cam_out/): no image of the model's 4 matches; nearest \
             image-name beginnings: `C\u{f3}pia de cam_out/` (4 images)"
        ),
        "{e}"
    );
    let e = covariance(&model, &control, &options("7"))
        .unwrap_err()
        .to_string();
    assert!(e.ends_with("; camera ids with images: 1 (4 images)"), "{e}");
}
