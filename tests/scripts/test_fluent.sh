#!/usr/bin/env bash
# Fluent .msh through the command line (issue 28), checked by OpenFOAM's
# Fluent converters: a two-region box made here (gmsh, .geo below) becomes an
# OpenFOAM case (gmshToFoam), a Fluent mesh (foamMeshToFluent: a Fluent file
# tetopt did not write), is improved by `tetopt improve in.msh -o out.msh`
# (read as Fluent by its content, written as Fluent since it came as one),
# ASCII and --binary (the binary one read back by tetopt: OpenFOAM's
# converters do not read binary sections), then:
#   - fluent3DMeshToFoam reads tetopt's output and checkMesh says "Mesh OK.";
#   - checkMesh lists the same patches with the same face counts as on the
#     case the Fluent file came from;
#   - every boundary zone's faces come back in order at bit-identical
#     coordinates, with the zones' names and types (this script's own
#     parser of the ASCII files);
#   - a Gmsh .msh and a Fluent .msh are told apart by content.
# usage: test_fluent.sh TETOPT SOURCE_DIR   (exit 77: OpenFOAM or gmsh absent)
set -u
T=$1
PY=/usr/bin/python3
for t in checkMesh gmshToFoam foamMeshToFluent fluent3DMeshToFoam gmsh; do
  command -v $t > /dev/null || { echo "skip: $t not installed (Debian: openfoam, gmsh)"; exit 77; }
done
[ -f /usr/share/openfoam/etc/bashrc ] || { echo "skip: no /usr/share/openfoam/etc/bashrc"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }
new_case() {
  mkdir -p "$1/system"
  cat > "$1/system/controlDict" <<'EOF'
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application checkMesh; startFrom startTime; startTime 0; stopAt endTime; endTime 1; deltaT 1;
writeControl timeStep; writeInterval 1; writeFormat ascii; writePrecision 17;
EOF
  cat > "$1/system/fvSchemes" <<'EOF'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes { default steadyState; } gradSchemes { default Gauss linear; } divSchemes { default none; }
laplacianSchemes { default Gauss linear corrected; } interpolationSchemes { default linear; } snGradSchemes { default corrected; }
EOF
  echo 'FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }' > "$1/system/fvSolution"
}
foam() { ( set +u; export WM_PROJECT_DIR=/usr/share/openfoam; . /usr/share/openfoam/etc/bashrc > /dev/null 2>&1; "$@" ) ; }
patch_counts() { sed -n '/Checking patch topology/,/^$/p' "$1" | awk 'NR > 2 && NF >= 2 { print $1, $2 }' | sort; }

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
gmsh -3 "$W/box.geo" -format msh2 -o "$W/box.msh" > "$W/gmsh.log" 2>&1 || { echo "FAIL gmsh"; exit 1; }
C="$W/case"; new_case "$C"
foam gmshToFoam "$W/box.msh" -case "$C" > "$W/g2f.log" 2>&1
foam checkMesh -case "$C" > "$C/check.log" 2>&1
foam foamMeshToFluent -case "$C" > "$W/f2fl.log" 2>&1
IN="$C/fluentInterface/case.msh"
check "foamMeshToFluent wrote a Fluent mesh" '[ -s "$IN" ] && head -c 1 "$IN" | grep -q "("'

cat > "$W/zones.py" <<'EOF'
# Boundary zones of two ASCII Fluent meshes: names, types and every face at
# its coordinates, in order (interior zones left out), must be equal.
import re, sys
def zones(path):
    t = open(path).read()
    nodes = []
    for m in re.finditer(r"\(10 \((\w+) (\w+) (\w+) \w+(?: \w+)?\)\s*\((.*?)\)\)", t, re.S):
        if int(m.group(1), 16) == 0:
            continue
        v = [float(x) for x in m.group(4).split()]
        nodes += [tuple(v[i:i + 3]) for i in range(0, len(v), 3)]
    info = {int(m.group(1)): (m.group(2), m.group(3)) for m in re.finditer(r"\((?:39|45) \((\d+) ([^\s()]+) ([^\s()]+)", t)}
    out = {}
    for m in re.finditer(r"\(13 \((\w+) (\w+) (\w+) (\w+) (\w+)\)\s*\((.*?)\)\)", t, re.S):
        zid = int(m.group(1), 16)
        if zid == 0 or info[zid][0] == "interior":
            continue
        fs = []
        for line in m.group(6).strip().splitlines():
            x = [int(a, 16) for a in line.split()]
            if int(m.group(5), 16) == 0:
                x = x[1:]
            fs.append(tuple(nodes[i - 1] for i in x[:3]))
        out[info[zid][1]] = (info[zid][0], fs)
    return out
a, b = zones(sys.argv[1]), zones(sys.argv[2])
assert sorted(a) == sorted(b), (sorted(a), sorted(b))
for k in a:
    assert a[k][0] == b[k][0], (k, a[k][0], b[k][0])
    assert a[k][1] == b[k][1], k
print("     %d boundary zones, %d faces: %s" % (len(a), sum(len(v[1]) for v in a.values()), sorted(a)))
EOF

for fmt in ascii binary; do
  opt=""; [ "$fmt" = binary ] && opt=--binary
  OUT="$W/out-$fmt.msh"
  "$T" improve "$IN" -o "$OUT" $opt -q --report "$W/r-$fmt.json"; rc=$?
  check "$fmt: improve in.msh -o out.msh (exit $rc)" '[ $rc -eq 0 ]'
  check "$fmt: the output is a Fluent mesh" 'head -c 1 "$OUT" | grep -q "("'
  [ "$fmt" = binary ] && check "binary: binary node and face sections" 'grep -aq "(3010 (" "$OUT" && grep -aq "(3013 (" "$OUT"'
  check "$fmt: improve's own check says the boundary is unchanged" \
    '$PY -c "import json,sys; b=json.load(open(sys.argv[1]))[\"boundary_unchanged\"]; sys.exit(0 if b[\"checked\"] and b[\"ok\"] else 1)" "$W/r-$fmt.json"'
  O="$W/foam-$fmt"; new_case "$O"
  # OpenFOAM v1912's converters read no binary section (fluent3DMeshToFoam:
  # 'Found unknown block of type: "3010"'; fluentMeshToFoam crashes), so the
  # binary output reaches them through tetopt's ASCII copy of it.
  "$T" convert "$OUT" "$W/a-$fmt.msh" 2> /dev/null
  foam fluent3DMeshToFoam "$W/a-$fmt.msh" -case "$O" > "$O/f2f.log" 2>&1; rc=$?
  check "$fmt: fluent3DMeshToFoam reads tetopt's output (exit $rc)" '[ $rc -eq 0 ] && [ -f "$O/constant/polyMesh/owner" ]'
  foam checkMesh -case "$O" > "$O/check.log" 2>&1; rc=$?
  check "$fmt: checkMesh on it: Mesh OK (exit $rc)" '[ $rc -eq 0 ] && grep -q "^Mesh OK." "$O/check.log"'
  patch_counts "$C/check.log" > "$W/p-in"; patch_counts "$O/check.log" > "$W/p-out"
  echo "     patches of the source case: $(tr '\n' ' ' < "$W/p-in")"
  echo "     patches after tetopt:       $(tr '\n' ' ' < "$W/p-out")"
  check "$fmt: the same patches with the same face counts" '[ -s "$W/p-in" ] && cmp -s "$W/p-in" "$W/p-out"'
  check "$fmt: every boundary zone's faces in order at bit-identical coordinates, names and types kept" \
    '$PY "$W/zones.py" "$IN" "$W/a-$fmt.msh"'
done

"$T" convert "$W/box.msh" "$W/g.msh" 2> /dev/null; "$T" convert "$W/box.msh" "$W/f.msh" --msh-version fluent 2> /dev/null
check "Gmsh and Fluent .msh told apart by content; --msh-version fluent writes Fluent" \
  'head -1 "$W/g.msh" | grep -q "^\$MeshFormat" && head -c 1 "$W/f.msh" | grep -q "(" && "$T" convert "$W/f.msh" "$W/g2.msh" --msh-version 41 2> /dev/null && head -1 "$W/g2.msh" | grep -q "^\$MeshFormat"'
exit $fail
