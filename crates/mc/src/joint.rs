//! Joint errors of grid points measured in the same test ([`GridStudy::joint`]).
//!
//! In correlated mode every point of a map takes the same chain draw in replicate `j` (one rig
//! error per crash test), so the errors of two points measured in one test are correlated: a
//! rig error that moves both points alike cancels in their distance. A map reports each
//! point's marginal statistics; [`GridStudy::joint`] draws a few points side by side — with
//! exactly the draws the map gives them (the same streams) — and keeps, per replicate, their
//! stacked coordinates and every pairwise distance: the covariance of all the coordinates
//! (cross-covariances included) and the mean and σ of each distance, from the replicates
//! themselves (no linearisation).

use crate::block::{ChainBlock, GroupSink, PointKernel, Scratch, solve_block};
use crate::error::Error;
use crate::grid::GridStudy;
use crate::kernel::normal::LANES;
use crate::map::{MapPath, MapRun};
use crate::options::{Draws, RunOptions};
use crate::schedule::{CHUNK, Engine, PointTicks, task_index};
use nalgebra::{DMatrix, Matrix3, Vector3};

/// Largest number of points of one joint run ([`GridStudy::joint`]): the covariance of their
/// stacked coordinates is kept per chunk of draws.
pub const JOINT_POINTS_MAX: usize = 16;

/// The distance between two points of a [`JointResult`] over the replicates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceStats {
    /// Position of the first point in [`JointResult::indices`].
    pub a: usize,
    /// Position of the second point (`a < b`).
    pub b: usize,
    /// Distance of the two grid points (mm).
    pub nominal_mm: f64,
    /// Mean measured distance (mm).
    pub mean_mm: f64,
    /// σ of the measured distance over the replicates (n − 1, mm): each replicate's distance
    /// of its two intersected points, so errors the points share cancel as they physically do.
    pub sigma_mm: f64,
}

/// Joint Monte Carlo statistics of grid points measured in the same test.
#[derive(Debug, Clone, PartialEq)]
pub struct JointResult {
    /// Grid indices of the points (into [`crate::Grid::points`]), as asked.
    pub indices: Vec<usize>,
    /// The grid points (mm).
    pub points: Vec<Vector3<f64>>,
    /// Replicates.
    pub count: u64,
    /// Mean intersected point of each (mm).
    pub mean_mm: Vec<Vector3<f64>>,
    /// Sample covariance (n − 1, mm²) of the stacked coordinates `x₀ y₀ z₀ x₁ y₁ z₁ …`
    /// (3k × 3k): the diagonal blocks are each point's covariance, the others the
    /// cross-covariances.
    pub covariance: DMatrix<f64>,
    /// Every pair `(a, b)`, `a < b`, in order (0, 1), (0, 2), …, (1, 2), ….
    pub distances: Vec<DistanceStats>,
}

impl JointResult {
    /// The cross-covariance (mm²) of points `a` and `b` (positions in
    /// [`JointResult::indices`]): `cov(X_a, X_b)`; point `a`'s own covariance for `a == b`.
    pub fn cross_covariance(&self, a: usize, b: usize) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.covariance[(3 * a + i, 3 * b + j)])
    }

    /// The statistics of the distance of points `a` and `b` (positions, either order).
    pub fn distance(&self, a: usize, b: usize) -> Option<&DistanceStats> {
        let (a, b) = (a.min(b), a.max(b));
        self.distances.iter().find(|d| d.a == a && d.b == b)
    }
}

impl GridStudy {
    /// The points `indices` of the grid ([`crate::Grid::points`], at most
    /// [`JOINT_POINTS_MAX`], no repeats) drawn jointly with `options.draws` replicates
    /// ([`Draws::Samples`]) under `options.seed`: the same draws each point gets in
    /// [`GridStudy::run`] (its own streams and, in correlated mode, the map's chain draw of
    /// each replicate), so each point's statistics are the map's, and the cross-covariances
    /// and distances show how the points err together (see [`JointResult`]). In correlated mode
    /// an error of the rig shared by every point (e.g. the outward camera's) moves the points
    /// together and leaves their distances alone; in independent mode the points are
    /// uncorrelated.
    ///
    /// ```
    /// use crashrig_mc::{GridStudy, RunOptions, Scenario};
    /// use std::path::Path;
    ///
    /// // Two aimed observers hanging off one outward camera (1 mm, 0.01°) through links of
    /// // 0.2 mm / 0.005°, drawn jointly with the chain.
    /// let text = r#"
    /// [[camera]]
    /// name = "out"
    /// position_mm = [0.0, -300.0, 0.0]
    /// angles_deg = [0.0, 0.0, 0.0]
    /// sigma_position_mm = [1.0, 1.0, 1.0]
    /// sigma_angles_deg = [0.01, 0.01, 0.01]
    /// [[camera]]
    /// name = "left"
    /// parent = "out"
    /// position_mm = [-600.0, 300.0, 0.0]
    /// angles_deg = [0.0, 0.0, 0.0]
    /// sigma_position_mm = [0.2, 0.2, 0.2]
    /// sigma_angles_deg = [0.005, 0.005, 0.005]
    /// [[camera]]
    /// name = "right"
    /// parent = "out"
    /// position_mm = [600.0, 300.0, 0.0]
    /// angles_deg = [0.0, 0.0, 0.0]
    /// sigma_position_mm = [0.2, 0.2, 0.2]
    /// sigma_angles_deg = [0.005, 0.005, 0.005]
    /// [grid]
    /// x_mm = [-200.0, 200.0, 2]
    /// y_mm = [1000.0, 1000.0, 1]
    /// z_mm = [0.0, 0.0, 1]
    /// correlated = true
    /// [[grid.observer]]
    /// position_mm = [-600.0, 0.0, 0.0]
    /// sigma_from = "left"
    /// [[grid.observer]]
    /// position_mm = [600.0, 0.0, 0.0]
    /// sigma_from = "right"
    /// "#;
    /// let sc = Scenario::from_toml_str(text, Path::new("pair.toml"))?;
    /// let study = GridStudy::new(&sc, 2000, 1)?;
    /// // The two grid points, 400 mm apart, measured in the same tests.
    /// let joint = study.joint(&[0, 1], &RunOptions::samples(4000, 7))?;
    /// let d = joint.distance(0, 1).unwrap();
    /// assert!((d.nominal_mm - 400.0).abs() < 1e-9);
    /// // The outward camera's error moves both points alike and cancels in their distance:
    /// // its σ is far below that of two independent points of the same σ.
    /// let var = |p: usize| joint.cross_covariance(p, p).trace();
    /// assert!(d.sigma_mm < 0.5 * (var(0) + var(1)).sqrt());
    /// # Ok::<(), crashrig_mc::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] for no point, more than [`JOINT_POINTS_MAX`], a repeated index or
    /// one past the grid, an adaptive `options.draws`, fewer than two draws, or a point seen
    /// by fewer than two observers; an aimed observer that cannot aim at a point.
    pub fn joint(&self, indices: &[usize], options: &RunOptions) -> Result<JointResult, Error> {
        let samples = match options.draws {
            Draws::Samples(n) if n >= 2 => n,
            _ => return Err(invalid("a joint run takes a fixed number (≥ 2) of draws")),
        };
        let all = self.grid().points();
        check_indices(indices, all.len())?;
        let points: Vec<Vector3<f64>> = indices.iter().map(|&i| all[i]).collect();
        let ticks = PointTicks::new(None, points.len(), 1);
        let run = MapRun {
            chain: self.chain(),
            seed: options.seed,
            engine: Engine::Simd(options.isa),
            ticks: &ticks,
            first: 0,
        };
        let sums = if self.has_fixed() {
            let (covariance, kinds) = self.resolved();
            let setup = self.setup(&covariance, &kinds, self.chain());
            let path = crate::fixed::FixedPath::new(&setup, &points);
            joint_sums(&path, &run, indices, samples)?
        } else {
            let path = crate::grid::AimedPath::new(self, &points);
            joint_sums(&path, &run, indices, samples)?
        };
        Ok(sums.result(indices, points))
    }
}

fn invalid(problem: &'static str) -> Error {
    Error::Invalid {
        key: "joint".to_string(),
        problem,
    }
}

fn check_indices(indices: &[usize], n: usize) -> Result<(), Error> {
    if indices.is_empty() || indices.len() > JOINT_POINTS_MAX {
        return Err(invalid("a joint run takes 1 to 16 grid points"));
    }
    for (k, &i) in indices.iter().enumerate() {
        if i >= n {
            return Err(invalid("a joint point is past the grid"));
        }
        if indices[..k].contains(&i) {
            return Err(invalid("a joint point is repeated"));
        }
    }
    Ok(())
}

/// The joint sums of the points of `path` (`indices` their grid indices), chunk by chunk in
/// order.
fn joint_sums<'a, P: MapPath<'a>>(
    path: &P,
    run: &MapRun<'_>,
    indices: &[usize],
    samples: usize,
) -> Result<JointSums, Error> {
    let plans = (0..indices.len())
        .map(|i| path.plan(i))
        .collect::<Result<Vec<_>, _>>()?;
    if plans.iter().any(|p| p.kernel.observers.len() < 2) {
        return Err(invalid(
            "a joint point is seen by fewer than two observers (not measurable)",
        ));
    }
    let nominal: Vec<Vector3<f64>> = (0..indices.len())
        .map(|i| path.finish(i, &plans[i], None).point)
        .collect();
    let chunks = samples.div_ceil(CHUNK);
    let mut total = JointSums::new(&nominal);
    crate::kernel::ordered::map_fold_in_order(
        chunks,
        |k| {
            let m = CHUNK.min(samples - k * CHUNK);
            let kernels: Vec<(&PointKernel<'_>, u64)> = plans
                .iter()
                .zip(indices)
                .map(|(p, &i)| (&p.kernel, task_index(i, k)))
                .collect();
            let mut sink = JointSink::new(&nominal);
            crate::map::draw_into(run, &kernels, (k * CHUNK) as u64, m, &mut sink);
            sink.sums
        },
        |_, part| total.merge(&part),
    );
    Ok(total)
}

/// Streaming sums of the stacked coordinates (deviations from the grid points) and of each
/// pairwise distance (deviation from the nominal distance).
#[derive(Debug, Clone)]
struct JointSums {
    nominal: Vec<Vector3<f64>>,
    n: u64,
    s1: Vec<f64>,
    /// Upper triangle of Σ vvᵀ, row by row.
    s2: Vec<f64>,
    /// Per pair: Σ (d − d̄) and Σ (d − d̄)².
    d1: Vec<f64>,
    d2: Vec<f64>,
}

impl JointSums {
    fn new(nominal: &[Vector3<f64>]) -> Self {
        let (k, pairs) = (3 * nominal.len(), nominal.len() * (nominal.len() - 1) / 2);
        JointSums {
            nominal: nominal.to_vec(),
            n: 0,
            s1: vec![0.0; k],
            s2: vec![0.0; k * (k + 1) / 2],
            d1: vec![0.0; pairs],
            d2: vec![0.0; pairs],
        }
    }

    /// Adds one replicate: the intersected point of each grid point.
    fn push(&mut self, x: &[Vector3<f64>]) {
        let v = |i: usize| x[i / 3][i % 3] - self.nominal[i / 3][i % 3];
        self.n += 1;
        let mut t = 0;
        for i in 0..self.s1.len() {
            let vi = v(i);
            self.s1[i] += vi;
            for j in i..self.s1.len() {
                self.s2[t] += vi * v(j);
                t += 1;
            }
        }
        let mut q = 0;
        for a in 0..x.len() {
            for b in a + 1..x.len() {
                let d = (x[a] - x[b]).norm() - (self.nominal[a] - self.nominal[b]).norm();
                self.d1[q] += d;
                self.d2[q] += d * d;
                q += 1;
            }
        }
    }

    fn merge(&mut self, o: &JointSums) {
        self.n += o.n;
        let add = |a: &mut Vec<f64>, b: &Vec<f64>| a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        add(&mut self.s1, &o.s1);
        add(&mut self.s2, &o.s2);
        add(&mut self.d1, &o.d1);
        add(&mut self.d2, &o.d2);
    }

    fn result(&self, indices: &[usize], points: Vec<Vector3<f64>>) -> JointResult {
        let n = self.n as f64;
        let k = self.s1.len();
        let mut covariance = DMatrix::zeros(k, k);
        let mut t = 0;
        for i in 0..k {
            for j in i..k {
                let c = (self.s2[t] - self.s1[i] * self.s1[j] / n) / (n - 1.0);
                covariance[(i, j)] = c;
                covariance[(j, i)] = c;
                t += 1;
            }
        }
        let mean_mm = points
            .iter()
            .enumerate()
            .map(|(p, x)| x + Vector3::from_fn(|i, _| self.s1[3 * p + i] / n))
            .collect();
        let mut distances = Vec::new();
        for a in 0..points.len() {
            for b in a + 1..points.len() {
                let q = distances.len();
                let nominal_mm = (points[a] - points[b]).norm();
                let var = (self.d2[q] - self.d1[q] * self.d1[q] / n) / (n - 1.0);
                distances.push(DistanceStats {
                    a,
                    b,
                    nominal_mm,
                    mean_mm: nominal_mm + self.d1[q] / n,
                    sigma_mm: var.max(0.0).sqrt(),
                });
            }
        }
        JointResult {
            indices: indices.to_vec(),
            points,
            count: self.n,
            mean_mm,
            covariance,
            distances,
        }
    }
}

/// The block kernel's sink of a joint run: each point's solved lanes, then per replicate the
/// stacked sums.
struct JointSink {
    xs: Vec<[[f64; LANES]; 3]>,
    /// One replicate's points (scratch).
    x: Vec<Vector3<f64>>,
    sums: JointSums,
}

impl JointSink {
    fn new(nominal: &[Vector3<f64>]) -> Self {
        JointSink {
            xs: vec![[[0.0; LANES]; 3]; nominal.len()],
            x: nominal.to_vec(),
            sums: JointSums::new(nominal),
        }
    }
}

impl GroupSink for JointSink {
    #[inline(always)]
    fn point(
        &mut self,
        i: usize,
        kernel: &PointKernel<'_>,
        shared: Option<&ChainBlock>,
        s: &mut Scratch,
        b: usize,
        _: bool,
    ) {
        solve_block(kernel, shared, s, b);
        self.xs[i] = s.xs;
    }

    fn block_done(&mut self, b: usize) {
        for l in 0..b {
            for (x, r) in self.x.iter_mut().zip(&self.xs) {
                *x = Vector3::new(r[0][l], r[1][l], r[2][l]);
            }
            self.sums.push(&self.x);
        }
    }
}

#[cfg(test)]
mod tests;
