#!/usr/bin/env bash
# What a CFD solver makes of tetopt's output (issue 27: the meshes users
# bring).  tests/data/gmsh/flow_box.geo (a body with a thin fin in a flow
# box, four named patches) is meshed as a surface by gmsh at each size
# factor S, and its volume by
#   * raw `tetgen -pQ` (the body's inside a hole: tests/scripts/mesh_to_smesh.py):
#     what a user gets from a constrained Delaunay tetrahedralisation, no
#     interior vertex;
#   * `gmsh -3`: the mesher's own volume mesh of the same surface.
# Each input, tetopt's default mode and --allow-insert --allow-remove on it
# (and, with MMG=, `mmg3d -optim -nosurf` with and without -noinsert), goes
# through OpenFOAM (bench/foam_case.sh): tetopt convert to a polyMesh,
# checkMesh, and simpleFoam, laminar at Reynolds number 120.  A row says
# whether the solve converged (and in how many SIMPLE iterations) or
# diverged, the drag coefficient it ended with (its pressure and viscous
# parts), and the error of OpenFOAM's Laplacian on the mesh
# (bench/foam_laplace.py: a harmonic function imposed on the boundary,
# laplacianFoam, RMS of the cell error over the largest value) and of
# CalculiX's linear tets on the same problem (bench/ccx_laplace.py).  The last
# rows of each size: gmsh's mesh of the same geometry at S/2 (the reference
# drag), and that mesh after tetopt's default mode and after --mode smooth
# (REF=0 skips them: minutes).
# tetopt's outputs are judged by ../shared/tools/meshcheck.py compare when
# present; MMG's are listed as they are (it may move boundary vertices).
#   usage: bench/solver.sh BUILD_DIR [OUT_DIR]    SIZES="1 0.5" (default)
#          MMG=/path/to/mmg3d_O3 to add MMG's two runs
set -uo pipefail
BUILD=${1:?usage: bench/solver.sh BUILD_DIR [OUT_DIR]}
OUT=${2:-out/bench/solver}
T=$(cd "$BUILD" && pwd)/tetopt
PY=/usr/bin/python3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
GEO=$ROOT/tests/data/gmsh/flow_box.geo
REFEREE=$ROOT/../shared/tools/meshcheck.py
for tool in gmsh tetgen checkMesh simpleFoam; do
  command -v $tool > /dev/null || { echo "bench/solver.sh: needs $tool (Debian: gmsh, tetgen, openfoam)"; exit 2; }
done
. "$ROOT/bench/foam_case.sh"
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
MD=$OUT/solver.md
worst() { "$T" quality "$1" --json 2> /dev/null | "$PY" -c 'import json, sys; print("%.4f" % json.load(sys.stdin)["alpha_worst"])'; }
referee() {
  [ -f "$REFEREE" ] || { echo "-"; return; }
  if "$PY" "$REFEREE" compare "$1" "$2" > "$2.ref" 2>&1; then echo valid; else echo REJECTED; fi
}
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
# row NAME MESH SECONDS VERDICT
row() {
  local name=$1 mesh=$2 s=$3 verdict=$4 case=$OUT/case_$1
  foam_case "$mesh" "$case" "$T" || { echo "| $name | - | $(worst "$mesh") | $s | $verdict | tetopt convert failed | | | | | | | | |" >> "$MD"; return; }
  foam_run "$case"
  local sum lap
  sum=$(foam_summary "$case")
  # The Laplacian's own error on this mesh (bench/foam_laplace.py).
  lap=$(foam_laplace "$mesh" "${case}_laplace" "$T" | sed -n 's/.*laplace_rms=\([^ ]*\).*/\1/p')
  sum="$sum laplace_rms=${lap:--}"
  # The same with CalculiX's linear tets (bench/ccx_laplace.py), when ccx is there.
  local fem=-
  if command -v ccx > /dev/null; then
    fem=$("$PY" "$ROOT/bench/ccx_laplace.py" "$mesh" "${case}_ccx" 2> /dev/null | sed -n 's/.*fem_rms=\([^ ]*\).*/\1/p')
  fi
  sum="$sum fem_rms=${fem:--}"
  echo "$name $sum" >&2
  "$PY" - "$name" "$(worst "$mesh")" "$s" "$verdict" "$sum" >> "$MD" <<'EOF'
import sys
name, w, s, verdict, summary = sys.argv[1:]
d = dict(kv.split("=", 1) for kv in summary.split())
solve = ("converged in %s" % d["converged"]) if "converged" in d else ("**diverged** at %s" % d["diverged"])
num = lambda k, f: f % float(d[k]) if d[k] != "?" else "?"
cd = (num("Cd", "%.3f") + " (" + d["Cd_pressure"] + " + " + d["Cd_viscous"] + ")") if "converged" in d else "-"
print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
    name, d["cells"], w, s, verdict, num("nonorth_max", "%.1f"), d["severe_nonorth"], num("skewness_max", "%.2f"),
    "yes" if d["mesh_ok"] == "1" else "no", solve, cd, d["solve_s"], d["laplace_rms"], d["fem_rms"]))
EOF
}
{
  echo "# bench/solver.sh, $(date -u +%Y-%m-%d\ %H:%M) UTC, tetopt $(git -C "$ROOT" rev-parse --short HEAD 2> /dev/null)"
  echo
  echo "| mesh | cells | worst α | improver s | referee | max non-orth (°) | faces > 70° | max skewness (checkMesh) | Mesh OK | simpleFoam (SIMPLE iterations) | Cd (pressure + viscous) | solve s | Laplacian error (RMS) | FEM error, ccx (RMS) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$MD"
for S in ${SIZES:-1 0.5}; do
  n=s$(echo "$S" | tr . p)
  flow_box_raw "$S" "$OUT/${n}_raw.mesh" "$T"
  gmsh -3 -nt 1 -setnumber s "$S" -format mesh "$GEO" -o "$OUT/${n}_gmsh.mesh" > /dev/null 2>&1
  for src in raw gmsh; do
    in=$OUT/${n}_$src.mesh
    row "${n}_$src" "$in" "" ""
    for mode in def ins; do
      extra=""; [ $mode = ins ] && extra="--allow-insert --allow-remove"
      o=$OUT/${n}_${src}_$mode.mesh
      t0=$(date +%s.%N)
      "$T" improve "$in" -o "$o" -q $extra
      t1=$(date +%s.%N)
      row "${n}_${src}_$mode" "$o" "$(secs "$t0" "$t1")" "$(referee "$in" "$o")"
    done
    if [ -n "${MMG:-}" ] && [ $src = raw ]; then
      for mm in mmg mmgni; do
        extra=""; [ $mm = mmgni ] && extra="-noinsert"
        o=$OUT/${n}_${src}_$mm.mesh
        t0=$(date +%s.%N)
        "$MMG" -optim -nosurf $extra "$in" -out "$o" > "$o.log" 2>&1
        t1=$(date +%s.%N)
        row "${n}_${src}_$mm" "$o" "$(secs "$t0" "$t1")" "$(referee "$in" "$o")"
      done
    fi
  done
  if [ "${REF:-1}" = 1 ]; then
    R=$(awk -v s="$S" 'BEGIN { print s / 2 }')
    r=ref_s$(echo "$R" | tr . p)
    [ -f "$OUT/$r.mesh" ] || gmsh -3 -nt 1 -setnumber s "$R" -format mesh "$GEO" -o "$OUT/$r.mesh" > /dev/null 2>&1
    row "${r}_gmsh" "$OUT/$r.mesh" "" ""
    # The reference mesh through tetopt: the default mode's rounds and
    # flips, and its smoothing alone (--mode smooth).
    for mode in def smooth; do
      extra=""; [ $mode = smooth ] && extra="--mode smooth"
      o=$OUT/${r}_gmsh_$mode.mesh
      t0=$(date +%s.%N)
      "$T" improve "$OUT/$r.mesh" -o "$o" -q $extra
      t1=$(date +%s.%N)
      row "${r}_gmsh_$mode" "$o" "$(secs "$t0" "$t1")" "$(referee "$OUT/$r.mesh" "$o")"
    done
  fi
done
cat "$MD"
