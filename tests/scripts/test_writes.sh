#!/usr/bin/env bash
# How outputs are written (issue 25, docs/formats.md "Writing"): a rewritten
# file keeps its mode, group and owner; the temporary file is fsynced before
# the rename and its folder after; symbolic link loops and names too long are
# exit 4 with the system's reason; a file size limit (SIGXFSZ) is exit 4 with
# nothing left behind; --field is .vtu only; -o never names IN; file names in
# messages are escaped so that each message stays one line.
# usage: test_writes.sh TETOPT SOURCE_DIR
set -u
T=$1
M=$(dirname "$T")/tetopt-mpi
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }
no_temps() { [ -z "$(find "$W" -name '*.tmp-*' | head -1)" ]; }

"$T" generate "$W/box.mesh" --cells 3 3 3 --jitter 0.3 --seed 1 > /dev/null
"$T" generate "$W/big.mesh" --cells 16 16 16 --jitter 0.3 --seed 1 > /dev/null   # about 1 MB

# 1. A rewritten output keeps the mode (and, where permitted, the owner and
# group) of the file it replaces: a 0600 mesh stayed 0644 before.
# A new file gets the umask's mode, as before.
cp "$W/box.mesh" "$W/m600.mesh" && chmod 600 "$W/m600.mesh"
"$T" convert "$W/box.mesh" "$W/m600.mesh"; rc=$?
check "convert over a 0600 file: still 0600" '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/m600.mesh")" = 600 ]'
cp "$W/box.mesh" "$W/m640.mesh" && chmod 640 "$W/m640.mesh"
"$T" improve "$W/box.mesh" -o "$W/m640.mesh" -q --threads 2; rc=$?
check "improve -o over a 0640 file (streamed writer): still 0640" '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/m640.mesh")" = 640 ]'
echo '{}' > "$W/r600.json" && chmod 600 "$W/r600.json"
"$T" improve "$W/box.mesh" -o "$W/ro.mesh" --report "$W/r600.json" -q; rc=$?
check "--report over a 0600 file: still 0600, rewritten" \
  '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/r600.json")" = 600 ] && grep -q boundary_unchanged "$W/r600.json"'
cp "$W/box.mesh" "$W/ro444.mesh" && chmod 444 "$W/ro444.mesh"
"$T" convert "$W/box.mesh" "$W/ro444.mesh"; rc=$?
check "a read-only (0444) output in a writable folder: rewritten, still 0444" \
  '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/ro444.mesh")" = 444 ]'
"$T" convert "$W/box.mesh" "$W/tg.node" && chmod 600 "$W/tg.node" && chmod 640 "$W/tg.ele" && rm -f "$W/tg.face"
(umask 077; "$T" convert "$W/box.mesh" "$W/tg.node"); rc=$?
check "TetGen set: each file keeps its own mode, the new .face gets the umask's" \
  '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/tg.node")" = 600 ] && [ "$(stat -c %a "$W/tg.ele")" = 640 ] && [ "$(stat -c %a "$W/tg.face")" = 600 ]'
(umask 027; "$T" convert "$W/box.mesh" "$W/new027.mesh"); rc=$?
check "a new output gets 0666 less the umask (027: 0640)" '[ $rc -eq 0 ] && [ "$(stat -c %a "$W/new027.mesh")" = 640 ]'
ln -s m600.mesh "$W/l600.mesh"
"$T" convert "$W/box.mesh" "$W/l600.mesh"; rc=$?
check "through a link: the file it names keeps 0600, the link stays" \
  '[ $rc -eq 0 ] && [ -L "$W/l600.mesh" ] && [ "$(stat -c %a "$W/m600.mesh")" = 600 ]'
if [ "$(id -u)" = 0 ]; then
  cp "$W/box.mesh" "$W/own.mesh" && chown 12345:23456 "$W/own.mesh" && chmod 2640 "$W/own.mesh"
  "$T" convert "$W/box.mesh" "$W/own.mesh"; rc=$?
  check "owner, group and setgid bit kept (root)" \
    '[ $rc -eq 0 ] && [ "$(stat -c %u:%g:%a "$W/own.mesh")" = 12345:23456:2640 ]'
else
  g=$(id -G | tr ' ' '\n' | grep -vx "$(id -g)" | head -1)
  if [ -n "$g" ]; then
    cp "$W/box.mesh" "$W/grp.mesh" && chgrp "$g" "$W/grp.mesh"
    "$T" convert "$W/box.mesh" "$W/grp.mesh"; rc=$?
    check "group kept (a supplementary group of ours)" '[ $rc -eq 0 ] && [ "$(stat -c %g "$W/grp.mesh")" = "$g" ]'
  else
    echo "skip owner and group checks (not root, no supplementary group)"
  fi
fi

# 2. The temporary file is fsynced before the rename, its folder after
# (strace: the order of the calls).
if command -v strace > /dev/null && strace -o /dev/null /bin/true 2> /dev/null; then
  for case in "convert $W/box.mesh $W/sync.mesh" "convert $W/box.mesh $W/sync.vtu" "convert $W/box.mesh $W/sync.node"; do
    # LeakSanitizer cannot run under ptrace (the sanitizer build would exit
    # non-zero at exit): leaks are checked by every other test.
    ASAN_OPTIONS=detect_leaks=0 strace -f -qq -o "$W/strace.log" \
      -e trace=openat,fsync,fdatasync,close,rename,renameat,renameat2 $T $case; rc=$?
    /usr/bin/python3 - "$W/strace.log" "$W" > "$W/strace.out" 2>&1 <<'PY'
import re, sys
log, folder = sys.argv[1], sys.argv[2]
fds, synced, renamed, dir_fds, dir_synced = {}, set(), [], {}, False
for line in open(log):
    line = line.split(None, 1)[1] if line[:1].isdigit() else line
    m = re.match(r'openat\(AT_FDCWD, "([^"]*)", ([^)]*)\)\s+=\s+(\d+)', line)
    if m:
        path, flags, fd = m.group(1), m.group(2), int(m.group(3))
        if ".tmp-" in path: fds[fd] = path
        elif path.rstrip("/") == folder and "O_DIRECTORY" in flags: dir_fds[fd] = path
        continue
    m = re.match(r'f(?:data)?sync\((\d+)\)\s+=\s+0', line)
    if m:
        fd = int(m.group(1))
        if fd in fds: synced.add(fds[fd])
        if fd in dir_fds and renamed: dir_synced = True
        continue
    m = re.match(r'rename(?:at2?)?\((?:AT_FDCWD, )?"([^"]*)"', line)
    if m:
        tmp = m.group(1)
        assert tmp in synced, "renamed before fsync: " + tmp
        renamed.append(tmp)
        continue
    m = re.match(r'close\((\d+)\)', line)
    if m: fds.pop(int(m.group(1)), None); dir_fds.pop(int(m.group(1)), None)
assert renamed, "no rename seen"
assert dir_synced, "the folder was not fsynced after the rename"
print("renamed", len(renamed), "file(s), each fsynced first; folder fsynced after")
PY
    prc=$?
    check "${case%% *} to ${case##*.}: fsync before the rename, folder fsync after ($(tr '\n' ' ' < "$W/strace.out"))" '[ $rc -eq 0 ] && [ $prc -eq 0 ]'
  done
else
  echo "skip fsync checks (strace absent or not permitted)"
fi

# 3. An output that is a symbolic link loop, or a name too long: exit 4 with
# the system's reason, before any work; the link stays a link.  (A loop was
# replaced by a regular file with exit 0, a long name said "cannot create
# files in folder".)
ln -s loop.mesh "$W/loop.mesh"
"$T" convert "$W/box.mesh" "$W/loop.mesh" 2> "$W/err"; rc=$?
check "convert to a link to itself: exit 4, 'Too many levels of symbolic links', the link kept" \
  '[ $rc -eq 4 ] && [ -L "$W/loop.mesh" ] && grep -q "loop.mesh: Too many levels of symbolic links" "$W/err" && [ $(wc -l < "$W/err") -eq 1 ]'
ln -s loop_b.vtu "$W/loop_a.vtu" && ln -s loop_a.vtu "$W/loop_b.vtu"
"$T" improve "$W/box.mesh" -o "$W/ok.mesh" --field "$W/loop_a.vtu" -q 2> "$W/err"; rc=$?
check "improve --field into a two-link loop: exit 4 before any output, links kept" \
  '[ $rc -eq 4 ] && [ ! -e "$W/ok.mesh" ] && [ -L "$W/loop_a.vtu" ] && [ -L "$W/loop_b.vtu" ] && grep -q "Too many levels of symbolic links" "$W/err"'
"$T" improve "$W/box.mesh" -o "$W/loop.mesh" -q 2> "$W/err"; rc=$?
check "improve -o a loop: exit 4" '[ $rc -eq 4 ] && [ -L "$W/loop.mesh" ] && grep -q "Too many levels" "$W/err"'
"$T" generate "$W/loop.mesh" --cells 1 1 1 2> "$W/err"; rc=$?
check "generate into a loop: exit 4, the link kept" '[ $rc -eq 4 ] && [ -L "$W/loop.mesh" ] && grep -q "Too many levels" "$W/err"'
ln -s loopdir "$W/loopdir"
"$T" convert "$W/box.mesh" "$W/loopdir/x.mesh" 2> "$W/err"; rc=$?
check "a folder that is a link loop: exit 4, the system's reason" '[ $rc -eq 4 ] && grep -q "Too many levels" "$W/err"'
long=$(printf 'n%.0s' $(seq 300)).mesh
"$T" convert "$W/box.mesh" "$W/$long" 2> "$W/err"; rc=$?
check "a 305-character name: exit 4, 'File name too long', one line" \
  '[ $rc -eq 4 ] && grep -q "File name too long" "$W/err" && ! grep -q "cannot create files" "$W/err" && [ $(wc -l < "$W/err") -eq 1 ]'
"$T" improve "$W/box.mesh" -o "$W/ok.mesh" --report "$W/$long.json" -q 2> "$W/err"; rc=$?
check "improve --report with a name too long: exit 4 before any output" \
  '[ $rc -eq 4 ] && [ ! -e "$W/ok.mesh" ] && grep -q "File name too long" "$W/err"'
name250=$(printf 'k%.0s' $(seq 245)).mesh   # 250 characters: valid, but not with ".tmp-PID-N" after it
"$T" convert "$W/box.mesh" "$W/$name250"; rc=$?
check "a 250-character name (its temporary's name would be too long): written" \
  '[ $rc -eq 0 ] && cmp -s "$W/box.mesh" "$W/$name250" && no_temps'
ln -s gone.mesh "$W/dangling.mesh"
"$T" convert "$W/box.mesh" "$W/dangling.mesh"; rc=$?
check "a dangling link: the file it names is created, the link stays" \
  '[ $rc -eq 0 ] && [ -L "$W/dangling.mesh" ] && cmp -s "$W/box.mesh" "$W/gone.mesh"'

# 4. A file size limit (ulimit -f: SIGXFSZ) is an output error: exit 4, one
# line with the system's reason, nothing left behind (the process was
# killed with a partial OUT.tmp-PID-N).
for out in x.mesh x.vtu x.node; do
  mkdir -p "$W/fsz"
  (ulimit -f 64; exec "$T" convert "$W/big.mesh" "$W/fsz/$out" --threads 2) 2> "$W/err"; rc=$?
  check "ulimit -f 64, convert to $out: exit 4, 'File too large', nothing written" \
    '[ $rc -eq 4 ] && grep -q "File too large" "$W/err" && [ -z "$(ls -A "$W/fsz")" ] && [ $(wc -l < "$W/err") -eq 1 ]'
  rm -rf "$W/fsz"
done
# A Medit file past 4 MiB is written in pieces by a helper thread: its
# failure comes back from that thread with its reason (errno is per thread).
"$T" generate "$W/huge.mesh" --cells 28 28 28 --jitter 0.3 --seed 1 > /dev/null   # about 4.5 MB
(ulimit -f 2000; exec "$T" convert "$W/huge.mesh" "$W/huge_out.mesh" --threads 2) 2> "$W/err"; rc=$?
check "ulimit -f 2000, a 4.5 MB .mesh written by the helper thread: exit 4, 'File too large', nothing written" \
  '[ $rc -eq 4 ] && grep -q "huge_out.mesh: write failed: File too large" "$W/err" && [ ! -e "$W/huge_out.mesh" ] && no_temps'
cp "$W/big.mesh" "$W/keep_big.mesh"
(ulimit -f 64; exec "$T" improve "$W/big.mesh" -o "$W/keep_big.mesh" --mode smooth --iterations 1 -q) 2> "$W/err"; rc=$?
check "ulimit -f 64, improve over an existing file: exit 4, the old file intact, no temporary" \
  '[ $rc -eq 4 ] && cmp -s "$W/big.mesh" "$W/keep_big.mesh" && no_temps'

# 5. --field writes VTK XML, so it takes only a .vtu name (--field x.mesh
# wrote VTU into a .mesh file).
"$T" quality "$W/box.mesh" --field "$W/f.mesh" > /dev/null 2> "$W/err"; rc=$?
check "quality --field f.mesh: exit 1, says .vtu, nothing written" \
  '[ $rc -eq 1 ] && grep -q "\.vtu" "$W/err" && [ ! -e "$W/f.mesh" ]'
"$T" improve "$W/box.mesh" -o "$W/fo.mesh" --field "$W/f.vtk" -q 2> "$W/err"; rc=$?
check "improve --field f.vtk: exit 1, says .vtu, nothing written" \
  '[ $rc -eq 1 ] && grep -q "\.vtu" "$W/err" && [ ! -e "$W/f.vtk" ] && [ ! -e "$W/fo.mesh" ]'
"$T" quality "$W/box.mesh" --field "$W/F.VTU" -q > /dev/null; rc=$?
check "quality --field F.VTU (any case) is accepted" '[ $rc -eq 0 ] && [ -s "$W/F.VTU" ]'

# 6. -o never names IN (as --report IN is refused): through another
# spelling, a hard link, a symbolic link or a TetGen companion too.  Exit 1,
# IN intact.
cp "$W/box.mesh" "$W/in.mesh" && cp "$W/box.mesh" "$W/in.orig"
ln "$W/in.mesh" "$W/hard.mesh" && ln -s in.mesh "$W/soft.mesh"
for o in "$W/in.mesh" "$W/./in.mesh" "$W/hard.mesh" "$W/soft.mesh"; do
  "$T" improve "$W/in.mesh" -o "$o" -q 2> "$W/err"; rc=$?
  check "improve -o ${o#$W/} over IN: exit 1, IN intact, says why" \
    '[ $rc -eq 1 ] && cmp -s "$W/in.mesh" "$W/in.orig" && grep -q "name the same file" "$W/err" && grep -q "no output may replace IN" "$W/err"'
done
"$T" convert "$W/box.mesh" "$W/tgi.node" && cp "$W/tgi.ele" "$W/tgi.ele.orig"
"$T" improve "$W/tgi.node" -o "$W/tgi.ele" -q 2> "$W/err"; rc=$?
check "improve IN.node -o IN.ele: exit 1, IN intact" '[ $rc -eq 1 ] && cmp -s "$W/tgi.ele" "$W/tgi.ele.orig"'
"$T" improve --help | grep -qi "never IN"; check "improve --help states the rule" '[ $? -eq 0 ]'
if [ -x "$M" ] && command -v mpirun > /dev/null; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
  mpirun --oversubscribe --allow-run-as-root -np 2 "$M" improve "$W/in.mesh" -o "$W/hard.mesh" -q 2> "$W/err"; rc=$?
  check "tetopt-mpi -o over IN (a hard link): exit 1, IN intact" \
    '[ $rc -eq 1 ] && cmp -s "$W/in.mesh" "$W/in.orig" && grep -q "name the same file" "$W/err"'
  mpirun --oversubscribe --allow-run-as-root -np 2 "$M" improve "$W/box.mesh" -o "$W/loop.mesh" -q 2> "$W/err"; rc=$?
  check "tetopt-mpi -o a link loop: exit 4" '[ $rc -eq 4 ] && [ -L "$W/loop.mesh" ] && grep -q "Too many levels" "$W/err"'
  "$M" --help | grep -qi "never IN"; check "tetopt-mpi --help states the rule" '[ $? -eq 0 ]'
else
  echo "skip tetopt-mpi checks (not built or no mpirun)"
fi

# 7. File names in messages are escaped (\n, \x1b), so each message is one
# line and prints no terminal escape; printable UTF-8 stays as it is.
nl=$'\n'; esc=$'\033'
"$T" convert "$W/box.mesh" "$W/no such${nl}dir/o${esc}[31m.mesh" 2> "$W/err"; rc=$?
check "write error with a newline and ESC in the name: one line, escaped" \
  '[ $rc -eq 4 ] && [ $(wc -l < "$W/err") -eq 1 ] && grep -qF "no such\\ndir" "$W/err" && grep -qF "o\\x1b[31m.mesh" "$W/err" && ! grep -q "$esc" "$W/err"'
"$T" quality "$W/in${nl}put${esc}.mesh" 2> "$W/err"; rc=$?
check "missing input with a newline in its name: one line, escaped" \
  '[ $rc -eq 2 ] && [ $(wc -l < "$W/err") -eq 1 ] && grep -qF "in\\nput\\x1b.mesh" "$W/err"'
printf 'MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 zz 0\nEnd\n' > "$W/bad${nl}x${esc}.mesh"
"$T" quality "$W/bad${nl}x${esc}.mesh" 2> "$W/err"; rc=$?
check "a reader's error for a name with a newline: one line, escaped" \
  '[ $rc -eq 2 ] && [ $(wc -l < "$W/err") -eq 1 ] && grep -qF "bad\\nx\\x1b.mesh" "$W/err" && ! grep -q "$esc" "$W/err"'
cp "$W/box.mesh" "$W/same${nl}.mesh"
"$T" improve "$W/same${nl}.mesh" -o "$W/o.mesh" --report "$W/same${nl}.mesh" -q 2> "$W/err"; rc=$?
check "same-file refusal naming a name with a newline: one line" '[ $rc -eq 1 ] && [ $(wc -l < "$W/err") -eq 1 ] && grep -qF "same\\n.mesh" "$W/err"'
"$T" improve "$W/same${nl}.mesh" -o "$W/o${nl}k.mesh" > "$W/out" 2> "$W/err"; rc=$?
check "improve's summary names IN and OUT on one line" \
  '[ $rc -eq 0 ] && grep -qF "same\\n.mesh -> " "$W/out" && grep -qF "o\\nk.mesh" "$W/out"'
cp "$W/box.mesh" "$W/café.mesh"
"$T" quality "$W/nope/café.mesh" 2> "$W/err"; rc=$?
check "printable UTF-8 in a name is kept" '[ $rc -eq 2 ] && grep -q "café.mesh" "$W/err"'

check "no temporary file left anywhere" 'no_temps'
exit $fail
