#!/usr/bin/env bash
# Six kinds of part users bring, none of them in the other benchmarks
# (tests/data/gmsh: gear.geo, a symmetric part with 24 sharp teeth;
# pipe_bend.geo, a curved CFD pipe; seven_bodies.geo, a box with seven
# bodies as holes; naca_wing.geo, a wing with a sharp trailing edge in a
# flow box; plate_stack.geo, plates one or two tets thick; cylinder_in_box.geo,
# two regions with an interface), each meshed two ways:
#   * gm: `gmsh -3` (the mesher's own volume mesh);
#   * tg: raw `tetgen -pQ` of gmsh's surface (the bodies and the wing as
#     holes: tests/scripts/mesh_to_smesh.py), no interior vertex; not for
#     the two-region part.
# On each: tetopt's default mode and --allow-insert --allow-remove, and with
# MMG= `mmg3d -optim -nosurf`; the referee (../shared/tools/meshcheck.py
# compare) on every output when present; the bound from `tetopt quality`.
# A row: tets, worst and mean alpha, tets below 0.2, the dihedral range,
# seconds, the referee's verdict, and the worst alpha over the bound.
#   usage: bench/sweep.sh BUILD_DIR [OUT_DIR]    THREADS=0 (all cores)
#          MMG=/path/to/mmg3d_O3 to add MMG; PARTS="gear naca_wing" to choose
set -uo pipefail
BUILD=${1:?usage: bench/sweep.sh BUILD_DIR [OUT_DIR]}
OUT=${2:-out/bench/sweep}
T=$(cd "$BUILD" && pwd)/tetopt
PY=/usr/bin/python3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
REFEREE=$ROOT/../shared/tools/meshcheck.py
THREADS=${THREADS:-0}
PARTS=${PARTS:-"gear pipe_bend seven_bodies naca_wing plate_stack cylinder_in_box"}
for tool in gmsh tetgen; do
  command -v $tool > /dev/null || { echo "bench/sweep.sh: needs $tool (Debian: gmsh, tetgen)"; exit 2; }
done
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

# Points inside the parts' holes (for tetgen), "" where there is none.
holes() {
  case $1 in
    seven_bodies) echo "0.5,0.5,0.5 0.9,1.0,0.9 1.5,0.4,1.1 2.4,0.8,0.5 1.2,0.75,0.65 1.9,0.7,0.75 2.45,1.1,1.0" ;;
    naca_wing) echo "0.3,0,0.5" ;;
    *) echo "" ;;
  esac
}

row() {  # row NAME TOOL IN OUT SECONDS
  local verdict=""
  if [ -f "$REFEREE" ] && [ "$2" != input ]; then
    if $PY "$REFEREE" compare "$3" "$4" > "$4.ref" 2>&1; then verdict=valid; else verdict=REJECTED; fi
  fi
  "$T" quality "$4" --json --threads "$THREADS" 2> /dev/null > "$4.json"
  $PY - "$4.json" "$1" "$2" "$5" "$verdict" "$BOUND" >> "$OUT/sweep.md" <<'PYEOF'
import json, sys
q = json.load(open(sys.argv[1]))
name, tool, secs, verdict, bound = sys.argv[2:7]
b = float(bound)
print(f"| {name} | {tool} | {q['tets']} | {q['alpha_worst']:.4f} | {q['alpha_mean']:.4f} | {q['alpha_below_0.2']} "
      f"| {q['dihedral_min']:.2f}–{q['dihedral_max']:.2f} | {secs} | {verdict} | {q['alpha_worst'] / b:.2f} |")
PYEOF
}

{
  echo "# bench/sweep.sh, $(date -u '+%Y-%m-%d %H:%M') UTC, tetopt $(cd "$ROOT" && git rev-parse --short HEAD 2> /dev/null), threads $THREADS"
  echo
  echo "| mesh | tool | tets | worst α | mean α | α < 0.2 | dihedral (°) | s | referee | worst / bound |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
} > "$OUT/sweep.md"

for part in $PARTS; do
  geo=$ROOT/tests/data/gmsh/$part.geo
  [ -f "$geo" ] || { echo "bench/sweep.sh: no $geo"; exit 2; }
  gmsh -3 -nt 1 -format mesh "$geo" -o "$OUT/${part}_gm.mesh" > "$OUT/${part}_gm.gmsh.log" 2>&1 ||
    { echo "FAIL gmsh -3 $part"; continue; }
  inputs="gm"
  if [ "$part" != cylinder_in_box ]; then
    gmsh -2 -nt 1 -format mesh "$geo" -o "$OUT/${part}_surf.mesh" > "$OUT/${part}_surf.gmsh.log" 2>&1
    h=$(holes "$part")
    if [ -n "$h" ]; then
      $PY "$ROOT/tests/scripts/mesh_to_smesh.py" "$OUT/${part}_surf.mesh" "$OUT/${part}_surf.smesh" $h &&
        tetgen -pQ "$OUT/${part}_surf.smesh" > "$OUT/${part}_tetgen.log" 2>&1
    else
      tetgen -pQ "$OUT/${part}_surf.mesh" > "$OUT/${part}_tetgen.log" 2>&1
    fi
    "$T" convert "$OUT/${part}_surf.1.node" "$OUT/${part}_tg.mesh" > /dev/null 2>&1 && inputs="gm tg" ||
      echo "FAIL raw tetgen mesh of $part"
  fi
  for kind in $inputs; do
    in=$OUT/${part}_$kind.mesh
    BOUND=$("$T" quality "$in" --json --threads "$THREADS" 2> /dev/null |
            $PY -c 'import json, sys; print(json.load(sys.stdin)["diagnosis"]["bound"]["alpha_upper_bound"])')
    row "${part}_$kind (bound $(printf %.4f "$BOUND"))" input "$in" "$in" ""
    for tool in default insert mmg; do
      o=$OUT/${part}_${kind}_$tool.mesh
      case $tool in
        default) cmd=("$T" improve "$in" -o "$o" -q --threads "$THREADS") ;;
        insert) cmd=("$T" improve "$in" -o "$o" -q --threads "$THREADS" --allow-insert --allow-remove) ;;
        mmg) [ -n "${MMG:-}" ] || continue; cmd=("$MMG" -in "$in" -out "$o" -optim -nosurf) ;;
      esac
      /usr/bin/time -f %e -o "$o.time" "${cmd[@]}" > "$o.log" 2>&1 || { echo "FAIL ${cmd[*]}"; continue; }
      row "${part}_$kind" "$tool" "$in" "$o" "$(cat "$o.time")"
    done
  done
done
cat "$OUT/sweep.md"
