#!/usr/bin/env bash
# A blade passage (issue 27: "blades"; tests/data/gmsh/blade_passage.geo): a
# cambered, twisted blade with a sharp trailing edge, hub to shroud, in a
# box one pitch wide.  Two inputs: gmsh's own tetrahedral mesh, and the raw
# constrained Delaunay tetrahedralisation (`tetgen -pQ`) of its surface,
# where every tet has four boundary vertices.  On both, tetopt
# --allow-insert --allow-remove must keep the boundary bit for bit (the
# referee when present, and tetopt's own check), end no lower than the
# default mode, and reach the issue's target: a worst alpha within 10% of
# the bound any boundary-keeping mesh obeys (from the report's diagnosis),
# with no tet below alpha 0.3 and a mean above 0.7.  The former insertion
# (--no-remesh) stays below that on both (0.4468 and 0.2706 against 0.4693
# when this test was written), so the target is the remesher's doing.
# Usage: bash test_blade.sh TETOPT_CLI SOURCE_DIR   (exit 77 = skip)
source "$(dirname "$0")/cli_prologue.sh" "$@" gmsh tetgen
GEO="$SRC/tests/data/gmsh/blade_passage.geo"
ARGS=(-nt 1 -setnumber s 0.1 -setnumber tk 0.05)

gmsh -3 "${ARGS[@]}" -format mesh "$GEO" -o "$T/gmsh.mesh" > "$T/gmsh3.log" 2>&1
# TetGen reads gmsh's surface as STL (its .mesh reader stops on this one).
gmsh -2 "${ARGS[@]}" -format stl "$GEO" -o "$T/surf.stl" > "$T/gmsh2.log" 2>&1
tetgen -pQ "$T/surf.stl" > "$T/tetgen.log" 2>&1
"$CLI" convert "$T/surf.1.node" "$T/raw.mesh" > /dev/null

for m in gmsh raw; do
  "$CLI" improve "$T/$m.mesh" -o "$T/${m}_def.mesh" --report "$T/${m}_def.json" -q
  "$CLI" improve "$T/$m.mesh" -o "$T/${m}_ins.mesh" --report "$T/${m}_ins.json" -q --allow-insert --allow-remove
  for x in def ins; do referee "$T/$m.mesh" "$T/${m}_$x.mesh" "${m}_$x"; done
done
[ $have_ref = 1 ] && echo "referee: every output keeps the boundary, no inverted tet, volumes kept"

"$PY" - "$T" <<'PYEOF'
import json, sys
d = sys.argv[1]
def fail(msg): print("FAIL:", msg); sys.exit(1)
for m in ("gmsh", "raw"):
    de, ins = (json.load(open(f"{d}/{m}_{x}.json")) for x in ("def", "ins"))
    for x, r in (("def", de), ("ins", ins)):
        b = r["boundary_unchanged"]
        if not (b["checked"] and b["ok"]): fail(f"{m} {x}: boundary_unchanged {b}")
    bound = ins["diagnosis"]["bound"]["alpha_upper_bound"]
    a, a0 = ins["after"], de["after"]
    print("%-4s input %6d tets worst %.4f | default %.4f | insertion %6d tets worst %.4f mean %.4f below 0.3: %d | bound %.4f (%.0f%%)" % (
        m, ins["before"]["tets"], ins["before"]["alpha_worst"], a0["alpha_worst"], a["tets"], a["alpha_worst"],
        a["alpha_mean"], a["alpha_below_0.3"], bound, 100 * a["alpha_worst"] / bound))
    if ins["operations"]["insertions"] <= 0: fail(f"{m}: nothing inserted")
    if not a["alpha_worst"] >= a0["alpha_worst"]: fail(f"{m}: insertion ends below the default mode")
    if not a["alpha_worst"] >= 0.9 * bound: fail(f"{m}: worst alpha {a['alpha_worst']:.4f} < 0.9 x the bound {bound:.4f}")
    if not a["alpha_worst"] <= bound + 1e-9: fail(f"{m}: worst alpha above the bound")
    if a["alpha_below_0.3"] != 0: fail(f"{m}: {a['alpha_below_0.3']} tets below alpha 0.3")
    if not a["alpha_mean"] > 0.7: fail(f"{m}: mean alpha {a['alpha_mean']:.4f} <= 0.7")
print("ok")
PYEOF
