#!/usr/bin/env bash
# The format chain of the foundation issue returns the original arrays bit for
# bit, refs included:  .mesh -> .msh 4.1 -> .vtu -> .meshb -> .msh 2.2 -> .node/.ele -> .mesh
# and a few extra legs (.vtk binary, .msh binary).  Byte-identical final .mesh
# is the check (the writer is deterministic, so equal arrays <=> equal bytes).
# usage: test_chain.sh TETOPT SOURCE_DIR
set -u
T=$1
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
"$T" generate "$W/a.mesh" --cells 5 4 3 --jitter 0.3 --regions 2 --seed 11 || exit 1
# non-trivial coordinates: improve moves interior vertices to arbitrary doubles
"$T" improve "$W/a.mesh" -o "$W/start.mesh" -q || exit 1
"$T" convert "$W/start.mesh" "$W/s1.msh" --msh-version 41 &&
"$T" convert "$W/s1.msh" "$W/s2.vtu" &&
"$T" convert "$W/s2.vtu" "$W/s3.meshb" &&
"$T" convert "$W/s3.meshb" "$W/s4.msh" --msh-version 22 &&
"$T" convert "$W/s4.msh" "$W/s5.node" &&
"$T" convert "$W/s5.node" "$W/end.mesh" || { echo "FAIL a conversion failed"; exit 1; }
if cmp -s "$W/start.mesh" "$W/end.mesh"; then echo "ok   chain returns the same bytes"; else
  echo "FAIL chain changed the mesh"; diff <(head -c 2000 "$W/start.mesh") <(head -c 2000 "$W/end.mesh") | head; fail=1; fi
"$T" convert "$W/start.mesh" "$W/b1.vtk" --binary &&
"$T" convert "$W/b1.vtk" "$W/b2.msh" --binary --msh-version 41 &&
"$T" convert "$W/b2.msh" "$W/b3.msh" --binary --msh-version 22 &&
"$T" convert "$W/b3.msh" "$W/b4.meshb" --meshb-version 4 &&
"$T" convert "$W/b4.meshb" "$W/b5.meshb" --meshb-version 2 &&
"$T" convert "$W/b5.meshb" "$W/end2.mesh" || { echo "FAIL a binary conversion failed"; exit 1; }
if cmp -s "$W/start.mesh" "$W/end2.mesh"; then echo "ok   binary chain returns the same bytes"; else echo "FAIL binary chain changed the mesh"; fail=1; fi
exit $fail
