//! [`GridBuilder`]: a grid study from typed values, without a scenario file.

use crate::chain::{CameraId, Chain};
use crate::error::Error;
use crate::grid::GridStudy;
use crate::model::{
    Adaptive, Aim, Axis, FixedCamera, Grid, Observer, ObserverSigma, PixelNoise, RotationNoise,
};
use nalgebra::{Matrix6, Vector3};

/// Builds a [`GridStudy`] without a scenario file: the grid axes, the observers (each with a
/// covariance or taking a chain camera's propagated one), options, and the number of draws
/// and the seed, given once.
///
/// ```
/// use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
/// use crashrig_mc::{Axis, ChainBuilder, GridBuilder};
/// use nalgebra::{Matrix6, Vector3};
///
/// let mut b = ChainBuilder::new();
/// let rig = b.world(
///     "rig",
///     UncertainPose::from_sigmas(Rigid3::translation(0.0, -300.0, 0.0), Vec3::repeat(0.5), Vec3::repeat(1e-4)),
/// )?;
/// let chain = b.build();
/// let axis = |a: f64, b: f64, n: usize| Axis { start: a, stop: b, count: n };
/// let study = GridBuilder::new(axis(1000.0, 1500.0, 2), axis(0.0, 0.0, 1), axis(0.0, 0.0, 1))
///     .chain(chain)
///     .observer_from("rig", Vector3::new(0.0, -300.0, 0.0), rig)
///     .observer("door", Vector3::new(0.0, 300.0, 0.0), Matrix6::from_diagonal_element(1e-2))
///     .threshold_mm(2.0)
///     .build(2000, 7)?;
/// let result = study.run(&study.options(), None)?;
/// assert_eq!(result.points.len(), 2);
/// # Ok::<(), crashrig_mc::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct GridBuilder {
    grid: Grid,
    chain: Option<Chain>,
    rotation_noise: RotationNoise,
}

impl GridBuilder {
    /// A grid over the three axes (mm), threshold 5 mm, no observer yet, no chain.
    pub fn new(x: Axis, y: Axis, z: Axis) -> Self {
        GridBuilder {
            grid: Grid {
                x,
                y,
                z,
                threshold_mm: 5.0,
                observers: Vec::new(),
                pixel: None,
                correlated: false,
                adaptive: None,
            },
            chain: None,
            rotation_noise: RotationNoise::Tangent,
        }
    }

    /// The chain the `observer_from` observers take their noise from.
    pub fn chain(mut self, chain: Chain) -> Self {
        self.chain = Some(chain);
        self
    }

    /// Threshold on σ_max (mm).
    pub fn threshold_mm(mut self, threshold_mm: f64) -> Self {
        self.grid.threshold_mm = threshold_mm;
        self
    }

    /// An observer at `position_mm` with a tangent covariance (mm, rad about its own axes).
    pub fn observer(
        mut self,
        name: impl Into<String>,
        position_mm: Vector3<f64>,
        covariance: Matrix6<f64>,
    ) -> Self {
        self.grid.observers.push(Observer {
            name: name.into(),
            position_mm,
            sigma: ObserverSigma::Covariance(covariance),
            aim: Aim::Point,
        });
        self
    }

    /// A fixed observer (`aim = "fixed"`): centre `position_mm`, orientation, lens and pixel
    /// noise in `camera`, pose noise `covariance` (mm, rad; tangent about its own axes).
    pub fn fixed_observer(
        mut self,
        name: impl Into<String>,
        position_mm: Vector3<f64>,
        covariance: Matrix6<f64>,
        camera: FixedCamera,
    ) -> Self {
        self.grid.observers.push(Observer {
            name: name.into(),
            position_mm,
            sigma: ObserverSigma::Covariance(covariance),
            aim: Aim::Fixed(Box::new(camera)),
        });
        self
    }

    /// An observer taking chain camera `camera`'s propagated world covariance (or, with
    /// [`GridBuilder::correlated`], its joint draw; it must then stand at that camera).
    pub fn observer_from(
        mut self,
        name: impl Into<String>,
        position_mm: Vector3<f64>,
        camera: CameraId,
    ) -> Self {
        self.grid.observers.push(Observer {
            name: name.into(),
            position_mm,
            sigma: ObserverSigma::From(camera.index()),
            aim: Aim::Point,
        });
        self
    }

    /// Pixel noise at every observer.
    pub fn pixel_noise(mut self, pixel: PixelNoise) -> Self {
        self.grid.pixel = Some(pixel);
        self
    }

    /// Draw the `observer_from` observers jointly from the chain (world-frame errors).
    pub fn correlated(mut self, correlated: bool) -> Self {
        self.grid.correlated = correlated;
        self
    }

    /// Adaptive number of draws per point.
    pub fn adaptive(mut self, adaptive: Adaptive) -> Self {
        self.grid.adaptive = Some(adaptive);
        self
    }

    /// The prepared study with `samples` draws per point (the maximum comes from
    /// [`Adaptive`] when set) and `seed`.
    ///
    /// # Errors
    /// Fewer than two observers, an `observer_from` without a chain or with a camera not in
    /// it, a correlated observer away from its camera, an observer on or vertically above a
    /// grid point, invalid covariances.
    pub fn build(self, samples: usize, seed: u64) -> Result<GridStudy, Error> {
        let chain = self
            .chain
            .unwrap_or_else(|| crate::chain::ChainBuilder::new().build());
        for (i, o) in self.grid.observers.iter().enumerate() {
            match o.sigma {
                ObserverSigma::From(c) if c >= chain.len() => {
                    return Err(Error::UnknownCamera {
                        key: format!("grid.observer[{i}].sigma_from"),
                        name: format!("#{c}"),
                    });
                }
                ObserverSigma::Covariance(m) => {
                    crashrig_geometry::uncertain::check_covariance(&m).map_err(|problem| {
                        Error::Covariance {
                            key: format!("grid.observer[{i}].covariance_tangent"),
                            problem,
                        }
                    })?;
                }
                _ => {}
            }
        }
        let positions: Vec<Vector3<f64>> = chain.nominal().iter().map(|p| p.position_mm).collect();
        let names: Vec<String> = chain.names().to_vec();
        crate::model::check_grid(&self.grid, &positions, &names)?;
        GridStudy::assemble(self.grid, chain, self.rotation_noise, samples, seed)
    }
}
