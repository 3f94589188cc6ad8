#!/usr/bin/env bash
# Issue 39's side-by-side whole-command timings (docs/performance.md, "Issue 39, quiet machine"):
# crashrig on two threads against the per-point NumPy references on one thread, alternated in
# each of five rounds, /usr/bin/time around every whole command. Needs a release build
# (`cargo build --release -p crashrig-cli`) and a Python with numpy and opencv-python-headless:
#   PY=/path/to/venv/bin/python benches/side_by_side.sh OUTDIR
# Appends "TAG wall_s user_s sys_s maxrss_kb" lines (and "round r load L") to OUTDIR/times.txt.
# Wall ratios are meaningful only on a quiet machine (two free cores); per-CPU-second ratios are
# stable under load.
set -u
cd "$(dirname "$0")/.."
OUT=${1:?usage: PY=python benches/side_by_side.sh OUTDIR}
mkdir -p "$OUT"
B=target/release/crashrig
P=${PY:-python3}
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
T() { local tag=$1; shift; /usr/bin/time -f "$tag %e %U %S %M" "$@" > "$OUT/$tag.out" 2>> "$OUT/times.txt"; }
for r in 1 2 3 4 5; do
  echo "round $r load $(cut -d' ' -f1 /proc/loadavg)" >> "$OUT/times.txt"
  T rs_real $B --threads 2 grid benches/real_map.toml --samples 400000 --no-plots --out "$OUT/rm"  # 88.4 M point-draws
  T np_real "$P" benches/real_map_numpy.py --samples 5000                                             # 1.105 M point-draws
  T rs_chain $B --threads 2 propagate fixtures/scenarios/paper_chain.toml --samples 10000000 --json
  T np_chain "$P" benches/chain_numpy.py fixtures/scenarios/paper_chain.toml --samples 1000000
  T rs_diag $B --threads 2 grid fixtures/scenarios/four_cameras_z0.toml --samples 1000000 --no-plots --out "$OUT/dg"  # 221 M draws
  T np_diag "$P" fixtures/gen/grid_numpy_bench.py fixtures/scenarios/four_cameras_z0.toml --samples 20000              # 4.42 M draws
done
