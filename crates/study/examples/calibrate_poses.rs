//! Calibrate a rig link from your own poses (no COLMAP): one `Epoch` per simultaneous pair of
//! poses `A_from_world`, `B_from_world`; the result is `A_from_B` over the epochs.
//!
//! `cargo run -p crashrig-study --example calibrate_poses`

use crashrig_geometry::{Rigid3, Vec3, opk::rotation_from_opk};
use crashrig_rig::{CalibrateOptions, Epoch, calibrate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A true link: B 60 mm right, 180 mm ahead of A, turned half a turn about A's y axis.
    let a_from_b = Rigid3::from_parts(
        Vec3::new(60.0, 0.0, 180.0).into(),
        rotation_from_opk(0.0, std::f64::consts::PI, 0.0).into(),
    );
    // Twenty epochs of the pair moving through the lab, with a small, known wobble of the link.
    let epochs: Vec<Epoch> = (0..20)
        .map(|i| {
            let t = i as f64;
            let a_from_world = Rigid3::from_parts(
                Vec3::new(100.0 * t, 20.0 * t.sin(), 1500.0).into(),
                rotation_from_opk(0.1 * t.cos(), 0.05 * t, 0.2).into(),
            );
            let wobble = Rigid3::from_parts(
                Vec3::new(0.5 * (1.3 * t).sin(), 0.5 * (0.7 * t).cos(), 0.0).into(),
                rotation_from_opk(1e-4 * t.sin(), 0.0, 0.0).into(),
            );
            let link = a_from_b * wobble;
            Epoch {
                name: format!("{i:03}"),
                a_from_world,
                b_from_world: link.inverse() * a_from_world,
            }
        })
        .collect();
    let options = CalibrateOptions {
        refine: None,
        ..CalibrateOptions::default()
    };
    let c = calibrate(&epochs, 1.0, &options, None)?;
    println!(
        "{} epochs: base {:.3?} mm ± {:.3?} (σ), SEM {:.3?}",
        c.all.n, c.all.base_mm, c.all.base_sigma_mm, c.all.base_sem_mm
    );
    assert!((c.all.base_mm - Vec3::new(60.0, 0.0, 180.0)).norm() < 0.5);
    Ok(())
}
