#!/bin/bash
# Merges the N shard directories of examples/scale/slurm-grid-array.sh into $OUT (docs/SCALE.md):
#   sbatch --dependency=afterok:<array job id> --export=ALL,OUT=grid_out,N=8 examples/scale/slurm-merge.sh
# `crashrig merge` refuses a missing, repeated or foreign shard with one error line.
#SBATCH --job-name=crashrig-merge
#SBATCH --cpus-per-task=1
#SBATCH --output=crashrig-merge-%j.log
set -euo pipefail

OUT=${OUT:-grid_out}
CRASHRIG=${CRASHRIG:-crashrig}
: "${N:?set N to the number of shards}"

dirs=()
for i in $(seq 1 "$N"); do
    dirs+=("$OUT.shards/$i")
done
exec "$CRASHRIG" merge "${dirs[@]}" --out "$OUT"
