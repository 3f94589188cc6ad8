//! The study file of `crashrig paper`: the paper's chain on the bundled data and its layouts
//! (Figures 10–13 with the paper's σ and with this run's, the pixel-noise and fixed-camera
//! variants), built from typed keys ([`study_toml`]) and serialised with `toml`.
//!
//! The command embeds the inputs and writes them next to this file; the layouts' grids are
//! read from the bundled scenarios, so the study file and the scenarios cannot disagree.

use crate::Error;
use crate::study_file::ChainCamera;
use serde::Serialize;
use std::path::Path;

/// What the bundled study file varies. No `Default`: it holds a seed and sample counts.
#[derive(Debug, Clone, Copy)]
pub struct PaperStudy {
    /// The study's seed.
    pub seed: u64,
    /// Monte Carlo draws per grid point (the heat maps).
    pub samples: usize,
    /// Monte Carlo draws of the chain propagation (Tables 3–4).
    pub chain_samples: usize,
    /// Bootstrap replicates of the tie (Figures 8–9).
    pub iterations: usize,
}

/// The text of a bundled input by its path below `DIR/inputs/` (`None` if there is none).
pub type Inputs<'a> = dyn Fn(&str) -> Option<&'a str> + 'a;

/// The four heat-map layouts of Figures 10–13: (figure, scenario stem, description, the chain
/// camera that feeds each of the scenario's observers, in their order).
const LAYOUTS: [(&str, &str, &str, [ChainCamera; 2]); 4] = [
    (
        "Figure 10",
        "four_cameras_z0",
        "four-camera system, points at camera height",
        [ChainCamera::Inward, ChainCamera::Inward],
    ),
    (
        "Figure 11",
        "four_cameras_z300",
        "four-camera system, points 30 cm higher",
        [ChainCamera::Inward, ChainCamera::Inward],
    ),
    (
        "Figure 12",
        "three_cameras_z0",
        "three-camera system, points at camera height",
        [ChainCamera::Inward, ChainCamera::Tie],
    ),
    (
        "Figure 13",
        "three_cameras_z300",
        "three-camera system, points 30 cm higher",
        [ChainCamera::Inward, ChainCamera::Tie],
    ),
];

/// The rows of the paper's Tables 3–4 (σ of the inward camera cam2, of the tied camera cam3)
/// that an observer fed by `camera` takes in the `*_paper` layouts.
fn published_sigma(camera: ChainCamera) -> ([f64; 3], [f64; 3]) {
    use crate::report::published::{TABLE3_MM, TABLE4_DEG};
    let row = match camera {
        ChainCamera::Tie => 2,
        ChainCamera::Inward | ChainCamera::Outward => 1,
    };
    (TABLE3_MM[row], TABLE4_DEG[row])
}

/// The top-level keys and the `[calibration]` and `[tie]` sections of the bundled study file.
#[derive(Serialize)]
struct StudyHead {
    seed: u64,
    samples: usize,
    chain_samples: usize,
    reference: &'static str,
    calibration: CalibrationKeys,
    tie: TieKeys,
}

#[derive(Serialize)]
struct CalibrationKeys {
    model: &'static str,
    camera_a: &'static str,
    camera_b: &'static str,
    scale_points: [u64; 2],
    scale_length_mm: f64,
}

#[derive(Serialize)]
struct TieKeys {
    database: &'static str,
    model: &'static str,
    image_a: &'static str,
    image_b: &'static str,
    method: &'static str,
    iterations: usize,
    mm_per_unit: f64,
}

#[derive(Serialize)]
struct OutwardKeys {
    position_mm: [f64; 3],
    angles_deg: [f64; 3],
    sigma_position_mm: [f64; 3],
    sigma_angles_deg: [f64; 3],
}

/// `[outward]` as its own document (a comment goes before it).
#[derive(Serialize)]
struct Outward {
    outward: OutwardKeys,
}

/// One `[[layout]]` of the study file (keys as `docs/REFERENCE.md` documents them).
#[derive(Serialize)]
struct LayoutKeys {
    name: String,
    description: String,
    x_mm: (f64, f64, usize),
    y_mm: (f64, f64, usize),
    z_mm: (f64, f64, usize),
    threshold_mm: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pixel_sigma_px: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    focal_px: Option<f64>,
    observer: Vec<ObserverKeys>,
}

/// One `[[layout.observer]]`: σ from the chain (`from`) or given, aimed or fixed.
#[derive(Serialize, Default)]
struct ObserverKeys {
    name: String,
    position_mm: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    from: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    aim: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    look_at_mm: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pixel_sigma_px: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma_position_mm: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma_angles_deg: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    camera: Option<LensKeys>,
}

/// A fixed observer's lens (COLMAP camera model and parameters).
#[derive(Serialize)]
struct LensKeys {
    model: &'static str,
    width: u32,
    height: u32,
    params: [f64; 8],
}

/// `[[layout]]` tables serialised as one array of tables.
#[derive(Serialize)]
struct Layouts<'a> {
    layout: &'a [LayoutKeys],
}

fn toml_text<T: Serialize>(value: &T) -> Result<String, Error> {
    toml::to_string(value).map_err(|e| bundled(Error::BundledToml(e)))
}

/// An error of the bundled inputs (a bug of the program, not of the user's input).
fn bundled(problem: Error) -> Error {
    Error::Bundled {
        problem: Box::new(problem),
    }
}

fn grid_axis(a: crashrig_mc::Axis) -> (f64, f64, usize) {
    (a.start, a.stop, a.count)
}

/// The grid of the bundled scenario `stem` (`scenarios/{stem}.toml` of `inputs`).
fn bundled_grid(stem: &str, inputs: &Inputs<'_>) -> Result<crashrig_mc::Grid, Error> {
    let text = inputs(&format!("scenarios/{stem}.toml")).ok_or_else(|| {
        bundled(Error::NoScenario {
            stem: stem.to_string(),
        })
    })?;
    crashrig_mc::Scenario::from_toml_str(text, Path::new(stem))
        .map_err(|source| Error::Scenario { source })?
        .grid
        .ok_or_else(|| {
            bundled(Error::NoGrid {
                stem: stem.to_string(),
            })
        })
}

/// A layout of the paper on the grid of a bundled scenario: its observers take the paper's
/// Table 3–4 σ, or (`this_run`) this run's propagated σ of the chain camera that feeds them.
fn paper_layout(
    name: String,
    description: String,
    stem: &str,
    feeds: [ChainCamera; 2],
    this_run: bool,
    pixel: bool,
    inputs: &Inputs<'_>,
) -> Result<LayoutKeys, Error> {
    let g = bundled_grid(stem, inputs)?;
    if g.observers.len() != feeds.len() {
        return Err(bundled(Error::BundledObservers {
            stem: stem.to_string(),
            observers: g.observers.len(),
            expected: feeds.len(),
        }));
    }
    let observer = g
        .observers
        .iter()
        .zip(feeds)
        .map(|(o, feed)| {
            let (p, r) = published_sigma(feed);
            ObserverKeys {
                name: o.name.clone(),
                position_mm: o.position_mm.into(),
                from: this_run.then(|| feed.name()),
                sigma_position_mm: (!this_run).then_some(p),
                sigma_angles_deg: (!this_run).then_some(r),
                ..ObserverKeys::default()
            }
        })
        .collect();
    Ok(LayoutKeys {
        name,
        description,
        x_mm: grid_axis(g.x),
        y_mm: grid_axis(g.y),
        z_mm: grid_axis(g.z),
        threshold_mm: g.threshold_mm,
        pixel_sigma_px: pixel.then_some(0.5),
        focal_px: pixel.then_some(1600.0),
        observer,
    })
}

/// The bundled study file: the paper's chain on the bundled data, and its layouts twice —
/// with the paper's Table 3–4 observer σ (`*_paper`) and with this run's propagated σ
/// (`*_this_run`) — plus the three-camera layout with pixel noise and the fixed-camera
/// variants. Built from typed keys and serialised with `toml`; only the comments are text.
/// `inputs` gives the text of a bundled input by its path below `DIR/inputs/` (the layouts'
/// grids are those of `scenarios/*.toml`).
///
/// # Errors
/// [`Error::Bundled`] or [`Error::Scenario`] when a bundled scenario is missing or unusable (a
/// bug of the program).
pub fn study_toml(a: &PaperStudy, inputs: &Inputs<'_>) -> Result<String, Error> {
    let head = StudyHead {
        seed: a.seed,
        samples: a.samples,
        chain_samples: a.chain_samples,
        reference: "kaminski2023",
        calibration: CalibrationKeys {
            model: "rig_sequence",
            camera_a: "cam_out/",
            camera_b: "cam_in/",
            scale_points: [1, 2],
            scale_length_mm: 2000.0,
        },
        tie: TieKeys {
            database: "twoview/database.db",
            model: "twoview/model",
            image_a: "cam_in/000001.png",
            image_b: "cam_door/000001.png",
            method: "absolute",
            iterations: a.iterations,
            mm_per_unit: 1000.0,
        },
    };
    let outward = Outward {
        outward: OutwardKeys {
            position_mm: [0.0; 3],
            angles_deg: [0.0; 3],
            sigma_position_mm: [1.0; 3],
            sigma_angles_deg: [0.01; 3],
        },
    };
    let mut layouts = Vec::new();
    for (figure, stem, what, feeds) in LAYOUTS {
        layouts.push(paper_layout(
            format!("{stem}_paper"),
            format!("{figure} (reproduced): {what}; observers with the paper's Table 3-4 sigma"),
            stem,
            feeds,
            false,
            false,
            inputs,
        )?);
        layouts.push(paper_layout(
            format!("{stem}_this_run"),
            format!("{figure}: {what}; observers with this run's propagated sigma"),
            stem,
            feeds,
            true,
            false,
            inputs,
        )?);
    }
    layouts.push(paper_layout(
        "three_cameras_z0_pixel_noise".into(),
        "Beyond the paper: three-camera layout at camera height with 0.5 px measurement noise at f = 1600 px (paper sigma)".into(),
        "three_cameras_z0",
        [ChainCamera::Inward, ChainCamera::Tie],
        false,
        true,
        inputs,
    )?);
    Ok(format!(
        "# Written by `crashrig paper`: the paper reproduction as a study file.\n\
         # `crashrig study <this file> --out DIR` reproduces the paper run's results.json.\n\
         {}\n\
         # World frame = the outward camera's frame; its bundle-adjustment uncertainty is the paper's 1 mm / 0.01 deg (section 3.2.1).\n\
         {}\n{}\n{FIXED_LENS_COMMENT}{}",
        toml_text(&head)?,
        toml_text(&outward)?,
        toml_text(&Layouts { layout: &layouts })?,
        toml_text(&Layouts {
            layout: &fixed_layouts()
        })?,
    ))
}

/// The paper's inward lens (see [`FIXED_LENS_COMMENT`]): OPENCV, 2560 × 1440 px, f = 1600 px,
/// principal point at the image centre, no distortion.
fn paper_inward_lens() -> LensKeys {
    LensKeys {
        model: "OPENCV",
        width: 2560,
        height: 1440,
        params: [1600.0, 1600.0, 1280.0, 720.0, 0.0, 0.0, 0.0, 0.0],
    }
}

/// What the fixed-camera variant assumes (written into the study file; the report repeats it).
pub const FIXED_LENS_COMMENT: &str = "\
# Beyond the paper: the paper's layouts with FIXED inward cameras (aim = \"fixed\"), bolted in
# place with the paper's lenses instead of turning towards every grid point (as
# fixtures/scenarios/fixed_{four,three}_cameras.toml). Paper section 3.1: 2560 x 1440 px sensors,
# 12.5 mm outward and 8 mm inward lenses. ASSUMED (not given in the paper):
#   - pixel pitch 5.0 um: the 8 mm inward lens is f = 1600 px (the 12.5 mm outward lens would
#     be 2500 px, but the outward camera looks out of the car and observes no interior point,
#     so only the inward lens appears here);
#   - principal point at the image centre, (cx, cy) = (1280, 720) px (COLMAP convention: the
#     upper-left pixel's centre is (0.5, 0.5));
#   - no distortion (OPENCV with k1 = k2 = p1 = p2 = 0); field of view 77.3 x 48.5 deg;
#   - pixel_sigma_px = 0, as in the paper's aimed study: the difference to the *_paper layouts
#     is the field of view alone;
#   - aim without roll: the rear camera looks along the car at (1200, 0, 150) mm, the door
#     camera across the car at (1000, 0, 150) mm (half-way between the two grid levels).
";

/// The fixed-camera variant of the four- and three-camera layouts (both z levels in one grid,
/// the paper's Table 3-4 σ).
fn fixed_layouts() -> Vec<LayoutKeys> {
    let variants = [
        (
            "four_cameras_fixed_paper",
            "Figures 10-11",
            "door (cam2')",
            ChainCamera::Inward,
        ),
        (
            "three_cameras_fixed_paper",
            "Figures 12-13",
            "door (cam3)",
            ChainCamera::Tie,
        ),
    ];
    let observer = |name: &str, position_mm, look_at_mm, feed| {
        let (p, r) = published_sigma(feed);
        ObserverKeys {
            name: name.into(),
            position_mm,
            aim: Some("fixed"),
            look_at_mm: Some(look_at_mm),
            camera: Some(paper_inward_lens()),
            pixel_sigma_px: Some(0.0),
            sigma_position_mm: Some(p),
            sigma_angles_deg: Some(r),
            ..ObserverKeys::default()
        }
    };
    variants
        .into_iter()
        .map(|(name, figure, door, door_feed)| LayoutKeys {
            name: name.into(),
            description: format!(
                "Beyond the paper: {figure} layout with fixed cameras and the paper's lenses (8 mm, 2560 x 1440 px; assumed 5 um pitch, centred principal point), points at camera height and 30 cm higher; paper sigma"
            ),
            x_mm: (400.0, 2000.0, 17),
            y_mm: (-600.0, 600.0, 13),
            z_mm: (0.0, 300.0, 2),
            threshold_mm: 5.0,
            pixel_sigma_px: None,
            focal_px: None,
            observer: vec![
                observer(
                    "rear (cam2)",
                    [200.0, 0.0, 0.0],
                    [1200.0, 0.0, 150.0],
                    ChainCamera::Inward,
                ),
                observer(
                    door,
                    [1300.0, -700.0, 0.0],
                    [1000.0, 0.0, 150.0],
                    door_feed,
                ),
            ],
        })
        .collect()
}
