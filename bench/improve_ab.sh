#!/bin/bash
# A/B of two tetopt builds on one mesh: `improve` at --threads 1 and 2, pinned
# to cores 0,1, the builds alternated REPS times; prints medians and minima of
# the whole process (wall) and of the improve call (the report's
# seconds.total), and the 1 -> 2 thread ratios.  (bench/threads_ab.sh also
# times `quality` on the 3M box; this one takes any mesh.)  EXTRA: more
# improve options for both builds (EXTRA="--allow-insert --allow-remove").
# usage: bench/improve_ab.sh OLD_TETOPT NEW_TETOPT REPS MESH
set -u
OLD=$1; NEW=$2; REPS=$3; MESH=$4
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
ext=${MESH##*.}
for i in $(seq "$REPS"); do for tag in old new; do
  b=$([ "$tag" = old ] && echo "$OLD" || echo "$NEW")  # one binary may be both sides
  for t in 1 2; do
    s=$( { /usr/bin/time -f "%e" taskset -c 0,1 "$b" improve "$MESH" -o "$W/o.$ext" --threads $t -q --report "$W/r.json" ${EXTRA:-}; } 2>&1 | tail -1)
    echo "whole $tag t$t $s"
    echo "improve $tag t$t $(/usr/bin/python3 -c "import json; print(json.load(open('$W/r.json'))['seconds']['total'])")"
  done
done; done | /usr/bin/python3 -c "
import sys, statistics as st, collections
d = collections.defaultdict(list)
for l in sys.stdin:
    k, b, t, w = l.split(); d[(k, b, t)].append(float(w))
for k, v in sorted(d.items()):
    print('%-8s %s %s median %.3f min %.3f n %d' % (k[0], k[1], k[2], st.median(v), min(v), len(v)))
for k in ('whole', 'improve'):
    for b in ('old', 'new'):
        t1, t2 = d[(k, b, 't1')], d[(k, b, 't2')]
        print(k, b, 't1/t2 median ratio %.3f  min ratio %.3f' % (st.median(t1) / st.median(t2), min(t1) / min(t2)))
"
