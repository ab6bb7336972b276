#!/usr/bin/env bash
# Out of memory is a message, never an abort (issue 25).  Every reader,
# improve and every writer run under shrinking address-space limits
# (ulimit -v): each run must end with 0, 2 (input needs more memory, a
# one-line message saying so) or 4 (output), never with a signal (std::
# bad_alloc used to abort with exit 134), and a failed run leaves no output.
# usage: test_oom.sh TETOPT SOURCE_DIR
set -u
T=$1
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
# An address-space limit breaks AddressSanitizer itself (it reserves
# terabytes of shadow memory): skip in sanitizer builds.
if ldd "$T" 2>/dev/null | grep -q 'libasan\|libubsan'; then echo "skip: sanitizer build"; exit 77; fi
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }
export TETOPT_NO_HUGEPAGES=1 TETOPT_NO_PREFAULT=1

"$T" generate "$W/b.msh" --cells 30 30 30 > /dev/null || { echo "FAIL generate"; exit 1; }
for ext in mesh meshb vtk vtu node; do
  "$T" convert "$W/b.msh" "$W/b.$ext" > /dev/null 2>&1 || { echo "FAIL convert to $ext"; exit 1; }
done
# Limits in KiB of address space, from too small to run at all upward.
# 10000-12000: just above what the shared libraries map, where the first
# allocations of a run fail; until main kept a reserve for that, many runs
# there aborted ("terminate called without an active exception", exit 134:
# convert at 10500 KiB in 7 of 8 runs, quality in up to 12 of 15), depending
# on where the address-space layout put the heap.
limits="10000 10500 11000 11500 12000 15000 20000 30000 40000 50000 60000 80000 120000"

# run CMD...: sets rc and err, under limit $lim
# A limit too small to map the shared libraries (exit 127 from the loader)
# counts as exit 0: the program never ran.  The loader says "error while
# loading shared libraries" when a mapping fails, and only "out of memory"
# when its own allocation does (seen at 10000 KiB once the binary grew by
# 4 KiB: LD_DEBUG=files shows it stopping after libc's link map, before
# main); tetopt itself never exits 127.
run_limited() {
  (ulimit -v "$lim"; "$@" > /dev/null 2> "$W/err"); rc=$?; err=$(head -c 400 "$W/err")
  if [ $rc -eq 127 ] && grep -qx ".*error while loading shared libraries.*\|out of memory" "$W/err"; then rc=0; fi
}

for ext in msh mesh meshb vtk vtu node; do
  saw2=0
  for lim in $limits; do
    run_limited "$T" quality "$W/b.$ext" --threads 1
    if [ $rc -ne 0 ] && [ $rc -ne 2 ]; then echo "FAIL read .$ext at $lim KiB: exit $rc: $err"; fail=1; fi
    if [ $rc -eq 2 ]; then
      saw2=1
      check "read .$ext at $lim KiB: one line naming the file and memory" \
        '[ "$(wc -l < "$W/err")" -eq 1 ] && grep -q "b\.$ext.*out of memory" "$W/err"'
    fi
  done
  check "read .$ext: some limit runs out of memory (exit 2)" '[ $saw2 -eq 1 ]'
done

# improve: exit 0, 2 (out of memory while reading or improving) or 4, and no
# output left by a failed run.
saw=0
for lim in $limits; do
  rm -f "$W/o.mesh"
  run_limited "$T" improve "$W/b.meshb" -o "$W/o.mesh" --threads 1
  case $rc in
    0) ;;
    2|4) saw=1; check "improve at $lim KiB: exit $rc leaves no output" '[ ! -e "$W/o.mesh" ]'
         check "improve at $lim KiB: the message says out of memory" 'grep -q "out of memory" "$W/err"' ;;
    *) echo "FAIL improve at $lim KiB: exit $rc: $err"; fail=1 ;;
  esac
done
check "improve: some limit runs out of memory" '[ $saw -eq 1 ]'

# convert's writers: reading .meshb is the cheapest, so a limit between the
# two makes the writer fail: exit 4 and nothing written.
saw4=0
for ext in msh vtk vtu mesh meshb node; do
  for lim in $limits; do
    rm -f "$W"/w.*
    run_limited "$T" convert "$W/b.meshb" "$W/w.$ext" --threads 1
    case $rc in
      0|2) ;;
      4) saw4=1; check "write .$ext at $lim KiB: nothing written" '[ -z "$(ls "$W"/w.* "$W"/.tmp-* 2>/dev/null)" ]' ;;
      *) echo "FAIL write .$ext at $lim KiB: exit $rc: $err"; fail=1 ;;
    esac
  done
done
check "some writer runs out of memory (exit 4)" '[ $saw4 -eq 1 ]'
exit $fail
