//! The former Monte Carlo loops (ChaCha8 streams, ziggurat normals, one draw or one
//! 64-draw block at a time), compiled into the tests only: `Engine::Legacy` runs them as an
//! independent statistical cross-check of the vectorised engine (different random numbers,
//! the same distribution). Not part of the library.

use crate::block::{Aimed, Ctx};
use crate::chain::WorldPose;
use crate::kernel::accumulate::Acc3;
use crate::kernel::ziggurat::FastNormal;
use crate::kernel::{Normal3, SMALL_ANGLE_SQ, exp_e3, exp_matrix, opk_e3, rot_opk};
use crate::model::RotationNoise;
use nalgebra::Vector3;

/// `m` draws of one grid point into `acc`.
#[inline(never)]
pub(crate) fn run_chunk<R: rand::Rng>(
    obs: &[Aimed],
    ctx: &Ctx,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let nd = FastNormal::new();
    let simple = ctx.pixel.is_none()
        && ctx.chain.is_none()
        && obs
            .iter()
            .all(|o| o.kind == RotationNoise::Tangent && o.noise.is_diagonal())
        && obs.len() == 2;
    if simple {
        run_two_observers(&obs[0], &obs[1], &nd, rng, m, acc);
        return;
    }
    let mut eps = vec![0.0; ctx.chain.as_ref().map_or(0, |c| 6 * c.len())];
    let mut drawn: Vec<WorldPose> = ctx
        .chain
        .as_ref()
        .map_or_else(Vec::new, |c| c.nominal().to_vec());
    for _ in 0..m {
        if let Some(chain) = &ctx.chain {
            chain.draw_into(rng, &mut eps, &mut drawn);
        }
        let mut n = Normal3::default();
        for o in obs {
            let (dc, rot) = match (o.source, &ctx.chain) {
                (Some(i), Some(chain)) => {
                    // World-frame rotation Exp(R̄θ) on the look-at L: L·Exp(Lᵀ R̄ θ).
                    let (dc, th) = chain.error_of(i, &drawn[i]);
                    (dc, Rot::Tangent(o.chain_to_own * th))
                }
                _ => {
                    let ep = normal3(&nd, rng);
                    let er = normal3(&nd, rng);
                    let (dp, dr) = if o.noise.is_diagonal() {
                        (o.sp.component_mul(&ep), o.sr.component_mul(&er))
                    } else {
                        let d = o.noise.matrix()
                            * nalgebra::Vector6::new(ep.x, ep.y, ep.z, er.x, er.y, er.z);
                        (
                            d.fixed_rows::<3>(0).into_owned(),
                            d.fixed_rows::<3>(3).into_owned(),
                        )
                    };
                    (
                        dp,
                        match o.kind {
                            RotationNoise::Tangent => Rot::Tangent(dr),
                            RotationNoise::Euler => Rot::Euler(dr),
                        },
                    )
                }
            };
            let c = o.c + dc;
            match ctx.pixel {
                None => {
                    let d = match rot {
                        Rot::Tangent(w) => o.r * exp_e3(&w),
                        Rot::Euler(da) => opk_e3(&(o.opk + da)),
                    };
                    n.add_ray(&d, &c);
                }
                Some(s) => {
                    let (x, y) = nd.pair(rng);
                    let (x, y) = (s * x, s * y);
                    let r = match rot {
                        Rot::Tangent(w) => o.r * exp_matrix(&w),
                        Rot::Euler(da) => rot_opk(&(o.opk + da)),
                    };
                    n.add_view(&r, &c, x, y);
                }
            }
        }
        acc.push(&n.solve());
    }
}

#[derive(Debug, Clone, Copy)]
enum Rot {
    Tangent(Vector3<f64>),
    Euler(Vector3<f64>),
}

#[inline(always)]
fn normal3<R: rand::Rng>(nd: &FastNormal, rng: &mut R) -> Vector3<f64> {
    let mut e = [0.0; 3];
    nd.fill(rng, &mut e);
    Vector3::from(e)
}

/// Draws per block of the two-observer kernel.
const LANES: usize = 64;

/// The hot path (two independent observers, tangent noise, principal point), written over
/// blocks of [`LANES`] draws in structure-of-arrays form so the compiler vectorises it.
///
/// Per block, 12 rows of [`LANES`] normals are drawn, component-major (all first components
/// of the block, then all second ones, …): observer j's position noise is rows 6j..6j+3, its
/// rotation noise rows 6j+3..6j+6. A final partial block still draws full rows and uses the
/// first lanes. A block holding an angle with θ² ≥ [`SMALL_ANGLE_SQ`] (never for realistic
/// σ) is recomputed with the exact `sin`/`cos` form.
#[inline(never)]
fn run_two_observers<R: rand::Rng>(
    o0: &Aimed,
    o1: &Aimed,
    nd: &FastNormal,
    rng: &mut R,
    m: usize,
    acc: &mut Acc3,
) {
    let mut e = [[0.0f64; LANES]; 12];
    let mut xs = [[0.0f64; LANES]; 3];
    let mut tmax = [0.0f64; LANES];
    let shift = acc.shift();
    let mut lanes = crate::kernel::accumulate::LaneSums::<LANES>::default();
    let mut done = 0;
    while done < m {
        let b = LANES.min(m - done);
        for row in e.iter_mut() {
            nd.fill(rng, row);
        }
        for d in 0..LANES {
            let (d0, c0, t0) = ray_taylor(o0, &e, 0, d);
            let (d1, c1, t1) = ray_taylor(o1, &e, 6, d);
            let mut n = Normal3::default();
            n.add_ray(&d0, &c0);
            n.add_ray(&d1, &c1);
            let x = n.solve();
            xs[0][d] = x.x;
            xs[1][d] = x.y;
            xs[2][d] = x.z;
            tmax[d] = t0.max(t1);
        }
        if tmax[..b].iter().any(|t| *t >= SMALL_ANGLE_SQ) {
            for d in 0..b {
                let mut n = Normal3::default();
                for (o, k) in [(o0, 0), (o1, 6)] {
                    let ep = Vector3::new(e[k][d], e[k + 1][d], e[k + 2][d]);
                    let er = Vector3::new(e[k + 3][d], e[k + 4][d], e[k + 5][d]);
                    let c = o.c + o.sp.component_mul(&ep);
                    let dir = o.r * exp_e3(&o.sr.component_mul(&er));
                    n.add_ray(&dir, &c);
                }
                let x = n.solve();
                xs[0][d] = x.x;
                xs[1][d] = x.y;
                xs[2][d] = x.z;
            }
        }
        lanes.add(&xs, b, &shift);
        done += b;
    }
    acc.merge(&lanes.reduce(shift));
}

/// Perturbed centre and ray of an observer for lane `d` (rows `k..k+6` of `e`), with the
/// Taylor form of `Exp(w)·e₃`; also returns θ² so the caller can check the series' range.
#[inline(always)]
fn ray_taylor(
    o: &Aimed,
    e: &[[f64; LANES]; 12],
    k: usize,
    d: usize,
) -> (Vector3<f64>, Vector3<f64>, f64) {
    let c = Vector3::new(
        o.c.x + o.sp.x * e[k][d],
        o.c.y + o.sp.y * e[k + 1][d],
        o.c.z + o.sp.z * e[k + 2][d],
    );
    let w = Vector3::new(
        o.sr.x * e[k + 3][d],
        o.sr.y * e[k + 4][d],
        o.sr.z * e[k + 5][d],
    );
    let t = w.norm_squared();
    let s = 1.0 - t / 6.0 * (1.0 - t / 20.0 * (1.0 - t / 42.0));
    let cc = 0.5 * (1.0 - t / 12.0 * (1.0 - t / 30.0 * (1.0 - t / 56.0)));
    let v = Vector3::new(
        s * w.y + cc * w.x * w.z,
        -s * w.x + cc * w.y * w.z,
        1.0 + cc * (w.z * w.z - t),
    );
    (o.r * v, c, t)
}
