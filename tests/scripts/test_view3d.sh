#!/usr/bin/env bash
# The HTML report's 3D view (issue 30) in headless Chromium (Debian's
# /usr/bin/chromium, driven by playwright-core from node_modules, pinned in
# package-lock.json; `make deps` runs npm ci).  WebGL runs on SwiftShader.
# For the pages of `tetopt quality` and `tetopt improve` on a small
# generated box (view3d_check.mjs):
#   - the view draws a first frame, with no console error and no request
#     outside the page (every host resolves to nothing as well);
#   - a screenshot of the view differs from its background;
#   - dragging rotates it;
#   - quality: clicking the worst tet's table row flies the camera to it, and
#     a click on the tet in the canvas shows the same row as the table;
#   - improve: the before/after toggle shows as many poor tets as the
#     input's statistics and the run's diagnosis count.
# usage: test_view3d.sh TETOPT SOURCE_DIR       exit 77: skipped (no chromium,
# node or playwright-core, or a tetopt built without the view)
set -u
T=$1; SRC=$2
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
PY=/usr/bin/python3
CHROME=${CHROMIUM:-/usr/bin/chromium}
[ -x "$CHROME" ] || { echo "skip: no $CHROME (Debian package chromium; make deps installs it)"; exit 77; }
command -v node > /dev/null || { echo "skip: no node (make deps)"; exit 77; }
[ "$(node -p "process.versions.node.split('.')[0]")" -ge 20 ] 2> /dev/null || { echo "skip: playwright-core needs node 20 or newer, this is $(node --version)"; exit 77; }
[ -f "$SRC/node_modules/playwright-core/package.json" ] ||
  { echo "skip: $SRC/node_modules/playwright-core is missing: run 'make deps' (npm ci)"; exit 77; }
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" generate "$W/box.mesh" --cells 6 6 6 --jitter 0.42 --regions 2 --seed 7 > /dev/null
"$T" quality "$W/box.mesh" --html "$W/quality.html" -q > /dev/null 2>&1; rc=$?
check "quality --html exits 0" '[ $rc -eq 0 ]'
if grep -q 'id="tv-off"' "$W/quality.html"; then
  echo "skip: this tetopt was built without the 3D view (TETOPT_VIEW3D=OFF)"; exit 77
fi
check "quality.html has the view and its data" 'grep -q "id=\"view3d\"" "$W/quality.html" && grep -q "id=\"tv-data\"" "$W/quality.html"'
"$T" improve "$W/box.mesh" -o "$W/out.mesh" --html "$W/improve.html" --report "$W/r.json" -q > /dev/null 2>&1; rc=$?
check "improve --html exits 0" '[ $rc -eq 0 ]'
# What the toggle must show: the input's tets below 0.3 and the run's diagnosis.
before=$("$T" quality "$W/box.mesh" --json | $PY -c 'import json, sys; print(json.load(sys.stdin)["alpha_below_0.3"])')
after=$($PY -c 'import json, sys; print(json.load(open(sys.argv[1]))["diagnosis"]["below_threshold"])' "$W/r.json")
check "the input has poor tets to show ($before)" '[ "$before" -gt 0 ]'

cd "$SRC" || exit 1
node tests/scripts/view3d_check.mjs "$W/quality.html" "$W/quality.png" click || fail=1
node tests/scripts/view3d_check.mjs "$W/improve.html" "$W/improve.png" sets=before,after before="$before" after="$after" || fail=1
exit $fail
