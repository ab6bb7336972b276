#!/usr/bin/env bash
# The HTML report's 3D view (issue 30, docs/report.md): page sizes and the
# time until the view's first frame in headless Chromium (bench/view3d_open.mjs,
# WebGL on SwiftShader), for
#   - the demo impeller (gmsh, demo/impeller.geo at s = 1.0): the pages of
#     `tetopt quality` and `tetopt improve`;
#   - a generated box of 260 x 260 x 50 cells (20,280,000 tets, 374,400
#     boundary triangles: above the view's 300k budget, so decimated): the
#     page of `tetopt quality`.
# usage: bench/view3d_bench.sh TETOPT [WORKDIR] [RUNS]
# Needs gmsh, /usr/bin/chromium and node_modules (make deps); about 3 GB of
# memory and 4 minutes on 2 cores.  Not a test: it prints numbers for
# docs/benchmarks.md.
set -eu
T=$(realpath "$1"); W=${2:-/tmp/tetopt-view3d-bench}; RUNS=${3:-5}
SRC=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$W"
echo "commit $(git -C "$SRC" rev-parse --short HEAD), $(nproc) cores, load: $(cut -d' ' -f1-3 /proc/loadavg)"
size() { stat -c %s "$1" | awk '{printf "%.2f MB (%d bytes)", $1 / 1e6, $1}'; }

[ -f "$W/impeller.mesh" ] || gmsh -3 -nt 1 -setnumber s 1.0 -format mesh "$SRC/demo/impeller.geo" -o "$W/impeller.mesh" > "$W/gmsh.log"
"$T" quality "$W/impeller.mesh" --html "$W/impeller_quality.html" -q > /dev/null
"$T" improve "$W/impeller.mesh" -o "$W/impeller_opt.mesh" --html "$W/impeller_improve.html" -q
for p in impeller_quality impeller_improve; do
  echo "$p.html: $(size "$W/$p.html"); $(grep -o 'id="tv-notes">[^<]*' "$W/$p.html" | sed 's/id="tv-notes">//')"
  node "$SRC/bench/view3d_open.mjs" "$W/$p.html" runs="$RUNS" | tail -1
done

[ -f "$W/big.meshb" ] || "$T" generate "$W/big.meshb" --cells 260 260 50 --jitter 0.35 --seed 3 > /dev/null
start=$(date +%s.%N)
"$T" quality "$W/big.meshb" --html "$W/big_quality.html" -q > /dev/null
echo "big: tetopt quality --html took $(awk -v a="$start" -v b="$(date +%s.%N)" "BEGIN { printf \"%.1f\", b - a }") s"
echo "big_quality.html: $(size "$W/big_quality.html"); $(grep -o 'id="tv-notes">.*</p>' "$W/big_quality.html" | sed 's/<[^>]*>//g')"
node "$SRC/bench/view3d_open.mjs" "$W/big_quality.html" runs="$RUNS"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
