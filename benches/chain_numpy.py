#!/usr/bin/env python3
"""NumPy reference of `crashrig propagate` (the chain Monte Carlo) on a scenario's cameras.

The speed and accuracy reference of docs/performance.md ("Chain propagation"): the draws
`crashrig propagate SCENARIO --samples N` makes, vectorised over the draws, written from the
contract (docs/REFERENCE.md and the scenario file it links, docs/SCENARIO.md: cameras, links, `sigma_*` / `covariance_tangent`, tangent
noise) with the helpers of fixtures/gen/mc_chain_reference.py (scenario_world_draws, log_so3),
not from the Rust code:

- per draw each pose or link takes delta = L·eps, L the Cholesky factor of its covariance
  (mm, rad); C = C_nom + delta_xyz (the parent's axes for a link), R = R_nom·Exp(delta_th);
  child: C = C_p + R_p·C_link, R = R_p·R_link;
- per camera what `propagate` reports: the σ and mean of the world centre, of ω φ κ
  (R = Rx(ω)·Ry(φ)·Rz(κ), offsets from the nominal wrapped to ±π) and the tangent covariance
  of (C − C̄, log(R̄ᵀR)), n − 1.

Usage:
  /work/helpers/venv-<you>/bin/python benches/chain_numpy.py fixtures/scenarios/paper_chain.toml \\
      [--samples 1000000] [--compare propagate.json]
prints the joint draws per second (one thread: set OMP/OPENBLAS threads to 1 outside) and,
with --compare (the output of `crashrig --json propagate … > propagate.json`), crashrig's σ
over this script's. Writes nothing.
"""

import argparse
import json
import math
import pathlib
import sys
import time
import tomllib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "fixtures" / "gen"))
from mc_chain_reference import log_so3, scenario_world_draws  # noqa: E402


def cov_rad(cam):
    """covariance_tangent (mm², mm·deg, deg²) or the σ keys, in mm and rad."""
    if "covariance_tangent" in cam:
        s = np.array(cam["covariance_tangent"], float)
    else:
        s = np.diag(np.square(np.r_[cam["sigma_position_mm"], cam["sigma_angles_deg"]]))
    d = np.r_[np.ones(3), np.full(3, np.pi / 180.0)]
    return s * np.outer(d, d)


def opk(r):
    """ω φ κ (rad) of a batch of rotations R = Rx(ω) Ry(φ) Rz(κ)."""
    return np.stack(
        [
            np.arctan2(-r[:, 1, 2], r[:, 2, 2]),
            np.arcsin(np.clip(r[:, 0, 2], -1.0, 1.0)),
            np.arctan2(-r[:, 0, 1], r[:, 0, 0]),
        ],
        axis=1,
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario", type=pathlib.Path)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=20261129)
    ap.add_argument("--compare", type=pathlib.Path)
    args = ap.parse_args()
    cams = tomllib.loads(args.scenario.read_text())["camera"]
    t0, c0 = time.perf_counter(), time.process_time()
    factors = [np.linalg.cholesky(cov_rad(c)) for c in cams]
    nominal = scenario_world_draws(cams, [np.zeros((6, 6))] * len(cams), 1, np.random.default_rng(0))
    rng = np.random.default_rng(args.seed)
    sums = {c["name"]: [] for c in cams}
    block = 200_000
    for s in range(0, args.samples, block):
        world = scenario_world_draws(cams, factors, min(block, args.samples - s), rng)
        for name, (c, r) in world.items():
            c0_, r0 = nominal[name]
            a = opk(r) - opk(r0)
            a = (a + np.pi) % (2 * np.pi) - np.pi
            t = log_so3(np.swapaxes(r0, 1, 2) @ r)
            # Moments per block (memory bounded): n, Σx, Σxxᵀ of (C − C̄, ω φ κ, θ).
            v = np.concatenate([c - c0_, a, t], axis=1)
            sums[name].append((len(v), v.sum(axis=0), v.T @ v))
    stats = {}
    for name, parts in sums.items():
        n = sum(p[0] for p in parts)
        s1 = sum(p[1] for p in parts)
        s2 = sum(p[2] for p in parts)
        stats[name] = np.sqrt(np.diag((s2 - np.outer(s1, s1) / n) / (n - 1)))
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    print(f"numpy: {args.samples} joint draws of {len(cams)} cameras in {dt:.3f} s wall,"
          f" {dc:.3f} s CPU = {args.samples / dt / 1e6:.4f} M draws/s wall,"
          f" {args.samples / dc / 1e6:.4f} M per CPU-s")
    if not args.compare:
        return
    doc = json.loads(args.compare.read_text())
    se = math.sqrt(1.0 / (2 * (args.samples - 1)) + 1.0 / (2 * (doc["samples"] - 1)))
    worst = 0.0
    for cam in doc["cameras"]:
        s = stats[cam["name"]]
        theirs = np.r_[cam["position_sigma_mm"], np.radians(cam["angles_sigma_deg"]),
                       np.radians(cam["tangent_sigma_deg"])]
        r = theirs / s
        worst = max(worst, np.abs(r - 1.0).max() / se)
        print(f"{cam['name']}: crashrig/numpy sigma (position, angles, tangent) "
              + " ".join(f"{x:.4f}" for x in r))
    print(f"largest |ratio − 1| = {worst:.2f} combined standard errors")


if __name__ == "__main__":
    main()
