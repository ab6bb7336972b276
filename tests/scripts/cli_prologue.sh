# Sourced by the script tests that run the CLI on meshes they make with gmsh
# (and tetgen): checks the arguments, skips (exit 77) when the CLI, a tool
# named after the two arguments or /usr/bin/python3 is missing, makes the
# scratch folder $T (removed on exit), and defines `referee BEFORE AFTER
# NAME`, which runs ../shared/tools/meshcheck.py compare when it and
# Debian's python3-meshio and python3-numpy are present (have_ref=1) and
# fails the test when it rejects AFTER, and `reaches REPORT.json MIN`, which
# fails the test unless the `improve --report` JSON says the boundary was
# checked and kept and its worst alpha is at least MIN and at most the bound.
# Usage: source cli_prologue.sh TETOPT_CLI SOURCE_DIR [TOOL...]
set -euo pipefail
CLI=${1:?usage: TEST TETOPT_CLI SOURCE_DIR}
SRC=${2:?usage: TEST TETOPT_CLI SOURCE_DIR}
shift 2
PY=/usr/bin/python3
[ -x "$CLI" ] || { echo "skip: no CLI at $CLI"; exit 77; }
for tool in "$@"; do
  command -v "$tool" >/dev/null || { echo "skip: no $tool"; exit 77; }
done
"$PY" -c 'import json' || { echo "skip: no $PY"; exit 77; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
REF="$SRC/../shared/tools/meshcheck.py"
have_ref=0
if [ -f "$REF" ] && "$PY" -c 'import meshio, numpy' 2>/dev/null; then have_ref=1; fi
referee() {
  [ "$have_ref" = 1 ] || return 0
  "$PY" "$REF" compare "$1" "$2" > "$T/ref_$3.log" 2>&1 || { cat "$T/ref_$3.log"; echo "FAIL: the referee rejects $3"; exit 1; }
}
reaches() {
  "$PY" - "$1" "$2" <<'PYEOF'
import json, sys
def fail(msg): print("FAIL:", msg); sys.exit(1)
r, least = json.load(open(sys.argv[1])), float(sys.argv[2])
b = r["boundary_unchanged"]
if not (b["checked"] and b["ok"]): fail(f"boundary_unchanged {b}")
bound = r["diagnosis"]["bound"]["alpha_upper_bound"]
a = r["after"]
print("input %d tets worst %.4f | insertion %d tets worst %.4f mean %.4f | bound %.4f (%.0f%%)" % (
    r["before"]["tets"], r["before"]["alpha_worst"], a["tets"], a["alpha_worst"], a["alpha_mean"], bound,
    100 * a["alpha_worst"] / bound))
if not a["alpha_worst"] >= least: fail(f"worst alpha {a['alpha_worst']:.4f} < {least}")
if not a["alpha_worst"] <= bound + 1e-9: fail("worst alpha above the bound")
PYEOF
}
