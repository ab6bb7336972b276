#!/usr/bin/env bash
# The remesher's size field near a feature 1e4 times finer than the part
# (tests/data/gmsh/tiny_hole.geo: a unit box with a spherical hole of radius
# 1e-4), as gmsh meshes it and as raw `tetgen -pQ` output of its surface.
# Each new vertex of the Delaunay refinement once took the mean size of its
# tet's vertices, so the sphere's size spread into the volume: more than
# 3 million tets and no end in 300 s.  Now the size is read from the field
# as the pass found it (src/insert.cpp, refine_pass): tetopt --allow-insert
# --allow-remove must end (each run is given 240 s), keep the boundary (the
# referee when present, and the run's own check), end at a worst alpha no
# lower than the default mode's and a mean above 0.7, and make a graded
# mesh: fewer than 200,000 tets, where a size growing by 0.26 per unit
# length from the sphere (kWallGradation) would take about 40,000.
# Usage: bash test_tiny_feature.sh TETOPT_CLI SOURCE_DIR   (exit 77 = skip)
source "$(dirname "$0")/cli_prologue.sh" "$@" gmsh tetgen

G="$SRC/tests/data/gmsh/tiny_hole.geo"
gmsh -3 -nt 1 -format mesh "$G" -o "$T/gm.mesh" > "$T/gmsh3.log" 2>&1
gmsh -2 -nt 1 -format mesh "$G" -o "$T/surf.mesh" > "$T/gmsh2.log" 2>&1
"$PY" "$SRC/tests/scripts/mesh_to_smesh.py" "$T/surf.mesh" "$T/surf.smesh" 0.5,0.5,0.5 > /dev/null
tetgen -pQ "$T/surf.smesh" > "$T/tetgen.log" 2>&1
"$CLI" convert "$T/surf.1.node" "$T/tg.mesh" > /dev/null
for x in gm tg; do
  "$CLI" improve "$T/$x.mesh" -o "$T/${x}_def.mesh" --report "$T/${x}_def.json" -q
  timeout 240 "$CLI" improve "$T/$x.mesh" -o "$T/${x}_ins.mesh" --report "$T/${x}_ins.json" -q \
    --allow-insert --allow-remove || { echo "FAIL: $x: the remesher did not end in 240 s (or failed)"; exit 1; }
  referee "$T/$x.mesh" "$T/${x}_ins.mesh" "$x"
done

"$PY" - "$T" <<'PYEOF'
import json, sys
d = sys.argv[1]
def fail(msg): print("FAIL:", msg); sys.exit(1)
for x in ("gm", "tg"):
    de, ins = (json.load(open(f"{d}/{x}_{k}.json")) for k in ("def", "ins"))
    b = ins["boundary_unchanged"]
    if not (b["checked"] and b["ok"]): fail(f"{x}: boundary_unchanged {b}")
    a = ins["after"]
    print("%s: input %d tets worst %.4f | default worst %.4f | insertion %d tets worst %.4f mean %.4f" % (
        x, ins["before"]["tets"], ins["before"]["alpha_worst"], de["after"]["alpha_worst"], a["tets"],
        a["alpha_worst"], a["alpha_mean"]))
    if not a["tets"] < 200000: fail(f"{x}: {a['tets']} tets: the size field did not grade away from the hole")
    if not a["alpha_worst"] >= de["after"]["alpha_worst"]: fail(f"{x}: worst alpha below the default mode's")
    if not a["alpha_mean"] > 0.7: fail(f"{x}: mean alpha {a['alpha_mean']:.4f} <= 0.7")
print("ok")
PYEOF
