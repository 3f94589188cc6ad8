#!/bin/bash
# One shard of `crashrig grid` per Slurm array task (docs/SCALE.md).
#
#   sbatch --array=1-8 --export=ALL,SCENARIO=layout.toml,OUT=grid_out examples/scale/slurm-grid-array.sh
#
# Task i of the array runs `crashrig grid … --shard i/N` (N = the array's task count) into
# $OUT.shards/i; merge afterwards with examples/scale/slurm-merge.sh (or use
# examples/scale/slurm-submit.sh, which submits both with a dependency). Every shard reads the
# same scenario file (a shared file system) and writes only its own directory.
#
# `measure` and `place` shard the same way: COMMAND names the command, SCENARIO its input,
# GRID_OPTIONS its options (the same for every task; not --out, --shard), e.g.
#   COMMAND=measure SCENARIO=seq/model GRID_OPTIONS="--camera-a cam_out/ --camera-b 2 \
#     --link link.json --observations markers.csv --mm-per-unit 1000 --frame-rate-hz 1000"
#   COMMAND=place GRID_OPTIONS="--candidates cands.toml --choose 4"
# and slurm-merge.sh merges any of them (`crashrig merge` reads the command from shard.json).
#SBATCH --job-name=crashrig-grid
#SBATCH --cpus-per-task=2
#SBATCH --output=crashrig-grid-%A_%a.log
set -euo pipefail

: "${SCENARIO:?set SCENARIO to the scenario file}"
OUT=${OUT:-grid_out}
CRASHRIG=${CRASHRIG:-crashrig}
# Extra grid options, e.g. "--samples 20000 --seed 7" (the same for every task).
GRID_OPTIONS=${GRID_OPTIONS:-}
COMMAND=${COMMAND:-grid}
case "$COMMAND" in
    grid | measure | place) ;;
    *)
        echo "error: COMMAND must be grid, measure or place, got $COMMAND" >&2
        exit 2
        ;;
esac

: "${SLURM_ARRAY_TASK_ID:?submit this script as a job array (sbatch --array=1-N)}"
if [ "${SLURM_ARRAY_TASK_MIN:-1}" != 1 ]; then
    echo "error: the array must start at 1 (--array=1-N), got ${SLURM_ARRAY_TASK_MIN}" >&2
    exit 2
fi
N=${SLURM_ARRAY_TASK_COUNT:-${SLURM_ARRAY_TASK_MAX:?}}
I=$SLURM_ARRAY_TASK_ID

# shellcheck disable=SC2086 # GRID_OPTIONS is a list of options
exec "$CRASHRIG" --threads "${SLURM_CPUS_PER_TASK:-1}" "$COMMAND" "$SCENARIO" $GRID_OPTIONS \
    --no-plots --out "$OUT.shards/$I" --shard "$I/$N"
