#!/usr/bin/env bash
# Proves that every seed fuzz/corpus/TARGET/seed-* is a valid file: runs the
# fuzz target on each with TETOPT_FUZZ_STRICT=1 (fuzz_common.hpp), so any
# refusal (reader, check_arrays, inverted tets, build_topology) aborts with
# its reason instead of returning quietly.  Uses the targets in build-fuzz
# (fuzz/run.sh builds them).  Exits 1 when a seed is refused.
#   usage: fuzz/check_seeds.sh [TARGET...]     TARGET: medit meditb gmsh vtk vtu tetgen openfoam fluent abaqus cgns exodus
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=${FUZZ_BUILD:-$root/build-fuzz}
targets=${*:-medit meditb gmsh vtk vtu tetgen openfoam fluent abaqus cgns exodus}
status=0
for t in $targets; do
  exe="$build/fuzz/${t}_fuzz"
  if [ ! -x "$exe" ]; then echo "check_seeds: $exe not built (run fuzz/run.sh 1 $t)" >&2; status=2; continue; fi
  n=0; bad=0
  for f in "$here/corpus/$t"/seed-*; do
    [ -e "$f" ] || continue
    n=$((n + 1))
    if ! out=$(TETOPT_FUZZ_STRICT=1 "$exe" "$f" 2>&1); then
      bad=$((bad + 1))
      echo "REFUSED $t/$(basename "$f"): $(echo "$out" | grep -m1 -E '^tetopt fuzz|ERROR|runtime error')"
    fi
  done
  echo "check_seeds $t: $n seeds, $bad refused"
  [ "$n" -gt 0 ] && [ "$bad" -eq 0 ] || status=1
done
exit $status
