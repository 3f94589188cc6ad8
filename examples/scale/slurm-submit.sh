#!/bin/bash
# Submits the N shards of a grid as a Slurm job array and the merge as a job that starts when
# every shard succeeded (docs/SCALE.md):
#   examples/scale/slurm-submit.sh 8 layout.toml grid_out [grid options…]
# measure and place shards: COMMAND=measure (or place) in the environment, e.g.
#   COMMAND=measure examples/scale/slurm-submit.sh 8 seq/model m_out --camera-a cam_out/ …
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 N SCENARIO.toml OUT [grid options…]" >&2
    exit 2
fi
N=$1 SCENARIO=$2 OUT=$3
shift 3
HERE=$(cd "$(dirname "$0")" && pwd)
export SCENARIO OUT N GRID_OPTIONS="$*"
array=$(sbatch --parsable --array="1-$N" --export=ALL "$HERE/slurm-grid-array.sh")
array=${array%%;*}
merge=$(sbatch --parsable --dependency="afterok:$array" --export=ALL "$HERE/slurm-merge.sh")
echo "shards: job array $array (1-$N); merge: job $merge -> $OUT"
