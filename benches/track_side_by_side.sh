#!/usr/bin/env bash
# Issue 43's side by side (docs/performance.md, "crashrig track against OpenCV"): the whole
# `crashrig track` command against an OpenCV pipeline (decode + cornerSubPix per marker,
# benches/track_opencv.py) on the same rendered frames, alternated over five rounds.
# Needs a release build (`cargo build --release -p crashrig-cli`) and a Python with numpy and
# opencv-python-headless:
#   PY=/path/to/venv/bin/python benches/track_side_by_side.sh OUTDIR [FRAMES]
# Renders FRAMES (default 400) frames of 224 × 168 px with six quadrant targets
# (fixtures/gen/render_targets.py --bench) into OUTDIR/seq, then appends one line per run to
# OUTDIR/times.txt: "TAG wall_s user_s sys_s maxrss_kb observations".
set -eu
cd "$(dirname "$0")/.."
OUT=${1:?usage: PY=python benches/track_side_by_side.sh OUTDIR [FRAMES]}
N=${2:-400}
mkdir -p "$OUT"
B=target/release/crashrig
P=${PY:-python3}
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
[ -d "$OUT/seq/frames" ] || "$P" fixtures/gen/render_targets.py --bench "$OUT/seq" --frames "$N"
for r in 1 2 3 4 5; do
  echo "round $r load $(cut -d' ' -f1 /proc/loadavg)" >> "$OUT/times.txt"
  for threads in 1 2; do
    /usr/bin/time -f "rs_track_t$threads %e %U %S %M" -o "$OUT/t.txt" \
      $B --threads $threads --json track "$OUT/seq/frames" --seeds "$OUT/seq/seeds.csv" --camera B --out "$OUT/track" > "$OUT/track.json"
    echo "$(cat "$OUT/t.txt") $(grep -o '"observations": [0-9]*' "$OUT/track.json" | head -1 | grep -o '[0-9]*$')" >> "$OUT/times.txt"
  done
  /usr/bin/time -f "opencv %e %U %S %M" -o "$OUT/t.txt" "$P" benches/track_opencv.py "$OUT/seq/frames" "$OUT/seq/seeds.csv" > "$OUT/opencv.json"
  echo "$(cat "$OUT/t.txt") $(grep -o '"observations": [0-9]*' "$OUT/opencv.json" | grep -o '[0-9]*$')" >> "$OUT/times.txt"
done
cat "$OUT/times.txt"
