#!/usr/bin/env bash
# Determinism: the same input and seed give byte-identical output for any
# thread count and across runs, in every mode and output format.
# usage: test_determinism.sh TETOPT SOURCE_DIR
set -u
T=$1; SRC=$2
[ -x "$T" ] || { echo "skip: no CLI at $T"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" generate "$W/in.mesh" --cells 5 5 5 --jitter 0.42 --regions 2 --seed 11 || { echo "FAIL generate"; exit 1; }
for mode in best combined smooth topo; do
  for ext in mesh msh vtu; do
    ref=""
    for th in 1 2 4 1; do
      out="$W/${mode}_t${th}_$RANDOM.$ext"
      "$T" improve "$W/in.mesh" -o "$out" --mode "$mode" --seed 3 --threads "$th" -q; rc=$?
      check "$mode .$ext threads $th exits 0" '[ $rc -eq 0 ]'
      if [ -z "$ref" ]; then ref=$out; else
        check "$mode .$ext threads $th identical to threads 1" 'cmp -s "$ref" "$out"'
      fi
    done
  done
done
# A different seed is allowed to differ, but must be deterministic too.
"$T" improve "$W/in.mesh" -o "$W/s7a.mesh" --seed 7 -q && "$T" improve "$W/in.mesh" -o "$W/s7b.mesh" --seed 7 --threads 3 -q
check "seed 7 repeatable" 'cmp -s "$W/s7a.mesh" "$W/s7b.mesh"'
# The report is deterministic apart from timings.
"$T" improve "$W/in.mesh" -o "$W/r1.mesh" --report "$W/r1.json" -q
"$T" improve "$W/in.mesh" -o "$W/r2.mesh" --report "$W/r2.json" --threads 2 -q
strip() { /usr/bin/python3 -c '
import json, sys
drop = {"seconds", "seconds_end_to_end", "output", "threads"}
def clean(x):
    if isinstance(x, dict): return {k: clean(v) for k, v in x.items() if k not in drop}
    if isinstance(x, list): return [clean(v) for v in x]
    return x
print(json.dumps(clean(json.load(open(sys.argv[1]))), sort_keys=True))' "$1"; }
check "reports agree apart from timings, output name and thread count" '[ "$(strip "$W/r1.json")" = "$(strip "$W/r2.json")" ]'
check "output meshes of the reported runs identical" 'cmp -s "$W/r1.mesh" "$W/r2.mesh"'
# quality: the same numbers for every thread count (parallel topology and statistics).
"$T" generate "$W/big.meshb" --cells 16 16 16 --jitter 0.4 --regions 2 --seed 5 > /dev/null  # 24,576 tets: 3 blocks
"$T" quality "$W/big.meshb" --json --threads 1 > "$W/q1.json"; "$T" quality "$W/big.meshb" --json --threads 3 > "$W/q3.json"
check "quality --threads 1 and 3 agree apart from timings" '[ -s "$W/q1.json" ] && [ "$(strip "$W/q1.json")" = "$(strip "$W/q3.json")" ]'
# The start-up re-execution with glibc's huge-page tunable (apps/cli/hugepages.hpp)
# changes speed only: the same bytes with it switched off, and with the
# tunable set by the caller (no re-execution).
TETOPT_NO_HUGEPAGES=1 "$T" improve "$W/big.meshb" -o "$W/h0.mesh" -q
"$T" improve "$W/big.meshb" -o "$W/h1.mesh" -q
GLIBC_TUNABLES=glibc.malloc.hugetlb=1 "$T" improve "$W/big.meshb" -o "$W/h2.mesh" -q
check "huge pages on, off or set by the caller: identical output" 'cmp -s "$W/h0.mesh" "$W/h1.mesh" && cmp -s "$W/h0.mesh" "$W/h2.mesh"'
# The parallel first touch of the heap (prefault_heap, same file) changes
# speed only: the same bytes with it off, at 2 threads where it runs.
TETOPT_NO_PREFAULT=1 "$T" improve "$W/big.meshb" -o "$W/p0.mesh" -q --threads 2
"$T" improve "$W/big.meshb" -o "$W/p1.mesh" -q --threads 2
check "heap prefault on or off: identical output" '[ -s "$W/p0.mesh" ] && cmp -s "$W/p0.mesh" "$W/p1.mesh"'
# The re-executed process sees the tunable (where THP is in madvise mode),
# and arguments survive the re-execution (a bad option is still reported).
"$T" improve "$W/big.meshb" -o "$W/h3.mesh" --threshold 7 2> "$W/h3.err"; rc=$?
check "re-executed: usage error still reported (exit 1)" '[ $rc -eq 1 ] && grep -q threshold "$W/h3.err"'
exit $fail
