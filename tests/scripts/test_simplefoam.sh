#!/usr/bin/env bash
# A real CFD solver on tetopt's output (issue 27; bench/solver.sh for the
# full table).  Raw `tetgen -pQ` output of tests/data/gmsh/flow_box.geo at
# s = 1 (1,350 tets, every vertex on the boundary) goes through
# `tetopt improve --allow-insert --allow-remove`, then OpenFOAM: checkMesh
# must say "Mesh OK.", simpleFoam (laminar, Reynolds number 120,
# bench/foam_case.sh) must reach its residual control, and the body's drag
# coefficient must be within 15% of 2.64, simpleFoam's value on gmsh's own
# mesh of the same geometry at s = 0.25 (130,215 cells, docs/benchmarks.md,
# thirty-first session).  On this machine the raw mesh diverged (a floating
# point exception at iteration 106) and the default mode's output (1,211
# cells, no vertex added) converged to a drag coefficient of 1.20; the
# insertion output converged in 113 iterations to 2.35.  Both contrasts are
# printed, not asserted: they are the solver's, not tetopt's.  The error of
# OpenFOAM's Laplacian alone (bench/foam_laplace.py: a harmonic function on
# the boundary, laplacianFoam) must be at most half the raw mesh's.  The
# boundary is kept bit for bit (the referee when present, tetopt's own
# check).
# Usage: bash test_simplefoam.sh TETOPT_CLI SOURCE_DIR   (exit 77 = skip)
source "$(dirname "$0")/cli_prologue.sh" "$@" gmsh tetgen checkMesh simpleFoam
[ -f /usr/share/openfoam/etc/bashrc ] || { echo "skip: no /usr/share/openfoam/etc/bashrc"; exit 77; }
source "$SRC/bench/foam_case.sh"

flow_box_raw 1 "$T/raw.mesh" "$CLI"
"$CLI" improve "$T/raw.mesh" -o "$T/ins.mesh" --report "$T/ins.json" -q --allow-insert --allow-remove
referee "$T/raw.mesh" "$T/ins.mesh" ins
"$PY" -c 'import json, sys; b = json.load(open(sys.argv[1]))["boundary_unchanged"]; sys.exit(0 if b["checked"] and b["ok"] else 1)' \
  "$T/ins.json" || { echo "FAIL: tetopt's own check of the boundary"; exit 1; }

summary() { foam_case "$1" "$T/$2" "$CLI" && foam_run "$T/$2" && foam_summary "$T/$2"; }
ins=$(summary "$T/ins.mesh" case_ins)
echo "insertion output: $ins"
"$CLI" improve "$T/raw.mesh" -o "$T/def.mesh" -q
echo "(for contrast, not asserted) raw input: $(summary "$T/raw.mesh" case_raw)"
echo "(for contrast, not asserted) default mode: $(summary "$T/def.mesh" case_def)"
lap_raw=$(foam_laplace "$T/raw.mesh" "$T/lap_raw" "$CLI")
lap_ins=$(foam_laplace "$T/ins.mesh" "$T/lap_ins" "$CLI")
echo "Laplacian error: raw input $lap_raw; insertion output $lap_ins"
"$PY" - "$ins" "$lap_raw" "$lap_ins" <<'PYEOF'
import sys
d = dict(kv.split("=", 1) for kv in sys.argv[1].split())
lr = dict(kv.split("=", 1) for kv in sys.argv[2].split())
li = dict(kv.split("=", 1) for kv in sys.argv[3].split())
def fail(msg): print("FAIL:", msg); sys.exit(1)
if d["mesh_ok"] != "1": fail("checkMesh did not say 'Mesh OK.'")
if "converged" not in d: fail(f"simpleFoam did not converge (last iteration {d.get('diverged')}, exit {d.get('rc')})")
ref = 2.64
cd = float(d["Cd"])
if not abs(cd - ref) <= 0.15 * ref: fail(f"drag coefficient {cd:.3f}, more than 15% from {ref}")
# The Laplacian's error: at most half the raw mesh's (on this machine 2.65e-3
# against 1.25e-2; the default mode's output 1.01e-2).
if not float(li["laplace_rms"]) <= 0.5 * float(lr["laplace_rms"]):
    fail(f"Laplacian error {li['laplace_rms']} not below half the raw mesh's {lr['laplace_rms']}")
print("ok: converged in %s SIMPLE iterations, Cd %.3f (reference %.2f), Laplacian error %s (raw %s)" % (
    d["converged"], cd, ref, li["laplace_rms"], lr["laplace_rms"]))
PYEOF
