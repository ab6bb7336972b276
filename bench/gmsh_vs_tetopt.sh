#!/bin/bash
# Gmsh's optimizer against tetopt on one mesh, alternated REPS times, like
# for like: Gmsh's optimize call and its whole process (python3-gmsh:
# gmsh.open, optimize("", force=True), gmsh.write .mesh) against tetopt's
# improve call (the report's seconds.total) and its whole process, at
# --threads 1 and 2.  Prints medians and the worst alpha of each output
# (tetopt's own `quality`, the same measure for both).
# usage: bench/gmsh_vs_tetopt.sh TETOPT MESH [REPS]
set -u
T=$1; MESH=$2; REPS=${3:-5}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
cat > "$W/g.py" <<'PY'
import sys, time, gmsh
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(sys.argv[1])
t0 = time.perf_counter()
gmsh.model.mesh.optimize("", force=True)
print("call", time.perf_counter() - t0)
gmsh.write(sys.argv[2])
gmsh.finalize()
PY
for i in $(seq "$REPS"); do
  s=$( { /usr/bin/time -f "whole %e" /usr/bin/python3 "$W/g.py" "$MESH" "$W/g.mesh"; } 2>&1 )
  echo "gmsh-call $(echo "$s" | awk '/^call/ {print $2}')"
  echo "gmsh-whole $(echo "$s" | awk '/^whole/ {print $2}')"
  for t in 1 2; do
    s=$( { /usr/bin/time -f "%e" "$T" improve "$MESH" -o "$W/t.mesh" --threads $t -q --report "$W/r.json"; } 2>&1 | tail -1)
    echo "tetopt-t$t-whole $s"
    echo "tetopt-t$t-call $(/usr/bin/python3 -c "import json; print(json.load(open('$W/r.json'))['seconds']['total'])")"
  done
done > "$W/times"
/usr/bin/python3 - "$W/times" <<'PY'
import sys, statistics as st, collections
d = collections.defaultdict(list)
for l in open(sys.argv[1]):
    k, v = l.split(); d[k].append(float(v))
for k in sorted(d):
    print("%-18s median %.3f  min %.3f  n %d" % (k, st.median(d[k]), min(d[k]), len(d[k])))
PY
for f in "$W/g.mesh" "$W/t.mesh"; do
  echo "$(basename "$f"): worst alpha $("$T" quality "$f" --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["alpha_worst"])')"
done
