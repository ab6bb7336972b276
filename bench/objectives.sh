#!/usr/bin/env bash
# Every --objective, guarded and not, on the shared meshes: the worst (and
# mean) of each per-tet measure after the run, measured by bench/measures.py
# (NumPy, independent of tetopt's own table), with the boundary judged by
# ../shared/tools/meshcheck.py compare.  Writes a markdown table to stdout.
# usage: bench/objectives.sh TETOPT [MESH...]   (default: the small shared meshes)
set -u
T=$1; shift
ROOT=$(cd "$(dirname "$0")/.." && pwd)
S=$ROOT/../shared/meshes
MC=$ROOT/../shared/tools/meshcheck.py
meshes=${*:-"$S/tire/tire.vtk $S/cube-clip-5/cube-clip-5.vtk $S/flat-tet-sphere/flat-tet-sphere.vtk $S/hinge_small/hinge_small.mesh $S/aorta_vessel/aorta_vessel.mesh"}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
echo "| mesh | run | s | worst α / mean α | sine | dihedral min–max | scaled Jacobian | radius ratio | mean ratio | skewness | referee |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for f in $meshes; do
  [ -f "$f" ] || { echo "skip $f" >&2; continue; }
  n=$(basename "$f"); ext=${n##*.}; base=${n%.*}
  row() {  # label file seconds referee
    m=$(/usr/bin/python3 "$ROOT/bench/measures.py" "$2" | sed 's/^[^:]*: //')
    /usr/bin/python3 -c '
import re,sys
s=sys.argv[1]
g=lambda k: re.search(k+r" ([-0-9.]+)(?:/([-0-9.]+))?", s).groups()
a=g("alpha"); si=g("sine_min"); dl=g("dihedral_min"); dh=g("dihedral_max"); sj=g("scaled_jacobian"); rr=g("radius_ratio"); mr=g("mean_ratio"); sk=g("equivolume_skewness")
print(f"| {sys.argv[5]} | {sys.argv[2]} | {sys.argv[3]} | {float(a[0]):.4f} / {float(a[1]):.4f} | {float(si[0]):.4f} | {float(dl[0]):.2f}–{float(dh[0]):.2f} | {float(sj[0]):.4f} | {float(rr[0]):.4f} | {float(mr[0]):.4f} | {float(sk[0]):.4f} | {sys.argv[4]} |")
' "$m" "$1" "$3" "$4" "$base"
  }
  row input "$f" - -
  for run in "alpha" "alpha --no-guard" "sine" "jacobian" "skewness"; do
    o=$W/$base.$ext
    t0=$(date +%s.%N)
    "$T" improve "$f" -o "$o" -q --objective $run > /dev/null 2>&1 || { echo "| $base | $run | FAILED |"; continue; }
    t1=$(date +%s.%N)
    ref=$(/usr/bin/python3 "$MC" compare "$f" "$o" > /dev/null 2>&1 && echo valid || echo VIOLATION)
    row "$run" "$o" "$(printf %.2f "$(echo "$t1 - $t0" | bc)")" "$ref"
  done
done
