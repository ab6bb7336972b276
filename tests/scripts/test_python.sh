#!/usr/bin/env bash
# The Python bindings' pytest suite (python/tests), against the module built
# next to the CLI: <build>/python.  Exit 77 (skip) only when the tools are
# truly absent (pybind11 headers, Python headers, numpy or pytest for
# /usr/bin/python3); a missing module when they are present is a failure.
# usage: test_python.sh TETOPT_CLI SOURCE_DIR
set -u
T=$1; SRC=$2
PY=/usr/bin/python3
BUILD=$(cd "$(dirname "$T")" && pwd)
T="$BUILD/$(basename "$T")"   # absolute: pytest runs from the tests folder
MOD="$BUILD/python"

[ -x "$PY" ] || { echo "skip: $PY not found"; exit 77; }
if [ ! -f /usr/include/pybind11/pybind11.h ] && [ ! -d /usr/lib/cmake/pybind11 ] && [ ! -d /usr/share/cmake/pybind11 ] \
   && ! "$PY" -c "import pybind11" 2>/dev/null; then
  echo "skip: pybind11 is not installed (Debian: pybind11-dev)"; exit 77
fi
inc=$("$PY" -c "import sysconfig; print(sysconfig.get_paths()['include'])" 2>/dev/null)
[ -f "$inc/Python.h" ] || { echo "skip: Python headers are not installed (Debian: python3-dev)"; exit 77; }
"$PY" -c "import numpy" 2>/dev/null || { echo "skip: numpy is not installed (Debian: python3-numpy)"; exit 77; }
"$PY" -c "import pytest" 2>/dev/null || { echo "skip: pytest is not installed (Debian: python3-pytest)"; exit 77; }

so=$(ls "$MOD"/tetopt/_tetopt*.so 2>/dev/null | head -n 1)
if [ -z "$so" ]; then
  echo "FAIL: pybind11 and Python headers are present but $MOD/tetopt/_tetopt*.so was not built"
  echo "      (configured with -DTETOPT_BUILD_PYTHON=OFF? see the 'tetopt: Python module' line of cmake)"
  exit 1
fi

# A sanitizer build (TETOPT_SANITIZE) instruments the module too: the ASan
# runtime must then be loaded first into the uninstrumented interpreter,
# with libstdc++ (else ASan cannot intercept __cxa_throw and aborts on the
# first C++ exception), and CPython's own allocations are not ours to report
# as leaks.
if ldd "$so" 2>/dev/null | grep -q libasan; then
  asan=$(ldd "$so" | awk '/libasan/ {print $3}')
  stdcxx=$(ldd "$so" | awk '/libstdc\+\+/ {print $3}')
  export LD_PRELOAD="$asan${stdcxx:+:$stdcxx}${LD_PRELOAD:+:$LD_PRELOAD}"
  export ASAN_OPTIONS="detect_leaks=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
  echo "note: sanitizer build, preloading $LD_PRELOAD"
fi

# The module imported must be the one in this build tree.
where=$(PYTHONPATH="$MOD" "$PY" -c "import tetopt; print(tetopt.__file__)") || { echo "FAIL: import tetopt"; exit 1; }
case "$where" in
  "$MOD"/*) echo "ok   import tetopt from $where" ;;
  *) echo "FAIL: imported tetopt from $where, not $MOD"; exit 1 ;;
esac

cd "$SRC/python/tests" || exit 1
PYTHONPATH="$MOD" TETOPT_CLI="$T" PYTHONDONTWRITEBYTECODE=1 \
  exec "$PY" -m pytest -q -p no:cacheprovider -rs "$SRC/python/tests"
