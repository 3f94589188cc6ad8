//! The worked example of `docs/COVARIANCE.md` through the library: camera A's covariance on the
//! bundled 8-epoch lab sequence (`fixtures/covariance/mc`), σ̂₀, every intrinsic marginalised.
//!
//! `cargo run -p crashrig-covariance --example worked_example [-- OUT.json]` prints the line
//! that `crashrig covariance` prints and A's σ per epoch; with OUT.json it also writes the
//! document that `measure --a-covariance` reads (the command's `--out`).

use crashrig_covariance::{CovarianceConfig, Intrinsics, Scale, run};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let f = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/covariance/mc");
    let r = run(
        &CovarianceConfig {
            model: f.join("model"),
            camera_a: "cam_out/".into(),
            control_points: f.join("control_points.csv"),
            scale: Scale::MmPerUnit(1000.0),
            pixel_sigma_px: None,
            intrinsics: Intrinsics::All,
        },
        None,
    )?;
    println!(
        "{} epochs of A, σ̂₀ = {:.3} px (used {:.3} px), {} observations",
        r.epochs.len(),
        r.sigma0_px,
        r.pixel_sigma_px,
        r.observations
    );
    for e in &r.epochs {
        let p = e.world_from_a.sigma_position();
        let a = e.world_from_a.sigma_rotation().map(f64::to_degrees);
        println!(
            "{}: σ centre {:.2} {:.2} {:.2} mm, σ rotation {:.4} {:.4} {:.4} deg",
            e.name, p.x, p.y, p.z, a.x, a.y, a.z
        );
    }
    if let Some(out) = std::env::args().nth(1) {
        std::fs::write(&out, serde_json::to_string_pretty(&r.to_json())?)?;
        println!("written: {out}");
    }
    Ok(())
}
