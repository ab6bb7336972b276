#!/bin/bash
# The --allow-insert / --allow-remove table of docs/results.md: every mesh
# improved three ways, judged by ../shared/tools/meshcheck.py.
# usage: bench/vertex_set_table.sh [TETOPT] [RAND_MESH]
#   RAND_MESH: made by /usr/bin/python3 ../shared/tools/randmesh.py rand_0.mesh 5086 0 0
set -u
cd "$(dirname "$0")/.."
T=${1:-build/tetopt}; RAND=${2:-}
S=../shared/meshes; MC=../shared/tools/meshcheck.py
[ -f "$MC" ] || { echo "needs ../shared (meshes and meshcheck.py)"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for f in out/demo/impeller.mesh $S/tire/tire.vtk $S/cube-clip-5/cube-clip-5.vtk $S/flat-tet-sphere/flat-tet-sphere.vtk \
         $S/cub_wedge_like/cub_wedge_like.vtk $S/hinge_small/hinge_small.mesh $RAND; do
  [ -f "$f" ] || continue
  n=$(basename "$f"); ext=${n##*.}
  for o in "--allow-insert" "--allow-insert --allow-remove" "--allow-remove"; do
    out="$W/out.$ext"
    "$T" improve "$f" -o "$out" $o --threads 1 --report "$W/r.json" -q || { echo "| $n | $o | failed (exit $?) |"; continue; }
    v=$(/usr/bin/python3 "$MC" compare "$f" "$out" 2>&1 | tail -1)
    /usr/bin/python3 - "$W/r.json" "$n" "$o" "$v" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); a = r["after"]; o = r["operations"]
print("| %s | %s | %.4f | %.2f°–%.2f° | %d → %d | %d | %d | %.2f | %s |" % (
    sys.argv[2], sys.argv[3], a["alpha_worst"], a["dihedral_min"], a["dihedral_max"], r["before"]["tets"],
    a["tets"], o["insertions"], o["vertex_removals"], r["seconds_end_to_end"], sys.argv[4]))
PY
  done
done
