#!/usr/bin/env bash
# `pip install .` and `pip wheel .` from the source tree (issue 29), offline,
# into a fresh `python3 -m venv --system-site-packages` (numpy, meshio and
# pytest from Debian), then the Python suite against the installed package.
# The in-tree backend (python/pep517) reuses this build tree
# (TETOPT_BUILD_DIR): it brings it up to date and packs the wheel, so the
# test costs a venv and a zip, not a build.  A build from scratch is what a
# plain `pip install .` does (README, docs/python.md).
# Exit 77 (skip) when python3-venv / python3-pip or the module are absent.
# usage: test_pip_install.sh TETOPT_CLI SOURCE_DIR
set -u
T=$1; SRC=$2
BUILD=$(cd "$(dirname "$T")" && pwd)
PY=/usr/bin/python3
so=$(ls "$BUILD"/python/tetopt/_tetopt*.so 2>/dev/null | head -n 1)
[ -n "$so" ] || { echo "skip: no Python module in $BUILD"; exit 77; }
# A sanitizer build's module needs the ASan runtime preloaded (test_python.sh
# does that for the build tree); a package for users is a plain build.
ldd "$so" 2>/dev/null | grep -q libasan && { echo "skip: sanitizer build"; exit 77; }
"$PY" -c "import ensurepip" 2>/dev/null || { echo "skip: python3-venv is not installed"; exit 77; }
"$PY" -m pip --version > /dev/null 2>&1 || { echo "skip: python3-pip is not installed"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
export PYTHONDONTWRITEBYTECODE=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INDEX=1 TETOPT_BUILD_DIR="$BUILD"
fail=0
ok() { echo "ok   $1"; }
bad() { echo "FAIL $1"; fail=1; }

"$PY" -m venv --system-site-packages "$W/venv" || { echo "FAIL python3 -m venv"; exit 1; }
V="$W/venv/bin"
if "$V/pip" install -q "$SRC" > "$W/install.log" 2>&1; then ok "pip install . (offline, in a fresh venv)"; else
  tail -30 "$W/install.log"; echo "FAIL pip install ."; exit 1; fi
where=$(cd "$W" && "$V/python" -c "import tetopt, os; print(os.path.dirname(tetopt.__file__))")
case "$where" in "$W/venv/"*) ok "import tetopt from the venv ($where)" ;; *) bad "import tetopt from $where" ;; esac
for f in __init__.py __init__.pyi py.typed _cli.py _bin/tetopt; do [ -e "$where/$f" ] || bad "installed: tetopt/$f missing"; done
ls "$where"/_tetopt*.so > /dev/null 2>&1 || bad "installed: the compiled module is missing"
[ -f "$W/venv/share/man/man1/tetopt.1" ] && ok "man page in the venv's share/man/man1" || bad "no man page in the venv"
[ "$("$V/tetopt" --version)" = "$("$T" --version)" ] && ok "the tetopt entry point runs ($("$V/tetopt" --version))" \
  || bad "the tetopt entry point"
"$V/tetopt" improve /nonexistent.mesh -o "$W/x.mesh" 2> /dev/null; rc=$?
[ $rc -eq 2 ] && ok "the entry point passes exit codes through (missing input: 2)" || bad "entry point exit code $rc, not 2"

# pip wheel: the same package as a wheel file.
if "$V/pip" wheel -q --no-deps -w "$W/wheels" "$SRC" > "$W/wheel.log" 2>&1; then
  whl=$(ls "$W"/wheels/tetopt-*.whl 2>/dev/null | head -n 1)
  if [ -n "$whl" ] && "$V/python" - "$whl" <<'PY'
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
need = ["tetopt/__init__.py", "tetopt/__init__.pyi", "tetopt/py.typed", "tetopt/_bin/tetopt",
        "tetopt-0.1.0.data/data/share/man/man1/tetopt.1", "tetopt-0.1.0.dist-info/entry_points.txt",
        "tetopt-0.1.0.dist-info/RECORD"]
missing = [n for n in need if n not in names] + ([] if any(n.startswith("tetopt/_tetopt.") for n in names) else ["module"])
sys.exit(f"missing: {missing}" if missing else 0)
PY
  then ok "pip wheel . gives $(basename "$whl")"; else bad "pip wheel: wheel missing or incomplete"; fi
else
  tail -20 "$W/wheel.log"; bad "pip wheel ."
fi

# The Python suite against the installed package (the entry point as the CLI).
cd "$W" || exit 1
if TETOPT_CLI="$V/tetopt" "$V/python" -m pytest -q -p no:cacheprovider -rfEs "$SRC/python/tests" > "$W/pytest.log" 2>&1; then
  ok "python/tests against the installed package: $(tail -n 1 "$W/pytest.log")"
else
  grep -E "^(FAILED|ERROR)" "$W/pytest.log"; tail -40 "$W/pytest.log"; bad "python/tests against the installed package"
fi
exit $fail
