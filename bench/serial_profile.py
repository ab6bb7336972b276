#!/usr/bin/python3
"""Where a multi-threaded run is serial: main-thread samples taken while no
other thread was busy, from `perf script` output.

    perf record -F 4999 -g --call-graph fp -o p.data \\
        build-prof/tetopt improve IN -o OUT --threads 2 -q
    perf script -i p.data -F tid,time,ip,sym > p.txt
    /usr/bin/python3 bench/serial_profile.py p.txt [p2.txt ...]

(build-prof: a Release build with -fno-omit-frame-pointer -g.)  The main
thread is the thread with the most samples.  A sample of a thread is "busy"
unless its innermost frame is in a library without symbols (oneTBB's
spinning and sleeping) or in sched_yield / futex.  A busy main-thread sample
is "serial" when no other thread has a busy sample within --window seconds
of it.  Samples are attributed to the outermost known phase (read, topology
build, smoothing, flip passes, write, ...) and to the innermost known detail
(page faults, plan_best, commit, ...); with several files the counts are
averaged per file.  At -F 4999 a sample is about 0.2 ms.
"""
import argparse
import bisect
import collections
import re

PHASES = ["tetopt::read_mesh", "tetopt::build_topology", "tetopt::compute_stats", "tetopt::capture_invariants",
          "tetopt::check_invariants", "tetopt::smooth_pass", "tetopt::pair_flip_pass",
          "tetopt::remove_all_boundary_tets", "tetopt::dihedral_pass", "tetopt::flip_pass", "tetopt::write_mesh",
          "tetopt::diagnose", "tetopt::relax", "tetopt::improve", "tetopt_cli::cmd_improve"]
DETAILS = ["TopoEditor::TopoEditor", "TopoEditor::finish(", "TopoEditor::finish_plan", "TopoEditor::commit", "TopoEditor::improve_tet_pair",
           "TopoEditor::improve_tet(", "TopoEditor::improve_tets", "build_vertex_tets", "page_fault", "sysmalloc",
           "memset", "memmove", "writev", "TopoEditor::plan_best", "fill_cache", "min_cached"]
HEADER = re.compile(r"^\s*(\d+)\s+(\d+\.\d+):")


def load(path):
    samples, cur = [], None
    with open(path) as fh:
        for line in fh:
            m = HEADER.match(line)
            if m:
                cur = [int(m.group(1)), float(m.group(2)), []]
                samples.append(cur)
            elif line.strip() and cur is not None:
                parts = line.strip().split(None, 1)
                cur[2].append(parts[1] if len(parts) > 1 else "?")
    return samples


def idle(frames):
    leaf = frames[0] if frames else "[unknown]"
    return leaf == "[unknown]" or "sched_yield" in leaf or "futex" in leaf


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--window", type=float, default=0.0005, help="seconds (default 0.0005)")
    ap.add_argument("--top", type=int, default=30)
    a = ap.parse_args()
    serial, total = collections.Counter(), collections.Counter()
    n_serial = n_main = 0
    for path in a.files:
        samples = load(path)
        if not samples:
            continue
        main_tid = collections.Counter(s[0] for s in samples).most_common(1)[0][0]
        others = sorted(t for tid, t, fr in samples if tid != main_tid and not idle(fr))

        def others_busy(t):
            i = bisect.bisect_left(others, t - a.window)
            return i < len(others) and others[i] <= t + a.window

        for tid, t, fr in samples:
            if tid != main_tid or idle(fr):
                continue
            phase = next((p for p in PHASES for f in fr if f.startswith(p)), "other")
            detail = next((d for f in fr for d in DETAILS if d in f), "-")
            total[(phase, detail)] += 1
            n_main += 1
            if not others_busy(t):
                serial[(phase, detail)] += 1
                n_serial += 1
    k = len(a.files)
    print(f"per file: {n_main / k:.0f} busy main-thread samples, {n_serial / k:.0f} of them serial")
    print(f"{'serial':>7} {'main':>7}  phase / detail")
    for key, v in serial.most_common(a.top):
        print(f"{v / k:7.0f} {total[key] / k:7.0f}  {key[0]} / {key[1]}")


if __name__ == "__main__":
    main()
