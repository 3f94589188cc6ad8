#!/usr/bin/env python3
"""Per-point NumPy + OpenCV reference of the real-study map (`benches/real_map.toml`).

The speed and accuracy reference of docs/performance.md, "The real-study path": the work of
`crashrig grid benches/real_map.toml` — the correlated map and its independent companion map —
done point by point, vectorised over the draws of a point, written from the contract
(docs/REFERENCE.md and the scenario file it links, docs/SCENARIO.md: chain, `covariance_tangent`, `sigma_from`, `correlated = true`, fixed
cameras) with the helpers of the independent references fixtures/gen/mc_chain_reference.py
(scenario_world_draws, scenario_nominal, exp_so3, log_so3) and fixtures/gen/fixed_reference.py (look_at, project,
undistort), not from the Rust code:

- the chain: per draw each pose or link takes delta = L·eps, L the Cholesky factor of its
  covariance_tangent (mm, rad); C = C_nom + delta_xyz (the parent's axes for a link),
  R = R_nom·Exp(delta_th); child: C = C_p + R_p·C_link, R = R_p·R_link;
- correlated map: an observer with `sigma_from = camera i` moves with camera i as a rigid body,
  C_obs = C̄_obs + (C_i − C̄_i), R_obs = R_i·R̄_iᵀ·R̄_obs (an aimed observer stands at camera
  i's nominal centre); this script draws the chain anew for every point (a per-point
  reference: no draw is shared between points);
- independent companion map: every observer drawn on its own with its chain camera's Monte
  Carlo tangent covariance (this script's own chain Monte Carlo, --chain-draws draws), centre
  in world axes, rotation R̄_obs·Exp(θ) about the observer's own axes;
- aimed observers look at the point without roll and observe it at the principal point (the
  DLT rows −c₁, −c₂); fixed cameras see a point in front of them inside the image; their
  observation is the true pixel + N(0, pixel_sigma_px) per axis, undistorted by
  cv2.undistortPoints; the rows x·c₃ − c₁, y·c₃ − c₂ of all observers that see the point
  solved by normal equations (≥ 2 observers);
- sigma = sample standard deviation (ddof = 1) of the intersected points.

Usage:
  /work/helpers/venv-<you>/bin/python benches/real_map_numpy.py [--samples 20000]
      [--compare DIR] [--crashrig-samples N]
prints the point-draws per second (each point-draw covers both maps, as the command's) and,
with --compare DIR (a `crashrig grid benches/real_map.toml --out DIR`), crashrig's σ of every
point over this script's (correlated map) and the independent companion's median σ_max.
Writes nothing. One thread: set OMP_NUM_THREADS / OPENBLAS_NUM_THREADS = 1 outside.
"""

import argparse
import csv
import json
import math
import pathlib
import sys
import time
import tomllib

import cv2
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "fixtures" / "gen"))
from fixed_reference import look_at, project, undistort  # noqa: E402
from mc_chain_reference import (  # noqa: E402
    exp_so3, log_so3, scenario_nominal, scenario_world_draws)

SCENARIO = pathlib.Path(__file__).resolve().parent / "real_map.toml"


def axis(spec):
    start, stop, n = spec
    return np.linspace(float(start), float(stop), int(n))


def cov_rad(cam):
    """covariance_tangent (mm², mm·deg, deg²) or the σ keys, in mm and rad."""
    if "covariance_tangent" in cam:
        s = np.array(cam["covariance_tangent"], float)
    else:
        s = np.diag(np.square(np.r_[cam["sigma_position_mm"], cam["sigma_angles_deg"]]))
    d = np.r_[np.ones(3), np.full(3, np.pi / 180.0)]
    return s * np.outer(d, d)


def tangent_covariances(sc, factors, nominal, draws, rng):
    """Each chain camera's Monte Carlo tangent covariance (mm, rad), n − 1."""
    sums = {}
    block = 100_000
    for s in range(0, draws, block):
        world = scenario_world_draws(sc["camera"], factors, min(block, draws - s), rng)
        for name, (c, r) in world.items():
            c0, r0 = nominal[name]
            t = np.concatenate([c - c0, log_so3(np.swapaxes(r0, 0, 1)[None] @ r)], axis=1)
            sums.setdefault(name, []).append(t)
    return {k: np.cov(np.concatenate(v), rowvar=False, ddof=1) for k, v in sums.items()}


def observer(o, nominal):
    src = o["sigma_from"]
    if o.get("aim", "point") == "fixed":
        cam = o["camera"]
        fx, fy, cx, cy, k1, k2, p1, p2 = cam["params"]
        return {
            "fixed": True,
            "C": np.asarray(o["position_mm"], float),
            "R": look_at(o["position_mm"], o["look_at_mm"]),
            "K": np.array([[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]]),
            "dist": np.array([k1, k2, p1, p2]),
            "w": cam["width"],
            "h": cam["height"],
            "sigma_px": o["pixel_sigma_px"],
            "source": src,
        }
    # A correlated aimed observer stands at its chain camera's nominal centre.
    return {"fixed": False, "C": nominal[src][0], "source": src}


def sees(c, point):
    """The true pixel of a fixed camera that sees `point`, else None."""
    u, depth = project(c, point)
    if depth <= 0 or not (0 <= u[0] < c["w"] and 0 <= u[1] < c["h"]):
        return None
    p = c["R"].T @ (point - c["C"])
    back = undistort(c, u[None, :])[0]
    if np.linalg.norm(back - p[:2] / p[2]) > 1e-9 * (1.0 + np.linalg.norm(p[:2] / p[2])):
        return None
    return u


def views(obs, point):
    out = []
    for o in obs:
        if o["fixed"]:
            u = sees(o, point)
            if u is not None:
                out.append((o, o["R"], u))
        else:
            out.append((o, look_at(o["C"], point), None))
    return out


def solve(rows, n):
    a_sum = np.zeros((n, 3, 3))
    b_sum = np.zeros((n, 3))
    for rot, cc, nrm in rows:
        c1, c2, c3 = rot[:, :, 0], rot[:, :, 1], rot[:, :, 2]
        for a in (c3 * nrm[:, :1] - c1, c3 * nrm[:, 1:] - c2):
            a_sum += a[:, :, None] * a[:, None, :]
            b_sum += a * np.sum(a * cc, axis=1, keepdims=True)
    return np.linalg.solve(a_sum, b_sum[:, :, None])[:, :, 0]


def observed(o, u, n, rng):
    if u is None:
        return np.zeros((n, 2))
    return undistort(o, u + o["sigma_px"] * rng.standard_normal((n, 2)))


def point_sigmas(sc, factors, nominal, tcov_factor, vs, n, rng):
    """σ (x, y, z) of the correlated map and of the independent map at one point."""
    world = scenario_world_draws(sc["camera"], factors, n, rng)
    rows = []
    for o, r_bar, u in vs:
        (ci, ri), (c0, r0) = world[o["source"]], nominal[o["source"]]
        rows.append((ri @ (r0.T @ r_bar), o["C"] + (ci - c0), observed(o, u, n, rng)))
    corr = solve(rows, n).std(axis=0, ddof=1)
    rows = []
    for o, r_bar, u in vs:
        d = rng.standard_normal((n, 6)) @ tcov_factor[o["source"]].T
        rows.append((r_bar[None] @ exp_so3(d[:, 3:]), o["C"] + d[:, :3], observed(o, u, n, rng)))
    ind = solve(rows, n).std(axis=0, ddof=1)
    return corr, ind


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=20_000)
    ap.add_argument("--chain-draws", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=20261129)
    ap.add_argument("--compare", type=pathlib.Path)
    ap.add_argument("--crashrig-samples", type=int)
    args = ap.parse_args()
    sc = tomllib.loads(SCENARIO.read_text())
    g = sc["grid"]
    t0, c0 = time.perf_counter(), time.process_time()
    factors = [np.linalg.cholesky(cov_rad(cam)) for cam in sc["camera"]]
    nominal = scenario_nominal(sc["camera"])
    rng = np.random.default_rng(args.seed)
    tcov = tangent_covariances(sc, factors, nominal, args.chain_draws, rng)
    tcov_factor = {k: np.linalg.cholesky(v) for k, v in tcov.items()}
    obs = [observer(o, nominal) for o in g["observer"]]
    points = [np.array([x, y, z]) for z in axis(g["z_mm"]) for y in axis(g["y_mm"])
              for x in axis(g["x_mm"])]
    result = []
    drawn = 0
    for i, p in enumerate(points):
        vs = views(obs, p)
        if len(vs) < 2:
            result.append(None)
            continue
        prng = np.random.default_rng(args.seed + 1 + i)
        result.append(point_sigmas(sc, factors, nominal, tcov_factor, vs, args.samples, prng))
        drawn += args.samples
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    print(f"numpy: {len(points)} points, {drawn} point-draws (both maps) in {dt:.3f} s wall,"
          f" {dc:.3f} s CPU = {drawn / dt / 1e6:.4f} M point-draws/s wall,"
          f" {drawn / dc / 1e6:.4f} M per CPU-s")
    if not args.compare:
        return
    n_r = args.crashrig_samples or args.samples
    se = math.sqrt(1.0 / (2 * (args.samples - 1)) + 1.0 / (2 * (n_r - 1)))
    ratios, outside = [], 0
    with open(args.compare / "grid.csv") as f:
        for row, (p, r) in zip(csv.DictReader(f), zip(points, result)):
            assert np.allclose([float(row[k]) for k in ("x_mm", "y_mm", "z_mm")], p)
            if r is None or not row["sigma_x_mm"]:
                continue
            for k, ax in enumerate("xyz"):
                q = float(row[f"sigma_{ax}_mm"]) / r[0][k]
                ratios.append(q)
                outside += abs(q - 1.0) > 4 * se
    q = np.array(ratios)
    print(f"correlated map: {len(q)} sigmas, crashrig/numpy min {q.min():.4f} median"
          f" {np.median(q):.4f} max {q.max():.4f}; outside 4 SE (±{4 * se:.4f}): {outside}")
    summary = json.loads((args.compare / "summary.json").read_text())
    ind = np.median([max(r[1]) for r in result if r is not None])
    theirs = summary["correlation"]["independent_median_sigma_max_mm"]
    print(f"independent map: median sigma_max crashrig {theirs:.5f} numpy {ind:.5f}"
          f" ratio {theirs / ind:.4f}")


if __name__ == "__main__":
    main()
