#!/usr/bin/env bash
# A worst tet with four constrained vertices, split (insert.cpp,
# split_locked_worst; improve.cpp, the rounds once more).  Raw `tetgen -pQ`
# output of tests/data/gmsh/crank.geo at s = 0.03 (61k tets, no interior
# vertex): insertion mode's rounds lifted the tets around the mesh to just
# above one tet on a web's face with its apex on the web's rim, all four of
# its vertices on the boundary, and stopped at 0.5376.  Splitting one of its
# edges on no constrained face gives it a free vertex, and the rounds once
# more then reach 0.5507.  The run must say it split a locked tet, keep the
# boundary bit for bit (the referee when present, and tetopt's own check),
# stay at or below the bound and reach 0.545 (the build before this failed:
# 0.5376).
# Usage: bash test_locked_split.sh TETOPT_CLI SOURCE_DIR   (exit 77 = skip)
source "$(dirname "$0")/cli_prologue.sh" "$@" gmsh tetgen

gmsh -2 -nt 1 -setnumber s 0.03 -format stl "$SRC/tests/data/gmsh/crank.geo" -o "$T/crank.stl" > "$T/gmsh.log" 2>&1
tetgen -pQ "$T/crank.stl" > "$T/tetgen.log" 2>&1
"$CLI" convert "$T/crank.1.node" "$T/raw.mesh" > /dev/null
"$CLI" improve "$T/raw.mesh" -o "$T/ins.mesh" --report "$T/ins.json" -v --allow-insert --allow-remove > "$T/ins.log" 2>&1
grep -q "^locked worst tets split: [1-9]" "$T/ins.log" || { grep -E "^(rounds again|locked)" "$T/ins.log"; echo "FAIL: no locked worst tet was split"; exit 1; }
referee "$T/raw.mesh" "$T/ins.mesh" ins
[ "$have_ref" = 1 ] && echo "referee: the output keeps the boundary, no inverted tet, volumes kept"

"$PY" - "$T" <<'PYEOF'
import json, sys
d = sys.argv[1]
def fail(msg): print("FAIL:", msg); sys.exit(1)
ins = json.load(open(f"{d}/ins.json"))
b = ins["boundary_unchanged"]
if not (b["checked"] and b["ok"]): fail(f"boundary_unchanged {b}")
bound = ins["diagnosis"]["bound"]["alpha_upper_bound"]
a = ins["after"]
print("input %d tets worst %.4f | insertion %d tets worst %.4f mean %.4f | bound %.4f (%.0f%%)" % (
    ins["before"]["tets"], ins["before"]["alpha_worst"], a["tets"], a["alpha_worst"], a["alpha_mean"], bound,
    100 * a["alpha_worst"] / bound))
if not a["alpha_worst"] >= 0.545: fail(f"worst alpha {a['alpha_worst']:.4f} < 0.545")
if not a["alpha_worst"] <= bound + 1e-9: fail("worst alpha above the bound")
print("ok")
PYEOF
