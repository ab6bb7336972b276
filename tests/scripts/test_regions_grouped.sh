#!/usr/bin/env bash
# improve writes the tets of one region together (issue 28): the demo
# impeller came back from improve with its two regions interleaved, and the
# Gmsh 4.1 writer wrote one element block per run, 1,012 blocks, which
# meshio returned as 1,012 tetra blocks.  Here a two-region box whose input
# already interleaves the regions (tetopt generate) is improved to Gmsh 4.1
# (ASCII and binary) and to Fluent: one tet block per region in the
# order of IN, the tets of each region in the order improve leaves them;
# --keep-order keeps improve's order (many blocks again).
# usage: test_regions_grouped.sh TETOPT SOURCE_DIR
set -u
T=$1
PY=/usr/bin/python3
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }
# Tet blocks of a Gmsh 4.1 ASCII file: "entityDim entityTag type count" lines
# in $Elements with dim 3 (read here, not by tetopt).
cat > "$W/blocks.py" <<'PYEOF'
import sys
lines = open(sys.argv[1]).read().split("$Elements\n")[1].split("$EndElements")[0].splitlines()
nblocks = int(lines[0].split()[0])
i, tets = 1, []
for _ in range(nblocks):
    dim, tag, typ, n = (int(x) for x in lines[i].split())
    if dim == 3:
        tets.append((tag, n))
    i += 1 + n
print(" ".join("%d:%d" % t for t in tets))
PYEOF
"$T" generate "$W/box.msh" --cells 6 6 6 --jitter 0.3 --regions 2 > /dev/null
before=$($PY "$W/blocks.py" "$W/box.msh")
"$T" improve "$W/box.msh" -o "$W/out.msh" -q; rc=$?
after=$($PY "$W/blocks.py" "$W/out.msh")
echo "     tet blocks before: $(echo $before | wc -w), after: $after"
check "improve (exit $rc): one tet block per region, regions in IN's order" \
  '[ $rc -eq 0 ] && [ $(echo $before | wc -w) -gt 2 ] && [ $(echo $after | wc -w) -eq 2 ] && [ "${after%% *}" != "${after#* }" ] && [ "${after%%:*}" = "${before%%:*}" ]'
"$T" improve "$W/box.msh" -o "$W/keep.msh" -q --keep-order
check "--keep-order: improve's own order (more than one block per region)" '[ $($PY "$W/blocks.py" "$W/keep.msh" | wc -w) -gt 2 ]'
# The same tets either way: the grouped output is a reordering of --keep-order's.
"$T" convert "$W/out.msh" "$W/out.mesh" 2> /dev/null; "$T" convert "$W/keep.msh" "$W/keep.mesh" 2> /dev/null
check "grouped and --keep-order outputs hold the same tets and refs" \
  '$PY - "$W/out.mesh" "$W/keep.mesh" <<PYEOF
import sys
def tets(p):
    t = open(p).read().split("Tetrahedra")[1].split("End")[0].split("\n")
    n = int(t[1]); rows = [tuple(r.split()) for r in t[2:2 + n]]
    return sorted((tuple(sorted(r[:4])), r[4]) for r in rows)
assert tets(sys.argv[1]) == tets(sys.argv[2])
PYEOF'
"$T" improve "$W/box.msh" -o "$W/out.vtu" -q; rc=$?
check "improve to .vtu (exit $rc): refs grouped in the cell order" \
  '$PY -c "import meshio,sys; r=list(meshio.read(sys.argv[1]).cell_data[\"ref\"][0]); c=sum(1 for a,b in zip(r,r[1:]) if a!=b); sys.exit(0 if c==1 else 1)" "$W/out.vtu" 2> /dev/null || ! $PY -c "import meshio" 2> /dev/null'
exit $fail
