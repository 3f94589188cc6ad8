//! Shared inputs of the Monte Carlo benchmarks: the criterion benches in `benches/benches/`
//! and the CPU-time harness `examples/mc_cpu.rs` run the same scenarios and instruction-set levels, defined
//! once here.
//!
//! ```
//! let levels = crashrig_benches::levels();
//! assert_eq!(levels[0].name(), "baseline");
//! assert_eq!(crashrig_benches::level_of_name("baseline"), Some(levels[0]));
//! ```
use crashrig_mc::Isa;

/// Two aimed observers with the σ of the paper's Tables 3–4 over a 17 × 13 grid (221 points).
pub const TWO_OBSERVERS: &str = r#"
seed = 1
samples = 2000
[grid]
x_mm = [400.0, 2000.0, 17]
y_mm = [-600.0, 600.0, 13]
z_mm = [0.0, 0.0, 1]
[[grid.observer]]
position_mm = [200.0, 0.0, 0.0]
sigma_position_mm = [1.52, 1.54, 1.52]
sigma_angles_deg = [0.011, 0.011, 0.013]
[[grid.observer]]
position_mm = [1300.0, -700.0, 0.0]
sigma_position_mm = [2.53, 2.51, 2.55]
sigma_angles_deg = [0.023, 0.023, 0.024]
"#;

/// [`TWO_OBSERVERS`] at one grid point (1000, 300, 0) mm: the per-draw cost of the kernel.
pub fn one_point_kernel() -> String {
    TWO_OBSERVERS
        .replace("x_mm = [400.0, 2000.0, 17]", "x_mm = [1000.0, 1000.0, 1]")
        .replace("y_mm = [-600.0, 600.0, 13]", "y_mm = [300.0, 300.0, 1]")
}

/// One grid point (1000, 300, 0) mm of each kernel path, by name: the real study's path
/// ([`study_path`]), tangent and euler noise
/// (diagonal factors), a full tangent covariance, pixel noise, three observers, and observers
/// drawn jointly from a chain (`correlated`). The per-path benches
/// (`benches/mc.rs`, group `paths_1thread`) run each on every instruction-set level.
pub fn kernel_paths() -> Vec<(&'static str, String)> {
    let one = one_point_kernel();
    let tangent = format!("rotation_noise = \"tangent\"\n{one}");
    let full = tangent.replacen(
        "sigma_position_mm = [1.52, 1.54, 1.52]\nsigma_angles_deg = [0.011, 0.011, 0.013]",
        "covariance_tangent = [[2.31, 0.4, 0.0, 0.001, 0.0, 0.0], [0.4, 2.37, 0.0, 0.0, 0.0, 0.0], \
         [0.0, 0.0, 2.31, 0.0, 0.0, 0.0], [0.001, 0.0, 0.0, 1.2e-4, 0.0, 0.0], \
         [0.0, 0.0, 0.0, 0.0, 1.2e-4, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 1.7e-4]]",
        1,
    );
    let pixel = tangent.replace(
        "[grid]\n",
        "[grid]\npixel_sigma_px = 0.5\nfocal_px = 1500.0\n",
    );
    let three = format!(
        "{tangent}[[grid.observer]]\nposition_mm = [1300.0, 700.0, 300.0]\n\
         sigma_position_mm = [2.0, 2.0, 2.0]\nsigma_angles_deg = [0.02, 0.02, 0.02]\n"
    );
    // The bundled correlated scenario (observers at cam2 and cam3, drawn jointly with the
    // chain) at the same single point.
    let correlated = include_str!("../../fixtures/scenarios/three_cameras_correlated.toml")
        .replace("x_mm = [400.0, 2000.0, 17]", "x_mm = [1000.0, 1000.0, 1]")
        .replace("y_mm = [-600.0, 600.0, 13]", "y_mm = [300.0, 300.0, 1]");
    vec![
        ("study", study_path()),
        ("tangent", tangent),
        ("euler", one),
        ("full_covariance", full),
        ("pixel", pixel),
        ("three_observers", three),
        ("correlated", correlated),
    ]
}

/// The path a real study takes, at the same single point (`benches/study_path.toml`): the
/// bundled correlated chain (A = cam1 localised with a full 6×6 tangent covariance, B = cam2
/// on the calibrated link with a full covariance, C = cam3 tied in), `correlated = true`, and
/// B and C as fixed OPENCV cameras with distortion and pixel noise, each drawn jointly from
/// its chain camera. `benches/study_path_numpy.py` is its NumPy equivalent.
pub fn study_path() -> String {
    include_str!("../study_path.toml").to_string()
}

/// The real-study path as a whole map (`benches/real_map.toml`): the chain of
/// [`study_path`] with full covariances, `correlated = true`, over 221 grid points seen by
/// two fixed OPENCV cameras with distortion and pixel noise and two aimed observers, all
/// drawn jointly from the chain (one chain draw per replicate for the whole map).
/// `crashrig grid` runs it and its independent companion map (observers drawn on their own
/// with their propagated covariances); `benches/real_map_numpy.py` is its per-point NumPy
/// reference.
pub fn real_map() -> String {
    include_str!("../real_map.toml").to_string()
}

/// A three-camera chain (the paper's cam1 → cam2 link, and a third camera).
pub const CHAIN: &str = r#"
seed = 1
samples = 1000
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
[[camera]]
name = "cam3"
parent = "cam2"
position_mm = [-900.0, 50.0, 600.0]
angles_deg = [0.0, 0.0, 0.0]
sigma_position_mm = [2.0, 2.0, 2.0]
sigma_angles_deg = [0.02, 0.02, 0.02]
"#;

/// Every instruction-set level this CPU has, slowest first.
pub fn levels() -> Vec<Isa> {
    Isa::LEVELS
        .into_iter()
        .filter(|l| l.is_available())
        .collect()
}

/// The level named `baseline`, `v3`, `v4` or `auto` ([`Isa::name`]), if any.
pub fn level_of_name(name: &str) -> Option<Isa> {
    match name {
        "auto" => Some(Isa::Auto),
        _ => Isa::LEVELS.into_iter().find(|l| l.name() == name),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crashrig_mc::{GridStudy, RunOptions, Scenario};
    use std::path::Path;

    #[test]
    fn every_kernel_path_parses_and_runs() {
        let paths = kernel_paths();
        // Every replacement took effect: seven different scenarios.
        for (i, (a, ta)) in paths.iter().enumerate() {
            for (b, tb) in &paths[i + 1..] {
                assert_ne!(ta, tb, "{a} and {b} are the same scenario");
            }
        }
        for (name, toml) in paths {
            let sc = Scenario::from_toml_str(&toml, Path::new("bench.toml"))
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let study = GridStudy::new(&sc, 0, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
            let r = study
                .run(
                    &RunOptions {
                        isa: Isa::Auto,
                        ..RunOptions::samples(200, 1)
                    },
                    None,
                )
                .unwrap();
            assert_eq!(r.points.len(), 1, "{name}");
            if name == "study" {
                // Both full covariances replaced the σ keys, the observers are drawn jointly
                // from the chain, and both fixed cameras see the point.
                assert_eq!(toml.matches("covariance_tangent").count(), 2);
                assert!(r.correlated);
                assert_eq!(r.points[0].observers_seen, 2);
            }
            assert!(
                r.points[0]
                    .sigma_mm
                    .iter()
                    .all(|s| s.is_finite() && *s > 0.0),
                "{name}"
            );
        }
    }
}
