#!/usr/bin/env bash
# Side-by-side cost of `crashrig merge` of two `grid` shards against the shards' work (issue 47,
# item 6; docs/SCALE.md, docs/performance.md "Sharded grid").
#
# Usage: benches/merge_side_by_side.sh SCENARIO SAMPLES REPS BIN_A [BIN_B ...]
# Each binary runs the two shards (`--threads 1 grid SCENARIO --samples SAMPLES --shard i/2`),
# then REPS rounds merge them with every binary in turn (with the heat maps, as `grid` writes
# them). Printed: each shard's `elapsed_s` (the work the merge reports), each merge's wall and
# user+sys time, and per binary the median and range of merge wall / (sum of its shards'
# elapsed_s), and the load average before and after.
set -euo pipefail
S=$1; N=$2; REPS=$3; shift 3
OUT=$(mktemp -d)
echo "loadavg before: $(cat /proc/loadavg)"
i=0
for b in "$@"; do
  i=$((i + 1))
  for k in 1 2; do
    "$b" --threads 1 grid "$S" --samples "$N" --out "$OUT/s$i/$k" --shard "$k/2" >/dev/null 2>&1
  done
done
for r in $(seq 1 "$REPS"); do
  i=0
  for b in "$@"; do
    i=$((i + 1))
    /usr/bin/time -f "%e %U %S" -o "$OUT/t" "$b" merge "$OUT/s$i/1" "$OUT/s$i/2" --out "$OUT/m${i}_$r" >/dev/null 2>&1
    read -r e u s <"$OUT/t"
    echo "merge $r bin$i $e $(echo "$u + $s" | bc)"
  done
done | tee "$OUT/runs"
echo "loadavg after: $(cat /proc/loadavg)"
python3 - "$OUT" "$#" <<'PY'
import sys, json, statistics as st
out, nb = sys.argv[1], int(sys.argv[2])
rows = [l.split() for l in open(f"{out}/runs")]
for i in range(1, nb + 1):
    work = sum(json.load(open(f"{out}/s{i}/{k}/shard.json"))["elapsed_s"] for k in (1, 2))
    walls = [float(e) for _, _, b, e, _ in rows if b == f"bin{i}"]
    cpus = [float(c) for _, _, b, _, c in rows if b == f"bin{i}"]
    r = [w / work for w in walls]
    print(f"bin{i}: shards' elapsed_s sum {work:.3f} s; merge wall median {st.median(walls):.3f} s "
          f"(CPU {st.median(cpus):.3f} s); merge/work median {100*st.median(r):.2f} % "
          f"(range {100*min(r):.2f}-{100*max(r):.2f} %); n={len(r)}")
PY
for i in $(seq 2 "$#"); do
  for f in "$OUT/m1_1"/*; do
    n=$(basename "$f"); [ "$n" = summary.json ] && continue
    cmp -s "$f" "$OUT/m${i}_1/$n" || echo "bin$i: $n differs from bin1's"
  done
done
echo "outputs kept in $OUT"
