#!/usr/bin/python3
"""The paper's experiments, re-run with tetopt; writes a Markdown report.

    /usr/bin/python3 bench/experiments.py [--tetopt build/tetopt] [--out out/experiments]
        [--impeller out/demo/impeller.mesh] [--meshes ../shared/meshes] [--quick]
        [--sections c,table2,table3,modes] > docs/results_generated.md

Sections
  c       the weight experiment (paper §5, Fig. 6): --mode smooth with
          C in {0.5 .. 0.9} on the impeller and the shared meshes
  table2  the paper's Table 2 on the demo impeller: smoothing vs combined
  table3  the paper's Table 3: min/max dihedral on tire and RAND-like meshes
          (randmesh.py OUT 5086 SEED 0) for smooth / combined / best
  modes   every mode on every shared mesh, with bound.py's estimate beside it

Every output is judged by ../shared/tools/meshcheck.py compare; a row whose
output the referee rejects says so.  Each table is printed with the command
that produced its rows.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def run(cmd, timeout=3600):
    t = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    return p, time.time() - t


class Ctx:
    def __init__(self, a):
        self.tetopt = a.tetopt
        self.out = a.out
        self.meshcheck = os.path.join(a.shared, "tools", "meshcheck.py")
        self.bound = os.path.join(a.shared, "tools", "bound.py")
        self.randmesh = os.path.join(a.shared, "tools", "randmesh.py")
        os.makedirs(self.out, exist_ok=True)

    def improve(self, src, tag, *opts):
        out = os.path.join(self.out, tag + ".mesh")
        rep = os.path.join(self.out, tag + ".json")
        p, secs = run([self.tetopt, "improve", src, "-o", out, "--report", rep, "-q", "--threads", "1", *opts])
        if p.returncode != 0:
            return {"error": (p.stderr or p.stdout).strip()[:200]}
        r = json.load(open(rep))
        r["wall"] = secs
        if os.path.exists(self.meshcheck):
            c, _ = run(["/usr/bin/python3", self.meshcheck, "compare", src, out])
            r["referee"] = "valid" if c.returncode == 0 else "REJECTED: " + c.stdout.strip().splitlines()[-1]
        else:
            r["referee"] = "not run"
        return r


def f4(x):
    return "-" if x is None else f"{x:.4f}"


def section_c(ctx, meshes):
    print("## The weight C (paper §5, Fig. 6)\n")
    print("Command per cell: `tetopt improve IN -o OUT --mode smooth --weight C --threads 1 --report R.json`\n")
    print("| mesh | C | worst α | mean α | boundary worst α | boundary mean α | time (s) | referee |")
    print("|---|---|---|---|---|---|---|---|")
    for name, path in meshes:
        for c in (0.5, 0.6, 0.7, 0.8, 0.9):
            r = ctx.improve(path, f"c_{name}_{c}", "--mode", "smooth", "--weight", str(c))
            if "error" in r:
                print(f"| {name} | {c} | error: {r['error']} |||||")
                continue
            a = r["after"]
            print(f"| {name} | {c} | {f4(a['alpha_worst'])} | {f4(a['alpha_mean'])} | "
                  f"{f4(a['alpha_boundary_worst'])} | {f4(a['alpha_boundary_mean'])} | "
                  f"{r['seconds']['total']:.2f} | {r['referee']} |")
    print()


def section_table2(ctx, impeller):
    print("## Table 2 on the demo impeller\n")
    print("Commands: `tetopt improve impeller.mesh -o OUT --mode smooth|combined|best --threads 1 --report R.json`\n")
    print("| method | tets | worst α | mean α | boundary worst α | boundary mean α | time (s) | referee |")
    print("|---|---|---|---|---|---|---|---|")
    first = True
    for mode in ("smooth", "combined", "best"):
        r = ctx.improve(impeller, f"t2_{mode}", "--mode", mode)
        if "error" in r:
            print(f"| {mode} | error: {r['error']} ||||||")
            continue
        b, a = r["before"], r["after"]
        if first:
            print(f"| input | {b['tets']} | {f4(b['alpha_worst'])} | {f4(b['alpha_mean'])} | "
                  f"{f4(b['alpha_boundary_worst'])} | {f4(b['alpha_boundary_mean'])} | | |")
            first = False
        print(f"| {mode} | {a['tets']} | {f4(a['alpha_worst'])} | {f4(a['alpha_mean'])} | "
              f"{f4(a['alpha_boundary_worst'])} | {f4(a['alpha_boundary_mean'])} | "
              f"{r['seconds']['total']:.2f} | {r['referee']} |")
    print("\nPaper (impeller, 428,049 tets): input 0.0052 / 0.5105; smoothing 0.0339 / 0.5760 in 122.9 s; "
          "combined 0.0671 / 0.5937 in 149.8 s.\n")


def section_table3(ctx, tire, seeds):
    print("## Table 3: dihedral angles on TIRE and RAND-like meshes\n")
    print("RAND-like meshes: `/usr/bin/python3 ../shared/tools/randmesh.py rand_S.mesh 5086 S 0`; "
          "commands: `tetopt improve IN -o OUT --mode M --threads 1 --report R.json`\n")
    print("| mesh | method | min dihedral | max dihedral | worst α | tets | time (s) | referee |")
    print("|---|---|---|---|---|---|---|---|")
    inputs = []
    if tire and os.path.exists(tire):
        inputs.append(("tire", tire))
    for s in seeds:
        path = os.path.join(ctx.out, f"rand_{s}.mesh")
        if not os.path.exists(path) and os.path.exists(ctx.randmesh):
            run(["/usr/bin/python3", ctx.randmesh, path, "5086", str(s), "0"])
        if os.path.exists(path):
            inputs.append((f"rand seed {s}", path))
    for name, path in inputs:
        shown = False
        for mode in ("smooth", "combined", "best"):
            r = ctx.improve(path, f"t3_{name.replace(' ', '_')}_{mode}", "--mode", mode)
            if "error" in r:
                print(f"| {name} | {mode} | error: {r['error']} |||||")
                continue
            b, a = r["before"], r["after"]
            if not shown:
                print(f"| {name} | input | {b['dihedral_min']:.2f} | {b['dihedral_max']:.2f} | "
                      f"{f4(b['alpha_worst'])} | {b['tets']} | | |")
                shown = True
            print(f"| {name} | {mode} | {a['dihedral_min']:.2f} | {a['dihedral_max']:.2f} | "
                  f"{f4(a['alpha_worst'])} | {a['tets']} | {r['seconds']['total']:.2f} | {r['referee']} |")
    print("\nPaper: TIRE 0.66°–178.88° → 22.57°–141.54° (combined), Freitag 13.67°–159.82°; "
          "RAND2 0.10°–179.84° → 25.69°–132.27° (combined), Freitag 7.50°–170.09°.\n")


def section_modes(ctx, meshes):
    print("## Every mode on every mesh, against the bound\n")
    print("bound = the best worst α any boundary-preserving method can reach, from `tetopt quality --json` "
          "(diagnosis.bound) and, on meshes under 30k tets, `bound.py MESH` beside it.\n")
    print("| mesh | input worst α | smooth | combined | best | bound | best: dihedrals | best: time (s) | referee |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, path in meshes:
        row = {}
        for mode in ("smooth", "combined", "best"):
            row[mode] = ctx.improve(path, f"m_{name}_{mode}", "--mode", mode)
        # tetopt's own bound (diagnose.hpp; agrees with bound.py to 1e-3 on
        # tire and hinge_raw), and bound.py itself on the small meshes.
        bound = "-"
        q, _ = run([ctx.tetopt, "quality", path, "--json"])
        if q.returncode == 0:
            bound = f"{json.loads(q.stdout)['diagnosis']['bound']['alpha_upper_bound']:.4f}"
        if os.path.exists(ctx.bound) and row["best"].get("before", {}).get("tets", 10**9) < 30000:
            p, _ = run(["/usr/bin/python3", ctx.bound, path], timeout=3600)
            for tok in p.stdout.split():
                if tok.startswith("alpha_upper_bound="):
                    bound += f" (bound.py {tok.split('=')[1]})"
        b = row["best"]
        if "error" in b:
            print(f"| {name} | error: {b['error']} ||||||||")
            continue

        def w(r):
            return "error" if "error" in r else f4(r["after"]["alpha_worst"])
        print(f"| {name} | {f4(b['before']['alpha_worst'])} | {w(row['smooth'])} | {w(row['combined'])} | "
              f"{w(b)} | {bound} | {b['after']['dihedral_min']:.2f}–{b['after']['dihedral_max']:.2f} | "
              f"{b['seconds']['total']:.2f} | {b['referee']} |")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tetopt", default=os.path.join(ROOT, "build", "tetopt"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "experiments"))
    ap.add_argument("--shared", default=os.path.join(ROOT, "..", "shared"))
    ap.add_argument("--impeller", default=os.path.join(ROOT, "out", "demo", "impeller.mesh"))
    ap.add_argument("--sections", default="table2,table3,modes,c")
    ap.add_argument("--seeds", default="0,1,2")
    a = ap.parse_args()
    ctx = Ctx(a)
    md = os.path.join(a.shared, "meshes")
    shared = [(n, os.path.join(md, p)) for n, p in [
        ("tire", "tire/tire.vtk"), ("cube-clip-5", "cube-clip-5/cube-clip-5.vtk"),
        ("flat-tet-sphere", "flat-tet-sphere/flat-tet-sphere.vtk"), ("cub_wedge_like", "cub_wedge_like/cub_wedge_like.vtk"),
        ("hinge_raw", "hinge_raw/hinge_raw.mesh"), ("hinge_small", "hinge_small/hinge_small.mesh"),
        ("screw_graded", "screw_graded/screw_graded.mesh"), ("flange", "flange/flange.mesh"),
        ("aorta_vessel", "aorta_vessel/aorta_vessel.mesh")] if os.path.exists(os.path.join(md, p))]
    secs = a.sections.split(",")
    print(f"<!-- generated by bench/experiments.py on {time.strftime('%Y-%m-%d %H:%M')} with {a.tetopt} -->\n")
    if "table2" in secs and os.path.exists(a.impeller):
        section_table2(ctx, a.impeller)
    if "table3" in secs:
        section_table3(ctx, os.path.join(md, "tire", "tire.vtk"), [int(s) for s in a.seeds.split(",") if s])
    if "modes" in secs:
        section_modes(ctx, shared +
                      ([("impeller", a.impeller)] if os.path.exists(a.impeller) else []))
    if "c" in secs:
        section_c(ctx, ([("impeller", a.impeller)] if os.path.exists(a.impeller) else []) + shared)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
