#!/bin/sh
# The worked example of docs/COVARIANCE.md: camera A's per-epoch pose covariance from the
# bundled 8-epoch lab sequence, then what `measure --a-covariance` reads.
# Run from the repository root:  sh examples/covariance/run.sh [OUT_DIR]   (default /tmp/crashrig_covariance)
# The library version of the same run: cargo run -p crashrig-covariance --example worked_example
set -eu
OUT=${1:-/tmp/crashrig_covariance}
F=fixtures/covariance/mc
mkdir -p "$OUT"
cargo run -q --release -p crashrig-cli -- covariance $F/model --camera cam_out/ \
    --control-points $F/control_points.csv --mm-per-unit 1000 --out "$OUT/a_covariance.json"
# stderr: 8 epochs of A, σ̂₀ = 0.497 px (used 0.497 px), 481 observations: $OUT/a_covariance.json
# The file holds "epochs" (8 × 6×6), "joint" (48×48), "sigma0_px", "epoch_sigmas", ...;
# `crashrig measure ... --a-covariance "$OUT/a_covariance.json"` draws A's 8 epochs of one
# replicate jointly from "joint" (docs/MEASURE.md, "A's pose uncertainty").
python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(d['epoch_sigmas'][0])" "$OUT/a_covariance.json"
