#!/usr/bin/env bash
# Cross-check of the Medit (.mesh, .meshb v2/v3/v4) and TetGen (.node/.ele)
# writers against meshio (Debian's python3-meshio), plus the round trip
# .mesh -> .node/.ele -> .mesh, which must give back the same bytes.
# Usage: bash test_meshio_medit_tetgen.sh TETOPT_CLI SOURCE_DIR   (exit 77 = skip)
set -euo pipefail
CLI=${1:?usage: $0 TETOPT_CLI SOURCE_DIR}
PY=/usr/bin/python3
[ -x "$CLI" ] || { echo "skip: no CLI at $CLI"; exit 77; }
"$PY" -c 'import meshio, numpy' >/dev/null 2>&1 || { echo "skip: $PY cannot import meshio"; exit 77; }

T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

"$CLI" generate "$T/a.mesh" --cells 4 3 2 --jitter 0.3 --regions 2 >/dev/null
"$CLI" convert "$T/a.mesh" "$T/a.node" >/dev/null
"$CLI" convert "$T/a.node" "$T/b.mesh" >/dev/null
cmp "$T/a.mesh" "$T/b.mesh" || { echo "FAIL: .mesh -> TetGen -> .mesh changed the file"; exit 1; }

# .meshb in the CLI's default GMF version (the unit tests cover 2, 3 and 4).
"$CLI" convert "$T/a.mesh" "$T/a.meshb" >/dev/null

"$PY" - "$T" <<'EOF'
import sys, warnings
warnings.simplefilter("ignore")
import numpy as np, meshio
d = sys.argv[1]

def tets(m):
    c = [(b.data, m.cell_data["medit:ref"][i] if "medit:ref" in m.cell_data else m.cell_data["tetgen:ref"][i])
         for i, b in enumerate(m.cells) if b.type == "tetra"]
    assert len(c) == 1, "expected one tetra block"
    return c[0]

a = meshio.read(d + "/a.mesh")
b = meshio.read(d + "/a.meshb")
g = meshio.read(d + "/a.node")
ta, ra = tets(a)
tb, rb = tets(b)
tg, rg = tets(g)
assert np.array_equal(a.points, b.points), ".mesh and .meshb coordinates differ"
assert np.array_equal(a.points, g.points), ".mesh and .node coordinates differ"
assert np.array_equal(ta, tb) and np.array_equal(ra, rb), ".mesh and .meshb tets differ"
# Written from a .mesh, the .ele holds the same positive tets (TetGen 1.5 writes positive tets too).
assert np.array_equal(ta, tg), ".ele tets are not the .mesh tets"
assert np.array_equal(ra, rg.astype(ra.dtype)), "region refs differ"
assert set(np.unique(ra)) == {1, 2}, "two regions expected"
p = a.points[ta]
vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
assert (vol > 0).all(), "Medit tets must be positive"
print("ok: %d points, %d tets, meshio agrees on .mesh/.meshb/.node" % (len(a.points), len(ta)))
EOF
