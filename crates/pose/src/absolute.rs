//! Absolute orientation (resection): P3P in seeded LO-RANSAC, then Levenberg–Marquardt on the
//! reprojection error through the camera model, with the first-order covariance.

use crate::lm::{self, Problem};
use crate::p3p::p3p;
use crate::ransac::{Consensus, Estimator, RansacOptions, lo_ransac};
use crate::{Degeneracy, Error, Projector};
use crashrig_geometry::{Mat6, Rigid3, Vec3, Vec6, se3, so3};
use nalgebra::{Matrix3, SMatrix, Vector2};

/// A refined `cam_from_world` pose and its first-order uncertainty.
///
/// The covariance is `σ₀²·(JᵀJ)⁻¹` in the **left** SE(3) tangent `[ω; v]` (rad, then the
/// points' length unit): the true pose is `se3::exp(ξ)·cam_from_world` with `ξ ~ N(0, Σ)`.
/// σ₀ is estimated from the residuals, `σ₀² = Σr²/(2m − 6)`.
#[derive(Debug, Clone, PartialEq)]
pub struct AbsoluteRefinement {
    /// The refined pose.
    pub cam_from_world: Rigid3,
    /// Number of observations used (m, repeats counted).
    pub n_observations: usize,
    /// Sum of squared reprojection errors, px².
    pub cost_px2: f64,
    /// A-posteriori σ of one image coordinate, px.
    pub sigma0_px: f64,
    /// 6×6 covariance, left tangent `[ω; v]`.
    pub covariance: Mat6,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
}

/// Result of [`estimate_absolute_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct AbsolutePose {
    /// Refinement on the final inliers.
    pub refinement: AbsoluteRefinement,
    /// Indices of the inlier correspondences (increasing).
    pub inliers: Vec<usize>,
    /// RANSAC hypotheses drawn.
    pub ransac_iterations: usize,
}

struct Reprojection<'a, C> {
    camera: &'a C,
    pixels: &'a [Vector2<f64>],
    points: &'a [Vec3],
    idx: &'a [usize],
}

impl<C: Projector> Problem<6> for Reprojection<'_, C> {
    type State = Rigid3;

    fn normal_equations(&self, s: &Rigid3) -> Result<(Mat6, Vec6, f64), usize> {
        let mut jtj = Mat6::zeros();
        let mut jtr = Vec6::zeros();
        let mut cost = 0.0;
        for &i in self.idx {
            let p = s.transform_point(&self.points[i].into()).coords;
            let (x, jp) = self.camera.project_with_jacobian(&p).ok_or(i)?;
            let r = x - self.pixels[i];
            let j = dx_img_from_pose_left(&jp, &p);
            jtj += j.transpose() * j;
            jtr += j.transpose() * r;
            cost += r.norm_squared();
        }
        Ok((jtj, jtr, cost))
    }

    fn cost(&self, s: &Rigid3) -> Result<f64, usize> {
        let mut cost = 0.0;
        for &i in self.idx {
            let p = s.transform_point(&self.points[i].into()).coords;
            let x = self.camera.project(&p).ok_or(i)?;
            cost += (x - self.pixels[i]).norm_squared();
        }
        Ok(cost)
    }

    fn retract(&self, s: &Rigid3, delta: &Vec6) -> Rigid3 {
        se3::exp(delta) * s
    }
}

/// Jacobian of a pixel with respect to the left SE(3) tangent `[ω; v]` of `cam_from_world`,
/// given the projection Jacobian `dx_img_dp` at the camera-frame point `p_cam`:
/// `∂(Exp(ξ)·p)/∂ξ = [−[p]×, I]`.
pub fn dx_img_from_pose_left(dx_img_dp: &SMatrix<f64, 2, 3>, p_cam: &Vec3) -> SMatrix<f64, 2, 6> {
    let mut j = SMatrix::<f64, 2, 6>::zeros();
    let minus_hat: Matrix3<f64> = -so3::hat(p_cam);
    j.fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(dx_img_dp * minus_hat));
    j.fixed_view_mut::<2, 3>(0, 3).copy_from(dx_img_dp);
    j
}

fn check_inputs(pixels: &[Vector2<f64>], points: &[Vec3]) -> Result<(), Error> {
    if pixels.len() != points.len() {
        return Err(Error::LengthMismatch {
            left: pixels.len(),
            right: points.len(),
        });
    }
    for (index, (x, p)) in pixels.iter().zip(points).enumerate() {
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(Error::NotFinite { index });
        }
    }
    Ok(())
}

/// Refines `init` (`cam_from_world`) by Levenberg–Marquardt on the reprojection error of the
/// correspondences `indices` (repeats allowed: a bootstrap resample) and returns the pose with
/// its first-order covariance.
///
/// Errors: too few (distinct) correspondences, a point that does not project at the initial
/// pose, singular normal equations (degenerate geometry).
pub fn refine_absolute_pose<C: Projector>(
    camera: &C,
    pixels: &[Vector2<f64>],
    points: &[Vec3],
    indices: &[usize],
    init: &Rigid3,
) -> Result<AbsoluteRefinement, Error> {
    check_inputs(pixels, points)?;
    if let Some(&bad) = indices.iter().find(|&&i| i >= pixels.len()) {
        return Err(Error::IndexOutOfRange {
            index: bad,
            len: pixels.len(),
        });
    }
    refine_unchecked(camera, pixels, points, indices, init, lm::MAX_ITERATIONS)
}

fn distinct_count(indices: &[usize]) -> usize {
    let mut v = indices.to_vec();
    v.sort_unstable();
    v.dedup();
    v.len()
}

fn refine_unchecked<C: Projector>(
    camera: &C,
    pixels: &[Vector2<f64>],
    points: &[Vec3],
    indices: &[usize],
    init: &Rigid3,
    max_iterations: usize,
) -> Result<AbsoluteRefinement, Error> {
    let m = indices.len();
    if m < 4 {
        return Err(Error::TooFewCorrespondences {
            needed: 4,
            found: m,
        });
    }
    if distinct_count(indices) < 3 {
        return Err(Error::Degenerate {
            what: Degeneracy::TooFewDistinct,
        });
    }
    let problem = Reprojection {
        camera,
        pixels,
        points,
        idx: indices,
    };
    let out = lm::solve(&problem, *init, max_iterations).map_err(|f| match f {
        lm::Failure::Undefined(index) => Error::Projection { index },
        lm::Failure::Diverged(iterations) => Error::Diverged { iterations },
    })?;
    let inv = lm::inverse_if_regular(&out.jtj).ok_or(Error::Degenerate {
        what: Degeneracy::SingularNormalEquations,
    })?;
    let dof = (2 * m - 6) as f64;
    let sigma0_sq = out.cost / dof;
    Ok(AbsoluteRefinement {
        cam_from_world: out.state,
        n_observations: m,
        cost_px2: out.cost,
        sigma0_px: sigma0_sq.sqrt(),
        covariance: inv * sigma0_sq,
        iterations: out.iterations,
    })
}

/// Squared reprojection error of correspondence `i` at `pose` (∞ if it does not project).
fn sq_error<C: Projector>(camera: &C, pose: &Rigid3, pixel: &Vector2<f64>, point: &Vec3) -> f64 {
    let p = pose.transform_point(&(*point).into()).coords;
    camera
        .project(&p)
        .map_or(f64::INFINITY, |x| (x - pixel).norm_squared())
}

/// MSAC score (Σ min(e², th²)) and inlier list of a pose.
fn score<C: Projector>(
    camera: &C,
    pixels: &[Vector2<f64>],
    points: &[Vec3],
    pose: &Rigid3,
    th2: f64,
) -> (f64, Vec<usize>) {
    let mut s = 0.0;
    let mut inliers = Vec::new();
    for (i, (x, p)) in pixels.iter().zip(points).enumerate() {
        let e2 = sq_error(camera, pose, x, p);
        if e2 < th2 {
            s += e2;
            inliers.push(i);
        } else {
            s += th2;
        }
    }
    (s, inliers)
}

/// Resection as an [`Estimator`] of the LO-RANSAC driver: P3P on three bearings, MSAC on the
/// reprojection error, a 10-iteration LM on the inliers as the local optimisation.
struct Resection<'a, C> {
    camera: &'a C,
    pixels: &'a [Vector2<f64>],
    points: &'a [Vec3],
    bearings: &'a [Vec3],
    th2: f64,
}

impl<C: Projector> Estimator for Resection<'_, C> {
    type Model = Rigid3;
    const SAMPLE: usize = 3;

    fn len(&self) -> usize {
        self.pixels.len()
    }

    fn minimal(&self, s: &[usize]) -> Vec<Rigid3> {
        let b = [
            self.bearings[s[0]],
            self.bearings[s[1]],
            self.bearings[s[2]],
        ];
        let p = [self.points[s[0]], self.points[s[1]], self.points[s[2]]];
        p3p(&b, &p)
    }

    fn score(&self, pose: &Rigid3) -> (f64, Vec<usize>) {
        score(self.camera, self.pixels, self.points, pose, self.th2)
    }

    fn local_optimize(&self, pose: &Rigid3, inliers: &[usize]) -> Option<Rigid3> {
        if inliers.len() < 6 {
            return None;
        }
        refine_unchecked(self.camera, self.pixels, self.points, inliers, pose, 10)
            .ok()
            .map(|r| r.cam_from_world)
    }
}

/// Estimates `cam_from_world` from 2D–3D correspondences: P3P hypotheses in a seeded
/// LO-RANSAC (each new best hypothesis is refined on its inliers and re-scored), then a final
/// Levenberg–Marquardt on the inliers with the first-order covariance.
///
/// `pixels[i]` (px, COLMAP convention) observes `points[i]` (world frame, any length unit).
pub fn estimate_absolute_pose<C: Projector>(
    camera: &C,
    pixels: &[Vector2<f64>],
    points: &[Vec3],
    options: &RansacOptions,
) -> Result<AbsolutePose, Error> {
    check_inputs(pixels, points)?;
    let n = pixels.len();
    let needed = options.min_inliers.max(4);
    if n < needed {
        return Err(Error::TooFewCorrespondences { needed, found: n });
    }
    let bearings: Vec<Vec3> = pixels
        .iter()
        .enumerate()
        .map(|(index, x)| {
            camera
                .normalized(x)
                .map(|u| Vec3::new(u.x, u.y, 1.0).normalize())
                .ok_or(Error::Unprojection { index })
        })
        .collect::<Result<_, _>>()?;
    let th2 = options.max_error_px * options.max_error_px;
    let problem = Resection {
        camera,
        pixels,
        points,
        bearings: &bearings,
        th2,
    };
    let Consensus {
        model: pose,
        inliers,
        iterations,
    } = lo_ransac(&problem, options, needed)?;
    // Final refinement, inlier update, refinement again.
    let r = refine_unchecked(camera, pixels, points, &inliers, &pose, lm::MAX_ITERATIONS)?;
    let (_, inliers) = score(camera, pixels, points, &r.cam_from_world, th2);
    if inliers.len() < needed {
        return Err(Error::NoConsensus {
            needed,
            best: inliers.len(),
            iterations,
        });
    }
    let refinement = refine_unchecked(
        camera,
        pixels,
        points,
        &inliers,
        &r.cam_from_world,
        lm::MAX_ITERATIONS,
    )?;
    Ok(AbsolutePose {
        refinement,
        inliers,
        ransac_iterations: iterations,
    })
}
