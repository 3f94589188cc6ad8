//! The vectorised draw loop of the chain propagation: blocks of [`LANES`] joint draws in
//! structure-of-arrays form, compiled per instruction-set level by [`crate::simd`].
//!
//! Per block: the normals ([`fill_block`], 6 per camera, rows `6i..6i+6` for camera i), then
//! per camera in topological order the link's perturbation `δ = L·ε` ([`NoiseFactor`],
//! diagonal today, `Chain::plan` builds it), the
//! perturbed link rotation (`R_l·Exp(δθ)` for tangent noise, `Rx Ry Rz` at `angles + δθ` for
//! euler noise, both by their small-angle series) and the composition with the parent; then
//! per camera the ω φ κ offsets from the nominal and the body-axis error `log(R̄ᵀR)`, both as
//! `atan` of a small ratio by its series; and per-lane shifted sums of (centre, offsets) and
//! of the body-axis error.
//!
//! A lane whose angles leave the series' range (a link rotation with θ² ≥ [`SMALL_ANGLE_SQ`],
//! an offset ratio |z| ≥ [`ATAN_Z_MAX`], or a camera turned by more than 90°) is recomputed
//! with the scalar formulas (`Chain::compose_into`, `atan2`, `log_near_identity`), lane by
//! lane: a draw's values never depend on its block or on the instruction set.

#![allow(clippy::needless_range_loop)] // lane-indexed loops over parallel arrays are the point (they vectorise)

use crate::chain::Chain;
use crate::kernel::SMALL_ANGLE_SQ;
use crate::kernel::lanes::{NoiseFactor, Trig, euler_rot, tangent_rot};
use crate::kernel::normal::{LANES, Lane, fill_block};
use crate::kernel::simd::Width;
use crate::model::RotationNoise;
use nalgebra::{Matrix6, Vector3, Vector6};

/// cos φ below which a lane goes to the scalar angle extraction (far above the geometry
/// crate's gimbal-lock threshold, `crashrig_geometry::tolerance::GIMBAL_LOCK_COS_PHI`).
const GIMBAL_COS_PHI: f64 = 1e-5;

/// Largest |z| for which `atan z` uses its series (terms to z¹⁵; truncation < 10⁻¹⁸ relative).
pub(crate) const ATAN_Z_MAX: f64 = 0.1;

/// `atan(z)/z` for z² = t < ATAN_Z_MAX² (series Σ (−t)^k/(2k+1), k ≤ 7).
#[inline(always)]
fn atan_over_z(t: f64) -> f64 {
    const C: [f64; 8] = [
        -1.0 / 15.0,
        1.0 / 13.0,
        -1.0 / 11.0,
        1.0 / 9.0,
        -1.0 / 7.0,
        1.0 / 5.0,
        -1.0 / 3.0,
        1.0,
    ];
    let mut p = C[0];
    for &k in &C[1..] {
        p = p.mul_add(t, k);
    }
    p
}

/// `atan2(y, x)` for x > 0 and |y/x| < ATAN_Z_MAX; `ok` false otherwise.
#[inline(always)]
fn atan2_small(y: f64, x: f64, ok: &mut bool) -> f64 {
    let z = y / x;
    let t = z * z;
    *ok &= x > 0.0 && t < ATAN_Z_MAX * ATAN_Z_MAX;
    z * atan_over_z(t)
}

/// Shifted sums of one camera's (centre mm, ω φ κ offsets rad) and body-axis error.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CamSums {
    pub(crate) n: u64,
    /// Σ of (centre − nominal centre, angle offsets).
    pub(crate) s1: [f64; 6],
    /// Σ of their products, upper triangle row by row (21).
    pub(crate) s2: [f64; 21],
    /// Σ θ of the body-axis error.
    pub(crate) t1: [f64; 3],
    /// Σ of the products of (centre − nominal centre, θ), upper triangle row by row (21).
    pub(crate) u2: [f64; 21],
}

impl CamSums {
    pub(crate) fn new() -> Self {
        CamSums {
            n: 0,
            s1: [0.0; 6],
            s2: [0.0; 21],
            t1: [0.0; 3],
            u2: [0.0; 21],
        }
    }

    pub(crate) fn merge(&mut self, o: &CamSums) {
        self.n += o.n;
        for k in 0..6 {
            self.s1[k] += o.s1[k];
        }
        for k in 0..21 {
            self.s2[k] += o.s2[k];
        }
        for k in 0..3 {
            self.t1[k] += o.t1[k];
        }
        for k in 0..21 {
            self.u2[k] += o.u2[k];
        }
    }

    /// Mean deviation (6) and sample covariance (n − 1).
    pub(crate) fn mean_cov(&self) -> (Vector6<f64>, Matrix6<f64>) {
        let n = self.n as f64;
        let mean = Vector6::from_fn(|i, _| self.s1[i] / n);
        let mut cov = Matrix6::from_element(f64::NAN);
        if self.n >= 2 {
            let mut k = 0;
            for i in 0..6 {
                for j in i..6 {
                    let c = (self.s2[k] - self.s1[i] * self.s1[j] / n) / (n - 1.0);
                    cov[(i, j)] = c;
                    cov[(j, i)] = c;
                    k += 1;
                }
            }
        }
        (mean, cov)
    }

    /// Sample covariance (n − 1) of (centre − nominal centre, body-axis error θ): the
    /// contract's `covariance_tangent` of the world pose.
    pub(crate) fn tangent_covariance(&self) -> Matrix6<f64> {
        let n = self.n as f64;
        let m = |i: usize| if i < 3 { self.s1[i] } else { self.t1[i - 3] };
        let mut cov = Matrix6::from_element(f64::NAN);
        if self.n >= 2 {
            let mut k = 0;
            for i in 0..6 {
                for j in i..6 {
                    let c = (self.u2[k] - m(i) * m(j) / n) / (n - 1.0);
                    cov[(i, j)] = c;
                    cov[(j, i)] = c;
                    k += 1;
                }
            }
        }
        cov
    }

    /// σ of the body-axis error.
    pub(crate) fn tangent_sigma(&self) -> Vector3<f64> {
        let c = self.tangent_covariance();
        Vector3::from_fn(|i, _| c[(3 + i, 3 + i)].sqrt())
    }
}

/// Per-lane version of [`CamSums`] (reduced in lane order).
#[derive(Debug, Clone)]
struct CamLanes {
    s1: [Lane; 6],
    s2: [Lane; 21],
    t1: [Lane; 3],
    u2: [Lane; 21],
}

impl CamLanes {
    fn new() -> Self {
        CamLanes {
            s1: [[0.0; LANES]; 6],
            s2: [[0.0; LANES]; 21],
            t1: [[0.0; LANES]; 3],
            u2: [[0.0; LANES]; 21],
        }
    }

    /// Adds lanes `0..b` of `v` (6 rows; without `ANGLES` only the centre, rows 0–2, and no
    /// products) and `th` (3 rows), products by fused multiply-adds. The centre–centre
    /// products are the same in both sums: with `ANGLES` they are summed once, in `s2`
    /// ([`Self::reduce`] copies them).
    #[inline(always)]
    fn add<const ANGLES: bool>(&mut self, v: &[Lane; 6], th: &[Lane; 3], b: usize) {
        for i in 0..if ANGLES { 6 } else { 3 } {
            for l in 0..b.min(LANES) {
                self.s1[i][l] += v[i][l];
            }
        }
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                if ANGLES {
                    let (vi, vj, s) = (&v[i], &v[j], &mut self.s2[k]);
                    for l in 0..b.min(LANES) {
                        s[l] = vi[l].mul_add(vj[l], s[l]);
                    }
                }
                k += 1;
            }
        }
        for i in 0..3 {
            for l in 0..b.min(LANES) {
                self.t1[i][l] += th[i][l];
            }
        }
        let u = |i: usize| if i < 3 { &v[i] } else { &th[i - 3] };
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                if !(ANGLES && j < 3) {
                    let (ui, uj, s) = (u(i), u(j), &mut self.u2[k]);
                    for l in 0..b.min(LANES) {
                        s[l] = ui[l].mul_add(uj[l], s[l]);
                    }
                }
                k += 1;
            }
        }
    }

    /// [`Self::add`] of `K` full blocks in order (`v[q]`, `th[q]` block q): per lane and
    /// sum the same operations in the same order as `K` calls of [`Self::add`], so the same
    /// bits, with each sum's lane row loaded and stored once.
    #[inline(always)]
    fn add_batch<const ANGLES: bool, const K: usize>(
        &mut self,
        v: [&[Lane; 6]; K],
        th: [&[Lane; 3]; K],
    ) {
        #[inline(always)]
        fn sum<const K: usize>(s: &mut Lane, x: impl Fn(usize, usize) -> f64) {
            for l in 0..LANES {
                let mut a = s[l];
                for q in 0..K {
                    a += x(q, l);
                }
                s[l] = a;
            }
        }
        #[inline(always)]
        fn fma<const K: usize>(s: &mut Lane, x: impl Fn(usize, usize) -> (f64, f64)) {
            for l in 0..LANES {
                let mut a = s[l];
                for q in 0..K {
                    let (p, r) = x(q, l);
                    a = p.mul_add(r, a);
                }
                s[l] = a;
            }
        }
        for i in 0..if ANGLES { 6 } else { 3 } {
            sum::<K>(&mut self.s1[i], |q, l| v[q][i][l]);
        }
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                if ANGLES {
                    fma::<K>(&mut self.s2[k], |q, l| (v[q][i][l], v[q][j][l]));
                }
                k += 1;
            }
        }
        for i in 0..3 {
            sum::<K>(&mut self.t1[i], |q, l| th[q][i][l]);
        }
        let u = |q: usize, i: usize, l: usize| if i < 3 { v[q][i][l] } else { th[q][i - 3][l] };
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                if !(ANGLES && j < 3) {
                    fma::<K>(&mut self.u2[k], |q, l| (u(q, i, l), u(q, j, l)));
                }
                k += 1;
            }
        }
    }

    fn reduce<const ANGLES: bool>(&self, n: u64) -> CamSums {
        let sum = |r: &Lane| r.iter().sum::<f64>();
        let s2: [f64; 21] = std::array::from_fn(|k| sum(&self.s2[k]));
        // The centre–centre entries (k of i ≤ j < 3: 0, 1, 2, 6, 7, 11) of `u2` are `s2`'s.
        let shared = |k: usize| ANGLES && matches!(k, 0 | 1 | 2 | 6 | 7 | 11);
        CamSums {
            n,
            s1: std::array::from_fn(|k| sum(&self.s1[k])),
            s2,
            t1: std::array::from_fn(|k| sum(&self.t1[k])),
            u2: std::array::from_fn(|k| if shared(k) { s2[k] } else { sum(&self.u2[k]) }),
        }
    }
}

/// A drawn world pose per lane: centre (3) and rotation (9, row-major).
#[derive(Debug, Clone)]
struct PoseLanes {
    c: [Lane; 3],
    r: [Lane; 9],
}

/// Blocks of joint draws composed before their sums are added ([`CamLanes::add_batch`]): a
/// camera's per-lane sums (45 lane rows, 23 KB; three cameras overflow the first-level cache)
/// are then read and written once per `BATCH` blocks instead of once per block.
const BATCH: usize = 4;

/// One composed block of a batch: each camera's `v` and `th` ([`Composer::compose`]).
type Composed = (Vec<[Lane; 6]>, Vec<[Lane; 3]>);

/// `m` joint draws (task `task` of the run keyed `key`), returning per-camera sums. Must be
/// called inside [`crate::kernel::simd::dispatch`].
/// Without `ANGLES` the ω φ κ offsets are neither extracted nor summed (their sums stay
/// zero): the tangent covariance alone, which is what a grid's `sigma_from` needs with
/// tangent noise — and no lane falls back to the scalar formulas for its angles near gimbal
/// lock.
#[inline(always)]
pub(crate) fn run_task<const ANGLES: bool>(
    chain: &Chain,
    key: [u32; 2],
    task: u64,
    m: usize,
    width: Width,
) -> Vec<CamSums> {
    let n = chain.len();
    let mut e = vec![[0.0; LANES]; 6 * n];
    let mut composer = Composer::new(chain);
    let mut lanes = vec![CamLanes::new(); n];
    // The composed blocks of a batch (each camera's `v` and `th`, swapped out of the composer).
    let mut held: Vec<Composed> = (0..BATCH)
        .map(|_| (vec![[[0.0; LANES]; 6]; n], vec![[[0.0; LANES]; 3]; n]))
        .collect();
    let mut done = 0;
    while done < m {
        let (mut k, mut b) = (0, LANES);
        while k < BATCH && done < m {
            b = LANES.min(m - done);
            fill_block(key, task, done as u64, &mut e, width);
            composer.compose::<ANGLES>(chain, &e, b);
            std::mem::swap(&mut composer.v, &mut held[k].0);
            std::mem::swap(&mut composer.th, &mut held[k].1);
            k += 1;
            done += b;
        }
        for i in 0..n {
            if k == BATCH && b == LANES {
                lanes[i].add_batch::<ANGLES, BATCH>(
                    std::array::from_fn(|q| &held[q].0[i]),
                    std::array::from_fn(|q| &held[q].1[i]),
                );
            } else {
                // The task's last blocks (the last one possibly partial), one at a time.
                for q in 0..k {
                    let bq = if q + 1 == k { b } else { LANES };
                    lanes[i].add::<ANGLES>(&held[q].0[i], &held[q].1[i], bq);
                }
            }
        }
    }
    lanes.iter().map(|c| c.reduce::<ANGLES>(m as u64)).collect()
}

/// The vectorised composition of a chain over a block of joint draws, with its lane arrays
/// (allocated once per task): per camera the centre error and ω φ κ offsets (`v`) and the
/// body-axis error `log(R̄ᵀR)` (`th`) for the chain propagation ([`run_task`],
/// [`Composer::compose`]); or the centre error and the world-frame rotation error `R·R̄ᵀ`
/// (`world`) for the grid kernel's observers drawn jointly from the chain
/// ([`Composer::compose_world`], `block::ChainBlock`).
pub(crate) struct Composer {
    plan: Vec<CamPlan>,
    poses: Vec<PoseLanes>,
    /// The perturbed link of the camera being composed (scratch).
    link: PoseLanes,
    /// Per camera: centre − nominal (mm, rows 0–2), ω φ κ offsets (rad, rows 3–5; only
    /// with `ANGLES`).
    pub(crate) v: Vec<[Lane; 6]>,
    /// Per camera: the body-axis error (rad).
    pub(crate) th: Vec<[Lane; 3]>,
    /// Per camera: the world-frame rotation error `R·R̄ᵀ` (row-major; [`Self::compose_world`]).
    pub(crate) world: Vec<[Lane; 9]>,
    delta: [Lane; 6],
    ok: [bool; LANES],
}

impl Composer {
    pub(crate) fn new(chain: &Chain) -> Self {
        let n = chain.len();
        Composer {
            plan: chain.plan(),
            poses: vec![
                PoseLanes {
                    c: [[0.0; LANES]; 3],
                    r: [[0.0; LANES]; 9],
                };
                n
            ],
            link: PoseLanes {
                c: [[0.0; LANES]; 3],
                r: [[0.0; LANES]; 9],
            },
            v: vec![[[0.0; LANES]; 6]; n],
            th: vec![[[0.0; LANES]; 3]; n],
            world: vec![[[0.0; LANES]; 9]; n],
            delta: [[0.0; LANES]; 6],
            ok: [true; LANES],
        }
    }

    /// Composes the block whose chain normals are the rows `e[..6n]` (6 per camera, camera
    /// `i` at `6i`) into `v` and `th`; the first `b` lanes are valid, a lane beyond the series'
    /// range is recomputed by the scalar formulas. Without `ANGLES` the ω φ κ offsets are
    /// skipped (rows 3–5 of `v` are left as they are).
    #[inline(always)]
    pub(crate) fn compose<const ANGLES: bool>(&mut self, chain: &Chain, e: &[Lane], b: usize) {
        self.poses(chain, e);
        let Composer {
            plan,
            poses,
            v,
            th,
            ok,
            ..
        } = self;
        for i in 0..chain.len() {
            errors::<ANGLES>(&plan[i], &poses[i], &mut v[i], &mut th[i], ok);
        }
        for l in 0..b {
            if !ok[l] {
                exact_lane(chain, &e[..6 * chain.len()], l, v, th);
            }
        }
    }

    /// Composes the block whose chain normals are the rows `e[..6n]` into each camera's centre
    /// error (`v`, rows 0–2) and world-frame rotation error `R·R̄ᵀ` (`world`): an observer
    /// carried by the camera as a rigid body is at `C̄_obs + δC`, turned to `R·R̄ᵀ·R̄_obs`. The
    /// first `b` lanes are valid; a lane whose link rotation leaves the series' range is
    /// recomputed by the scalar composition.
    #[inline(always)]
    pub(crate) fn compose_world(&mut self, chain: &Chain, e: &[Lane], b: usize) {
        self.poses(chain, e);
        let Composer {
            plan,
            poses,
            v,
            world,
            ok,
            ..
        } = self;
        for i in 0..chain.len() {
            world_errors(&plan[i], &poses[i], &mut v[i], &mut world[i]);
        }
        for l in 0..b {
            if !ok[l] {
                exact_world_lane(chain, &e[..6 * chain.len()], l, v, world);
            }
        }
    }

    /// Every camera's world pose per lane (`poses`), the links by their series; `ok` marks
    /// the lanes inside the series' range.
    #[inline(always)]
    fn poses(&mut self, chain: &Chain, e: &[Lane]) {
        let Composer {
            plan,
            poses,
            link,
            delta,
            ok,
            ..
        } = self;
        *ok = [true; LANES];
        for &i in chain.order() {
            let p = &plan[i];
            let rows: &[Lane; 6] = e[6 * i..6 * i + 6].try_into().expect("six rows");
            p.noise_factor.apply(rows, delta);
            // The link's perturbed pose, with the noise kind chosen outside the lane loop (a
            // `match` inside it kept the loop from vectorising).
            match p.noise {
                RotationNoise::Tangent => link_lanes::<true>(p, delta, link, ok),
                RotationNoise::Euler => link_lanes::<false>(p, delta, link, ok),
            }
            match p.parent {
                None => poses[i].clone_from(link),
                Some(pi) => {
                    let (parent, own) = if pi < i {
                        let (a, b2) = poses.split_at_mut(i);
                        (&a[pi], &mut b2[0])
                    } else {
                        let (a, b2) = poses.split_at_mut(pi);
                        (&b2[0], &mut a[i])
                    };
                    compose_lanes(parent, link, own);
                }
            }
        }
    }
}

/// Per lane: a camera's centre error and its world-frame rotation error `R·R̄ᵀ`.
#[inline(always)]
fn world_errors(p: &CamPlan, pose: &PoseLanes, v: &mut [Lane; 6], world: &mut [Lane; 9]) {
    for k in 0..3 {
        for l in 0..LANES {
            v[k][l] = pose.c[k][l] - p.nominal_c[k];
        }
    }
    let rn = &p.nominal_r;
    for k in 0..9 {
        let (a, b) = (k / 3, k % 3);
        let (r0, r1, r2) = (&pose.r[3 * a], &pose.r[3 * a + 1], &pose.r[3 * a + 2]);
        let w = &mut world[k];
        for l in 0..LANES {
            // (R·R̄ᵀ)_ab = Σ_m R_am R̄_bm.
            w[l] = r0[l].mul_add(
                rn[3 * b],
                r1[l].mul_add(rn[3 * b + 1], r2[l] * rn[3 * b + 2]),
            );
        }
    }
}

/// Lane `l` of [`Composer::compose_world`] by the scalar composition.
#[inline(never)]
fn exact_world_lane(
    chain: &Chain,
    e: &[Lane],
    l: usize,
    v: &mut [[Lane; 6]],
    world: &mut [[Lane; 9]],
) {
    let eps: Vec<f64> = e.iter().map(|row| row[l]).collect();
    let poses = chain.compose(&eps);
    for (i, pose) in poses.iter().enumerate() {
        let nom = &chain.nominal()[i];
        let dc = pose.position_mm - nom.position_mm;
        let w = pose.rotation * nom.rotation.transpose();
        for k in 0..3 {
            v[i][k][l] = dc[k];
        }
        for k in 0..9 {
            world[i][k][l] = w[(k / 3, k % 3)];
        }
    }
}

/// The perturbed link of camera plan `p` per lane from its `delta` (centre in the parent's
/// axes, rotation by the grid kernel's own series forms: `R_l·Exp(δθ)` for `TANGENT`, else
/// ω φ κ + δθ); a lane whose angle leaves the series' range is marked in `ok`.
#[inline(always)]
fn link_lanes<const TANGENT: bool>(
    p: &CamPlan,
    delta: &[Lane; 6],
    link: &mut PoseLanes,
    ok: &mut [bool; LANES],
) {
    for l in 0..LANES {
        let d: [f64; 6] = std::array::from_fn(|k| delta[k][l]);
        for k in 0..3 {
            link.c[k][l] = p.position[k] + d[k];
        }
        let w = [d[3], d[4], d[5]];
        let (rl, t) = if TANGENT {
            tangent_rot(&p.rotation, w)
        } else {
            euler_rot(&p.angles, w)
        };
        ok[l] &= t < SMALL_ANGLE_SQ;
        for k in 0..9 {
            link.r[k][l] = rl[k];
        }
    }
}

/// The world pose of a child per lane, `C = C_p + R_p·C_l`, `R = R_p·R_l` (row-major 3×3
/// products summed left to right), one output element at a time over the whole block: the
/// lane loop innermost vectorises, where a loop over lanes around the whole product did not.
#[inline(always)]
fn compose_lanes(parent: &PoseLanes, link: &PoseLanes, own: &mut PoseLanes) {
    let (rp, rl) = (&parent.r, &link.r);
    for k in 0..3 {
        let (a0, a1, a2) = (&rp[3 * k], &rp[3 * k + 1], &rp[3 * k + 2]);
        let (pc, c) = (&parent.c[k], &mut own.c[k]);
        for l in 0..LANES {
            c[l] = pc[l]
                + a0[l].mul_add(
                    link.c[0][l],
                    a1[l].mul_add(link.c[1][l], a2[l] * link.c[2][l]),
                );
        }
    }
    for k in 0..9 {
        let (i, j) = (k / 3, k % 3);
        let (a0, a1, a2) = (&rp[3 * i], &rp[3 * i + 1], &rp[3 * i + 2]);
        let (b0, b1, b2) = (&rl[j], &rl[3 + j], &rl[6 + j]);
        let r = &mut own.r[k];
        for l in 0..LANES {
            r[l] = a0[l].mul_add(b0[l], a1[l].mul_add(b1[l], a2[l] * b2[l]));
        }
    }
}

/// Per lane: (centre − nominal, ω φ κ offsets) and the body-axis error of one camera.
#[inline(always)]
fn errors<const ANGLES: bool>(
    p: &CamPlan,
    pose: &PoseLanes,
    v: &mut [Lane; 6],
    th: &mut [Lane; 3],
    ok: &mut [bool; LANES],
) {
    let [so, sp, sk] = p.nominal_sin;
    let [co, cp, ck] = p.nominal_cos;
    let rn = &p.nominal_r;
    for l in 0..LANES {
        let r: [f64; 9] = std::array::from_fn(|k| pose.r[k][l]);
        let mut lok = ok[l];
        for k in 0..3 {
            v[k][l] = pose.c[k][l] - p.nominal_c[k];
        }
        if ANGLES {
            // ω = atan2(−r₁₂, r₂₂), κ = atan2(−r₀₁, r₀₀) (both scaled by cos φ > 0);
            // φ = atan2(r₀₂, √(r₀₀² + r₀₁²)). Offsets by the angle-difference identities.
            let (yo, xo) = (-r[5], r[8]);
            v[3][l] = atan2_small(yo * co - xo * so, xo * co + yo * so, &mut lok);
            let cphi = (r[0] * r[0] + r[1] * r[1]).sqrt();
            // Near gimbal lock the scalar extraction switches convention: leave it to it.
            lok &= cphi >= GIMBAL_COS_PHI;
            v[4][l] = atan2_small(r[2] * cp - cphi * sp, cphi * cp + r[2] * sp, &mut lok);
            let (yk, xk) = (-r[1], r[0]);
            v[5][l] = atan2_small(yk * ck - xk * sk, xk * ck + yk * sk, &mut lok);
        }
        // Body-axis error: M = R̄ᵀR, v = ½(M − Mᵀ)∨, θ = atan2(|v|, (tr M − 1)/2)·v/|v|.
        let mt = |i: usize, j: usize| {
            // (R̄ᵀR)_ij
            rn[i].mul_add(r[j], rn[3 + i].mul_add(r[3 + j], rn[6 + i] * r[6 + j]))
        };
        let w = [
            0.5 * (mt(2, 1) - mt(1, 2)),
            0.5 * (mt(0, 2) - mt(2, 0)),
            0.5 * (mt(1, 0) - mt(0, 1)),
        ];
        let cos = 0.5 * (mt(0, 0) + mt(1, 1) + mt(2, 2) - 1.0);
        let s2 = w[0].mul_add(w[0], w[1].mul_add(w[1], w[2] * w[2]));
        // One division: t = |v|²/cos², f = atan(√t)/√t / cos.
        let inv = 1.0 / cos;
        let t = s2 * (inv * inv);
        lok &= cos > 0.0 && t < ATAN_Z_MAX * ATAN_Z_MAX;
        let f = atan_over_z(t) * inv;
        for k in 0..3 {
            th[k][l] = w[k] * f;
        }
        ok[l] = lok;
    }
}

/// Lane `l` recomputed by the scalar formulas.
#[inline(never)]
fn exact_lane(chain: &Chain, e: &[Lane], l: usize, v: &mut [[Lane; 6]], th: &mut [[Lane; 3]]) {
    let eps: Vec<f64> = e.iter().map(|row| row[l]).collect();
    let poses = chain.compose(&eps);
    for (i, pose) in poses.iter().enumerate() {
        let (dc, theta) = chain.error_of(i, pose);
        let a = chain.angle_offsets(i, pose);
        for k in 0..3 {
            v[i][k][l] = dc[k];
            v[i][3 + k][l] = a[k];
            th[i][k][l] = theta[k];
        }
    }
}

/// What the block loop needs of one camera.
#[derive(Debug, Clone)]
pub(crate) struct CamPlan {
    pub(crate) parent: Option<usize>,
    pub(crate) noise: RotationNoise,
    pub(crate) position: [f64; 3],
    pub(crate) rotation: [f64; 9],
    /// Sines and cosines of the link's ω φ κ (base of euler noise).
    pub(crate) angles: Trig,
    /// The link's noise factor: δ = L·ε (x y z in the parent's axes, rotation).
    pub(crate) noise_factor: NoiseFactor,
    pub(crate) nominal_c: [f64; 3],
    pub(crate) nominal_r: [f64; 9],
    pub(crate) nominal_sin: [f64; 3],
    pub(crate) nominal_cos: [f64; 3],
}
