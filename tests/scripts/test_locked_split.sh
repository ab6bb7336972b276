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

reaches "$T/ins.json" 0.545
echo ok
