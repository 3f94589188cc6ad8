//! `crashrig covariance` on COLMAP models as a new user would run it (the rule of
//! `tests/bundled_models.rs`: camera A = the camera id with the most registered images, control
//! points chosen from the model's own points, all fixed; intrinsics `all`, then `colmap`, then
//! `fixed` as the error's hint says; a control point that the command refuses is replaced by
//! the rule's next choice), one line per model: the outcome, A's σ range and the warnings, or
//! the errors.
//!
//! ```text
//! cargo run --release -p crashrig-covariance --example survey -- [--camera ID] MODEL_DIR…
//! ```
//!
//! `--camera ID` takes that camera id as A instead of the rule's.

use crashrig_colmap::Reconstruction;
use crashrig_covariance::{CovarianceConfig, Error, Intrinsics, Scale, run};
use std::path::{Path, PathBuf};

#[path = "../tests/rule/mod.rs"]
mod rule;

/// Control points replaced before giving up.
const MAX_REPLACED: usize = 20;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let camera = match args.iter().position(|a| a == "--camera") {
        Some(k) if k + 1 < args.len() => {
            let id = args[k + 1]
                .parse::<u32>()
                .expect("--camera takes a camera id");
            args.drain(k..k + 2);
            Some(id)
        }
        Some(_) => panic!("--camera takes a camera id"),
        None => None,
    };
    let tmp = tempfile::tempdir().expect("a temporary folder");
    for dir in args.iter().map(PathBuf::from) {
        println!("{}: {}", dir.display(), survey(&dir, camera, tmp.path()));
    }
}

/// One model: its outcome in words.
fn survey(dir: &Path, camera: Option<u32>, tmp: &Path) -> String {
    let model = match Reconstruction::read(dir) {
        Ok(m) => m,
        Err(e) => return format!("unreadable: {e}"),
    };
    let Some(cam) = camera.or_else(|| rule::camera_a(&model)) else {
        return "skipped (no camera A)".into();
    };
    let mut excluded = Vec::new();
    let mut notes = Vec::new();
    let csv = tmp.join("control.csv");
    'control: while excluded.len() <= MAX_REPLACED {
        let Some(ids) = rule::control_points_excluding(&model, &excluded) else {
            return format!("skipped (no three non-collinear points){}", notes.concat());
        };
        let body: String = ids.iter().map(|id| format!("{id},0\n")).collect();
        std::fs::write(&csv, format!("point3D_id,sigma_mm\n{body}")).expect("write");
        let mut errors = Vec::new();
        for mode in [Intrinsics::All, Intrinsics::Colmap, Intrinsics::Fixed] {
            let config = CovarianceConfig {
                model: dir.to_path_buf(),
                camera_a: cam.to_string(),
                control_points: csv.clone(),
                scale: Scale::MmPerUnit(1000.0),
                pixel_sigma_px: None,
                intrinsics: mode,
            };
            match run(&config, None) {
                Ok(r) => {
                    let sp: Vec<f64> = r
                        .epochs
                        .iter()
                        .flat_map(|e| {
                            let s = e.world_from_a.sigma_position();
                            [s.x, s.y, s.z]
                        })
                        .collect();
                    let lo = sp.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = sp.iter().copied().fold(0.0, f64::max);
                    let warnings: String = r
                        .warnings
                        .iter()
                        .map(|w| format!("\n    warning: {w}"))
                        .collect();
                    return format!(
                        "ok ({}; camera {cam}, control {ids:?}, {} epochs, {} frames, σ̂₀ {:.3} px, \
                         σ position {lo:.3e}–{hi:.3e} mm){}{}{warnings}",
                        mode.name(),
                        r.epochs.len(),
                        r.frames,
                        r.sigma0_px,
                        notes.concat(),
                        if errors.is_empty() {
                            String::new()
                        } else {
                            format!("\n    after: {}", errors.join("\n    after: "))
                        },
                    );
                }
                Err(Error::ControlCsv { line, problem, .. }) if line >= 2 => {
                    let id = ids[line as usize - 2];
                    notes.push(format!("\n    control point {id} replaced: {problem}"));
                    excluded.push(id);
                    continue 'control;
                }
                Err(e) => errors.push(e.to_string()),
            }
        }
        return format!("{}{}", errors.join("\n    error: "), notes.concat());
    }
    format!(
        "gave up after replacing {MAX_REPLACED} control points{}",
        notes.concat()
    )
}
