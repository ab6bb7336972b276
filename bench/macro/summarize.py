#!/usr/bin/python3
"""Summarise a bench/run_bench.sh run: OUT/runs.jsonl (timed CLI runs),
OUT/peers/peers.json (bench/peers.py) and OUT/micro.json (Google Benchmark)
into OUT/results.json and OUT/results.md, and put results.md between the
markers <!-- bench:begin --> and <!-- bench:end --> of DOC when it has them.

usage: summarize.py OUT DOC
"""
import datetime
import json
import os
import platform
import subprocess
import sys

PAPER_IMPELLER_S = 149.8  # Liu et al. 2012: 428,049 tets, combined mode


def load_jsonl(path):
    rows = []
    if os.path.exists(path):
        with open(path) as fh:
            for line in fh:
                line = line.strip()
                if line:
                    rows.append(json.loads(line))
    return rows


def fmt(v, f):
    return "—" if v is None else format(v, f)


def main():
    out, doc = sys.argv[1], sys.argv[2]
    runs = load_jsonl(os.path.join(out, "runs.jsonl"))
    for r in runs:
        t = max(1, r["tets"])
        r["tets_per_s"] = t / r["wall_s"] if r["wall_s"] else None
        r["us_per_tet_cpu"] = 1e6 * (r["user_s"] + r["sys_s"]) / t
        r["peak_bytes_per_tet"] = 1024.0 * r["peak_kb"] / t
    peers = None
    pp = os.path.join(out, "peers", "peers.json")
    if os.path.exists(pp) and os.path.getmtime(pp) >= os.path.getmtime(os.path.join(out, "runs.jsonl")) - 3600 * 6:
        with open(pp) as fh:
            peers = json.load(fh)
    micro = None
    mp = os.path.join(out, "micro.json")
    if os.path.exists(mp):
        with open(mp) as fh:
            micro = json.load(fh)
    ceiling = None
    cp = os.path.join(out, "ceiling.json")
    if os.path.exists(cp):
        with open(cp) as fh:
            ceiling = json.load(fh)
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = "?"
    try:
        load = os.getloadavg()
    except OSError:
        load = (0, 0, 0)
    meta = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "commit": commit,
            "machine": f"{platform.machine()}, {os.cpu_count()} cores", "load_average": load}
    res = {"meta": meta, "runs": runs, "peers": peers, "ceiling": ceiling,
           "micro": micro["benchmarks"] if micro else None}
    with open(os.path.join(out, "results.json"), "w") as fh:
        json.dump(res, fh, indent=1)

    md = [f"Run {meta['date']}, commit {commit}, {meta['machine']}, load average at the end "
          f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (a shared machine: compare ratios within one run).", ""]
    md += ["| run | tets | wall s | CPU s | tets/s (wall) | CPU µs/tet | peak bytes/tet | rc |",
           "|---|---|---|---|---|---|---|---|"]
    for r in runs:
        md.append(f"| {r['name']} | {r['tets']:,} | {r['wall_s']:.2f} | {r['user_s'] + r['sys_s']:.2f} | "
                  f"{fmt(r['tets_per_s'], ',.0f')} | {r['us_per_tet_cpu']:.2f} | {r['peak_bytes_per_tet']:.0f} | {r['rc']} |")
    smooth = [r for r in runs if r["name"].startswith("smooth_box") and r["rc"] == 0]
    if len(smooth) >= 2:
        per = [r["us_per_tet_cpu"] for r in smooth]
        md += ["", f"Growth (smoothing, CPU time per tet): max/min = {max(per) / min(per):.2f} "
               f"over {smooth[0]['tets']:,} .. {smooth[-1]['tets']:,} tets (target within 1.5)."]
    imp = {r["name"]: r for r in runs if r["name"].startswith("impeller_best")}
    if imp:
        t1 = imp.get("impeller_best_t1")
        if t1:
            of = f", the median of {t1['median_of']} alternated runs" if t1.get("median_of") else ""
            md += ["", f"Impeller, default mode, 1 thread: {t1['wall_s']:.2f} s wall{of} "
                   f"({PAPER_IMPELLER_S / t1['wall_s']:.0f}x the paper's {PAPER_IMPELLER_S} s), "
                   f"{t1['user_s'] + t1['sys_s']:.2f} s CPU."]
        t2 = imp.get("impeller_best_t2")
        if t1 and t2 and t2["wall_s"]:
            md += [f"Threads 1 -> 2: {t1['wall_s'] / t2['wall_s']:.2f}x wall (medians)."]
            if t1.get("walls_s") and t2.get("walls_s"):
                md += [f"Wall times, sorted: 1 thread {', '.join(f'{w:.2f}' for w in t1['walls_s'])} s; "
                       f"2 threads {', '.join(f'{w:.2f}' for w in t2['walls_s'])} s."]
            if ceiling:
                md += [f"The machine's own 1 -> 2 thread speed-up right after (bench/ceiling.cpp, medians of "
                       f"{ceiling['reps']}): {ceiling['compute']['speedup']:.2f}x compute-bound, "
                       f"{ceiling['random_walk']['speedup']:.2f}x for a random walk through 32 MiB per thread (each read "
                       f"waits for the one before)."]
    if peers:
        md += ["", "Peers (bench/peers.py, judged by meshcheck; seconds as peers.py measures them), "
               "ratio = peer seconds / tetopt seconds:", "",
               "| mesh | tool | worst α | mean α | tets | seconds | ratio | boundary kept |", "|---|---|---|---|---|---|---|---|"]
        for m in peers:
            rows = {r["tool"]: r for r in m["rows"]}
            ts = rows.get("tetopt", {}).get("seconds")
            for r in m["rows"]:
                ratio = (r["seconds"] / ts) if (ts and r.get("seconds") and r["tool"] != "tetopt") else None
                md.append(f"| {m['name']} | {r['tool']} | {fmt(r.get('alpha_worst'), '.4f')} | "
                          f"{fmt(r.get('alpha_mean'), '.4f')} | {fmt(r.get('tets'), ',')} | "
                          f"{fmt(r.get('seconds'), '.2f')} | {fmt(ratio, '.2f')} | "
                          f"{ {True: 'yes', False: 'NO', None: '—'}[r.get('boundary_kept')] } |")
    if micro:
        md += ["", "| micro-benchmark | real time | CPU time | unit |", "|---|---|---|---|"]
        for b in micro["benchmarks"]:
            md.append(f"| {b['name']} | {b['real_time']:.4g} | {b['cpu_time']:.4g} | {b['time_unit']} |")
    text = "\n".join(md) + "\n"
    with open(os.path.join(out, "results.md"), "w") as fh:
        fh.write(text)
    print(text)
    if os.path.exists(doc):
        with open(doc) as fh:
            d = fh.read()
        b, e = "<!-- bench:begin -->", "<!-- bench:end -->"
        if b in d and e in d:
            d = d[:d.index(b) + len(b)] + "\n" + text + d[d.index(e):]
            with open(doc, "w") as fh:
                fh.write(d)
            print(f"updated {doc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
