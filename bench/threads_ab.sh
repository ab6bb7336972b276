#!/bin/bash
# Thread scaling of two builds in one run (the tables of docs/benchmarks.md):
# the demo impeller (whole process and improve call) and `tetopt quality` on
# the 3.07M-tet box as .meshb and ASCII .mesh, at --threads 1 and 2, pinned to
# two cores, alternating the binaries; prints medians.
# usage: bench/threads_ab.sh OLD_TETOPT NEW_TETOPT [REPS]
#   needs out/demo/impeller.mesh (make demo) and out/bench/box80.meshb (make bench)
set -u
cd "$(dirname "$0")/.."
OLD=$1; NEW=$2; REPS=${3:-5}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
"$NEW" convert out/bench/box80.meshb "$W/box80.mesh" > /dev/null || exit 1
for i in $(seq "$REPS"); do
  for b in "$OLD" "$NEW"; do
    tag=$([ "$b" = "$OLD" ] && echo old || echo new)
    for t in 1 2; do
      s=$( { /usr/bin/time -f "%e" taskset -c 0,1 "$b" improve out/demo/impeller.mesh -o "$W/o.mesh" --threads $t -q --report "$W/r.json"; } 2>&1 )
      echo "impeller-whole $tag t$t $s"
      echo "impeller-improve $tag t$t $(/usr/bin/python3 -c "import json; print(json.load(open('$W/r.json'))['seconds']['total'])")"
      for q in out/bench/box80.meshb "$W/box80.mesh"; do
        s=$( { /usr/bin/time -f "%e" taskset -c 0,1 "$b" quality "$q" --threads $t --json > /dev/null; } 2>&1 | tail -1)
        echo "quality-3M-${q##*.} $tag t$t $s"
      done
    done
  done
done | /usr/bin/python3 -c "
import sys, statistics as st, collections
d = collections.defaultdict(list)
for l in sys.stdin:
    k, b, t, w = l.split(); d[(k, b, t)].append(float(w))
for k, v in sorted(d.items()):
    print('%-18s %s %s median %.3f min %.3f n %d' % (k[0], k[1], k[2], st.median(v), min(v), len(v)))
"
