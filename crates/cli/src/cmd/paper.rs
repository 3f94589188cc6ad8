//! `crashrig paper`: `crashrig study` on a bundled study file.
//!
//! The inputs (the paper's calibration sequence, the two-view tie scene) are embedded in the
//! binary and written to `DIR/inputs/` with the study file `DIR/inputs/study.toml` that names
//! them; then the study runs exactly as `crashrig study DIR/inputs/study.toml --out DIR` would,
//! so that command reproduces `DIR/results.json` bit for bit. The study file carries
//! `reference = "kaminski2023"`, which adds the paper's published values and the "what
//! differs" section to the report.

use crate::Global;
use anyhow::Context;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `crashrig paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Output directory for report.html, results.json, figures and the inputs used.
    #[arg(long, default_value = "out/paper")]
    pub out: PathBuf,
    /// Monte Carlo draws per grid point (the heat maps).
    #[arg(long, default_value_t = 2000, value_parser = crate::limits::parse_samples)]
    pub samples: usize,
    /// Monte Carlo draws of the chain propagation (Tables 3–4).
    #[arg(long = "chain-samples", default_value_t = 200_000, value_parser = crate::limits::parse_samples)]
    pub chain_samples: usize,
    /// Bootstrap replicates (Figures 8–9).
    #[arg(long, default_value_t = 500, value_parser = crate::limits::parse_iterations)]
    pub iterations: usize,
}

/// Default seed of the study when `--seed` is not given.
pub const DEFAULT_SEED: u64 = 20261121;

/// An embedded input file: its path below `DIR/inputs/` and its bytes.
type Embedded = (&'static str, &'static [u8]);

macro_rules! embed {
    ($($rel:literal => $src:literal),* $(,)?) => {
        &[$(($rel, include_bytes!(concat!("../../../../fixtures/", $src)) as &[u8])),*]
    };
}

const INPUTS: &[Embedded] = embed![
    "rig_sequence/cameras.bin" => "rig/paper/cameras.bin",
    "rig_sequence/images.bin" => "rig/paper/images.bin",
    "rig_sequence/points3D.bin" => "rig/paper/points3D.bin",
    "rig_sequence/rigs.bin" => "rig/paper/rigs.bin",
    "rig_sequence/frames.bin" => "rig/paper/frames.bin",
    "twoview/model/cameras.bin" => "paper/twoview/model/cameras.bin",
    "twoview/model/images.bin" => "paper/twoview/model/images.bin",
    "twoview/model/points3D.bin" => "paper/twoview/model/points3D.bin",
    "twoview/model/rigs.bin" => "paper/twoview/model/rigs.bin",
    "twoview/model/frames.bin" => "paper/twoview/model/frames.bin",
    "twoview/database.db" => "paper/twoview/database.db",
    "scenarios/paper_chain.toml" => "scenarios/paper_chain.toml",
    "scenarios/four_cameras_z0.toml" => "scenarios/four_cameras_z0.toml",
    "scenarios/four_cameras_z300.toml" => "scenarios/four_cameras_z300.toml",
    "scenarios/three_cameras_z0.toml" => "scenarios/three_cameras_z0.toml",
    "scenarios/three_cameras_z300.toml" => "scenarios/three_cameras_z300.toml",
    "scenarios/three_cameras_correlated.toml" => "scenarios/three_cameras_correlated.toml",
];

/// The four heat-map layouts of Figures 10–13: (figure, scenario stem, description).
const LAYOUTS: [(&str, &str, &str); 4] = [
    (
        "Figure 10",
        "four_cameras_z0",
        "four-camera system, points at camera height",
    ),
    (
        "Figure 11",
        "four_cameras_z300",
        "four-camera system, points 30 cm higher",
    ),
    (
        "Figure 12",
        "three_cameras_z0",
        "three-camera system, points at camera height",
    ),
    (
        "Figure 13",
        "three_cameras_z300",
        "three-camera system, points 30 cm higher",
    ),
];

/// Writes the embedded inputs below `dir`.
fn write_inputs(dir: &Path) -> anyhow::Result<()> {
    for (rel, bytes) in INPUTS {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create the directory", parent.display()))?;
        }
        crate::output::write_atomic(&path, bytes)?;
    }
    Ok(())
}

fn arr(v: [f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

/// The bundled study file: the paper's chain on the bundled data, and its layouts twice —
/// with the paper's Table 3–4 observer σ (`*_paper`) and with this run's propagated σ
/// (`*_this_run`) — plus the three-camera layout with pixel noise.
pub fn study_toml(a: &PaperArgs, seed: u64) -> anyhow::Result<String> {
    let mut s = String::new();
    writeln!(
        s,
        "# Written by `crashrig paper`: the paper reproduction as a study file."
    )?;
    writeln!(
        s,
        "# `crashrig study <this file> --out DIR` reproduces the paper run's results.json."
    )?;
    writeln!(
        s,
        "seed = {seed}\nsamples = {}\nchain_samples = {}\nreference = \"kaminski2023\"\n",
        a.samples, a.chain_samples
    )?;
    writeln!(
        s,
        "[calibration]\nmodel = \"rig_sequence\"\ncamera_a = \"cam_out/\"\ncamera_b = \"cam_in/\"\nscale_points = [1, 2]\nscale_length_mm = 2000.0\n"
    )?;
    writeln!(
        s,
        "[tie]\ndatabase = \"twoview/database.db\"\nmodel = \"twoview/model\"\nimage_a = \"cam_in/000001.png\"\nimage_b = \"cam_door/000001.png\"\nmethod = \"absolute\"\niterations = {}\nmm_per_unit = 1000.0\n",
        a.iterations
    )?;
    writeln!(
        s,
        "# World frame = the outward camera's frame; its bundle-adjustment uncertainty is the paper's 1 mm / 0.01 deg (section 3.2.1)."
    )?;
    writeln!(
        s,
        "[outward]\nposition_mm = [0.0, 0.0, 0.0]\nangles_deg = [0.0, 0.0, 0.0]\nsigma_position_mm = [1.0, 1.0, 1.0]\nsigma_angles_deg = [0.01, 0.01, 0.01]\n"
    )?;
    let paper_sigma = |cam3: bool| -> (String, String) {
        let i = usize::from(cam3) + 1;
        (
            arr(crashrig_study::report::published::TABLE3_MM[i]),
            arr(crashrig_study::report::published::TABLE4_DEG[i]),
        )
    };
    let scenario = |stem: &str| -> anyhow::Result<crashrig_mc::Scenario> {
        let (_, bytes) = INPUTS
            .iter()
            .find(|(rel, _)| *rel == format!("scenarios/{stem}.toml"))
            .with_context(|| format!("internal: no bundled scenario {stem}"))?;
        crashrig_mc::Scenario::from_toml_str(std::str::from_utf8(bytes)?, Path::new(stem))
            .with_context(|| format!("internal: bundled scenario {stem}"))
    };
    let mut layout =
        |name: &str, desc: &str, stem: &str, this_run: bool, pixel: bool| -> anyhow::Result<()> {
            let sc = scenario(stem)?;
            let g = sc
                .grid
                .context("internal: bundled scenario without a grid")?;
            writeln!(s, "[[layout]]\nname = \"{name}\"\ndescription = \"{desc}\"")?;
            for (k, ax) in [("x_mm", g.x), ("y_mm", g.y), ("z_mm", g.z)] {
                writeln!(s, "{k} = [{:?}, {:?}, {}]", ax.start, ax.stop, ax.count)?;
            }
            writeln!(s, "threshold_mm = {:?}", g.threshold_mm)?;
            if pixel {
                writeln!(s, "pixel_sigma_px = 0.5\nfocal_px = 1600.0")?;
            }
            for o in &g.observers {
                let cam3 = o.name.contains("cam3");
                writeln!(
                    s,
                    "\n[[layout.observer]]\nname = \"{}\"\nposition_mm = {}",
                    o.name,
                    arr(o.position_mm.into())
                )?;
                if this_run {
                    writeln!(s, "from = \"{}\"", if cam3 { "tie" } else { "inward" })?;
                } else {
                    let (p, r) = paper_sigma(cam3);
                    writeln!(s, "sigma_position_mm = {p}\nsigma_angles_deg = {r}")?;
                }
            }
            writeln!(s)?;
            Ok(())
        };
    for (figure, stem, what) in LAYOUTS {
        layout(
            &format!("{stem}_paper"),
            &format!("{figure} (reproduced): {what}; observers with the paper's Table 3-4 sigma"),
            stem,
            false,
            false,
        )?;
        layout(
            &format!("{stem}_this_run"),
            &format!("{figure}: {what}; observers with this run's propagated sigma"),
            stem,
            true,
            false,
        )?;
    }
    layout(
        "three_cameras_z0_pixel_noise",
        "Beyond the paper: three-camera layout at camera height with 0.5 px measurement noise at f = 1600 px (paper sigma)",
        "three_cameras_z0",
        false,
        true,
    )?;
    fixed_layouts(&mut s)?;
    Ok(s)
}

/// The paper's lens as a study `camera` table (see [`FIXED_LENS_COMMENT`]).
pub const PAPER_INWARD_LENS: &str = "{ model = \"OPENCV\", width = 2560, height = 1440, params = [1600.0, 1600.0, 1280.0, 720.0, 0.0, 0.0, 0.0, 0.0] }";

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
fn fixed_layouts(s: &mut String) -> anyhow::Result<()> {
    s.push_str(FIXED_LENS_COMMENT);
    for (name, figure, door, door_sigma) in [
        (
            "four_cameras_fixed_paper",
            "Figures 10-11",
            "door (cam2')",
            1,
        ),
        (
            "three_cameras_fixed_paper",
            "Figures 12-13",
            "door (cam3)",
            2,
        ),
    ] {
        writeln!(
            s,
            "[[layout]]\nname = \"{name}\"\ndescription = \"Beyond the paper: {figure} layout with fixed cameras and the paper's lenses (8 mm, 2560 x 1440 px; assumed 5 um pitch, centred principal point), points at camera height and 30 cm higher; paper sigma\"\nx_mm = [400.0, 2000.0, 17]\ny_mm = [-600.0, 600.0, 13]\nz_mm = [0.0, 300.0, 2]\nthreshold_mm = 5.0"
        )?;
        for (obs, position, target, sigma) in [
            ("rear (cam2)", [200.0, 0.0, 0.0], [1200.0, 0.0, 150.0], 1),
            (
                door,
                [1300.0, -700.0, 0.0],
                [1000.0, 0.0, 150.0],
                door_sigma,
            ),
        ] {
            writeln!(
                s,
                "\n[[layout.observer]]\nname = \"{obs}\"\nposition_mm = {}\naim = \"fixed\"\nlook_at_mm = {}\ncamera = {PAPER_INWARD_LENS}\npixel_sigma_px = 0.0\nsigma_position_mm = {}\nsigma_angles_deg = {}",
                arr(position),
                arr(target),
                arr(crashrig_study::report::published::TABLE3_MM[sigma]),
                arr(crashrig_study::report::published::TABLE4_DEG[sigma]),
            )?;
        }
        writeln!(s)?;
    }
    Ok(())
}

/// Runs `crashrig paper`.
pub fn run(a: PaperArgs, g: &Global) -> anyhow::Result<()> {
    let results = compute(&a, g)?;
    if g.json {
        crate::output::print_json(&results)?;
    } else {
        println!(
            "crashrig paper: {}",
            super::study::summary_line(&a.out, &results)
        );
    }
    Ok(())
}

/// Writes the inputs and the study file below `a.out`, runs the study there and returns
/// `results.json`'s content.
pub fn compute(a: &PaperArgs, g: &Global) -> anyhow::Result<Value> {
    let seed = g.seed.unwrap_or(DEFAULT_SEED);
    super::study::at_least_two("--samples", a.samples)?;
    super::study::at_least_two("--chain-samples", a.chain_samples)?;
    let inputs = a.out.join("inputs");
    std::fs::create_dir_all(&inputs)
        .with_context(|| format!("{}: cannot create the output directory", inputs.display()))?;
    write_inputs(&inputs)?;
    let study = inputs.join("study.toml");
    crate::output::write_atomic(&study, study_toml(a, seed)?.as_bytes())?;
    let command = format!(
        "crashrig paper --out {} --seed {seed} --samples {} --chain-samples {} --iterations {}   (= crashrig study {} --out {})",
        a.out.display(),
        a.samples,
        a.chain_samples,
        a.iterations,
        study.display(),
        a.out.display()
    );
    super::study::execute(&study, &a.out, None, None, false, &command)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `paper` is `study` on the bundled study file: running `study` on `DIR/inputs/study.toml`
    /// into another directory gives the same results.json, byte for byte.
    #[test]
    fn paper_equals_study_on_its_study_file() {
        let tmp = tempfile::tempdir().unwrap();
        let a = PaperArgs {
            out: tmp.path().join("paper"),
            samples: 20,
            chain_samples: 2000,
            iterations: 20,
        };
        let g = Global {
            json: true,
            seed: Some(7),
            threads: None,
        };
        let r = compute(&a, &g).unwrap();
        let again = tmp.path().join("again");
        let study = a.out.join("inputs/study.toml");
        let r2 = super::super::study::execute(&study, &again, None, None, false, "test").unwrap();
        assert_eq!(r, r2);
        assert_eq!(
            std::fs::read(a.out.join("results.json")).unwrap(),
            std::fs::read(again.join("results.json")).unwrap()
        );
        assert_eq!(r["seed"], 7);
        assert_eq!(r["layouts"].as_array().unwrap().len(), 11);
        assert!(
            r["layouts"][10]["summary"]["fixed"]["fraction_measurable"]
                .as_f64()
                .unwrap()
                < 1.0
        );
        let html = std::fs::read_to_string(a.out.join("report.html")).unwrap();
        assert!(html.contains("What differs from the paper"));
        assert!(html.contains("verified inliers only"));
        assert!(
            html.contains("pixel pitch 5.0 µm"),
            "the report states the assumed lens"
        );
    }
}
