#!/usr/bin/env bash
# Issue 27's benchmark: the interior remesher (--allow-insert --allow-remove)
# beside the default mode and MMG's -optim -nosurf, in the same run, on
#   * raw `tetgen -pQ` output of tests/data/gmsh/body_in_box.geo (s = 0.5,
#     0.25): a body in a flow box with no interior vertex;
#   * raw `tetgen -pAQ` output of cylinder_hole.geo (h = 0.1) and
#     thin_wall.geo (ch_0p1_A, tw_A: inner surfaces kept as interfaces);
#   * blade_passage.geo (s = 0.06, tk = 0.05): gmsh's mesh and raw `tetgen -pQ`;
#   * raw `tetgen -pQ` output of crank.geo (s = 0.03), a CAD part;
#   * the demo impeller at s = 2 (a mesher's output, two regions);
#   * ../shared/meshes hinge_raw (raw tetgen), tire and flange when present.
# Every output is judged by ../shared/tools/meshcheck.py compare (boundary
# bit-identical, no inverted tet, volumes kept); worst / mean alpha and the
# tets below alpha 0.2 come from its statistics; the input row gives the
# bound on the worst alpha from `tetopt quality`.  Time: wall seconds of each
# process; the ratios (insert / default, MMG / insert) are what to read.
# Extra meshes: MESHES="a.mesh b.mesh" (read in place).  Seconds are wall
# (CPU = user + sys in brackets).
#   usage: bench/remesh.sh BUILD_DIR [OUT_DIR]     MMG=/path/to/mmg3d_O3 to add MMG,
#          BEFORE=/path/to/an/older/tetopt to add its --allow-insert --allow-remove run
set -uo pipefail
BUILD=${1:?usage: bench/remesh.sh BUILD_DIR [OUT_DIR]}
OUT=${2:-out/bench/remesh}
T=$BUILD/tetopt
PY=/usr/bin/python3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
REF=$ROOT/../shared/tools/meshcheck.py
SH=$ROOT/../shared/meshes
mkdir -p "$OUT"
meshes=()
for s in 0.5 0.25; do
  n=bib_$(echo $s | tr . p)
  if [ ! -f "$OUT/$n.mesh" ]; then
    gmsh -2 -nt 1 -setnumber s $s -format mesh "$ROOT/tests/data/gmsh/body_in_box.geo" -o "$OUT/${n}_surf.mesh" > /dev/null 2>&1
    tetgen -pQ "$OUT/${n}_surf.mesh" > /dev/null 2>&1
    "$T" convert "$OUT/${n}_surf.1.node" "$OUT/$n.mesh" > /dev/null
  fi
  meshes+=("$OUT/$n.mesh")
done
# Raw `tetgen -pAQ` output whose inner surfaces are region interfaces (kept
# by every tool): a cylinder with a spherical hole at h = 0.1 (ch_0p1_A) and
# a cylinder wall 0.005 thick in a box (tw_A, a wall one tet thick).
raw() {  # name, geo, gmsh arguments...
  local n=$1 g=$2; shift 2
  if [ ! -f "$OUT/$n.mesh" ]; then
    gmsh -2 -nt 1 "$@" -format mesh "$ROOT/tests/data/gmsh/$g" -o "$OUT/${n}_surf.mesh" > /dev/null 2>&1
    tetgen -pAQ "$OUT/${n}_surf.mesh" > /dev/null 2>&1
    "$T" convert "$OUT/${n}_surf.1.node" "$OUT/$n.mesh" > /dev/null
  fi
  meshes+=("$OUT/$n.mesh")
}
raw ch_0p1_A cylinder_hole.geo -setnumber h 0.1
raw tw_A thin_wall.geo
# A blade passage (blade_passage.geo: a thin twisted blade with a sharp
# trailing edge, hub to shroud): gmsh's own mesh (bp_g) and the raw
# `tetgen -pQ` output of its surface (bp_raw; TetGen reads it as STL).
bp="-nt 1 -setnumber s 0.06 -setnumber tk 0.05"
[ -f "$OUT/bp_g.mesh" ] || gmsh -3 $bp -format mesh "$ROOT/tests/data/gmsh/blade_passage.geo" -o "$OUT/bp_g.mesh" > /dev/null 2>&1
if [ ! -f "$OUT/bp_raw.mesh" ]; then
  gmsh -2 $bp -format stl "$ROOT/tests/data/gmsh/blade_passage.geo" -o "$OUT/bp_surf.stl" > /dev/null 2>&1
  tetgen -pQ "$OUT/bp_surf.stl" > /dev/null 2>&1
  "$T" convert "$OUT/bp_surf.1.node" "$OUT/bp_raw.mesh" > /dev/null
fi
meshes+=("$OUT/bp_g.mesh" "$OUT/bp_raw.mesh")
# A crankshaft-like CAD part (crank.geo, s = 0.03): raw `tetgen -pQ` output.
if [ ! -f "$OUT/crank_raw.mesh" ]; then
  gmsh -2 -nt 1 -setnumber s 0.03 -format stl "$ROOT/tests/data/gmsh/crank.geo" -o "$OUT/crank_surf.stl" > /dev/null 2>&1
  tetgen -pQ "$OUT/crank_surf.stl" > /dev/null 2>&1
  "$T" convert "$OUT/crank_surf.1.node" "$OUT/crank_raw.mesh" > /dev/null
fi
meshes+=("$OUT/crank_raw.mesh")
[ -f "$OUT/impeller_s2.mesh" ] || gmsh -3 -nt 1 -setnumber s 2 -format mesh "$ROOT/demo/impeller.geo" -o "$OUT/impeller_s2.mesh" > /dev/null 2>&1
meshes+=("$OUT/impeller_s2.mesh")
for f in hinge_raw/hinge_raw.mesh tire/tire.vtk flange/flange.mesh; do [ -f "$SH/$f" ] && meshes+=("$SH/$f"); done
for f in ${MESHES:-}; do meshes+=("$f"); done

stats() {  # referee verdict and statistics of $2 against $1
  local v
  if "$PY" "$REF" compare "$1" "$2" > "$2.ref" 2>&1; then v=valid; else v=REJECTED; fi
  "$PY" - "$2.ref" "$v" <<'PYEOF'
import re, sys
t = open(sys.argv[1]).read().split("after:")[-1]
w = re.search(r"alpha worst ([0-9.]+) mean ([0-9.]+)", t); b = re.search(r"alpha<0.2: (\d+)", t)
n = re.search(r"(\d+) tets", t)
print("%s | %.4f | %.4f | %s | %s" % (n.group(1) if n else "?", float(w.group(1)), float(w.group(2)), b.group(1), sys.argv[2]))
PYEOF
}
run() {  # name, output, command...: prints "wall (cpu)"
  local name=$1 o=$2; shift 2
  /usr/bin/time -f "%e %U %S" -o "$o.time" "$@" > "$o.log" 2>&1
  awk '{printf "%.2f (%.2f)", $1, $2 + $3}' "$o.time"
}
wall() { echo "${1%% *}"; }
echo "| mesh | tool | seconds | tets | worst α | mean α | tets α<0.2 | referee |"
echo "|---|---|---|---|---|---|---|---|"
for m in "${meshes[@]}"; do
  b=$(basename "${m%.*}")
  ext=mesh
  s0=$(run def "$OUT/${b}_def.$ext" "$T" improve "$m" -o "$OUT/${b}_def.$ext" -q)
  s1=$(run ins "$OUT/${b}_ins.$ext" "$T" improve "$m" -o "$OUT/${b}_ins.$ext" -q --allow-insert --allow-remove)
  # The bound any boundary-keeping mesh obeys (tetopt quality: walls and
  # wedges counted), against which issue 27 judges the worst alpha.
  bnd=$("$T" quality "$m" --json 2>/dev/null | "$PY" -c 'import json, sys; print("%.4f" % json.load(sys.stdin)["diagnosis"]["bound"]["alpha_upper_bound"])' 2>/dev/null || echo "?")
  echo "| $b | input (bound α $bnd) | | $(stats "$m" "$m" | cut -d'|' -f1-4) | |"
  echo "| $b | tetopt default | $s0 | $(stats "$m" "$OUT/${b}_def.$ext") |"
  echo "| $b | tetopt --allow-insert --allow-remove | $s1, $(echo "scale=1; $(wall "$s1") / $(wall "$s0")" | bc)x default | $(stats "$m" "$OUT/${b}_ins.$ext") |"
  if [ -n "${BEFORE:-}" ] && [ -x "$BEFORE" ]; then
    s3=$(run old "$OUT/${b}_old.$ext" "$BEFORE" improve "$m" -o "$OUT/${b}_old.$ext" -q --allow-insert --allow-remove)
    echo "| $b | BEFORE --allow-insert --allow-remove | $s3 | $(stats "$m" "$OUT/${b}_old.$ext") |"
  fi
  if [ -n "${MMG:-}" ] && [ -x "$MMG" ]; then
    src=$m
    if [ "${m##*.}" != mesh ]; then src=$OUT/${b}_in.mesh; "$T" convert "$m" "$src" > /dev/null; fi
    s2=$(run mmg "$OUT/${b}_mmg.mesh" "$MMG" -optim -nosurf -v -1 "$src" -out "$OUT/${b}_mmg.mesh")
    echo "| $b | MMG -optim -nosurf | $s2, $(echo "scale=2; $(wall "$s2") / $(wall "$s1")" | bc)x tetopt insert | $(stats "$m" "$OUT/${b}_mmg.mesh") |"
  fi
done
