//! A chain study from code: outward camera → calibrated link → tied camera as typed uncertain
//! poses, propagated by Monte Carlo, then a grid of the interior seen by two observers.
//!
//! `cargo run -p crashrig-study --example chain_study`

use crashrig_geometry::{Rigid3, UncertainPose, Vec3, opk::rotation_from_opk};
use crashrig_mc::{Axis, ChainBuilder, ChainOptions, GridBuilder};
use nalgebra::Vector3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let deg = f64::to_radians;
    let mut chain = ChainBuilder::new();
    // The outward camera's world pose: 1 mm and 0.01° (tangent) of bundle-adjustment noise.
    let outward = chain.world(
        "outward",
        UncertainPose::from_sigmas(
            Rigid3::identity(),
            Vec3::repeat(1.0),
            Vec3::repeat(deg(0.01)),
        ),
    )?;
    // The calibrated link A_from_B with its SEM (the paper's Table 1-2 σ/√n).
    let link = Rigid3::from_parts(
        Vec3::new(61.98, -1.71, 179.76).into(),
        rotation_from_opk(deg(179.92), deg(-0.09), deg(179.76)).into(),
    );
    let inward = chain.link(
        "inward",
        outward,
        UncertainPose::from_sigmas(
            link,
            Vec3::new(0.19, 0.26, 0.13),
            Vec3::new(deg(0.004), deg(0.005), deg(0.008)),
        ),
    )?;
    let chain = chain.build();
    for p in chain.monte_carlo(&ChainOptions::new(20_000, 1), None)? {
        println!(
            "{}: σ position {:.3?} mm, tangent σ {:.4?}°",
            p.name,
            p.position_sigma_mm,
            p.tangent_sigma_rad.map(f64::to_degrees)
        );
    }
    let axis = |a: f64, b: f64, n: usize| Axis {
        start: a,
        stop: b,
        count: n,
    };
    let grid = GridBuilder::new(
        axis(400.0, 2000.0, 5),
        axis(-600.0, 600.0, 4),
        axis(0.0, 0.0, 1),
    )
    .chain(chain)
    .observer_from("rear", Vector3::new(200.0, 0.0, 0.0), inward)
    .observer(
        "door",
        Vector3::new(1300.0, -700.0, 0.0),
        UncertainPose::from_sigmas(
            Rigid3::identity(),
            Vec3::repeat(2.5),
            Vec3::repeat(deg(0.023)),
        )
        .covariance,
    )
    .threshold_mm(5.0)
    .build(500, 1)?;
    let r = grid.run(&grid.options(), None)?;
    println!(
        "{:.0} % of the grid below 5 mm",
        100.0 * r.fraction_below(5.0)
    );
    Ok(())
}
