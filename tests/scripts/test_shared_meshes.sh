#!/usr/bin/env bash
# On every mesh of ../shared/meshes (skipped when absent):
#  - tetopt quality --json agrees with meshcheck.py stats --json (worst and mean
#    alpha to 1e-9 relative, dihedral extremes to 1e-6 deg, boundary and
#    all-boundary counts exactly);
#  - tetopt improve (default mode) passes meshcheck.py compare, does not
#    lower the worst alpha and adds at most 25 dihedral angles of 170 degrees
#    or more.
# usage: test_shared_meshes.sh TETOPT SOURCE_DIR
set -u
T=$1; SRC=$2
M="$SRC/../shared/meshes"; MC="$SRC/../shared/tools/meshcheck.py"
[ -d "$M" ] && [ -f "$MC" ] || { echo "skip: ../shared/meshes or meshcheck.py absent"; exit 77; }
/usr/bin/python3 -c "import meshio, numpy" 2>/dev/null || { echo "skip: meshio/numpy absent"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
for f in tire/tire.vtk house2/house2.node cube-clip-5/cube-clip-5.vtk flat-tet-sphere/flat-tet-sphere.vtk \
         hinge_raw/hinge_raw.mesh hinge_small/hinge_small.mesh screw_graded/screw_graded.mesh flange/flange.mesh \
         cub_wedge_like/cub_wedge_like.vtk aorta_vessel/aorta_vessel.mesh; do
  in="$M/$f"; [ -f "$in" ] || { echo "skip $f (absent)"; continue; }
  name=$(basename "${f%.*}")
  # meshio reads TetGen through .node/.ele only with its own conventions: compare via a .mesh copy
  ref="$in"
  if [[ "$f" == *.node ]]; then "$T" convert "$in" "$W/$name.mesh"; ref="$W/$name.mesh"; fi
  if ! "$T" quality "$in" --json > "$W/$name.t.json" 2> "$W/$name.err"; then
    echo "FAIL $f: tetopt quality: $(cat "$W/$name.err")"; fail=1; continue
  fi
  /usr/bin/python3 "$MC" stats "$ref" --json > "$W/$name.m.json"
  if /usr/bin/python3 - "$W/$name.t.json" "$W/$name.m.json" <<'PY'
import json, sys
t = json.load(open(sys.argv[1])); m = json.load(open(sys.argv[2]))
bad = []
def rel(a, b): return abs(a - b) / max(abs(b), 1e-300)
for k in ("alpha_worst", "alpha_mean", "alpha_boundary_worst", "alpha_boundary_mean"):
    if rel(t[k], m[k]) > 1e-9: bad.append(f"{k}: {t[k]} vs {m[k]}")
for k in ("dihedral_min", "dihedral_max"):
    if abs(t[k] - m[k]) > 1e-6: bad.append(f"{k}: {t[k]} vs {m[k]}")
for k in ("boundary_tets", "all_boundary_tets", "tets", "alpha_below_0.1", "inverted_or_flat"):
    if t[k] != m[k]: bad.append(f"{k}: {t[k]} vs {m[k]}")
print("; ".join(bad)); sys.exit(1 if bad else 0)
PY
  then echo "ok   $f quality agrees with meshcheck"; else echo "FAIL $f quality disagrees"; fail=1; fi
  out="$W/$name.out.mesh"
  if "$T" improve "$in" -o "$out" -q --report "$W/$name.r.json" 2> "$W/$name.err"; then
    if /usr/bin/python3 "$MC" compare "$ref" "$out" > "$W/$name.cmp" 2>&1; then
      echo "ok   $f improve: $(grep '^after' -A1 "$W/$name.cmp" | tail -1 | sed 's/^ *//')"
    else
      echo "FAIL $f improve rejected by the referee:"; cat "$W/$name.cmp"; fail=1
    fi
    /usr/bin/python3 -c "
import json,sys; r=json.load(open('$W/$name.r.json'))
sys.exit(0 if r['after']['alpha_worst'] >= r['before']['alpha_worst'] else 1)" \
      || { echo "FAIL $f worst alpha decreased"; fail=1; }
    # Dihedral angles of 170 degrees or more (the last 10-degree bin of the
    # histogram of all 6 nt angles): mode best may add a few (its alpha
    # rounds do on aorta_vessel: 1 -> 10) but not dozens (1 -> 105 there
    # before TopoOptions::angle_keep).
    /usr/bin/python3 -c "
import json,sys; r=json.load(open('$W/$name.r.json'))
b, a = r['before']['dihedral_histogram_10deg'][-1], r['after']['dihedral_histogram_10deg'][-1]
print('     angles of 170 degrees or more: %d -> %d' % (b, a)); sys.exit(0 if a <= b + 25 else 1)" \
      || { echo "FAIL $f too many new angles of 170 degrees or more"; fail=1; }
  else
    echo "FAIL $f improve: $(cat "$W/$name.err")"; fail=1
  fi
done
exit $fail
