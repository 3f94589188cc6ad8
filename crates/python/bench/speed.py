"""Side-by-side timings of the Python module (docs/performance.md, section "Python module").

1. `crashrig.grid` against `crashrig grid --no-plots` (the CLI binary) on the same scenario,
   draws and seed: wall-clock draws/s of each (points × draws / seconds, best of `--repeat`),
   and their ratio (issue 28 asks for >= 0.8).
2. `crashrig.read_model` against `pycolmap.Reconstruction` on the largest bundled model: best
   time of each over `--repeat` × `--inner` reads, the ratio, and the same with every 3-D point
   touched once (`.points3D` iterated).

Run (release wheel and release CLI):
    python crates/python/bench/speed.py --cli target/release/crashrig
"""

import argparse
import os
import pathlib
import subprocess
import tempfile
import time

import crashrig

ROOT = pathlib.Path(__file__).resolve().parents[3]


def best(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def grid_speed(cli, scenario, samples, seed, repeat):
    cols = crashrig.grid(scenario, samples=samples, seed=seed)
    draws = len(cols["x_mm"]) * samples
    t_py = best(lambda: crashrig.grid(scenario, samples=samples, seed=seed), repeat)
    with tempfile.TemporaryDirectory() as d:
        cmd = [cli, "grid", str(scenario), "--out", os.path.join(d, "g"), "--samples",
               str(samples), "--seed", str(seed), "--no-plots"]
        t_cli = best(lambda: subprocess.run(cmd, check=True, capture_output=True), repeat)
    print(f"grid {scenario.name}: {len(cols['x_mm'])} points x {samples} draws")
    print(f"  python  {t_py:.3f} s  {draws / t_py:.3e} draws/s")
    print(f"  cli     {t_cli:.3f} s  {draws / t_cli:.3e} draws/s")
    print(f"  ratio python/cli draws/s = {t_cli / t_py:.3f}")


def read_speed(model, repeat, inner):
    import pycolmap

    def ours():
        for _ in range(inner):
            crashrig.read_model(model)

    def theirs():
        for _ in range(inner):
            pycolmap.Reconstruction(str(model))

    def ours_all():
        for _ in range(inner):
            m = crashrig.read_model(model)
            for p in m.points3D.values():
                p.xyz

    def theirs_all():
        for _ in range(inner):
            m = pycolmap.Reconstruction(str(model))
            for p in m.points3D.values():
                p.xyz

    a, b = best(ours, repeat) / inner, best(theirs, repeat) / inner
    c, d = best(ours_all, repeat) / inner, best(theirs_all, repeat) / inner
    print(f"read_model {model.relative_to(ROOT)} (pycolmap {pycolmap.__version__})")
    print(f"  read:            crashrig {a * 1e3:.3f} ms  pycolmap {b * 1e3:.3f} ms  "
          f"pycolmap/crashrig = {b / a:.2f}")
    print(f"  read + points3D: crashrig {c * 1e3:.3f} ms  pycolmap {d * 1e3:.3f} ms  "
          f"pycolmap/crashrig = {d / c:.2f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default=str(ROOT / "target" / "release" / "crashrig"))
    ap.add_argument("--scenario", default=str(ROOT / "fixtures/scenarios/four_cameras_z0.toml"))
    ap.add_argument("--samples", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--inner", type=int, default=20)
    ap.add_argument("--model", default=str(ROOT / "fixtures/rig/paper"))
    a = ap.parse_args()
    grid_speed(a.cli, pathlib.Path(a.scenario), a.samples, 1, a.repeat)
    read_speed(pathlib.Path(a.model), a.repeat, a.inner)


if __name__ == "__main__":
    main()
