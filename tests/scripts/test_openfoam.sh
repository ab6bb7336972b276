#!/usr/bin/env bash
# OpenFOAM polyMesh through the command line (issue 28), checked by
# OpenFOAM itself: a two-region box made here (gmsh, from a .geo written
# below), turned into a case by gmshToFoam in ASCII and in binary, improved
# by `tetopt improve case/constant/polyMesh -o out/constant/polyMesh`, and
# then:
#   - checkMesh passes on every output ("Mesh OK.");
#   - checkMesh lists the same patches with the same face counts before and
#     after;
#   - every patch's faces come back in the same order at the same
#     coordinates, bit for bit (parsed as doubles), cellZones and faceZones
#     keep their names;
#   - a Gmsh file converted to a polyMesh keeps its physical names as patch
#     and cellZone names, and checkMesh accepts it.
# usage: test_openfoam.sh TETOPT SOURCE_DIR   (exit 77: OpenFOAM or gmsh absent)
set -u
T=$1
PY=/usr/bin/python3
command -v checkMesh > /dev/null && command -v gmshToFoam > /dev/null && [ -f /usr/share/openfoam/etc/bashrc ] ||
  { echo "skip: OpenFOAM's checkMesh/gmshToFoam not installed (Debian: openfoam)"; exit 77; }
command -v gmsh > /dev/null || { echo "skip: gmsh not installed"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

# A case folder with what checkMesh needs (system/controlDict, fvSchemes, fvSolution).
new_case() {
  mkdir -p "$1/system"
  cat > "$1/system/controlDict" <<EOF
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application checkMesh; startFrom startTime; startTime 0; stopAt endTime; endTime 1; deltaT 1;
writeControl timeStep; writeInterval 1; writeFormat ${2:-ascii}; writePrecision 17;
EOF
  cat > "$1/system/fvSchemes" <<'EOF'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes { default steadyState; } gradSchemes { default Gauss linear; } divSchemes { default none; }
laplacianSchemes { default Gauss linear corrected; } interpolationSchemes { default linear; } snGradSchemes { default corrected; }
EOF
  echo 'FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }' > "$1/system/fvSolution"
}
foam() { ( set +u; export WM_PROJECT_DIR=/usr/share/openfoam; . /usr/share/openfoam/etc/bashrc > /dev/null 2>&1; "$@" ) ; }
# "name faces" for each patch checkMesh lists.
patch_counts() { sed -n '/Checking patch topology/,/^$/p' "$1" | awk 'NR > 2 && NF >= 2 { print $1, $2 }'; }

cat > "$W/box.geo" <<'EOF'
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Box(2) = {1, 0, 0, 1, 1, 1};
Coherence;
Physical Volume("fluid") = {1};
Physical Volume("solid") = {2};
Physical Surface("inlet") = {1};
Physical Surface("walls") = {2, 3, 4, 5, 7, 8, 9, 10};
Physical Surface("outlet") = {11};
Mesh.CharacteristicLengthMax = 0.4;
EOF
gmsh -3 "$W/box.geo" -format msh2 -o "$W/box.msh" > "$W/gmsh.log" 2>&1 || { echo "FAIL gmsh"; tail -5 "$W/gmsh.log"; exit 1; }

# The checks in Python (standard library only): patches face by face at
# their coordinates, zone names; physical names of a .msh.
cat > "$W/patches.py" <<'EOF'
import re, sys
def body(path):
    t = open(path, "rb").read().decode("latin-1")
    t = re.sub(r"/\*.*?\*/", "", t, flags=re.S)
    t = re.sub(r"//[^\n]*", "", t)
    return t[t.index("}", t.index("FoamFile")) + 1:]
def patches(d):
    pts = [tuple(float(x) for x in m.split()) for m in re.findall(r"\(([^()]*)\)", body(d + "/points"))[0:]]
    faces = [tuple(int(x) for x in m.split()) for m in re.findall(r"3\(([^()]*)\)", body(d + "/faces"))]
    out = {}
    for name, dic in re.findall(r"(\w+)\s*\{([^}]*)\}", body(d + "/boundary")):
        n = int(re.search(r"nFaces\s+(\d+)", dic).group(1)); s = int(re.search(r"startFace\s+(\d+)", dic).group(1))
        t = re.search(r"type\s+(\w+)", dic).group(1)
        out[name] = (t, [tuple(pts[v] for v in faces[f]) for f in range(s, s + n)])
    return out
def zone_names(d, f):
    return re.findall(r"(\w+)\s*\{\s*type", body(d + "/" + f))
a, b = patches(sys.argv[1]), patches(sys.argv[2])
assert list(a) == list(b), (list(a), list(b))
for k in a:
    assert a[k] == b[k], k
orig = sys.argv[3]
if open(orig + "/points", "rb").read().find(b"format      ascii") >= 0:
    o = patches(orig)   # gmshToFoam's own ASCII files, read here
    assert list(o) == list(a), (list(o), list(a))
    for k in o:
        assert o[k] == a[k], k
for f in ("cellZones", "faceZones"):
    assert zone_names(orig, f) == zone_names(sys.argv[2], f), f
print("     %d patches, %d faces, zones %s" % (len(a), sum(len(v[1]) for v in a.values()), zone_names(sys.argv[2], "cellZones")))
EOF
cat > "$W/names.py" <<'EOF'
import sys
def names(p):
    t = open(p).read(); s = t.index("$PhysicalNames"); e = t.index("$EndPhysicalNames")
    return set(l.strip() for l in t[s:e].splitlines()[2:])
a, b = names(sys.argv[1]), names(sys.argv[2])
assert a and a <= b, (a, b)
print("     names kept:", sorted(a))
EOF

for fmt in ascii binary; do
  C="$W/in-$fmt"; O="$W/out-$fmt"
  new_case "$C" "$fmt"; new_case "$O"
  foam gmshToFoam "$W/box.msh" -case "$C" > "$C/g.log" 2>&1
  check "$fmt: gmshToFoam made a polyMesh" '[ -f "$C/constant/polyMesh/owner" ]'
  foam checkMesh -case "$C" > "$C/check.log" 2>&1
  opt=""; [ "$fmt" = binary ] && opt=--binary
  "$T" improve "$C/constant/polyMesh" -o "$O/constant/polyMesh" $opt -q --report "$W/r-$fmt.json"; rc=$?
  check "$fmt: improve case/constant/polyMesh -o out/constant/polyMesh (exit $rc)" '[ $rc -eq 0 ]'
  check "$fmt: improve's own check says the boundary is unchanged" '$PY -c "import json,sys; b=json.load(open(sys.argv[1]))[\"boundary_unchanged\"]; sys.exit(0 if b[\"checked\"] and b[\"ok\"] else 1)" "$W/r-$fmt.json"'
  [ "$fmt" = binary ] && check "binary: the output is binary" 'grep -aq "format      binary" "$O/constant/polyMesh/faces"'
  foam checkMesh -case "$O" > "$O/check.log" 2>&1; rc=$?
  check "$fmt: checkMesh on tetopt's output: Mesh OK (exit $rc)" '[ $rc -eq 0 ] && grep -q "^Mesh OK." "$O/check.log"'
  patch_counts "$C/check.log" > "$W/p-in"; patch_counts "$O/check.log" > "$W/p-out"
  echo "     patches before: $(tr '\n' ' ' < "$W/p-in")"
  echo "     patches after:  $(tr '\n' ' ' < "$W/p-out")"
  check "$fmt: checkMesh lists the same patches with the same face counts" '[ -s "$W/p-in" ] && cmp -s "$W/p-in" "$W/p-out"'
  # The patches face by face, at their coordinates, through tetopt's ASCII
  # copies of both (the binary input is read by tetopt; the ASCII one by
  # this script's own parser as well, so that tetopt does not judge itself alone).
  "$T" convert "$C/constant/polyMesh" "$W/a-$fmt/constant/polyMesh" 2> /dev/null
  "$T" convert "$O/constant/polyMesh" "$W/b-$fmt/constant/polyMesh" 2> /dev/null
  check "$fmt: every patch's faces, in order, at bit-identical coordinates; zones keep their names" \
    '$PY "$W/patches.py" "$W/a-$fmt/constant/polyMesh" "$W/b-$fmt/constant/polyMesh" "$C/constant/polyMesh"'
done

# Gmsh -> polyMesh: physical names become patch and cellZone names.
G="$W/from-gmsh"; new_case "$G"
"$T" convert "$W/box.msh" "$G/constant/polyMesh" 2> /dev/null; rc=$?
check "convert box.msh case/constant/polyMesh (exit $rc)" '[ $rc -eq 0 ]'
foam checkMesh -case "$G" > "$G/check.log" 2>&1; rc=$?
check "checkMesh on the converted Gmsh mesh: Mesh OK" '[ $rc -eq 0 ] && grep -q "^Mesh OK." "$G/check.log"'
check "the Gmsh names are the patch and cellZone names" \
  'for n in inlet walls outlet; do grep -q "^    $n$" "$G/constant/polyMesh/boundary" || exit 1; done; grep -q "^fluid$" "$G/constant/polyMesh/cellZones" && grep -q "^solid$" "$G/constant/polyMesh/cellZones"'
# And back: the refs and names survive polyMesh -> Gmsh.
"$T" convert "$G/constant/polyMesh" "$W/back.msh" 2> /dev/null
check "polyMesh -> .msh keeps the physical names and the refs" \
  '$PY "$W/names.py" "$W/box.msh" "$W/back.msh"'

# --write-boundary: a mesh that lists no triangle (here a generated
# two-region box with its Triangles section taken out) gets its boundary and
# interface as named groups, so gmshToFoam makes a patch per region's
# boundary and a faceZone for the interface (without it: one defaultFaces
# patch and no faceZone, as the issue found).
"$T" generate "$W/two.mesh" --cells 3 3 3 --regions 2 > /dev/null
$PY - "$W/two.mesh" <<'PYEOF'
import re, sys
t = open(sys.argv[1]).read()
open(sys.argv[1], "w").write(re.sub(r"\nTriangles\n\d+\n(?:[^A-Za-z\n][^\n]*\n)*", "\n", t))
PYEOF
check "the test mesh lists no triangle" '! grep -q "^Triangles" "$W/two.mesh"'
B="$W/wb"; new_case "$B"
"$T" convert "$W/two.mesh" "$W/wb.msh" --msh-version 22 --write-boundary 2> /dev/null
foam gmshToFoam "$W/wb.msh" -case "$B" > "$B/g.log" 2>&1
foam checkMesh -case "$B" > "$B/check.log" 2>&1; rc=$?
check "--write-boundary -> gmshToFoam: patches boundary_1, boundary_2, faceZone interface_1_2, Mesh OK" \
  '[ $rc -eq 0 ] && grep -q "^Mesh OK." "$B/check.log" && grep -q "boundary_1" "$B/constant/polyMesh/boundary" && grep -q "boundary_2" "$B/constant/polyMesh/boundary" && ! grep -q defaultFaces "$B/constant/polyMesh/boundary" && grep -q "^interface_1_2" "$B/constant/polyMesh/faceZones"'
exit $fail
