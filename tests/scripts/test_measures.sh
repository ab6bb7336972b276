#!/usr/bin/env bash
# Every measure of measures.hpp through `tetopt quality`: text, --json,
# --field, --html; and, where OpenFOAM is installed (Debian: apt-get install
# openfoam), the face measures against checkMesh on the same mesh (gmshToFoam
# of a .msh 2.2).  Without OpenFOAM that part is skipped, not failed.
# usage: test_measures.sh TETOPT SOURCE_DIR
set -u
T=$1
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
PY=/usr/bin/python3
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" generate "$W/box.mesh" --cells 6 6 6 --jitter 0.42 --regions 2 --seed 7 > /dev/null
"$T" quality "$W/box.mesh" > "$W/q.txt" 2>&1; rc=$?
check "quality exits 0" '[ $rc -eq 0 ]'
for k in sine_min dihedral_min dihedral_max scaled_jacobian radius_ratio mean_ratio equivolume_skewness \
         non_orthogonality skewness; do
  check "text table has $k" 'grep -q "^  $k (\(higher\|lower\))" "$W/q.txt"'
done
check "text has the Fluent bands" 'grep -q "bands: excellent [0-9]* good [0-9]* fair" "$W/q.txt"'
check "text has the measure histograms" 'grep -q "non_orthogonality histogram (one per face" "$W/q.txt" && grep -q "equivolume_skewness histogram (one per tet" "$W/q.txt"'
"$T" quality "$W/box.mesh" --no-histogram > "$W/qn.txt" 2>&1
check "--no-histogram drops them" '! grep -q "histogram" "$W/qn.txt" && grep -q "^  scaled_jacobian (higher)" "$W/qn.txt"'

"$T" quality "$W/box.mesh" --json > "$W/q.json"
check "quality --json: nested measures and faces, sane" '$PY - "$W/q.json" <<EOF
import json, sys, math
q = json.load(open(sys.argv[1])); ms = q["measures"]; f = q["faces"]
assert ms["alpha"]["worst"] == q["alpha_worst"]
for k, v in ms.items():
    assert v["count"] == q["tets"] and sum(v["histogram"]["counts"]) == q["tets"], k
assert 0 < ms["sine_min"]["worst"] < ms["sine_min"]["mean"] < 2 * math.sqrt(2) / 3
assert 0 < ms["scaled_jacobian"]["worst"] < ms["scaled_jacobian"]["mean"] < 1
assert 0 < ms["equivolume_skewness"]["mean"] < ms["equivolume_skewness"]["worst"] < 1
assert 2 * f["interior"] + f["boundary"] == 4 * q["tets"]
assert f["non_orthogonality"]["fail"]["gt_70"] >= 0 and f["skewness"]["fail"]["gt_4"] == 0
EOF'
# The same numbers for every thread count (10368 tets: two blocks of the parallel loops).
"$T" generate "$W/big.mesh" --cells 12 12 12 --jitter 0.45 --seed 3 > /dev/null
"$T" quality "$W/big.mesh" --json --threads 1 > "$W/q1.json"
"$T" quality "$W/big.mesh" --json --threads 3 > "$W/q3.json"
check "quality --json is the same for 1 and 3 threads (but the diagnosis' timings)" '$PY -c "
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:])
a.pop(\"diagnosis\"); b.pop(\"diagnosis\")
assert a == b
" "$W/q1.json" "$W/q3.json"'

"$T" quality "$W/box.mesh" --field "$W/q.vtu" -q > /dev/null
check "--field has the new arrays" '( for n in sine_min scaled_jacobian radius_ratio mean_ratio equivolume_skewness non_orthogonality_max face_skewness_max; do grep -q "Name=\"$n\"" "$W/q.vtu" || exit 1; done )'
"$T" quality "$W/box.mesh" --html "$W/q.html" -q > /dev/null
check "--html has the measures table and histograms" 'grep -q "<table id=\"measures\">" "$W/q.html" && grep -q "data-measure=\"non_orthogonality\"" "$W/q.html" && grep -q "id=\"hist-equivolume_skewness\"" "$W/q.html" && grep -q "id=\"hist-skewness\"" "$W/q.html"'

# checkMesh cross-check.
if command -v checkMesh > /dev/null && command -v gmshToFoam > /dev/null && [ -f /usr/share/openfoam/etc/bashrc ]; then
  C="$W/case"; mkdir -p "$C/system"
  cat > "$C/system/controlDict" <<'EOF'
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application checkMesh; startFrom startTime; startTime 0; stopAt endTime; endTime 1; deltaT 1;
writeControl timeStep; writeInterval 1; writeFormat ascii; writePrecision 17;
EOF
  cat > "$C/system/fvSchemes" <<'EOF'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes { default steadyState; } gradSchemes { default Gauss linear; } divSchemes { default none; }
laplacianSchemes { default Gauss linear corrected; } interpolationSchemes { default linear; } snGradSchemes { default corrected; }
EOF
  echo 'FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }' > "$C/system/fvSolution"
  "$T" convert "$W/box.mesh" "$C/box.msh" --msh-version 22 2> /dev/null
  ( set +u; export WM_PROJECT_DIR=/usr/share/openfoam; . /usr/share/openfoam/etc/bashrc > /dev/null 2>&1
    cd "$C" && gmshToFoam box.msh -case "$C" > gmsh.log 2>&1 && checkMesh -case "$C" > check.log 2>&1 )
  check "checkMesh: non-orthogonality max, average, >70 count and skewness max agree" '$PY - "$C/check.log" "$W/q.json" <<EOF
import json, re, sys
log = open(sys.argv[1]).read(); f = json.load(open(sys.argv[2]))["faces"]
m = re.search(r"Mesh non-orthogonality Max: (\S+) average: (\S+)", log)
s = re.search(r"Max skewness = (\S+)", log)
n = re.search(r"Number of severely non-orthogonal \(> 70 degrees\) faces: (\d+)", log)
i = re.search(r"internal faces:\s+(\d+)", log)
assert m and s and i, log[-2000:]
print("     checkMesh max %s avg %s skew %s; tetopt %.17g %.17g %.17g" % (m.group(1), m.group(2), s.group(1),
      f["non_orthogonality"]["worst"], f["non_orthogonality"]["checkmesh_average"], f["skewness"]["worst"]))
assert abs(float(m.group(1)) - f["non_orthogonality"]["worst"]) < 1e-9
assert abs(float(m.group(2)) - f["non_orthogonality"]["checkmesh_average"]) < 1e-9
assert abs(float(s.group(1)) - f["skewness"]["worst"]) < 1e-9
assert int(n.group(1) if n else 0) == f["non_orthogonality"]["fail"]["gt_70"]
assert int(i.group(1)) == f["interior"]
EOF'
else
  echo "skip checkMesh cross-check (OpenFOAM's checkMesh/gmshToFoam not installed)"
fi
exit $fail
