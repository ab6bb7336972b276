#!/usr/bin/env bash
# Abaqus / CalculiX .inp through the command line (issue 28), checked by
# Debian's CalculiX (ccx): a unit cube made by gmsh (.geo below) with a
# volume group and two surface groups, improved by
# `tetopt improve cube.msh -o cube.inp` and read back, then a static job on
# it: the cube's x = 0 face held in x (three nodes more against rigid
# motion), a pressure of 1 on the element surface "loaded" (x = 1).  Linear
# tets reproduce the exact, uniform strain, so every node of x = 1 must move
# by -p/E in x on the unimproved and on the improved mesh alike (the patch
# test; a surface written on the wrong faces moves them otherwise).
# Also: .inp -> tetopt -> .inp keeps sets, surfaces and coordinates.
# usage: test_abaqus.sh TETOPT SOURCE_DIR   (exit 77: ccx or gmsh absent)
set -u
T=$1
PY=/usr/bin/python3
command -v ccx > /dev/null || { echo "skip: ccx not installed (Debian: calculix-ccx)"; exit 77; }
command -v gmsh > /dev/null || { echo "skip: gmsh not installed"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

cat > "$W/cube.geo" <<'EOF'
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Physical Volume("solid") = {1};
Physical Surface("fixed") = {1};
Physical Surface("loaded") = {2};
Physical Surface("sides") = {3, 4, 5, 6};
Mesh.CharacteristicLengthMax = 0.3;
EOF
gmsh -3 "$W/cube.geo" -o "$W/cube.msh" > "$W/gmsh.log" 2>&1 || { echo "FAIL gmsh"; exit 1; }

# The job around a mesh file: node sets from the coordinates (this script's
# own reading of the .inp), material, section, constraints, pressure.
cat > "$W/job.py" <<'EOF'
import re, sys
mesh, job = sys.argv[1], sys.argv[2]
text = open(mesh).read()
block = re.search(r"^\*NODE[^\n]*\n(.*?)^\*", text, re.S | re.M).group(1)
nodes = {}
for line in block.splitlines():
    f = [x.strip() for x in line.split(",")]
    nodes[int(f[0])] = tuple(float(x) for x in f[1:4])
x0 = [n for n, p in nodes.items() if p[0] == 0.0]
x1 = [n for n, p in nodes.items() if p[0] == 1.0]
def at(p):
    return [n for n, q in nodes.items() if q == p][0]
def nset(name, ids):
    return "*NSET, NSET=%s\n" % name + "".join("%d,\n" % i for i in ids)
open(job, "w").write(
    "*INCLUDE, INPUT=%s\n" % mesh + nset("XZERO", x0) + nset("XONE", x1) +
    "*MATERIAL, NAME=STEEL\n*ELASTIC\n210000., 0.3\n*SOLID SECTION, ELSET=solid, MATERIAL=STEEL\n"
    "*STEP\n*STATIC\n*BOUNDARY\nXZERO, 1, 1\n%d, 2, 3\n%d, 3, 3\n%d, 2, 2\n" % (at((0., 0., 0.)), at((0., 1., 0.)), at((0., 0., 1.))) +
    "*DSLOAD\nloaded, P, 1.\n*NODE PRINT, NSET=XONE\nU\n*END STEP\n")
print(len(x0), len(x1))
EOF
cat > "$W/ux.py" <<'EOF'
# Every x displacement of the x = 1 nodes in ccx's .dat: -p/E = -1/210000.
import sys
vals = []
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) == 4:
        try:
            vals.append([float(x) for x in f[1:]])
        except ValueError:
            pass
assert vals, "no displacements in the .dat"
want = -1.0 / 210000.0
worst = max(abs(v[0] - want) for v in vals)
print("     %d nodes, u_x %.9g .. %.9g (exact %.9g)" % (len(vals), min(v[0] for v in vals), max(v[0] for v in vals), want))
assert worst < 1e-6 * abs(want), worst
EOF

run_ccx() {  # DIR MESH.inp: writes DIR/job.inp, runs ccx there
  cp "$2" "$1/mesh.inp"
  ( cd "$1" && $PY "$W/job.py" mesh.inp job.inp > sets.txt && ccx -i job > ccx.log 2>&1 )
}

mkdir -p "$W/before" "$W/after"
"$T" convert "$W/cube.msh" "$W/before.inp" 2> "$W/conv.err"; rc=$?
check "convert cube.msh before.inp (exit $rc)" '[ $rc -eq 0 ]'
"$T" improve "$W/cube.msh" -o "$W/after.inp" -q --report "$W/r.json"; rc=$?
check "improve cube.msh -o after.inp (exit $rc)" '[ $rc -eq 0 ]'
check "improve's own check says the boundary is unchanged" \
  '$PY -c "import json,sys; b=json.load(open(sys.argv[1]))[\"boundary_unchanged\"]; sys.exit(0 if b[\"checked\"] and b[\"ok\"] else 1)" "$W/r.json"'
check "the .inp has C3D4 elements, the element set and both surfaces" \
  'grep -q "^\*ELEMENT, TYPE=C3D4" "$W/after.inp" && grep -q "^\*ELSET, ELSET=solid" "$W/after.inp" && grep -q "^\*SURFACE, NAME=loaded, TYPE=ELEMENT" "$W/after.inp" && grep -q "^\*SURFACE, NAME=fixed, TYPE=ELEMENT" "$W/after.inp"'
for d in before after; do
  run_ccx "$W/$d" "$W/$d.inp"; rc=$?
  check "$d: ccx runs the static job (exit $rc)" '[ $rc -eq 0 ] && grep -q "Job finished" "$W/$d/ccx.log"'
  check "$d: every node of x = 1 moves by -p/E (patch test)" '$PY "$W/ux.py" "$W/$d/job.dat"'
done
# .inp -> .inp: sets, surfaces and coordinates come back.
"$T" convert "$W/after.inp" "$W/again.inp" 2> /dev/null
check "after.inp read and written again: the same file" 'cmp -s "$W/after.inp" "$W/again.inp"'
"$T" convert "$W/after.inp" "$W/back.msh" 2> /dev/null
check "after.inp -> .msh keeps the group names" \
  'grep -q "\"solid\"" "$W/back.msh" && grep -q "\"loaded\"" "$W/back.msh" && grep -q "\"fixed\"" "$W/back.msh"'
exit $fail
