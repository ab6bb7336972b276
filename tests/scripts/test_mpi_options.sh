#!/usr/bin/env bash
# tetopt-mpi accepts every option of tetopt improve (both parse them with
# apps/cli/improve_args.cpp).  The options are read from `tetopt improve
# --help`, so an option added there without a value below fails this test.
# For each option: `tetopt-mpi improve` with a valid value exits 0 and writes
# the output; with an invalid value both executables exit 1, write nothing and
# print the same error (up to the "tetopt improve:" / "tetopt-mpi:" prefix).
# tetopt-mpi --help lists every shared option.
# usage: test_mpi_options.sh TETOPT SOURCE_DIR   (exit 77: tetopt-mpi or mpirun absent)
set -u
T=$1
M=$(dirname "$T")/tetopt-mpi
[ -x "$T" ] || { echo "skip: no CLI at $T"; exit 77; }
[ -x "$M" ] || { echo "skip: tetopt-mpi not built (MPI or METIS absent at configure time)"; exit 77; }
command -v mpirun >/dev/null || { echo "skip: no mpirun"; exit 77; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"  # Open MPI's runtime (see test_mpi.sh)
MPIRUN="mpirun --oversubscribe --allow-run-as-root -np 2"
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

# Options of tetopt improve only (not offered by tetopt-mpi, docs/mpi.md).
ONLY_TETOPT=" --field --html "
# A valid value for each option that takes one ("" = a flag; --size and
# --gradation with the --allow-insert they need), and an invalid
# one ("" = none to try).
declare -A GOOD=([--mode]=combined [--optimizer]=maxmin [--weight]=0.8 [--threshold]=0.35
                 [--iterations]=3 [--seed]=7 [--threads]=2 [--report]=REPORT [--msh-version]=22 [--meshb-version]=4
                 [--binary]="" [--allow-insert]="" [--allow-remove]="" [--size]="0.5 --allow-insert" [--gradation]="1.3 --allow-insert" [--no-remesh]="" [--no-check]="" [--objective]=sine [--no-guard]="" [--polish]="" [--keep-order]="" [--write-boundary]="" [--reorder-above]=1000 [-q]="" [--quiet]="" [-v]="" [--verbose]="")
declare -A BAD=([--mode]=bogus [--optimizer]=bogus [--weight]=1.5 [--threshold]=0 [--iterations]=0
                [--seed]=x [--objective]=checkmesh [--reorder-above]=-1 [--size]=-1 [--gradation]=0.9 [--threads]=2000 [--msh-version]=3 [--meshb-version]=5)

"$T" generate "$W/in.mesh" --cells 4 4 4 --jitter 0.3 --seed 2 > /dev/null || { echo "FAIL generate"; exit 1; }
"$T" improve --help > "$W/help_t" && "$M" --help > "$W/help_m" < /dev/null || { echo "FAIL --help"; exit 1; }
# Option names: words starting with - in the options section of the help.
opts=$(sed -n '/^options:/,/^$/p' "$W/help_t" | grep -oE '(^|[ ,])--?[a-z][a-z-]*' | tr -d ' ,' | sort -u)
check "tetopt improve --help lists options ($(echo $opts | wc -w))" '[ $(echo $opts | wc -w) -ge 15 ]'

for o in $opts; do
  case "$o" in -o|--output|-h|--help) continue ;; esac
  case "$ONLY_TETOPT" in *" $o "*) continue ;; esac
  if [ -z "${GOOD[$o]+set}" ]; then
    check "$o: no test value in test_mpi_options.sh (add one)" false
    continue
  fi
  check "$o: listed by tetopt-mpi --help" "grep -qE -- '(^|[ ,])$o([ ,]|\$)' '$W/help_m'"
  v=${GOOD[$o]}; [ "$v" = REPORT ] && v=$W/r.json
  rm -f "$W/out.mesh"
  $MPIRUN "$M" improve "$W/in.mesh" -o "$W/out.mesh" --rounds 1 $o $v > /dev/null 2> "$W/err" < /dev/null; rc=$?
  check "tetopt-mpi improve $o ${GOOD[$o]}: exit 0, output written" '[ $rc -eq 0 ] && [ -s "$W/out.mesh" ]'
  [ $rc -eq 0 ] || head -3 "$W/err"
  [ -n "${BAD[$o]:-}" ] || continue
  rm -f "$W/x.mesh"
  "$T" improve "$W/in.mesh" -o "$W/x.mesh" $o "${BAD[$o]}" > /dev/null 2> "$W/et"; rt=$?
  $MPIRUN "$M" improve "$W/in.mesh" -o "$W/x.mesh" $o "${BAD[$o]}" > /dev/null 2> "$W/em" < /dev/null; rm_=$?
  lt=$(head -1 "$W/et" | sed -E 's/^tetopt( improve)?: //'); lm=$(head -1 "$W/em" | sed -E 's/^tetopt-mpi: //')
  check "$o ${BAD[$o]}: exit 1 in both, nothing written, same message ($lt)" \
    '[ $rt -eq 1 ] && [ $rm_ -eq 1 ] && [ ! -e "$W/x.mesh" ] && [ -n "$lt" ] && [ "$lt" = "$lm" ]'
done

# An option missing its value, and an unknown option: same messages, exit 1.
"$T" improve "$W/in.mesh" -o "$W/x.mesh" --report 2> "$W/et" > /dev/null; rt=$?
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/x.mesh" --report 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "--report without value: same message, exit 1" \
  '[ $rt -eq 1 ] && [ $rm_ -eq 1 ] && [ "$(head -1 "$W/et" | cut -d: -f2-)" = "$(head -1 "$W/em" | cut -d: -f2-)" ]'
"$T" improve "$W/in.mesh" -o "$W/x.mesh" --no-such 2> "$W/et" > /dev/null; rt=$?
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/x.mesh" --no-such 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "unknown option: same message, exit 1" \
  '[ $rt -eq 1 ] && [ $rm_ -eq 1 ] && [ "$(head -1 "$W/et" | cut -d: -f2-)" = "$(head -1 "$W/em" | cut -d: -f2-)" ]'
# Outputs that cannot be written are refused before any work, as in tetopt
# improve: exit 4, nothing written.
mkdir -p "$W/adir.json"
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/y.mesh" --report "$W/adir.json" -q 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "--report naming a folder: exit 4, no output written" '[ $rm_ -eq 4 ] && [ ! -e "$W/y.mesh" ] && grep -q "is a folder" "$W/em"'
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/no/such/y.mesh" -q 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "-o into a missing folder: exit 4" '[ $rm_ -eq 4 ] && grep -q "no such folder" "$W/em"'
# Files that are one: refused with exit 1 before any work, as in tetopt
# improve ("--report IN" replaced the input mesh with the report).
cp "$W/in.mesh" "$W/keep.mesh"
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/z.mesh" --report "$W/in.mesh" -q 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "--report IN: exit 1, IN intact, nothing written" \
  '[ $rm_ -eq 1 ] && cmp -s "$W/in.mesh" "$W/keep.mesh" && [ ! -e "$W/z.mesh" ] && grep -q "name the same file" "$W/em"'
$MPIRUN "$M" improve "$W/in.mesh" -o "$W/z.mesh" --report "$W/z.mesh" -q 2> "$W/em" > /dev/null < /dev/null; rm_=$?
check "--report OUT: exit 1, nothing written" '[ $rm_ -eq 1 ] && [ ! -e "$W/z.mesh" ]'
# tetopt-mpi's own options are its own.
"$T" improve "$W/in.mesh" -o "$W/x.mesh" --rounds 2 2> "$W/et" > /dev/null; rt=$?
check "tetopt improve rejects --rounds (tetopt-mpi only)" '[ $rt -eq 1 ] && grep -q "unknown option" "$W/et"'
exit $fail
