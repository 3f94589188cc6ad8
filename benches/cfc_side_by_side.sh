#!/usr/bin/env bash
# Side-by-side cost of `measure --cfc 180` against the same `measure` without it (issue 47, item 6).
#
# Usage: benches/cfc_side_by_side.sh SEQUENCE_DIR REPS SAMPLES BIN_A [BIN_B ...]
#   SEQUENCE_DIR  from `fixtures/gen/measure_sequence.py --out DIR --epochs 1000 --markers 20`
#   REPS          rounds; in each round every binary runs without and with `--cfc 180`, interleaved
#   SAMPLES       --samples (the issue's figure: 2000)
# Prints one line per run (binary, variant, wall s, user+sys s) and, per binary, the median and
# the range of the per-round ratios cfc/base (wall; CPU) and the load average before and after.
# THREADS=n in the environment adds `--threads n`.
set -euo pipefail
S=$1; REPS=$2; N=$3; shift 3
OUT=$(mktemp -d)
C=(measure "$S/model" --camera-a cam_out/ --camera-b 2 --camera-c 3 --link "$S/link.json"
   --tie "$S/tie.json" --observations "$S/observations.csv" --a-covariance "$S/a_covariance.json"
   --mm-per-unit 1000 --pixel-sigma-px 0.1 --frame-rate-hz 20000 --samples "$N" --no-plots ${THREADS:+--threads "$THREADS"})
echo "loadavg before: $(cat /proc/loadavg)"
for r in $(seq 1 "$REPS"); do
  i=0
  for b in "$@"; do
    i=$((i + 1))
    for v in base cfc; do
      extra=(); [ "$v" = cfc ] && extra=(--cfc 180)
      /usr/bin/time -f "%e %U %S" -o "$OUT/t" "$b" "${C[@]}" "${extra[@]}" --out "$OUT/o_${i}_$v" >/dev/null 2>&1
      read -r e u s <"$OUT/t"
      echo "run $r bin$i $v $e $(echo "$u + $s" | bc)"
    done
  done
done | tee "$OUT/runs"
echo "loadavg after: $(cat /proc/loadavg)"
python3 - "$OUT/runs" "$#" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
nb = int(sys.argv[2])
for i in range(1, nb + 1):
    t = {}
    for _, r, b, v, e, c in rows:
        if b == f"bin{i}":
            t.setdefault(r, {})[v] = (float(e), float(c))
    w = [x["cfc"][0] / x["base"][0] for x in t.values()]
    c = [x["cfc"][1] / x["base"][1] for x in t.values()]
    print(f"bin{i}: cfc/base wall median {st.median(w):.3f} (range {min(w):.3f}-{max(w):.3f}); "
          f"CPU median {st.median(c):.3f} (range {min(c):.3f}-{max(c):.3f}); n={len(w)}")
PY
echo "outputs kept in $OUT"
