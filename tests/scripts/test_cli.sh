#!/usr/bin/env bash
# CLI behaviour: help, exit codes, clear errors, atomic output, determinism,
# and improve judged by the independent referee when it is available.
# usage: test_cli.sh TETOPT SOURCE_DIR
set -u
T=$1; SRC=$2
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" --help > "$W/help" 2>&1;                 check "--help exits 0" '[ $? -eq 0 ]'
check "--help documents exit codes" 'grep -q "invariant failure" "$W/help"'
for c in quality improve convert generate; do
  "$T" $c --help > "$W/h_$c" 2>&1;            check "$c --help exits 0" '[ $? -eq 0 ] && grep -q "usage: tetopt $c" "$W/h_$c"'
done
"$T" frobnicate > /dev/null 2>&1;             check "unknown command exits 1" '[ $? -eq 1 ]'
"$T" improve "$W/none.mesh" -o "$W/x.mesh" 2> "$W/err"; rc=$?
check "missing input exits 2" '[ $rc -eq 2 ]'
check "missing input message names the file" 'grep -q "none.mesh" "$W/err"'
"$T" improve in.mesh --weight 1.5 -o "$W/x.mesh" 2> /dev/null; check "bad --weight exits 1" '[ $? -eq 1 ]'
for bad in -5 99999999999999999999; do   # negative, or past 64 bits (was taken as LLONG_MAX)
  "$T" improve in.mesh --seed $bad -o "$W/x.mesh" 2> /dev/null; check "--seed $bad exits 1" '[ $? -eq 1 ]'
done

# A malformed file: one line naming file and line, exit 2, nothing written.
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 9 1\nEnd\n' > "$W/bad.mesh"
"$T" improve "$W/bad.mesh" -o "$W/bad_out.mesh" 2> "$W/err"; rc=$?
check "out-of-range index exits 2" '[ $rc -eq 2 ]'
check "error names the file" 'grep -q "bad.mesh" "$W/err"'
check "nothing written on input error" '[ ! -e "$W/bad_out.mesh" ]'
check "error is one line" '[ $(wc -l < "$W/err") -eq 1 ]'

# Generated two-region mesh, improved twice: identical bytes, valid result.
"$T" generate "$W/box.mesh" --cells 6 6 6 --jitter 0.4 --regions 2 --seed 5
check "generate writes a mesh" '[ -s "$W/box.mesh" ]'
"$T" improve "$W/box.mesh" -o "$W/a.mesh" --report "$W/r.json" -q; rc=$?
check "improve exits 0" '[ $rc -eq 0 ]'
"$T" improve "$W/box.mesh" -o "$W/b.mesh" -q
check "same input and seed give byte-identical output" 'cmp -s "$W/a.mesh" "$W/b.mesh"'
# --meshb-version as in convert: the GMF version word of the .meshb written.
"$T" improve "$W/box.mesh" -o "$W/v4.meshb" --meshb-version 4 -q; rc=$?
check "improve --meshb-version 4 writes a version-4 .meshb" \
  '[ $rc -eq 0 ] && [ "$(od -A n -t d4 -j 4 -N 4 "$W/v4.meshb" | tr -d " ")" = 4 ]'
"$T" improve "$W/box.mesh" -o "$W/v5.meshb" --meshb-version 5 -q 2> /dev/null; rc=$?
check "improve --meshb-version 5 exits 1" '[ $rc -eq 1 ] && [ ! -e "$W/v5.meshb" ]'
# convert --threads: the parallel reader and writer give the serial bytes
# (83k tets: sections larger than the reader's 1 MiB chunks).
"$T" generate "$W/big.mesh" --cells 24 24 24 --jitter 0.3 --seed 3
"$T" convert "$W/big.mesh" "$W/c1.mesh" --threads 1
"$T" convert "$W/big.mesh" "$W/c2.mesh" --threads 2; rc=$?
check "convert --threads 2 exits 0" '[ $rc -eq 0 ]'
check "convert --threads 2 gives the bytes of 1 thread" 'cmp -s "$W/c1.mesh" "$W/c2.mesh" && [ -s "$W/c1.mesh" ]'
# An option without its value: exit 1 and say so.
"$T" quality "$W/box.mesh" --threads 2> "$W/err"; rc=$?
check "option without a value exits 1" '[ $rc -eq 1 ]'
check "option without a value is named" 'grep -q -- "--threads needs a value" "$W/err"'
"$T" convert "$W/box.mesh" "$W/nv.mesh" --msh-version 2> "$W/err"; rc=$?
check "convert option without a value exits 1, writes nothing" '[ $rc -eq 1 ] && [ ! -e "$W/nv.mesh" ] && grep -q "needs a value" "$W/err"'
check "report is JSON with the invariant verdict" '/usr/bin/python3 -c "
import json,sys; r=json.load(open(\"$W/r.json\"))
assert r[\"boundary_unchanged\"][\"ok\"] is True
assert r[\"after\"][\"alpha_worst\"] > r[\"before\"][\"alpha_worst\"]
assert r[\"options\"][\"mode\"] == \"best\"
"'
"$T" quality "$W/a.mesh" --json > "$W/q.json"
check "quality --json parses" '/usr/bin/python3 -c "import json; json.load(open(\"$W/q.json\"))"'
"$T" quality "$W/a.mesh" --field "$W/q.vtu" -q > /dev/null
check "quality --field writes a .vtu" 'grep -q "Name=\"alpha\"" "$W/q.vtu"'

# Unwritable output: exit 4, no partial file left behind.
"$T" improve "$W/box.mesh" -o "$W/no/such/dir/out.mesh" -q 2> "$W/err"; rc=$?
check "unwritable output exits 4" '[ $rc -eq 4 ]'
check "no temporary files left" '[ -z "$(ls "$W" | grep tmp-)" ]'

# A tangled input (one free vertex dragged through its neighbours): improve
# untangles it, exits 0, and never makes the mesh worse.
"$T" generate "$W/t.mesh" --cells 4 4 4 --seed 2
/usr/bin/python3 - "$W/t.mesh" <<'PY'
import sys
p = sys.argv[1]; L = open(p).read().split("\n")
i = L.index("Vertices") + 2
# vertex (2,2,2) of the 5x5x5 grid is id 2*25+2*5+2 = 62 (0-based)
x, y, z, r = L[i + 62].split()
L[i + 62] = f"{float(x)+1.3} {y} {z} {r}"
open(p, "w").write("\n".join(L))
PY
"$T" quality "$W/t.mesh" --json -q > "$W/tq.json" 2>/dev/null
check "the tangled input has inverted tets" '/usr/bin/python3 -c "import json; assert json.load(open(\"$W/tq.json\"))[\"inverted_or_flat\"] > 0"'
"$T" improve "$W/t.mesh" -o "$W/tu.mesh" --report "$W/tu.json" > "$W/tu.out" 2>&1; rc=$?
check "tangled input: improve exits 0" '[ $rc -eq 0 ]'
check "tangled input: every tet positive afterwards" '/usr/bin/python3 -c "
import json; r=json.load(open(\"$W/tu.json\"))
assert r[\"after\"][\"inverted_or_flat\"] == 0 and r[\"operations\"][\"untangled\"] > 0"'

# An inverted tet no move can fix (all four vertices constrained: it folds
# back over its neighbour): exit 0, and the summary must not claim "no
# inverted tet" (it did) but say that input tets stay inverted or flat.
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 0\nTetrahedra\n2\n1 2 3 4 1\n5 3 2 4 1\nEnd\n' > "$W/fold.mesh"
"$T" improve "$W/fold.mesh" -o "$W/fold_out.mesh" --threads 1 --html "$W/fold.html" > "$W/fold.out" 2> /dev/null; rc=$?
check "folded input: improve exits 0" '[ $rc -eq 0 ]'
check "folded input: summary says the input tet stays inverted" 'grep -q "no new inverted or flat tet (1 input tets stay inverted or flat)" "$W/fold.out"'
check "folded input: summary does not claim no inverted tet" '! grep -q "no inverted tet" "$W/fold.out"'
check "folded input: HTML verdict says the same" 'grep -q "1 input tets stay inverted or flat" "$W/fold.html"'

# Signals while an output is being written: SIGTERM and SIGHUP end the
# process as usual but remove the temporary file (OUT.tmp-PID-N was left
# behind); Ctrl-C ends convert, quality and generate with exit 130 and
# nothing written (it was ignored: exit 0).  A signal that comes after the
# run ended tests nothing and is reported as such.
"$T" generate "$W/sig.mesh" --cells 32 32 32 --jitter 0.3 > /dev/null
/usr/bin/python3 - "$T" "$W" > "$W/sig.out" 2>&1 <<'PY'
import os, signal, subprocess, sys, time
T, W = os.path.abspath(sys.argv[1]), sys.argv[2]
d = os.path.join(W, "sig"); os.makedirs(d)
bad = 0
def case(args, sig, want_rc):
    global bad
    for f in os.listdir(d): os.remove(os.path.join(d, f))
    p = subprocess.Popen([T] + args, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.time()
    def writing():  # a temporary file with bytes in it (the empty one is the start's folder probe)
        try: return any(".tmp-" in f and os.path.getsize(os.path.join(d, f)) > 0 for f in os.listdir(d))
        except OSError: return False
    while p.poll() is None and not writing() and time.time() - t0 < 60:
        time.sleep(0.0002)
    if p.poll() is not None:
        print("not tested (ended before its output was begun):", args[0], sig); p.wait(); return
    p.send_signal(sig); rc = p.wait()
    left = sorted(os.listdir(d))
    ok = rc == want_rc and not any(".tmp-" in f for f in left) and (sig != signal.SIGINT or not left)
    print("ok  " if ok else "BAD ", args[0], int(sig), "rc", rc, "left", left)
    bad += not ok
case(["improve", "../sig.mesh", "-o", "o.mesh", "--threads", "1", "-q"], signal.SIGTERM, -signal.SIGTERM)
case(["convert", "../sig.mesh", "o.vtu"], signal.SIGHUP, -signal.SIGHUP)
case(["convert", "../sig.mesh", "o.mesh"], signal.SIGINT, 130)
sys.exit(bad)
PY
rc=$?
check "signals while writing: no temporary file left, Ctrl-C exits 130 ($(tr '\n' ';' < "$W/sig.out"))" '[ $rc -eq 0 ]'

# Two outputs that are one file through a link that points nowhere yet:
# refused with exit 1 (the field file used to replace the improved mesh,
# exit 0).
mkdir -p "$W/ln/sub" && ln -s ../o.mesh "$W/ln/sub/x.vtu" && ln -s r.json "$W/ln/l.json"
"$T" improve "$W/box.mesh" -o "$W/ln/o.mesh" --field "$W/ln/sub/x.vtu" -q 2> "$W/ln/err1"; rc=$?
check "dangling link to -o as --field: exit 1, nothing written" '[ $rc -eq 1 ] && [ ! -e "$W/ln/o.mesh" ] && grep -q "name the same file" "$W/ln/err1"'
"$T" improve "$W/box.mesh" -o "$W/ln/x.mesh" --report "$W/ln/r.json" --html "$W/ln/l.json" -q 2> /dev/null; rc=$?
check "dangling link to --report as --html: exit 1" '[ $rc -eq 1 ] && [ ! -e "$W/ln/r.json" ]'

# An option given twice with two values: exit 1 naming both (the last one
# silently won); the same value twice is accepted.
"$T" improve "$W/box.mesh" -o "$W/tw1.mesh" -o "$W/tw2.vtu" -q 2> "$W/err"; rc=$?
check "-o given twice: exit 1, both values named, nothing written" \
  '[ $rc -eq 1 ] && grep -q "given twice" "$W/err" && [ ! -e "$W/tw1.mesh" ] && [ ! -e "$W/tw2.vtu" ]'
"$T" improve "$W/box.mesh" -o "$W/tw3.mesh" --threads 1 --threads 1 -q; rc=$?
check "the same value twice is accepted" '[ $rc -eq 0 ] && [ -s "$W/tw3.mesh" ]'

# generate: a box beyond 32-bit tet ids is refused before any allocation
# (1300^3 cells aborted with std::length_error); a seed out of range is
# refused, not saturated.
"$T" generate "$W/huge.mesh" --cells 1300 1300 1300 2> "$W/err"; rc=$?
check "generate beyond 2^31 - 1 tets: exit 1, says why" '[ $rc -eq 1 ] && grep -q "32-bit" "$W/err" && [ ! -e "$W/huge.mesh" ]'
"$T" generate "$W/s.mesh" --cells 2 2 2 --seed 99999999999999999999999 2> "$W/err"; rc=$?
check "generate --seed out of range: exit 1" '[ $rc -eq 1 ] && grep -q "out of range" "$W/err"'
"$T" generate "$W/s.mesh" --cells 2 2 2 --seed -5 2> /dev/null; rc=$?
check "generate --seed -5: exit 1" '[ $rc -eq 1 ]'

# --iterations 0 is refused (it ran one round anyway, and the report said 1).
"$T" improve "$W/box.mesh" -o "$W/it0.mesh" --iterations 0 -q 2> "$W/err"; rc=$?
check "--iterations 0: exit 1, nothing written" '[ $rc -eq 1 ] && grep -q "1..1000000" "$W/err" && [ ! -e "$W/it0.mesh" ]'

# --allow-remove: vertices removed (none left unreferenced), the proof holds,
# the worst alpha within 3% of the run without it on this mesh.  (Removal
# takes only changes that raise a star's worst alpha, but the later passes
# then meet another mesh: on this box it ended 0.8% below the run without
# after the pair search came in, 0.5405 against 0.5450, measured 2026-11-23.)
"$T" generate "$W/rm.mesh" --cells 8 8 8 --jitter 0.45 --seed 3 > /dev/null
"$T" improve "$W/rm.mesh" -o "$W/rm_a.mesh" --allow-insert --report "$W/rm_a.json" -q
"$T" improve "$W/rm.mesh" -o "$W/rm_b.mesh" --allow-insert --allow-remove --report "$W/rm_b.json" -q; rc=$?
check "--allow-remove exits 0" '[ $rc -eq 0 ]'
check "--allow-remove: vertices removed and dropped, proof ok, worst alpha within 3% of without" '/usr/bin/python3 -c "
import json
a = json.load(open(\"$W/rm_a.json\")); b = json.load(open(\"$W/rm_b.json\"))
assert b[\"options\"][\"allow_remove\"] is True and a[\"options\"][\"allow_remove\"] is False
assert b[\"operations\"][\"vertex_removals\"] > 0, b[\"operations\"]
assert b[\"boundary_unchanged\"][\"ok\"] is True
assert b[\"after\"][\"alpha_worst\"] >= 0.97 * a[\"after\"][\"alpha_worst\"], (b[\"after\"][\"alpha_worst\"], a[\"after\"][\"alpha_worst\"])
"'
check "--allow-remove: no unreferenced vertex in the output" '/usr/bin/python3 -c "
tok = open(\"$W/rm_b.mesh\").read().split()
i = tok.index(\"Vertices\"); nv = int(tok[i + 1])
j = tok.index(\"Tetrahedra\"); nt = int(tok[j + 1])
used = set(int(x) for k in range(nt) for x in tok[j + 2 + 5 * k: j + 6 + 5 * k])
assert used == set(range(1, nv + 1)), (nv, len(used))
"'

MC="$SRC/../shared/tools/meshcheck.py"
if [ -f "$MC" ] && /usr/bin/python3 -c "import meshio" 2>/dev/null; then
  for mode in smooth topo combined best; do
    "$T" improve "$W/box.mesh" -o "$W/m_$mode.mesh" --mode $mode -q
    /usr/bin/python3 "$MC" compare "$W/box.mesh" "$W/m_$mode.mesh" > "$W/mc_$mode" 2>&1
    check "referee accepts --mode $mode" '[ $? -eq 0 ]'
  done
else
  echo "skip referee checks (../shared/tools/meshcheck.py or meshio absent)"
fi
# A tet listed with two vertices exchanged (the same order as its neighbour
# on their shared face): refused with exit 2, the tet named, nothing written.
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0.2 0.2 0.2 0\nTetrahedra\n4\n1 2 3 5 1\n1 4 2 5 1\n1 3 4 5 1\n2 3 4 5 1\nEnd\n' > "$W/misnumbered.mesh"
"$T" improve "$W/misnumbered.mesh" -o "$W/misnumbered_out.mesh" -q 2> "$W/misnumbered.err"; rc=$?
check "a misnumbered tet is refused (exit 2, named, nothing written)" \
  '[ $rc -eq 2 ] && [ ! -e "$W/misnumbered_out.mesh" ] && grep -q "misnumbered.mesh: 1 tet is listed with vertices in the opposite order.*(tet 4," "$W/misnumbered.err"'
sed 's/^2 3 4 5 1$/2 4 3 5 1/' "$W/misnumbered.mesh" > "$W/renumbered.mesh"
"$T" improve "$W/renumbered.mesh" -o "$W/renumbered_out.mesh" -q; rc=$?
check "the same mesh listed consistently is improved" '[ $rc -eq 0 ] && [ -s "$W/renumbered_out.mesh" ]'
# Side outputs never replace the input or the main output (exit 1, the file
# intact), and an output into a missing folder fails before anything is written.
cp "$W/renumbered.mesh" "$W/keep.mesh"
"$T" quality "$W/keep.mesh" --field "$W/keep.mesh" 2> /dev/null; rc=$?
check "quality --field over IN: exit 1, IN intact" '[ $rc -eq 1 ] && cmp -s "$W/keep.mesh" "$W/renumbered.mesh"'
"$T" improve "$W/keep.mesh" -o "$W/side.mesh" --html "$W/./keep.mesh" -q 2> /dev/null; rc=$?
check "improve --html over IN: exit 1, IN intact, no output" '[ $rc -eq 1 ] && cmp -s "$W/keep.mesh" "$W/renumbered.mesh" && [ ! -e "$W/side.mesh" ]'
"$T" improve "$W/keep.mesh" -o "$W/side.mesh" --report "$W/side.mesh" -q 2> /dev/null; rc=$?
check "improve --report over -o: exit 1, nothing written" '[ $rc -eq 1 ] && [ ! -e "$W/side.mesh" ]'
"$T" improve "$W/keep.mesh" -o "$W/side.mesh" --field "$W/no/such/f.vtu" -q 2> "$W/side.err"; rc=$?
check "improve --field into a missing folder: exit 4, no output written" '[ $rc -eq 4 ] && [ ! -e "$W/side.mesh" ] && grep -q "no such folder" "$W/side.err"'
# A TetGen name stands for its .node, .ele and .face: a side output over one
# of IN's or OUT's companions is refused like one over the file named.
"$T" convert "$W/keep.mesh" "$W/tg.node" && cp "$W/tg.ele" "$W/tg.ele.orig"
"$T" improve "$W/tg.node" -o "$W/tgo.mesh" --report "$W/tg.ele" -q 2> "$W/tg.err"; rc=$?
check "improve --report over IN's .ele: exit 1, IN intact, no output" \
  '[ $rc -eq 1 ] && cmp -s "$W/tg.ele" "$W/tg.ele.orig" && [ ! -e "$W/tgo.mesh" ] && grep -q "both name the file" "$W/tg.err"'
"$T" improve "$W/keep.mesh" -o "$W/tgo.node" --html "$W/tgo.face" -q 2> /dev/null; rc=$?
check "improve --html over OUT's .face: exit 1, nothing written" '[ $rc -eq 1 ] && [ ! -e "$W/tgo.node" ] && [ ! -e "$W/tgo.face" ]'
"$T" improve "$W/keep.mesh" -o "$W/tgr.mesh" --report "$W/tgr.ele" -q; rc=$?
check "a report named .ele beside a .mesh output is fine" '[ $rc -eq 0 ] && [ -s "$W/tgr.ele" ]'
mkdir -p "$W/tgd.face"
"$T" convert "$W/keep.mesh" "$W/tgd.node" 2> "$W/tg.err"; rc=$?
check "convert to a TetGen set whose .face is a folder: exit 4, no .node or .ele" \
  '[ $rc -eq 4 ] && [ ! -e "$W/tgd.node" ] && [ ! -e "$W/tgd.ele" ] && grep -q "tgd.face" "$W/tg.err"'
# What OUT's format cannot hold is named in a warning and in the report.
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n5\n0 0 0 1\n1 0 0 2\n0 1 0 0\n0 0 1 0\n1 1 1 7\nTetrahedra\n2\n1 2 3 4 1\n2 3 4 5 2\nRequiredVertices\n1\n2\nEnd\n' > "$W/vr.mesh"
# Options that would do nothing are refused; "--" ends the options.
"$T" improve "$W/vr.mesh" -o "$W/ai.mesh" --mode smooth --allow-insert 2> "$W/ai.err"; rc=$?
check "--allow-insert outside mode best: exit 1, says so" '[ $rc -eq 1 ] && grep -q "works in --mode best only" "$W/ai.err" && [ ! -e "$W/ai.mesh" ]'
cp "$W/vr.mesh" "$W/-dash.mesh"
(cd "$W" && "$T" improve -o dash_out.mesh -q -- -dash.mesh); rc=$?
check "-- ends the options: an input named -dash.mesh" '[ $rc -eq 0 ] && [ -s "$W/dash_out.mesh" ]'
"$T" convert "$W/vr.mesh" "$W/vr.msh" 2> "$W/vr.err"; rc=$?
check "convert to .msh warns of the vertex refs and required vertices it leaves out" \
  '[ $rc -eq 0 ] && grep -q "vr.msh: this format cannot hold the input.s vertex refs (3 nonzero) and required vertices (1)" "$W/vr.err"'
"$T" convert "$W/vr.mesh" "$W/vr2.mesh" 2> "$W/vr.err"
check "convert to .mesh keeps everything: no warning" '[ ! -s "$W/vr.err" ]'
"$T" improve "$W/vr.mesh" -o "$W/vr.vtu" --report "$W/vr.json" -q 2> "$W/vr.err"
check "improve -q: no warning, the report lists what was left out" \
  '[ ! -s "$W/vr.err" ] && /usr/bin/python3 -c "import json,sys; sys.exit(json.load(open(sys.argv[1]))[\"dropped_on_write\"] != [\"vertex refs (3 nonzero)\", \"required vertices (1)\"])" "$W/vr.json"'
# An output that is a folder, a FIFO or a link to a device is refused before
# any work (renaming the temporary over it would replace it): exit 4, the
# target as it was, no other output written.  A link to a regular file is
# followed: the file is rewritten and the link stays a link.
mkdir -p "$W/adir.html"
"$T" improve "$W/keep.mesh" -o "$W/side.mesh" --report "$W/side.json" --html "$W/adir.html" -q 2> "$W/side.err"; rc=$?
check "improve --html naming a folder: exit 4 before any output" \
  '[ $rc -eq 4 ] && [ -d "$W/adir.html" ] && [ ! -e "$W/side.mesh" ] && [ ! -e "$W/side.json" ] && grep -q "is a folder" "$W/side.err"'
ln -sf /dev/null "$W/null.json"
"$T" improve "$W/keep.mesh" -o "$W/side.mesh" --report "$W/null.json" -q 2> "$W/side.err"; rc=$?
check "improve --report through a link to /dev/null: exit 4, link and device intact" \
  '[ $rc -eq 4 ] && [ -L "$W/null.json" ] && [ -c /dev/null ] && [ ! -e "$W/side.mesh" ] && grep -q "not a regular file" "$W/side.err"'
if mkfifo "$W/outfifo.mesh" 2> /dev/null; then
  "$T" convert "$W/keep.mesh" "$W/outfifo.mesh" 2> /dev/null; rc=$?
  check "convert into a FIFO: exit 4, the FIFO kept" '[ $rc -eq 4 ] && [ -p "$W/outfifo.mesh" ]'
fi
echo old > "$W/real_out.mesh"
ln -sf real_out.mesh "$W/link_out.mesh"
"$T" improve "$W/keep.mesh" -o "$W/link_out.mesh" -q; rc=$?
check "improve -o through a link to a file: the file rewritten, the link kept" \
  '[ $rc -eq 0 ] && [ -L "$W/link_out.mesh" ] && head -1 "$W/real_out.mesh" | grep -q MeshVersionFormatted'
# A FIFO as input is refused at once (opening it must not wait for a writer).
if mkfifo "$W/fifo.mesh" 2> /dev/null; then
  timeout 20 "$T" quality "$W/fifo.mesh" 2> "$W/fifo.err"; rc=$?
  check "a FIFO as input: exit 2 without waiting" '[ $rc -eq 2 ] && grep -q "not a regular file" "$W/fifo.err"'
fi
# Coordinates where alpha would overflow: quality and improve refuse them
# (exit 2, the vertex named); convert keeps every digit.
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1e70 0 0 0\n0 1e70 0 0\n0 0 1e70 0\nTetrahedra\n1\n1 2 3 4 1\nEnd\n' > "$W/huge.mesh"
"$T" quality "$W/huge.mesh" -q 2> "$W/huge.err"; rc=$?
check "coordinates of 1e70: quality exits 2 naming the vertex" '[ $rc -eq 2 ] && grep -q "huge.mesh: vertex 2 has a coordinate beyond 1e60" "$W/huge.err"'
"$T" convert "$W/huge.mesh" "$W/huge.meshb" && "$T" convert "$W/huge.meshb" "$W/huge2.mesh"; rc=$?
check "coordinates of 1e70: convert round-trips them" '[ $rc -eq 0 ] && grep -q "^1e+70 0 0" "$W/huge2.mesh"'
# A mesh of --reorder-above tets or more whose tets follow no spatial order
# (a 94k-tet box with its tets shuffled; the default, 1,000,000 tets, would
# make a slow test) is put in Morton order before improve: the report says
# so, its input worst tet is still counted in IN's order, the result is the
# same for 1 and 2 threads and keeps the boundary.  --keep-order keeps IN's
# order, so does the default threshold here, and the in-order box is not
# reordered.
"$T" generate "$W/big.mesh" --cells 25 25 25 --jitter 0.3 --seed 3 > /dev/null
/usr/bin/python3 - "$W/big.mesh" "$W/scattered.mesh" <<'PY'
import random, sys
lines = open(sys.argv[1]).read().split("\n")
i = lines.index("Tetrahedra"); n = int(lines[i + 1])
body = lines[i + 2:i + 2 + n]
random.Random(4).shuffle(body)
lines[i + 2:i + 2 + n] = body
open(sys.argv[2], "w").write("\n".join(lines))
PY
field() { /usr/bin/python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
for t in 1 2; do
  "$T" improve "$W/scattered.mesh" -o "$W/sc$t.mesh" --mode smooth --iterations 1 --threads $t --reorder-above 90000 --report "$W/sc$t.json" -q; rc=$?
  check "scattered 94k tets, $t thread(s): exit 0" '[ $rc -eq 0 ]'
done
check "scattered mesh: reordered, same bytes for 1 and 2 threads" \
  '[ "$(field "$W/sc1.json" "d[\"tets_reordered\"]")" = True ] && cmp -s "$W/sc1.mesh" "$W/sc2.mesh"'
wq=$("$T" quality "$W/scattered.mesh" --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["worst_tet"])')
check "scattered mesh: the report's input worst tet is IN's ($wq)" '[ "$(field "$W/sc1.json" "d[\"before\"][\"worst_tet\"]")" = "$wq" ]'
"$T" improve "$W/scattered.mesh" -o "$W/sck.mesh" --mode smooth --iterations 1 --keep-order --reorder-above 90000 --report "$W/sck.json" -q
check "scattered mesh, --keep-order (before --reorder-above): not reordered" '[ "$(field "$W/sck.json" "d[\"tets_reordered\"]")" = False ]'
"$T" improve "$W/scattered.mesh" -o "$W/scd.mesh" --mode smooth --iterations 1 --report "$W/scd.json" -q
check "scattered mesh below the default threshold: not reordered" '[ "$(field "$W/scd.json" "d[\"tets_reordered\"]")" = False ]'
"$T" improve "$W/big.mesh" -o "$W/bigo.mesh" --mode smooth --iterations 1 --reorder-above 90000 --report "$W/bigo.json" -q
check "the same box in order: not reordered" '[ "$(field "$W/bigo.json" "d[\"tets_reordered\"]")" = False ]'
# A topology error found after the reorder names tets by their number in IN:
# the same message as without reordering (a tet of the shuffled box repeated
# at the end of its list).
/usr/bin/python3 - "$W/scattered.mesh" "$W/dup.mesh" <<'PY'
import sys
lines = open(sys.argv[1]).read().split("\n")
i = lines.index("Tetrahedra"); n = int(lines[i + 1])
lines[i + 1] = str(n + 1)
lines.insert(i + 2 + n, lines[i + 2 + 500])
open(sys.argv[2], "w").write("\n".join(lines))
PY
"$T" improve "$W/dup.mesh" -o "$W/dup_out.mesh" --reorder-above 90000 -q 2> "$W/dup_r.err"; rc=$?
"$T" improve "$W/dup.mesh" -o "$W/dup_out.mesh" --keep-order -q 2> "$W/dup_k.err"
check "topology error after the reorder: exit 2, tets named as in IN (same message as --keep-order)" \
  '[ $rc -eq 2 ] && [ -s "$W/dup_r.err" ] && cmp -s "$W/dup_r.err" "$W/dup_k.err" && grep -q "501" "$W/dup_r.err" && [ ! -e "$W/dup_out.mesh" ]'
if [ -f "$MC" ] && /usr/bin/python3 -c "import meshio" 2>/dev/null; then
  /usr/bin/python3 "$MC" compare "$W/scattered.mesh" "$W/sc1.mesh" > "$W/mc_sc" 2>&1
  check "referee accepts the reordered result" '[ $? -eq 0 ]'
fi
# --report compares every measure (tet and face) before and after; with the
# guards (default) every per-tet measure is kept, and the objective and the
# guards are in the report (issue 26).
"$T" generate "$W/mb.mesh" --cells 5 5 5 --jitter 0.42 --seed 11 --regions 2 > /dev/null
"$T" improve "$W/mb.mesh" -o "$W/mb_out.mesh" --objective sine --report "$W/mb.json" -q
check "improve --objective sine --report: exit 0" '[ $? -eq 0 ]'
/usr/bin/python3 - "$W/mb.json" > "$W/mb.out" 2>&1 <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["options"]["objective"] == "sine" and r["options"]["guard"] is True, r["options"]
ba = r["measures_before_after"]
keys = ["alpha", "sine_min", "dihedral_min", "dihedral_max", "scaled_jacobian", "radius_ratio", "mean_ratio",
        "equivolume_skewness", "non_orthogonality", "skewness"]
assert sorted(ba) == sorted(keys), sorted(ba)
for k in keys[:8]:
    assert ba[k]["kept"] is True, (k, ba[k])
assert ba["sine_min"]["after"] > ba["sine_min"]["before"], ba["sine_min"]
assert r["guards"]["on"] is True and r["guards"]["mean_alpha_kept"] is True, r["guards"]
print("ok")
PY
check "report: measures_before_after of all 10 measures, per-tet ones kept, sine raised ($(tail -1 "$W/mb.out"))" 'grep -q "^ok" "$W/mb.out"'
"$T" improve "$W/mb.mesh" -o "$W/mb_x.mesh" --objective checkmesh 2> "$W/err"; rc=$?
check "--objective checkmesh (not an objective): exit 1, says which are" '[ $rc -eq 1 ] && grep -q "alpha, sine, jacobian, skewness or openfoam" "$W/err"'
# --objective openfoam: the face pass runs after the alpha stages; its
# report gives the largest non-orthogonality before and after it, no higher
# after, every per-tet measure kept, and the summary says so.
"$T" improve "$W/box.mesh" -o "$W/of.mesh" --objective openfoam --report "$W/of.json" > "$W/of.out"
check "improve --objective openfoam: exit 0" '[ $? -eq 0 ]'
/usr/bin/python3 - "$W/of.json" > "$W/of.chk" 2>&1 <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
fp = r["face_pass"]
assert r["options"]["objective"] == "openfoam", r["options"]
assert fp["non_orthogonality_after"] <= fp["non_orthogonality_before"], fp
assert abs(r["measures_before_after"]["non_orthogonality"]["after"] - fp["non_orthogonality_after"]) < 1e-9, (r["measures_before_after"]["non_orthogonality"], fp)
for k, v in r["measures_before_after"].items():
    if k not in ("non_orthogonality", "skewness"):
        assert v["kept"] is True, (k, v)
print("ok", fp["non_orthogonality_before"], fp["non_orthogonality_after"])
PY
check "openfoam report: face_pass before/after, the table's value, per-tet worsts kept ($(tail -1 "$W/of.chk"))" 'grep -q "^ok" "$W/of.chk"'
check "openfoam summary line" 'grep -q "face pass (--objective openfoam): largest non-orthogonality" "$W/of.out"'
# --polish: the report says so, the mean alpha rises above the same run's
# without it, and every per-tet measure's worst is kept.
"$T" improve "$W/box.mesh" -o "$W/pol0.mesh" --report "$W/pol0.json" -q
"$T" improve "$W/box.mesh" -o "$W/pol1.mesh" --polish --report "$W/pol1.json" -q
check "improve --polish: exit 0" '[ $? -eq 0 ]'
/usr/bin/python3 - "$W/pol0.json" "$W/pol1.json" > "$W/pol.out" 2>&1 <<'PY'
import json, sys
r0, r1 = (json.load(open(f)) for f in sys.argv[1:3])
assert r0["options"]["polish"] is False and r1["options"]["polish"] is True, (r0["options"], r1["options"])
assert r1["after"]["alpha_mean"] > r0["after"]["alpha_mean"], (r0["after"]["alpha_mean"], r1["after"]["alpha_mean"])
for k, v in r1["measures_before_after"].items():
    if k not in ("non_orthogonality", "skewness"):
        assert v["kept"] is True, (k, v)
print("ok", r0["after"]["alpha_mean"], r1["after"]["alpha_mean"])
PY
check "--polish raises the mean alpha, keeps every per-tet worst ($(tail -1 "$W/pol.out"))" 'grep -q "^ok" "$W/pol.out"'
# --name=value is --name value (GNU style); an unknown option is one line
# naming it, not the whole help.
"$T" improve "$W/box.mesh" -o "$W/eq1.mesh" --threads=1 --threshold=0.35 -q
"$T" improve "$W/box.mesh" -o "$W/eq2.mesh" --threads 1 --threshold 0.35 -q
check "improve --threads=1 --threshold=0.35 writes what --threads 1 --threshold 0.35 does" 'cmp -s "$W/eq1.mesh" "$W/eq2.mesh"'
"$T" quality "$W/box.mesh" --threshold=0.35 --json > "$W/eq1.json"
"$T" quality "$W/box.mesh" --threshold 0.35 --json > "$W/eq2.json"
/usr/bin/python3 - "$W/eq1.json" "$W/eq2.json" > "$W/eq.out" 2>&1 <<'PY'
import json, sys
def strip(x):  # timings differ run to run
    if isinstance(x, dict): return {k: strip(v) for k, v in x.items() if "seconds" not in k}
    if isinstance(x, list): return [strip(v) for v in x]
    return x
a, b = (strip(json.load(open(f))) for f in sys.argv[1:3])
assert a == b and a["diagnosis"]["threshold"] == 0.35, "differ"
print("ok")
PY
check "quality --threshold=0.35 prints what --threshold 0.35 does" 'grep -q "^ok" "$W/eq.out"'
"$T" improve "$W/box.mesh" -o "$W/eq3.mesh" --no-such=3 > /dev/null 2> "$W/unk"; rc=$?
check "an unknown option: exit 1, one line naming it, nothing written" \
  '[ $rc -eq 1 ] && [ "$(wc -l < "$W/unk")" -eq 1 ] && grep -q "unknown option .--no-such." "$W/unk" && [ ! -e "$W/eq3.mesh" ]'
# The remesher's options without the remesher are a usage error, not ignored.
"$T" improve "$W/box.mesh" -o "$W/sz.mesh" --size 0.5 > /dev/null 2> "$W/sz"; rc=$?
check "--size without --allow-insert: exit 1, says to add it, nothing written" \
  '[ $rc -eq 1 ] && grep -q "add --allow-insert" "$W/sz" && [ ! -e "$W/sz.mesh" ]'
"$T" improve "$W/box.mesh" -o "$W/sz.mesh" --allow-insert --no-remesh --gradation 1.3 > /dev/null 2> "$W/sz"; rc=$?
check "--gradation with --no-remesh: exit 1" '[ $rc -eq 1 ] && grep -q "no-remesh" "$W/sz" && [ ! -e "$W/sz.mesh" ]'
exit $fail
