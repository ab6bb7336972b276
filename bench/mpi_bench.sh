#!/usr/bin/env bash
# MPI benchmark (issue 11): single-process tetopt improve (1 thread and one
# thread per core) beside tetopt-mpi on
# 1, 2 and 4 ranks, on flange_large (../shared/meshes, 2.0M tets) or a mesh
# given on the command line.  Prints one table (end-to-end time, worst and
# mean alpha, rounds, per-phase seconds summed over rounds, bytes sent) and
# keeps the JSON reports in OUTDIR.  Ranks are not bound to cores (Open MPI
# binds one core per rank for -np <= 2, which would keep rank 0's lone
# phases -- read, partition, merge, write -- on one core).
#
# usage: bench/mpi_bench.sh [BUILD_DIR] [MESH] [OUTDIR] [RANKS...]
#   BUILD_DIR  holds tetopt and tetopt-mpi (default: build)
#   MESH       .mesh / .mesh.gz / any format tetopt reads
#              (default: ../shared/meshes/flange_large/flange_large.mesh.gz)
#   OUTDIR     default: a temporary folder (printed)
#   RANKS      default: 1 2 4
# Exit 77 when the mesh or tetopt-mpi is absent.
set -u
HERE=$(cd "$(dirname "$0")/.." && pwd)
B=${1:-$HERE/build}
MESH=${2:-$HERE/../shared/meshes/flange_large/flange_large.mesh.gz}
OUT=${3:-$(mktemp -d /tmp/tetopt_mpi_bench.XXXX)}
shift $(( $# < 3 ? $# : 3 ))
RANKS=${*:-1 2 4}
T=$B/tetopt; M=$B/tetopt-mpi
[ -x "$M" ] || { echo "skip: no $M (MPI or METIS absent at configure time)"; exit 77; }
[ -f "$MESH" ] || { echo "skip: no mesh $MESH"; exit 77; }
command -v mpirun >/dev/null || { echo "skip: no mpirun"; exit 77; }
mkdir -p "$OUT"
IN=$MESH
case "$MESH" in
  *.gz) IN=$OUT/$(basename "${MESH%.gz}"); [ -f "$IN" ] || zcat "$MESH" > "$IN" ;;
esac
ext=${IN##*.}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
echo "mesh $IN; $(nproc) cores; results in $OUT"
# The single process at 1 thread and at every core (the issue compares the
# distributed run with the shared-memory one at equal core count).
NC=$(nproc)
/usr/bin/time -f "%e s wall, %M KB max RSS" -o "$OUT/single.time" \
  "$T" improve "$IN" -o "$OUT/single.$ext" --threads 1 --report "$OUT/single.json" -q || { echo "single run failed"; exit 1; }
/usr/bin/time -f "%e s wall, %M KB max RSS" -o "$OUT/singlet.time" \
  "$T" improve "$IN" -o "$OUT/singlet.$ext" --threads "$NC" --report "$OUT/singlet.json" -q || { echo "single run failed"; exit 1; }
for k in $RANKS; do
  /usr/bin/time -f "%e s wall, %M KB max RSS (mpirun)" -o "$OUT/mpi$k.time" \
    mpirun --bind-to none --oversubscribe -np "$k" "$M" improve "$IN" -o "$OUT/mpi$k.$ext" --report "$OUT/mpi$k.json" -q \
    || { echo "tetopt-mpi -np $k failed"; exit 1; }
done
/usr/bin/python3 - "$OUT" "$NC" $RANKS <<'EOF'
import json, sys
out, nc, ranks = sys.argv[1], sys.argv[2], sys.argv[3:]
s = json.load(open(f"{out}/single.json"))
st = json.load(open(f"{out}/singlet.json"))
wall = lambda n: open(f"{out}/{n}.time").read().split()[0]
print(f"{'run':<10} {'wall s':>8} {'e2e s':>8} {'worst a':>8} {'mean a':>7} {'tets out':>9} {'rounds':>6} "
      f"{'part s':>7} {'extr s':>7} {'scat s':>7} {'impr max':>8} {'impr sum':>8} {'g.wait':>7} {'g.xfer':>7} "
      f"{'merge s':>7} {'MB sent':>8} {'MB back':>8}")
print(f"{'tetopt t1':<10} {wall('single'):>8} {s['seconds_end_to_end']:8.2f} {s['after']['alpha_worst']:8.4f} "
      f"{s['after']['alpha_mean']:7.4f} {s['after']['tets']:9d}")
print(f"{'tetopt t' + nc:<10} {wall('singlet'):>8} {st['seconds_end_to_end']:8.2f} {st['after']['alpha_worst']:8.4f} "
      f"{st['after']['alpha_mean']:7.4f} {st['after']['tets']:9d}")
for k in ranks:
    r = json.load(open(f"{out}/mpi{k}.json"))
    tot = lambda key: sum(x['seconds'][key] for x in r['rounds'])
    print(f"{'mpi -np ' + k:<10} {wall('mpi' + k):>8} {r['seconds_end_to_end']:8.2f} {r['after']['alpha_worst']:8.4f} "
          f"{r['after']['alpha_mean']:7.4f} {r['after']['tets']:9d} {len(r['rounds']):6d} {tot('partition'):7.2f} "
          f"{tot('extract'):7.2f} {tot('scatter'):7.3f} {tot('improve_max'):8.2f} {tot('improve_sum'):8.2f} "
          f"{tot('gather_wait'):7.2f} {tot('gather_transfer'):7.3f} {tot('merge') + tot('stats'):7.2f} "
          f"{r['bytes_scatter'] / 1e6:8.1f} {r['bytes_gather'] / 1e6:8.1f}")
    print("           per round: " + "; ".join(
        f"r{x['round']} thr {x['threshold']:.2f} worst {x['alpha_worst']:.4f} impr {x['seconds']['improve_max']:.2f}/"
        f"{x['seconds']['improve_min']:.2f} s frozen {x['frozen_tets']} refrozen {x['refrozen_tets']}"
        for x in r['rounds']))
print(f"(read {s.get('seconds_read', 'n/a')}; tetopt-mpi read/check/write: " + ", ".join(
    f"-np {k}: {json.load(open(f'{out}/mpi{k}.json'))['seconds_read']:.2f}/"
    f"{json.load(open(f'{out}/mpi{k}.json'))['seconds_check']:.2f}/"
    f"{json.load(open(f'{out}/mpi{k}.json'))['seconds_write']:.2f} s" for k in ranks) + ")")
EOF
if [ -f "$HERE/../shared/tools/meshcheck.py" ]; then
  for k in $RANKS; do
    printf "meshcheck compare IN mpi%s: " "$k"
    /usr/bin/python3 "$HERE/../shared/tools/meshcheck.py" compare "$IN" "$OUT/mpi$k.$ext" | tail -1
  done
fi
