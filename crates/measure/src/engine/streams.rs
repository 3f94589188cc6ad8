//! The random-stream layout of the Monte Carlo: which stream each draw comes from (the link
//! and tie per block, camera A jointly, the trigger offsets) and the draws themselves.

use super::Epoch;
use super::prepare::LinkPrep;
use crate::Error;
use crate::input::JointA;
use crashrig_geometry::{Mat3, Mat6, Vec3, Vec6, so3};
use crashrig_stats::{StreamRng, stream};
use nalgebra::{DMatrix, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::collections::HashMap;

#[derive(Debug, Clone, Copy)]
pub(super) struct LinkDraw {
    pub(super) r_ab: Mat3,
    pub(super) c_ab: Vec3,
    pub(super) r_bc: Mat3,
    pub(super) c_bc: Vec3,
    /// A's trigger offset in this replicate (s; 0 without `sync_sigma_ms`).
    pub(super) sync_s: f64,
}

fn normals6(rng: &mut StreamRng) -> Vec6 {
    Vec6::from_fn(|_, _| rng.sample(StandardNormal))
}

/// Draws `R̄·Exp(δθ)`, `C̄ + δC` with `δ = L·ε`.
pub(super) fn perturb(r: &Mat3, c: &Vec3, l: &Mat6, rng: &mut StreamRng) -> (Mat3, Vec3) {
    apply(r, c, &(l * normals6(rng)))
}

/// `R̄·Exp(δθ)`, `C̄ + δC`.
pub(super) fn apply(r: &Mat3, c: &Vec3, d: &Vec6) -> (Mat3, Vec3) {
    let dr = so3::exp(&Vector3::new(d[3], d[4], d[5])).into_inner();
    (r * dr, c + Vector3::new(d[0], d[1], d[2]))
}

/// Stream index of A's joint draws in block `b` (apart from the link, epoch and sync streams).
fn joint_stream(b: usize) -> u64 {
    u64::MAX - (1 << 40) - b as u64
}

/// A factor `L` of A's joint covariance (`L·Lᵀ = Σ`), [`joint_factor`]'s result.
#[derive(Debug, Clone)]
pub(super) struct JointFactor {
    pub(super) l: DMatrix<f64>,
    /// `L` is lower triangular (a Cholesky factor; else `V·√Λ`, a full matrix).
    pub(super) lower: bool,
}

/// Rows of `L` multiplied per call in [`joint_draws`] (8 epochs): the product of a row block
/// stops at the block's last column, so the triangle's zeros are not multiplied.
const JOINT_ROWS: usize = 48;

/// A's joint draws of the `len` replicates of block `block`: `out[e][r]` = `δ_A` of measured
/// epoch `e` in replicate `r` (`L·ε`, one 6m-vector `ε` per replicate, in replicate order).
///
/// A lower-triangular `L` is multiplied by row blocks of [`JOINT_ROWS`], each only over the
/// columns up to its last row: about half the work of the full product, with its bits — every
/// element is the same general matrix product (the same kernel, the same blocks of the inner
/// dimension from column 0) with the exact zeros above the diagonal left out, and a zero term
/// adds nothing (`joint_draws_triangle_is_the_full_product_bit_for_bit`).
pub(super) fn joint_draws(
    factor: &JointFactor,
    seed: u64,
    block: usize,
    len: usize,
) -> Vec<Vec<Vec6>> {
    let mut rng = stream(seed, joint_stream(block));
    let l = &factor.l;
    let n = l.nrows();
    let mut eps = DMatrix::<f64>::zeros(n, len);
    for r in 0..len {
        for k in 0..n {
            eps[(k, r)] = rng.sample(StandardNormal);
        }
    }
    let d = if factor.lower {
        let mut d = DMatrix::<f64>::zeros(n, len);
        for r0 in (0..n).step_by(JOINT_ROWS) {
            let r1 = (r0 + JOINT_ROWS).min(n);
            d.rows_mut(r0, r1 - r0)
                .copy_from(&(l.view((r0, 0), (r1 - r0, r1)) * eps.rows(0, r1)));
        }
        d
    } else {
        l * eps
    };
    (0..n / 6)
        .map(|e| {
            (0..len)
                .map(|r| Vec6::from_fn(|i, _| d[(6 * e + i, r)]))
                .collect()
        })
        .collect()
}

/// The factor `L` (`L·Lᵀ = Σ`) of the joint covariance of the measured epochs `measured`
/// (indices into `epochs`): the sub-matrix of their blocks (the marginal of the Gaussian),
/// Cholesky when it is positive definite, else `V·√Λ` of its eigen-decomposition (a
/// semi-definite matrix, e.g. epochs whose errors are fully correlated).
///
/// # Errors
/// [`Error::Json`] naming `joint.epochs` when a measured epoch is not in the joint matrix,
/// `joint.covariance_tangent` when the matrix is not positive semi-definite.
pub(super) fn joint_factor(
    joint: &JointA,
    epochs: &[Epoch],
    measured: &[usize],
) -> Result<JointFactor, Error> {
    let index: HashMap<&str, usize> = joint
        .epochs
        .iter()
        .enumerate()
        .map(|(k, n)| (n.as_str(), k))
        .collect();
    let mut blocks = Vec::with_capacity(measured.len());
    for &e in measured {
        let ep = &epochs[e];
        let k = index
            .get(ep.name.as_str())
            .or_else(|| index.get(ep.key.as_str()))
            .ok_or_else(|| Error::Json {
                path: joint.path.clone(),
                key: "joint.epochs".into(),
                problem: format!(
                    "the measured epoch `{}` is not in the joint covariance",
                    ep.name
                ),
            })?;
        blocks.push(*k);
    }
    let n = 6 * blocks.len();
    let sub = DMatrix::from_fn(n, n, |i, j| {
        joint.covariance[(6 * blocks[i / 6] + i % 6, 6 * blocks[j / 6] + j % 6)]
    });
    if let Some(c) = sub.clone().cholesky() {
        return Ok(JointFactor {
            l: c.unpack(),
            lower: true,
        });
    }
    let eig = sub.symmetric_eigen();
    let tol = crashrig_geometry::uncertain::COVARIANCE_RELATIVE_TOLERANCE * joint.covariance.amax();
    let min = eig.eigenvalues.min();
    if min < -tol {
        return Err(Error::Json {
            path: joint.path.clone(),
            key: "joint.covariance_tangent".into(),
            problem: format!(
                "not positive semi-definite (smallest eigenvalue {min:e}, library units mm and rad)"
            ),
        });
    }
    // Eigenvalues within rounding of zero (the usual numerical-rank tolerance n·ε·λmax) are
    // zero: a fully correlated set of epochs then shares its draw exactly.
    let floor = n as f64 * f64::EPSILON * eig.eigenvalues.max();
    let root = eig
        .eigenvalues
        .map(|l| if l > floor { l.sqrt() } else { 0.0 });
    Ok(JointFactor {
        l: &eig.eigenvectors * DMatrix::from_diagonal(&root),
        lower: false,
    })
}

/// Stream index of epoch `e` in block `b`.
pub(super) fn epoch_stream(e: usize, b: usize) -> u64 {
    ((e as u64 + 1) << 32) | b as u64
}

/// Stream index of the trigger offsets of block `b` (far above every epoch stream, so the
/// other draws are the same with and without an offset).
fn sync_stream(b: usize) -> u64 {
    u64::MAX - b as u64
}

pub(super) fn link_draws(
    link: &LinkPrep,
    seed: u64,
    block: usize,
    len: usize,
    sync_sigma_s: f64,
) -> Vec<LinkDraw> {
    let mut rng = stream(seed, block as u64);
    let mut sync_rng = (sync_sigma_s > 0.0).then(|| stream(seed, sync_stream(block)));
    (0..len)
        .map(|_| {
            let (r_ab, c_ab) = perturb(&link.r_ab, &link.c_ab, &link.l_ab, &mut rng);
            let (r_bc, c_bc) = match &link.c {
                Some((r, c, l)) => perturb(r, c, l, &mut rng),
                None => (Mat3::identity(), Vec3::zeros()),
            };
            let sync_s = sync_rng.as_mut().map_or(0.0, |r| {
                let z: f64 = r.sample(StandardNormal);
                sync_sigma_s * z
            });
            LinkDraw {
                r_ab,
                c_ab,
                r_bc,
                c_bc,
                sync_s,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::BLOCK;

    /// The joint draws reproduce the joint covariance: every entry of the sample covariance
    /// of 40 blocks (10 240 replicates) of 3 epochs × 6 axes is within 4.5 standard errors
    /// of the matrix, `SE(sᵢⱼ) = √((ΣᵢᵢΣⱼⱼ + Σᵢⱼ²)/(n − 1))`, the marginals (diagonal
    /// blocks) and the between-epoch blocks alike (171 entries: a false alarm at 4.5 SE has
    /// probability ~1e-3 for some seed; this seed is fixed).
    #[test]
    fn joint_draws_reproduce_the_joint_covariance() {
        let n = 18;
        // A random-looking SPD matrix with strong between-epoch correlation: B·Bᵀ + 0.1·I
        // with B's entries from a fixed formula.
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.4);
        let sigma = &b * b.transpose() + DMatrix::identity(n, n) * 0.1;
        let l = JointFactor {
            l: sigma.clone().cholesky().unwrap().unpack(),
            lower: true,
        };
        let blocks = 40;
        let mut draws: Vec<Vec<Vec6>> = vec![Vec::new(); 3];
        for blk in 0..blocks {
            for (e, d) in joint_draws(&l, 5, blk, BLOCK).into_iter().enumerate() {
                draws[e].extend(d);
            }
        }
        let count = blocks * BLOCK;
        let x = DMatrix::from_fn(n, count, |k, r| draws[k / 6][r][k % 6]);
        let mean = x.column_mean();
        let c = DMatrix::from_fn(n, n, |i, j| {
            (0..count)
                .map(|r| (x[(i, r)] - mean[i]) * (x[(j, r)] - mean[j]))
                .sum::<f64>()
                / (count - 1) as f64
        });
        for i in 0..n {
            for j in 0..=i {
                let se = ((sigma[(i, i)] * sigma[(j, j)] + sigma[(i, j)].powi(2))
                    / (count - 1) as f64)
                    .sqrt();
                let z = (c[(i, j)] - sigma[(i, j)]) / se;
                assert!(
                    z.abs() < 4.5,
                    "({i}, {j}): {} vs {} (z {z})",
                    c[(i, j)],
                    sigma[(i, j)]
                );
            }
        }
        // Bit-identical on a second call (one stream per block).
        assert_eq!(joint_draws(&l, 5, 3, 7), joint_draws(&l, 5, 3, 7));
    }

    /// The triangular product gives the full product's bits: a Cholesky factor of 100 epochs
    /// (600 rows: several row blocks, and an inner dimension beyond the product kernel's
    /// blocks of it), once as lower triangular and once as a general matrix, the same draws.
    #[test]
    fn joint_draws_triangle_is_the_full_product_bit_for_bit() {
        let n = 600;
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.4);
        let sigma = &b * b.transpose() + DMatrix::identity(n, n) * 0.1;
        let l = sigma.cholesky().unwrap().unpack();
        let tri = JointFactor {
            l: l.clone(),
            lower: true,
        };
        let full = JointFactor { l, lower: false };
        let (a, f) = (joint_draws(&tri, 9, 2, 5), joint_draws(&full, 9, 2, 5));
        assert_eq!(a.len(), 100);
        for (a, f) in a.iter().flatten().zip(f.iter().flatten()) {
            for (x, y) in a.iter().zip(f.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        assert!(a[99][4].norm() > 0.0, "the last epoch is drawn");
    }
}
