#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan+UBSan) in build-fuzz and runs each
# for SECONDS (default 60) on its corpus.
#   usage: fuzz/run.sh [SECONDS] [TARGET...]      TARGET: medit meditb gmsh vtk vtu tetgen openfoam fluent abaqus ops
#                                                         cgns exodus (built where libcgns / the Exodus II library are found)
#   FUZZ_MERGE=1   merge the new interesting inputs into fuzz/corpus/TARGET
#                  (minimised with -merge=1; keep the committed corpus < 2 MB)
#   FUZZ_JOBS=N    build parallelism (default 2)
#   FUZZ_NOBUILD=1 run the targets already built in build-fuzz
#   FUZZ_SEED=S    libFuzzer seed (default 1, so a CI run is repeatable; 0 = random)
# fuzz/corpus/TARGET holds the seeds (seed-*: valid files of every variant,
# written by fuzz/make_seeds.py; fuzz/check_seeds.sh proves each is read) and
# the merged inputs of earlier runs; fuzz/dict/TARGET.dict, when present, is
# passed as -dict= (the format's keywords).
# New inputs found during a run go to build-fuzz/corpus/TARGET (not committed);
# crashes go to build-fuzz/artifacts/ and make the script exit 1; each target's
# whole output is in build-fuzz/logs/TARGET.log.  Every
# crash must become a regression test (tests/regression/, test_hostile.cpp).
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
secs=${1:-60}; shift || true
# cgns: libcgns 3.4.0 (Debian's libcgns3.4) itself writes past a heap
# buffer under ASan on some mutated ADF files, inside its first call
# (ADFI_read_sub_node_table, reached from cg_is_cgns -> cgio_get_node_id ->
# ADF_Get_Node_ID -> ADFI_check_4_child_name; within 40 s, seed 2,
# 2026-11-28): the reader now refuses ADF files before libcgns sees them
# (src/io/cgns.cpp; the seeds are HDF5).  HDF5's own error paths leak a few
# hundred bytes (LeakSanitizer, within a dozen runs: malloc in
# libhdf5_serial; cgi_malloc in libcgns), which no check of ours can
# prevent, so cgns runs with leak detection off (-detect_leaks=0 and
# ASAN_OPTIONS detect_leaks=0, the check at exit): memory errors still fail it.
# exodus is in: its reader checks the netCDF header before the library
# parses it (src/io/exodus.cpp, check_cdf_header; libnetcdf allocated
# gigabytes on a fuzzed name length before that check, and a 'file_size'
# attribute of several values overran the stack in libexoIIv2c's
# ex_large_model: the check now wants one value there).
targets=${*:-medit meditb gmsh vtk vtu tetgen openfoam fluent abaqus exodus cgns ops}
build=${FUZZ_BUILD:-$root/build-fuzz}
clangxx=$(command -v clang++ || true)
if [ -z "$clangxx" ]; then echo "fuzz: clang++ not found (apt-get install clang libclang-rt-14-dev)" >&2; exit 2; fi
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTETOPT_BUILD_FUZZ=ON \
    -DTETOPT_BUILD_TESTS=OFF -DTETOPT_BUILD_BENCH=OFF -DTETOPT_BUILD_PYTHON=OFF > /dev/null || exit 2
fi
# cgns_fuzz / exodus_fuzz exist only where CMake found their library: a
# target that does not exist is left out, with a line saying so.
known=$(cmake --build "$build" --target help 2>/dev/null)
kept=""; for t in $targets; do
  case $t in cgns|exodus) echo "$known" | grep -q "${t}_fuzz" || { echo "fuzz $t: no target (its library was not found at configure time); skipped" >&2; continue; } ;; esac
  kept="$kept $t"
done
targets=$kept
tlist=""; for t in $targets; do tlist="$tlist ${t}_fuzz"; done
[ "${FUZZ_NOBUILD:-0}" = 1 ] || cmake --build "$build" -j "${FUZZ_JOBS:-2}" --target $tlist > "$build/fuzz-build.log" 2>&1 || { tail -30 "$build/fuzz-build.log" >&2; exit 2; }
mkdir -p "$build/artifacts" "$build/logs"
status=0
failed=""
for t in $targets; do
  work="$build/corpus/$t"; seeds="$here/corpus/$t"
  mkdir -p "$work" "$seeds"
  dict=(); [ -f "$here/dict/$t.dict" ] && dict=(-dict="$here/dict/$t.dict")
  echo "== fuzz $t for ${secs}s"
  # cgns / exodus: their seeds (fuzz/make_lib_seeds.cpp, written by the
  # libraries) are HDF5 and netCDF files of a few kB to 31 kB.
  maxlen=8192; extra=(); asan=${ASAN_OPTIONS:-}
  [ "$t" = cgns ] && { maxlen=32768; extra=(-detect_leaks=0); asan="${asan:+$asan:}detect_leaks=0"; }
  if [ ! -x "$build/fuzz/${t}_fuzz" ]; then echo "fuzz $t: not built (library not found at configure time?)" >&2; status=1; failed="$failed $t"; continue; fi
  ASAN_OPTIONS=$asan "$build/fuzz/${t}_fuzz" -seed="${FUZZ_SEED:-1}" -max_total_time="$secs" -max_len=$maxlen -timeout=20 -rss_limit_mb=2048 \
      "${dict[@]}" "${extra[@]}" -artifact_prefix="$build/artifacts/${t}-" -print_final_stats=1 "$work" "$seeds" 2>&1 |
    tee "$build/logs/$t.log" |
    grep -E "^(#[0-9]+[[:space:]]+DONE|==[0-9]+== ?ERROR|SUMMARY|tetopt|stat::number_of_executed_units|stat::new_units_added)|ERROR: libFuzzer|Test unit written|runtime error"
  rc=${PIPESTATUS[0]}
  if [ "$rc" -ne 0 ]; then echo "fuzz $t: FAILED (exit $rc), see $build/artifacts/" >&2; status=1; failed="$failed $t"; fi
  if [ "${FUZZ_MERGE:-0}" = 1 ]; then
    "$build/fuzz/${t}_fuzz" -merge=1 -max_len=$maxlen "$seeds" "$work" > /dev/null 2>&1
  fi
done
# A failure is repeated at the end, with the end of its log (the full log is
# in build-fuzz/logs/TARGET.log), so that the tail of a CI log names it.
for t in $failed; do
  echo "== fuzz $t FAILED; the end of $build/logs/$t.log:" >&2
  grep -v -E "^(#[0-9]+[[:space:]]+(NEW|REDUCE|pulse|RELOAD)|INFO:)" "$build/logs/$t.log" | tail -40 >&2
  ls -la "$build/artifacts/" | grep -- "$t-" >&2
done
exit $status
