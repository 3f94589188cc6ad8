//! Tests of the scenario parser: the nominal file and every documented error.

use super::*;
use approx::assert_relative_eq;

const BASE: &str = r#"
seed = 1
samples = 2000
rotation_noise = "tangent"

[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [1.0, 1.0, 1.0]
sigma_angles_deg = [0.01, 0.01, 0.01]

[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [61.98, -1.71, 179.76]
angles_deg = [179.92, -0.09, 179.76]
sigma_position_mm = [0.19, 0.26, 0.13]
sigma_angles_deg = [0.004, 0.005, 0.008]

[grid]
x_mm = [0.0, 2000.0, 21]
y_mm = [-700.0, 700.0, 15]
z_mm = [0.0, 0.0, 1]
threshold_mm = 5.0

[[grid.observer]]
position_mm = [2200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.52, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]

[[grid.observer]]
position_mm = [1000.0, 800.0, 0.0]
sigma_from = "cam2"
"#;

/// Parses, and unwraps the line location (tested on its own in `scenario_errors_name_the_line`)
/// so the tests below can match the error itself.
fn parse(text: &str) -> Result<Scenario, Error> {
    Scenario::from_toml_str(text, Path::new("s.toml")).map_err(|e| match e {
        Error::Located { source, .. } => *source,
        other => other,
    })
}

#[test]
fn scenario_nominal_interface_example() {
    let s = parse(BASE).unwrap();
    assert_eq!(s.seed, 1);
    assert_eq!(s.samples, 2000);
    assert_eq!(s.rotation_noise, RotationNoise::Tangent);
    assert_eq!(s.cameras.len(), 2);
    assert_eq!(s.cameras[1].parent, Some(0));
    assert_eq!(topological_order(&s.cameras).unwrap(), vec![0, 1]);
    // Degrees become radians exactly as f64::to_radians does.
    assert_relative_eq!(
        s.cameras[1].angles_rad.x,
        179.92f64.to_radians(),
        epsilon = 1e-15
    );
    let g = s.grid.unwrap();
    assert_eq!(g.points().len(), 21 * 15);
    assert_relative_eq!(g.x.values()[1], 100.0, epsilon = 1e-12);
    assert_eq!(g.observers[1].sigma, ObserverSigma::From(1));
    assert_eq!(g.observers[0].name, "obs0");
}

#[test]
fn scenario_parent_after_child_is_ordered() {
    // A child listed before its parent is still composed after it.
    let text = BASE.replacen("name = \"cam1\"", "name = \"camX\"", 1);
    let text = text.replace("parent = \"cam1\"", "parent = \"camX\"");
    let s = parse(&text).unwrap();
    assert_eq!(topological_order(&s.cameras).unwrap(), vec![0, 1]);
}

#[test]
fn scenario_unknown_parent_names_key() {
    let err = parse(&BASE.replace("parent = \"cam1\"", "parent = \"nope\"")).unwrap_err();
    assert!(
        matches!(&err, Error::UnknownCamera { key, name } if key == "camera[1].parent" && name == "nope"),
        "{err}"
    );
}

#[test]
fn scenario_cycle_is_error() {
    let text = BASE.replacen(
        "name = \"cam1\"\n",
        "name = \"cam1\"\nparent = \"cam2\"\n",
        1,
    );
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(&err, Error::Cycle { cameras } if cameras.len() == 2),
        "{err}"
    );
}

#[test]
fn scenario_negative_sigma_names_key() {
    let text = BASE.replace(
        "sigma_angles_deg = [0.004, 0.005, 0.008]",
        "sigma_angles_deg = [0.004, -0.005, 0.008]",
    );
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(&err, Error::Invalid { key, .. } if key == "camera[1].sigma_angles_deg"),
        "{err}"
    );
}

#[test]
fn scenario_nan_names_key() {
    let text = BASE.replace(
        "position_mm = [2200.0, 0.0, 0.0]",
        "position_mm = [2200.0, nan, 0.0]",
    );
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(&err, Error::Invalid { key, .. } if key == "grid.observer[0].position_mm"),
        "{err}"
    );
}

#[test]
fn scenario_too_few_observers() {
    let cut = BASE.rfind("[[grid.observer]]").unwrap();
    let err = parse(&BASE[..cut]).unwrap_err();
    assert!(matches!(err, Error::TooFewObservers { found: 1 }), "{err}");
}

#[test]
fn scenario_observer_at_grid_point() {
    let text = BASE.replace(
        "position_mm = [2200.0, 0.0, 0.0]",
        "position_mm = [200.0, 0.0, 0.0]",
    );
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(&err, Error::ObserverAtGridPoint { key, .. } if key == "grid.observer[0]"),
        "{err}"
    );
}

#[test]
fn scenario_vertical_aim_is_error() {
    let text = BASE.replace(
        "position_mm = [2200.0, 0.0, 0.0]",
        "position_mm = [200.0, 0.0, 500.0]",
    );
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(&err, Error::VerticalAim { key, .. } if key == "grid.observer[0]"),
        "{err}"
    );
}

#[test]
fn scenario_toml_syntax_error_has_line() {
    let text = BASE.replace("samples = 2000", "samples = = 2000");
    let err = parse(&text).unwrap_err();
    assert!(matches!(&err, Error::Toml { line: 3, .. }), "{err}");
    assert!(err.to_string().starts_with("s.toml:3:"), "{err}");
}

#[test]
fn scenario_unknown_key_is_error() {
    let text = BASE.replace("threshold_mm = 5.0", "treshold_mm = 5.0");
    let err = parse(&text).unwrap_err();
    assert!(matches!(&err, Error::Toml { .. }), "{err}");
    assert!(err.to_string().contains("treshold_mm"), "{err}");
}

#[test]
fn scenario_duplicate_name_and_bad_enum() {
    let text = BASE.replace("name = \"cam2\"", "name = \"cam1\"");
    assert!(matches!(parse(&text), Err(Error::DuplicateName { .. })));
    let text = BASE.replace("\"tangent\"", "\"quaternion\"");
    assert!(matches!(parse(&text), Err(Error::Invalid { key, .. }) if key == "rotation_noise"));
    let text = BASE.replace("sigma_from = \"cam2\"", "sigma_from = \"cam9\"");
    assert!(
        matches!(parse(&text), Err(Error::UnknownCamera { key, .. }) if key == "grid.observer[1].sigma_from")
    );
}

#[test]
fn scenario_pixel_noise_needs_focal() {
    let text = BASE.replace(
        "threshold_mm = 5.0",
        "threshold_mm = 5.0\npixel_sigma_px = 0.3",
    );
    assert!(matches!(parse(&text), Err(Error::Invalid { key, .. }) if key == "grid.focal_px"));
    let text = BASE.replace(
        "threshold_mm = 5.0",
        "threshold_mm = 5.0\npixel_sigma_px = 0.3\nfocal_px = 1200.0",
    );
    let g = parse(&text).unwrap().grid.unwrap();
    assert_relative_eq!(
        g.pixel.unwrap().sigma_normalized(),
        0.3 / 1200.0,
        epsilon = 1e-18
    );
}

#[test]
fn axis_values_single_and_ends() {
    let a = Axis {
        start: 0.3,
        stop: 0.7,
        count: 3,
    };
    assert_eq!(a.values().len(), 3);
    assert_eq!(a.values()[2], 0.7);
    let one = Axis {
        start: 5.0,
        stop: 5.0,
        count: 1,
    };
    assert_eq!(one.values(), vec![5.0]);
}

const LOCATED: &str = r#"seed = 1
[[camera]]
name = "cam1"
position_mm = [0.0, 0.0, 0.0]
[[camera]]
name = "cam2"
parent = "cam1"
position_mm = [nan, 0.0, 0.0]
[grid]   # the grid
x_mm = [0.0, 1.0, 2]
[[grid.observer]]
position_mm = [0.0, 5.0, 0.0]
[[grid.observer]]
sigma_from = "camX"
"#;

#[test]
fn key_line_nominal() {
    use super::key_line;
    assert_eq!(key_line(LOCATED, "camera[1].position_mm"), Some(8));
    assert_eq!(key_line(LOCATED, "camera[0].name"), Some(3));
    assert_eq!(key_line(LOCATED, "grid.observer[1].sigma_from"), Some(14));
    assert_eq!(key_line(LOCATED, "grid.x_mm"), Some(10));
    assert_eq!(key_line(LOCATED, "seed"), Some(1));
    assert_eq!(key_line(LOCATED, "grid.observer[1]"), Some(13));
    assert_eq!(key_line(LOCATED, "grid.observer"), Some(11));
    assert_eq!(key_line(LOCATED, "camera"), Some(2));
    // An absent key (a default) points at its table's header.
    assert_eq!(key_line(LOCATED, "camera[1].sigma_angles_deg"), Some(5));
    assert_eq!(key_line(LOCATED, "nowhere.at_all"), None);
}

#[test]
fn scenario_errors_name_the_line() {
    // Contract: bad input names the file and, for text, the line.
    let text = BASE.replace("position_mm = [61.98", "position_mm = [nan");
    let expected = 1 + text.lines().position(|l| l.contains("[nan")).unwrap();
    let err = Scenario::from_toml_str(&text, Path::new("s.toml")).unwrap_err();
    match &err {
        Error::Located { line, source, .. } => {
            assert_eq!(*line, expected, "{err}");
            assert_eq!(source.key(), Some("camera[1].position_mm"));
        }
        other => panic!("unexpected {other:?}"),
    }
    let shown = crashrig_input::message::error_line(&err);
    assert!(
        shown.starts_with(&format!("s.toml:{expected}: `camera[1].position_mm`")),
        "{shown}"
    );
    // A cross-reference: the unknown `sigma_from` of the second observer.
    let text = BASE.replace("sigma_from = \"cam2\"", "sigma_from = \"camX\"");
    let expected = 1 + text.lines().position(|l| l.contains("camX")).unwrap();
    match Scenario::from_toml_str(&text, Path::new("s.toml")).unwrap_err() {
        Error::Located { line, .. } => assert_eq!(line, expected),
        other => panic!("unexpected {other:?}"),
    }
}

/// Issue 36 §2: the scenario reader's plausibility warnings (lengths in metres), each naming the
/// file, the key's line, the key and the unit; the base scenario and every bundled scenario
/// give none.
#[test]
fn plausibility_warnings_name_key_line_and_unit() {
    let p = Path::new("s.toml");
    assert!(
        Scenario::from_toml_str(BASE, p)
            .unwrap()
            .warnings
            .is_empty()
    );
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let mut read = 0;
    for dir in ["scenarios", "mc", "fixed", "acceptance"] {
        for e in std::fs::read_dir(fixtures.join(dir)).unwrap().flatten() {
            let f = e.path();
            if f.extension().is_some_and(|x| x == "toml") {
                let s = Scenario::from_path(&f).unwrap();
                assert!(s.warnings.is_empty(), "{}: {:?}", f.display(), s.warnings);
                read += 1;
            }
        }
    }
    assert!(read >= 10, "{read} bundled scenarios");
    let line = |t: &str, what: &str| t.lines().position(|l| l.contains(what)).unwrap() + 1;
    for (from, to, key, says) in [
        // A grid in metres.
        (
            "x_mm = [0.0, 2000.0, 21]",
            "x_mm = [0.0, 2.0, 21]",
            "grid.x_mm",
            "spans 2 mm (less than 20 mm) — a car interior is metres across; lengths are in millimetres",
        ),
        // A rig link in metres.
        (
            "position_mm = [61.98, -1.71, 179.76]",
            "position_mm = [0.06198, -0.00171, 0.17976]",
            "camera[1].position_mm",
            "puts the camera 0.1902 mm from its parent",
        ),
        // A link σ in metres (below a micrometre).
        (
            "sigma_position_mm = [0.19, 0.26, 0.13]",
            "sigma_position_mm = [0.00019, 0.00026, 0.00013]",
            "camera[1].sigma_position_mm",
            "σ of 0.00013 mm is below a micrometre",
        ),
        // An observer σ of 1.52 mm in metres is above a micrometre, but its lever arm gives it
        // away: 0.00152 mm / 0.013° (2.269e-4 rad) = 6.7 mm.
        (
            "sigma_position_mm = [1.52, 1.52, 1.52]",
            "sigma_position_mm = [0.00152, 0.00152, 0.00152]",
            "grid.observer[0].sigma_position_mm",
            "position σ 0.00152 mm over angle σ 0.013° is a lever arm of 6.699 mm (less than 10 mm)",
        ),
        // A threshold in metres.
        (
            "threshold_mm = 5.0",
            "threshold_mm = 0.005",
            "grid.threshold_mm",
            "0.005 mm is below 0.01 mm",
        ),
        // An observer millimetres from its chain camera (cam2 stands at
        // (61.98, −1.71, 179.76) in the world): 5 mm away, not at it.
        (
            "position_mm = [1000.0, 800.0, 0.0]",
            "position_mm = [61.98, 3.29, 179.76]",
            "grid.observer[1].position_mm",
            "is 5 mm from camera `cam2` without being at it",
        ),
    ] {
        let t = BASE.replacen(from, to, 1);
        assert_ne!(t, BASE, "{from}");
        let s = Scenario::from_toml_str(&t, p).unwrap();
        let want = format!("s.toml:{}: `{key}` {says}", line(&t, to));
        assert!(
            s.warnings.iter().any(|w| w.starts_with(&want)),
            "want {want}\ngot {:?}",
            s.warnings
        );
        assert!(
            s.warnings
                .iter()
                .all(|w| w.ends_with("lengths are in millimetres")
                    || w.ends_with("lengths are in millimetres (0.8 mm, not 0.0008)")),
            "{:?}",
            s.warnings
        );
    }
    // A covariance_tangent whose position variance is 1e-8 mm² (σ 0.1 µm).
    let t = BASE.replacen(
        "sigma_position_mm = [1.52, 1.52, 1.52]\nsigma_angles_deg = [0.011, 0.011, 0.013]",
        "covariance_tangent = [[1e-8, 0, 0, 0, 0, 0], [0, 1e-8, 0, 0, 0, 0], [0, 0, 1e-8, 0, 0, 0], [0, 0, 0, 1e-4, 0, 0], [0, 0, 0, 0, 1e-4, 0], [0, 0, 0, 0, 0, 1e-4]]",
        1,
    );
    let s = Scenario::from_toml_str(&t, p).unwrap();
    let want = format!(
        "s.toml:{}: `grid.observer[0].covariance_tangent` σ of 0.0001 mm is below a micrometre",
        line(&t, "covariance_tangent")
    );
    assert!(
        s.warnings.iter().any(|w| w.starts_with(&want)),
        "{:?}",
        s.warnings
    );
}
