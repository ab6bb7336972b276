#!/usr/bin/env bash
# CGNS through the command line (issue 28), checked by Debian's cgnscheck
# (package cgns-convert): a two-region box with its boundary triangles,
# converted to .cgns and improved (`tetopt improve box.cgns -o out.cgns`);
# cgnscheck must read both with no error and no warning, and see the
# TETRA_4 sections, the TRI_3 section and its BC.  The improved file's
# boundary triangles come back identical (tetopt convert to Medit, whose
# Triangles section lists them, compared before and after).
# usage: test_cgns.sh TETOPT SOURCE_DIR   (exit 77: cgnscheck absent or tetopt built without CGNS)
set -u
T=$1
command -v cgnscheck > /dev/null || { echo "skip: cgnscheck not installed (Debian: cgns-convert)"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" generate "$W/box.mesh" --cells 4 3 3 --jitter 0.35 --regions 2 > /dev/null || { echo "FAIL generate"; exit 1; }
if ! "$T" convert "$W/box.mesh" "$W/box.cgns" > "$W/convert.log" 2>&1; then
  if grep -q "built without CGNS" "$W/convert.log"; then echo "skip: tetopt built without CGNS"; exit 77; fi
  cat "$W/convert.log"; echo "FAIL convert to .cgns"; exit 1
fi
check "improve box.cgns -o out.cgns" '"$T" improve "$W/box.cgns" -o "$W/out.cgns" -q'
for f in box out; do
  cgnscheck "$W/$f.cgns" > "$W/$f.check" 2>&1
  check "cgnscheck $f.cgns: complete" 'grep -q "^checking complete" "$W/$f.check"'
  check "cgnscheck $f.cgns: no error, no warning" '! grep -qiE "error|warning" "$W/$f.check"'
  check "cgnscheck $f.cgns: the sections and the BC" \
    'grep -q "element set \"Region_1\"" "$W/$f.check" && grep -q "element set \"Region_2\"" "$W/$f.check" && grep -q "checking BC \"Boundary_1\"" "$W/$f.check"'
done
"$T" convert "$W/box.cgns" "$W/a.mesh" > /dev/null && "$T" convert "$W/out.cgns" "$W/b.mesh" > /dev/null
# The listed triangles with their coordinates (Medit writes 17 digits).
tris() {
  awk '/^Vertices/{getline; nv=$1; for(i=1;i<=nv;i++){getline; p[i]=$1" "$2" "$3}}
       /^Triangles/{getline; n=$1; for(i=1;i<=n;i++){getline; print p[$1]" | "p[$2]" | "p[$3]" | "$4}}' "$1" | sort
}
check "improve kept the boundary triangles (coordinates, order, refs)" 'diff <(tris "$W/a.mesh") <(tris "$W/b.mesh") > /dev/null'
check "improve changed the mesh" '! cmp -s "$W/a.mesh" "$W/b.mesh"'
exit $fail
