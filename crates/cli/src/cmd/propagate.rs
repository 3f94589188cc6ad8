//! `crashrig propagate`: Monte Carlo and linear propagation through a camera chain.

use crate::Global;
use anyhow::Context;
use crashrig_mc::{Chain, Scenario};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `crashrig propagate`.
#[derive(Debug, clap::Args)]
pub struct PropagateArgs {
    /// Scenario file (TOML, every key in docs/SCENARIO.md).
    pub scenario: PathBuf,
    /// Monte Carlo draws (overrides the scenario's `samples`).
    #[arg(long)]
    pub samples: Option<usize>,
}

/// Reads a scenario; every error names the file (TOML errors also the line).
pub fn load_scenario(path: &Path) -> anyhow::Result<Scenario> {
    Scenario::from_path(path).map_err(|e| match e {
        crashrig_mc::Error::Io { .. }
        | crashrig_mc::Error::Toml { .. }
        | crashrig_mc::Error::Located { .. } => anyhow::Error::new(e),
        other => anyhow::Error::new(other).context(path.display().to_string()),
    })
}

/// The `samples` to use: the option, else the scenario's; at least 2.
pub fn resolve_samples(option: Option<usize>, scenario: &Scenario) -> anyhow::Result<usize> {
    let n = option.unwrap_or(scenario.samples);
    anyhow::ensure!(n >= 2, "--samples must be at least 2, got {n}");
    let max = crashrig_mc::limits::MAX_SAMPLES;
    anyhow::ensure!(
        n <= max,
        "--samples {n} exceeds the limit of {max} (docs/LIMITS.md)"
    );
    Ok(n)
}

#[derive(Serialize)]
struct LinearJson {
    position_sigma_mm: [f64; 3],
    /// `null` where the nominal ω φ κ are at gimbal lock (see `angles_singular`).
    angles_sigma_deg: Option<[f64; 3]>,
    tangent_sigma_deg: [f64; 3],
    covariance_tangent: [[f64; 6]; 6],
}

#[derive(Serialize)]
struct CameraJson {
    name: String,
    parent: Option<String>,
    position_mm: [f64; 3],
    angles_deg: [f64; 3],
    position_sigma_mm: [f64; 3],
    /// `null` at gimbal lock of the nominal world ω φ κ.
    angles_sigma_deg: Option<[f64; 3]>,
    tangent_sigma_deg: [f64; 3],
    position_mean_mm: [f64; 3],
    /// `null` at gimbal lock of the nominal world ω φ κ.
    angles_mean_deg: Option<[f64; 3]>,
    /// True when the nominal world rotation is at φ = ±90° (to within
    /// `crashrig_geometry::opk::GIMBAL_LOCK_COS_PHI`): ω and κ are then not separable, so the
    /// ω φ κ σ are `null`; the tangent covariance is unaffected.
    angles_singular: bool,
    /// The world pose's covariance over the draws: centre in world axes (mm), rotation about
    /// the camera's own axes (deg); n − 1.
    covariance_tangent: [[f64; 6]; 6],
    linear: LinearJson,
}

#[derive(Serialize)]
struct PropagateJson {
    samples: usize,
    seed: u64,
    rotation_noise: &'static str,
    cameras: Vec<CameraJson>,
    elapsed_s: f64,
}

fn deg(v: nalgebra::Vector3<f64>) -> [f64; 3] {
    v.map(f64::to_degrees).into()
}

/// A tangent covariance (mm, rad) in the contract's units (mm, deg) as 6 rows.
fn rows_deg(c: &nalgebra::Matrix6<f64>) -> [[f64; 6]; 6] {
    let u = crashrig_geometry::UncertainPose {
        b_from_a: crashrig_geometry::Rigid3::identity(),
        covariance: *c,
    }
    .covariance_deg();
    std::array::from_fn(|i| std::array::from_fn(|j| u[(i, j)]))
}

/// Runs the propagation and returns the JSON document of the contract (for the tests).
#[cfg(test)]
fn compute(a: &PropagateArgs, seed: Option<u64>) -> anyhow::Result<serde_json::Value> {
    serde_json::to_value(compute_typed(a, seed)?).context("formatting the propagation result")
}

/// Runs `crashrig propagate`.
pub fn run(a: PropagateArgs, g: &Global) -> anyhow::Result<()> {
    let out = compute_typed(&a, g.seed)?;
    if g.json {
        return crate::output::print_json(&out);
    }
    // A closed pipe (e.g. `| head`) ends the output quietly instead of panicking.
    quiet_pipe(print_table(&out))
}

fn compute_typed(a: &PropagateArgs, seed: Option<u64>) -> anyhow::Result<PropagateJson> {
    let scenario = load_scenario(&a.scenario)?;
    anyhow::ensure!(
        !scenario.cameras.is_empty(),
        "{}: `camera`: the scenario has no camera",
        a.scenario.display()
    );
    let samples = resolve_samples(a.samples, &scenario)?;
    let seed = seed.unwrap_or(scenario.seed);
    let chain = Chain::new(&scenario);
    // Any ω φ κ input is a valid rotation; only the ω φ κ *output* of a camera at φ = ±90° is
    // singular: its angle σ are null, with one warning.
    for (i, name) in chain.names().iter().enumerate() {
        if chain.angles_singular(i) {
            eprintln!(
                "warning: {}: camera `{name}`: its world orientation is at φ = ±90° (gimbal lock), where ω and κ are not separable; its ω φ κ σ are null (see covariance_tangent / tangent_sigma_deg)",
                a.scenario.display()
            );
        }
    }
    let start = std::time::Instant::now();
    let bar = crate::progress::Bar::new("crashrig propagate");
    let chunks = bar.stage("chunks of draws");
    let mc = chain.monte_carlo_with_progress(samples, seed, bar.hook(&chunks));
    bar.finish();
    let elapsed_s = start.elapsed().as_secs_f64();
    let lin = chain.linear();
    let cameras: Vec<CameraJson> = mc
        .iter()
        .zip(&lin)
        .zip(&scenario.cameras)
        .map(|((m, l), c)| {
            let ok = !m.angles_singular;
            CameraJson {
                name: m.name.clone(),
                parent: c.parent.map(|p| scenario.cameras[p].name.clone()),
                position_mm: m.nominal.position_mm.into(),
                angles_deg: deg(m.nominal.angles_rad()),
                position_sigma_mm: m.position_sigma_mm.into(),
                angles_sigma_deg: ok.then(|| deg(m.angles_sigma_rad)),
                tangent_sigma_deg: deg(m.tangent_sigma_rad),
                position_mean_mm: m.position_mean_mm.into(),
                angles_mean_deg: ok.then(|| deg(m.angles_mean_rad)),
                angles_singular: m.angles_singular,
                covariance_tangent: rows_deg(&m.covariance_tangent),
                linear: LinearJson {
                    position_sigma_mm: l.position_sigma_mm.into(),
                    angles_sigma_deg: l.angles_sigma_rad.filter(|_| ok).map(deg),
                    tangent_sigma_deg: deg(l.tangent_sigma_rad),
                    covariance_tangent: rows_deg(&l.covariance_tangent),
                },
            }
        })
        .collect();
    let out = PropagateJson {
        samples,
        seed,
        rotation_noise: match scenario.rotation_noise {
            crashrig_mc::RotationNoise::Tangent => "tangent",
            crashrig_mc::RotationNoise::Euler => "euler",
        },
        cameras,
        elapsed_s,
    };
    Ok(out)
}

fn print_table(out: &PropagateJson) -> std::io::Result<()> {
    use std::io::Write;
    let mut w = std::io::stdout().lock();
    writeln!(
        w,
        "{} draws, seed {}, rotation noise {} ({:.3} s)",
        out.samples, out.seed, out.rotation_noise, out.elapsed_s
    )?;
    writeln!(
        w,
        "{:<12} {:>26} {:>29} {:>26} {:>29}",
        "camera",
        "σ position MC [mm]",
        "σ ω φ κ MC [°]",
        "σ position linear [mm]",
        "σ ω φ κ linear [°]"
    )?;
    for c in &out.cameras {
        let p = |v: [f64; 3]| format!("{:8.3} {:8.3} {:8.3}", v[0], v[1], v[2]);
        let q = |v: Option<[f64; 3]>| {
            v.map_or_else(
                || format!("{:>29}", "(φ = ±90°: see tangent σ)"),
                |v| format!("{:9.5} {:9.5} {:9.5}", v[0], v[1], v[2]),
            )
        };
        writeln!(
            w,
            "{:<12} {:>26} {:>29} {:>26} {:>29}",
            c.name,
            p(c.position_sigma_mm),
            q(c.angles_sigma_deg),
            p(c.linear.position_sigma_mm),
            q(c.linear.angles_sigma_deg)
        )?;
    }
    Ok(())
}

/// Treats a closed stdout pipe as success (the reader went away), other errors as errors.
pub fn quiet_pipe(r: std::io::Result<()>) -> anyhow::Result<()> {
    match r {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other.context("writing to stdout"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn propagate_compute_nominal_contract_fields() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/scenarios/paper_chain.toml");
        let a = PropagateArgs {
            scenario: path,
            samples: Some(2000),
        };
        let v = compute(&a, Some(1)).unwrap();
        assert_eq!(v["samples"], 2000);
        let cams = v["cameras"].as_array().unwrap();
        assert_eq!(cams.len(), 3);
        for c in cams {
            for key in [
                "name",
                "position_mm",
                "angles_deg",
                "position_sigma_mm",
                "angles_sigma_deg",
            ] {
                assert!(c.get(key).is_some(), "camera lacks {key}");
            }
            assert_eq!(
                c["linear"]["position_sigma_mm"].as_array().unwrap().len(),
                3
            );
            assert_eq!(c["linear"]["angles_sigma_deg"].as_array().unwrap().len(), 3);
        }
        // Same seed, same numbers.
        assert_eq!(compute(&a, Some(1)).unwrap()["cameras"], v["cameras"]);
    }

    #[test]
    fn propagate_compute_syntax_error_has_line() {
        let tmp = tempfile::tempdir().unwrap();
        let p = tmp.path().join("s.toml");
        std::fs::write(&p, "seed = 1\nsamples = = 3\n").unwrap();
        let a = PropagateArgs {
            scenario: p,
            samples: None,
        };
        let msg = format!("{:#}", compute(&a, None).unwrap_err());
        assert!(msg.contains("s.toml:2:"), "{msg}");
    }
}
