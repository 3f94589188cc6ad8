#!/usr/bin/env python3
"""NumPy + OpenCV equivalent of the real-study Monte Carlo path (`benches/study_path.toml`).

The speed reference of docs/performance.md, "The real-study path": the same work per draw as
crashrig's kernel path `study` (criterion group `paths_1thread`, `mc_cpu study`), vectorised
over the draws, written from the contract (docs/REFERENCE.md and the scenario file it links, docs/SCENARIO.md: chain, `covariance_tangent`,
`correlated = true`, fixed cameras) with the helpers of the independent references
fixtures/gen/mc_chain_reference.py (scenario_world_draws, scenario_nominal) and fixtures/gen/fixed_reference.py
(look_at, project, undistort), not from the Rust code:

- per draw, each chain pose or link takes delta = L·eps, L the Cholesky factor of its
  covariance_tangent (mm, rad); C = C_nom + delta_xyz (the parent's axes for a link),
  R = R_nom·Exp(delta_th); child: C = C_p + R_p·C_link, R = R_p·R_link;
- correlated observers: an observer at chain camera i moves with it as a rigid body,
  C_obs = C_fixed + (C_i − C̄_i), R_obs = R_i·R̄_iᵀ·R_fixed;
- its observation is the true pixel + N(0, pixel_sigma_px) per axis, undistorted by
  cv2.undistortPoints; the two DLT rows of each observer, solved by normal equations;
- sigma = sample standard deviation (ddof = 1) of the intersected points.

Usage:
  /work/venv/bin/python benches/study_path_numpy.py [--draws 200000] [--repeat 3]
      [--compare DIR/grid.csv]
prints the draws per second of each repeat (one thread: set OMP/OPENBLAS threads to 1
outside) and the sigma; with --compare, crashrig's sigma over this one (writes nothing).
"""

import argparse
import csv
import pathlib
import sys
import time
import tomllib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "fixtures" / "gen"))
from fixed_reference import look_at, project, undistort  # noqa: E402
from mc_chain_reference import scenario_nominal, scenario_world_draws  # noqa: E402

SCENARIO = pathlib.Path(__file__).resolve().parent / "study_path.toml"


def cov_rad(cam):
    """covariance_tangent (mm², mm·deg, deg²) or the σ keys, in mm and rad."""
    if "covariance_tangent" in cam:
        s = np.array(cam["covariance_tangent"], float)
    else:
        s = np.diag(np.square(np.r_[cam["sigma_position_mm"], cam["sigma_angles_deg"]]))
    d = np.r_[np.ones(3), np.full(3, np.pi / 180.0)]
    return s * np.outer(d, d)


def fixed_camera(obs):
    cam = obs["camera"]
    fx, fy, cx, cy, k1, k2, p1, p2 = cam["params"]
    return {
        "C": np.asarray(obs["position_mm"], float),
        "R": look_at(obs["position_mm"], obs["look_at_mm"]),
        "K": np.array([[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]]),
        "dist": np.array([k1, k2, p1, p2]),
        "sigma_px": obs["pixel_sigma_px"],
        "source": obs["sigma_from"],
    }


def draw(sc, cams, chain, point, n, rng):
    # The chain, composed per draw, and its nominal poses.
    world = scenario_world_draws(sc["camera"], chain, n, rng)
    nominal = scenario_nominal(sc["camera"])
    a_sum = np.zeros((n, 3, 3))
    b_sum = np.zeros((n, 3))
    for c in cams:
        u, _ = project(c, point)
        obs = u + c["sigma_px"] * rng.standard_normal((n, 2))
        nrm = undistort(c, obs)
        (ci, ri), (c0, r0) = world[c["source"]], nominal[c["source"]]
        cc = c["C"] + (ci - c0)
        rot = ri @ (r0.T @ c["R"])
        c1, c2, c3 = rot[:, :, 0], rot[:, :, 1], rot[:, :, 2]
        for a in (c3 * nrm[:, :1] - c1, c3 * nrm[:, 1:] - c2):
            a_sum += a[:, :, None] * a[:, None, :]
            b_sum += a * np.sum(a * cc, axis=1, keepdims=True)
    return np.linalg.solve(a_sum, b_sum[:, :, None])[:, :, 0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=200_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--compare", type=pathlib.Path)
    args = ap.parse_args()
    sc = tomllib.loads(SCENARIO.read_text())
    chain = [np.linalg.cholesky(cov_rad(cam)) for cam in sc["camera"]]
    cams = [fixed_camera(o) for o in sc["grid"]["observer"]]
    g = sc["grid"]
    point = np.array([g["x_mm"][0], g["y_mm"][0], g["z_mm"][0]], float)
    rng = np.random.default_rng(sc["seed"])
    block = 100_000
    for _ in range(args.repeat):
        t, c = time.perf_counter(), time.process_time()
        pts = [draw(sc, cams, chain, point, min(block, args.draws - s), rng)
               for s in range(0, args.draws, block)]
        dt, dc = time.perf_counter() - t, time.process_time() - c
        pts = np.concatenate(pts)
        s = pts.std(axis=0, ddof=1)
        print(f"numpy: {args.draws} draws in {dt:.3f} s = {args.draws / dt / 1e6:.4f} M draws/s"
              f" wall, {args.draws / dc / 1e6:.4f} M per CPU-s;"
              f" sigma_mm = {s[0]:.5f} {s[1]:.5f} {s[2]:.5f}")
    if args.compare:
        row = next(csv.DictReader(args.compare.open()))
        se = 4.0 * np.sqrt(1.0 / (2.0 * (args.draws - 1)) + 1.0 / (2.0 * (int(row.get("samples", 0) or 2) - 1)))
        for k, ax in enumerate("xyz"):
            r = float(row[f"sigma_{ax}_mm"]) / s[k]
            print(f"sigma_{ax}: crashrig/numpy = {r:.4f} (4 SE ≈ {se:.4f})")


if __name__ == "__main__":
    main()
