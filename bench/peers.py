#!/usr/bin/python3
"""peers.py: run tetopt's peers side by side on the same meshes, judged by meshcheck.

    /usr/bin/python3 bench/peers.py [--out DIR] [--timeout S] [--tools LIST]
                                    [--tetopt BIN] [--meshcheck PATH] MESH...

For each input mesh (anything meshio reads: Medit .mesh, VTK .vtk/.vtu, Gmsh .msh)
the script writes a canonical copy DIR/<name>/input.mesh (coordinates with 17
significant digits, tet refs, and every constrained face -- boundary faces and
faces between tets of different refs -- as a tagged triangle, so that every tool
knows what it must not touch), then runs each tool on it:

  gmsh    Gmsh's own optimizer (Debian python3-gmsh), in a subprocess:
          gmsh.open(in); gmsh.model.mesh.optimize("", force=True); the result is
          read back through the API and written with 17 digits.
  tetgen  TetGen 1.5 `tetgen -rqYS0` on .node/.ele/.face written from the mesh;
  tetgen-opt  the same with TetGen's strongest optimisation, -rqYS0O9/7o/110.
          Orientation: Debian's TetGen 1.5.0 writes right-handed tets, like Medit
          (checked: `tetgen` on the unit tet corners plus (1,1,1) gives tets of
          volume +1/6 by the right-hand rule), and with -r it re-orients input tets
          that it finds the other way round; Stellar's .ele files (house2) are
          left-handed.  So tets go in right-handed and the output's orientation is
          checked, not assumed.
  netgen  Netgen's Mesh.OptimizeVolumeMesh() (Debian python3-netgen), in a
          subprocess (Netgen's tets are also left-handed: swapped in and out).
  tetopt  `TETOPT improve input.mesh -o out.mesh` when --tetopt names a binary
          whose `improve --help` works.
  tetopt-polish  the same with --polish (the mean polish, issue 26).
  mmg, mmg-insert  MMG's `mmg3d -optim -nosurf` with -noinsert (keeps the
          vertex set) and without it, when --mmg names an mmg3d binary built
          outside the repository (its code never enters it).

Every output is judged against the ORIGINAL input by
`/usr/bin/python3 meshcheck.py compare IN OUT --json` (the independent referee:
no inverted tet, boundary and interfaces bit for bit, volumes per region, tags).
Results go to DIR/peers.json and DIR/peers.md (one table per input: tool, worst
alpha, mean alpha, dihedral min/max, tets, seconds, boundary kept, violations).

"seconds" is the time the tool itself took where it can be measured apart from
file input/output (gmsh, netgen: the optimize call; tetgen, tetopt: the whole
process, including reading and writing its files).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import textwrap
import time

import meshio
import numpy as np

PY = "/usr/bin/python3"
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
ALL_TOOLS = ["gmsh", "tetgen", "tetgen-opt", "netgen", "tetopt", "tetopt-polish", "mmg", "mmg-insert"]
# TetGen switches: the plain run, and its strongest optimisation (level 9, all of
# flips/smoothing/edge-face removal, target maximum dihedral 110 degrees; its
# default target, 165 degrees, leaves meshes already below it untouched)
TETGEN_SWITCHES = {"tetgen": "-rqYS0", "tetgen-opt": "-rqYS0O9/7o/110"}

# local faces of a tet (the face opposite vertex i), as meshcheck numbers them
FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


# --------------------------------------------------------------------------
# reading and writing
# --------------------------------------------------------------------------

def load(path):
    """points, tets, tet refs, triangles, triangle refs, as meshcheck reads them."""
    m = meshio.read(path)
    pts = np.asarray(m.points, dtype=np.float64)
    tets, tt, tris, ft = [], [], [], []
    for i, block in enumerate(m.cells):
        tags = None
        for name, arrays in m.cell_data.items():
            if name == "gmsh:geometrical":
                continue
            arr = np.asarray(arrays[i])
            if arr.ndim == 1 and np.issubdtype(arr.dtype, np.integer):
                tags = arr
                break
        n = len(block.data)
        if tags is None:
            tags = np.zeros(n, dtype=np.int64)
        if block.type == "tetra":
            tets.append(block.data)
            tt.append(tags)
        elif block.type == "triangle":
            tris.append(block.data)
            ft.append(tags)
    if not tets:
        raise SystemExit(f"{path}: no tetrahedra")
    cat = lambda a, shape: np.concatenate(a).astype(np.int64) if a else np.zeros(shape, np.int64)
    return pts, cat(tets, (0, 4)), cat(tt, 0), cat(tris, (0, 3)), cat(ft, 0)


def signed_volumes(pts, tets):
    a, b, c, d = (pts[tets[:, i]] for i in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0


def orientation(pts, tets):
    v = signed_volumes(pts, tets)
    return 1 if (v > 0).sum() >= (v < 0).sum() else -1


def flip(tets):
    """swap the last two vertices: reverses the orientation of every tet."""
    return tets[:, [0, 1, 3, 2]].copy()


def constrained_faces(tets, tags):
    """faces on one tet, or between tets of different refs; oriented outward of
    their (first) tet in the file's own orientation; with the ref of that tet and
    of the tet across (-1 on the boundary)."""
    f = np.concatenate([tets[:, FACES[k]] for k in range(4)])
    owner = np.tile(np.arange(len(tets)), 4)
    keys = np.sort(f, axis=1)
    uniq, first, inv, counts = np.unique(keys, axis=0, return_index=True,
                                         return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    other = np.full(len(uniq), -1)
    # the second owner of each interior face
    order = np.argsort(inv, kind="stable")
    inv_sorted = inv[order]
    dup = np.nonzero(inv_sorted[1:] == inv_sorted[:-1])[0]
    other[inv_sorted[dup]] = owner[order[dup + 1]]
    own = owner[first]
    inner = np.where(other >= 0, tags[np.maximum(other, 0)], -1)
    keep = (counts == 1) | ((other >= 0) & (tags[own] != inner))
    return f[first[keep]], tags[own[keep]], inner[keep]


def write_medit(path, pts, tets, tet_tags, tris, tri_tags):
    with open(path, "w") as fh:
        fh.write("MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n%d\n" % len(pts))
        fh.write("".join("%.17g %.17g %.17g 0\n" % tuple(p) for p in pts.tolist()))
        if len(tris):
            fh.write("\nTriangles\n%d\n" % len(tris))
            fh.write("".join("%d %d %d %d\n" % (a + 1, b + 1, c + 1, r)
                             for (a, b, c), r in zip(tris.tolist(), tri_tags.tolist())))
        fh.write("\nTetrahedra\n%d\n" % len(tets))
        fh.write("".join("%d %d %d %d %d\n" % (a + 1, b + 1, c + 1, d + 1, r)
                         for (a, b, c, d), r in zip(tets.tolist(), tet_tags.tolist())))
        fh.write("\nEnd\n")


def read_tetgen(stem):
    """(points, tets, tet attributes, faces, face markers) of stem.node/.ele/.face."""
    def table(path):
        rows = []
        with open(path) as fh:
            for line in fh:
                line = line.split("#", 1)[0].split()
                if line:
                    rows.append(line)
        return rows[0], rows[1:]

    head, rows = table(stem + ".node")
    n = int(head[0])
    ids = np.array([int(r[0]) for r in rows[:n]])
    base = int(ids.min()) if n else 0
    pts = np.zeros((n, 3))
    pts[ids - base] = np.array([[float(x) for x in r[1:4]] for r in rows[:n]])
    head, rows = table(stem + ".ele")
    nt, npe, natt = int(head[0]), int(head[1]), int(head[2]) if len(head) > 2 else 0
    tets = np.array([[int(x) for x in r[1:5]] for r in rows[:nt]], dtype=np.int64) - base
    att = (np.array([int(float(r[5])) for r in rows[:nt]], dtype=np.int64) if natt
           else np.zeros(nt, np.int64))
    tris, marks = np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    if os.path.exists(stem + ".face"):
        head, rows = table(stem + ".face")
        nf, nmark = int(head[0]), int(head[1]) if len(head) > 1 else 0
        if nf:
            tris = np.array([[int(x) for x in r[1:4]] for r in rows[:nf]], dtype=np.int64) - base
            marks = (np.array([int(r[4]) for r in rows[:nf]], dtype=np.int64) if nmark
                     else np.zeros(nf, np.int64))
    return pts, tets, att, tris, marks


# --------------------------------------------------------------------------
# the tools; each returns (output path or None, seconds or None, note)
# --------------------------------------------------------------------------

def run_sub(cmd, timeout, log, cwd=None, stdin=None):
    t0 = time.perf_counter()
    try:
        with open(log, "w") as fh:
            p = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT, timeout=timeout,
                               cwd=cwd, input=stdin, text=True if stdin else None)
        return p.returncode, time.perf_counter() - t0
    except subprocess.TimeoutExpired:
        return "timeout", time.perf_counter() - t0


def tail(log, n=3):
    try:
        with open(log, errors="replace") as fh:
            lines = [l.strip() for l in fh if l.strip()]
        return " | ".join(lines[-n:])
    except OSError:
        return ""


GMSH_SCRIPT = r"""
import json, sys, time
import numpy as np
import gmsh
inp, out, res = sys.argv[1:4]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 1)
gmsh.open(inp)
t0 = time.perf_counter()
gmsh.model.mesh.optimize("", force=True)
sec = time.perf_counter() - t0
tags, xyz, _ = gmsh.model.mesh.getNodes()
xyz = np.asarray(xyz).reshape(-1, 3)
index = {int(t): i for i, t in enumerate(tags)}
def ref(dim, tag):
    phys = gmsh.model.getPhysicalGroupsForEntity(dim, tag)
    return int(phys[0]) if len(phys) else int(tag)
blocks = {2: ([], []), 3: ([], [])}
for dim, tag in gmsh.model.getEntities():
    if dim not in blocks:
        continue
    types, _, nodes = gmsh.model.mesh.getElements(dim, tag)
    for t, nd in zip(types, nodes):
        if (dim, int(t)) not in ((2, 2), (3, 4)):
            continue
        k = 3 if dim == 2 else 4
        arr = np.array([index[int(x)] for x in nd], dtype=np.int64).reshape(-1, k)
        blocks[dim][0].append(arr)
        blocks[dim][1].append(np.full(len(arr), ref(dim, tag), dtype=np.int64))
gmsh.finalize()
def cat(parts, k):
    return np.concatenate(parts) if parts else np.zeros((0, k) if k else 0, np.int64)
np.savez(out, pts=xyz, tets=cat(blocks[3][0], 4), tet_tags=cat(blocks[3][1], 0),
         tris=cat(blocks[2][0], 3), tri_tags=cat(blocks[2][1], 0))
json.dump({"seconds": sec}, open(res, "w"))
"""


def tool_gmsh(ctx):
    d = ctx["dir"]
    npz, res, log = (os.path.join(d, "gmsh.npz"), os.path.join(d, "gmsh.time.json"),
                     os.path.join(d, "gmsh.log"))
    rc, wall = run_sub([PY, "-c", GMSH_SCRIPT, ctx["input"], npz, res], ctx["timeout"], log)
    if rc != 0:
        return None, wall, f"gmsh failed ({rc}): {tail(log)}"
    z = np.load(npz)
    out = os.path.join(d, "gmsh.mesh")
    write_medit(out, z["pts"], z["tets"], z["tet_tags"], z["tris"], z["tri_tags"])
    os.remove(npz)
    return out, json.load(open(res))["seconds"], "gmsh.model.mesh.optimize('', force=True)"


def tool_tetgen(ctx, variant="tetgen"):
    exe = shutil.which("tetgen")
    if not exe:
        return None, None, "skipped: tetgen not installed (Debian package tetgen)"
    d = os.path.join(ctx["dir"], variant)
    os.makedirs(d, exist_ok=True)
    pts, tets, tt, tris, ft = ctx["mesh"]       # tets right-handed here
    stem = os.path.join(d, "in")
    with open(stem + ".node", "w") as fh:
        fh.write("%d 3 0 0\n" % len(pts))
        fh.write("".join("%d %.17g %.17g %.17g\n" % (i + 1, *p) for i, p in enumerate(pts.tolist())))
    tg = tets                                    # TetGen 1.5.0: right-handed too
    with open(stem + ".ele", "w") as fh:
        fh.write("%d 4 1\n" % len(tg))
        fh.write("".join("%d %d %d %d %d %d\n" % (i + 1, a + 1, b + 1, c + 1, e + 1, r)
                         for i, ((a, b, c, e), r) in enumerate(zip(tg.tolist(), tt.tolist()))))
    # TetGen markers must be non-zero to be kept as boundary markers
    marks = np.where(ft == 0, ft.max(initial=0) + 1, ft) if len(ft) else ft
    with open(stem + ".face", "w") as fh:
        fh.write("%d 1\n" % len(tris))
        fh.write("".join("%d %d %d %d %d\n" % (i + 1, a + 1, b + 1, c + 1, m)
                         for i, ((a, b, c), m) in enumerate(zip(tris.tolist(), marks.tolist()))))
    switches = TETGEN_SWITCHES[variant]
    if len(np.unique(tt)) > 1:
        switches += "A"                          # keep region attributes
    log = os.path.join(ctx["dir"], variant + ".log")
    rc, wall = run_sub([exe, switches, "in"], ctx["timeout"], log, cwd=d)
    if rc != 0:
        return None, wall, f"tetgen {switches} failed ({rc}): {tail(log)}"
    p2, t2, a2, f2, m2 = read_tetgen(os.path.join(d, "in.1"))
    if not len(np.unique(tt)) > 1:
        a2 = np.full(len(t2), tt[0] if len(tt) else 0)
    # map the markers back: faces whose marker was made non-zero get ref 0 again
    if len(ft) and (ft == 0).any():
        m2 = np.where(m2 == ft.max(initial=0) + 1, 0, m2)
    # TetGen also lists faces it found without a marker (0); keep constrained ones only
    if orientation(p2, t2) < 0:                  # not seen with 1.5.0; be safe
        t2 = flip(t2)
    out = os.path.join(ctx["dir"], variant + ".mesh")
    write_medit(out, p2, t2, a2, f2, m2)
    return out, wall, f"tetgen {switches} (whole process)"


NETGEN_SCRIPT = r"""
import json, sys, time
import numpy as np
from netgen.meshing import Mesh, MeshPoint, Pnt, Element3D, Element2D, FaceDescriptor
z = np.load(sys.argv[1])
out, res = sys.argv[2], sys.argv[3]
pts, tets, tt = z["pts"], z["tets"], z["tet_tags"]
tris, inner, outer, ft = z["tris"], z["dom_in"], z["dom_out"], z["tri_tags"]
m = Mesh(dim=3)
pid = [m.Add(MeshPoint(Pnt(*p))) for p in pts.tolist()]
regions = sorted(set(tt.tolist()))
dom = {r: i + 1 for i, r in enumerate(regions)}
fds = {}
for a, b, c, din, dout, tag in zip(*tris.T.tolist(), inner.tolist(), outer.tolist(), ft.tolist()):
    key = (dom[din], dom.get(dout, 0), tag)
    if key not in fds:
        fds[key] = m.Add(FaceDescriptor(surfnr=len(fds) + 1, domin=key[0], domout=key[1], bc=len(fds) + 1))
    m.Add(Element2D(fds[key], [pid[a], pid[b], pid[c]]))
for (a, b, c, d), r in zip(tets.tolist(), tt.tolist()):
    m.Add(Element3D(dom[r], [pid[a], pid[b], pid[c], pid[d]]))
t0 = time.perf_counter()
m.OptimizeVolumeMesh()
sec = time.perf_counter() - t0
P = np.array([[p[0], p[1], p[2]] for p in m.Points()])
T = np.array([[v.nr - 1 for v in e.vertices] for e in m.Elements3D()], dtype=np.int64)
R = np.array([regions[e.index - 1] for e in m.Elements3D()], dtype=np.int64)
back = {v: k[2] for k, v in fds.items()}
S = np.array([[v.nr - 1 for v in e.vertices] for e in m.Elements2D()], dtype=np.int64).reshape(-1, 3)
SR = np.array([back.get(e.index, 0) for e in m.Elements2D()], dtype=np.int64)
np.savez(out, pts=P, tets=T, tet_tags=R, tris=S, tri_tags=SR)
json.dump({"seconds": sec}, open(res, "w"))
"""


def tool_netgen(ctx):
    chk = subprocess.run([PY, "-c", "import netgen.meshing as m; m.Mesh.OptimizeVolumeMesh"],
                         capture_output=True, text=True)
    if chk.returncode != 0:
        return None, None, "skipped: python3-netgen with Mesh.OptimizeVolumeMesh not importable"
    d = ctx["dir"]
    pts, tets, tt, tris, ft = ctx["mesh"]
    # Netgen: left-handed tets; a surface element's normal points out of domin
    inp = os.path.join(d, "netgen_in.npz")
    np.savez(inp, pts=pts, tets=flip(tets), tet_tags=tt, tris=tris[:, [0, 2, 1]],
             dom_in=ctx["dom_in"], dom_out=ctx["dom_out"], tri_tags=ft)
    npz, res, log = (os.path.join(d, "netgen.npz"), os.path.join(d, "netgen.time.json"),
                     os.path.join(d, "netgen.log"))
    rc, wall = run_sub([PY, "-c", NETGEN_SCRIPT, inp, npz, res], ctx["timeout"], log)
    os.remove(inp)
    if rc != 0:
        return None, wall, f"netgen failed ({rc}): {tail(log)}"
    z = np.load(npz)
    out = os.path.join(d, "netgen.mesh")
    write_medit(out, z["pts"], flip(z["tets"]), z["tet_tags"], z["tris"][:, [0, 2, 1]], z["tri_tags"])
    os.remove(npz)
    return out, json.load(open(res))["seconds"], "Mesh.OptimizeVolumeMesh()"


def tool_mmg(ctx, insert):
    exe = ctx.get("mmg")
    if not exe or not os.access(exe, os.X_OK):
        return None, None, "skipped: no mmg3d binary (--mmg)"
    name = "mmg-insert" if insert else "mmg"
    # Binary output: MMG's ASCII .mesh prints 15 significant digits, which
    # changes every coordinate's last bits; its .meshb holds the doubles.
    outb = os.path.join(ctx["dir"], name + ".meshb")
    out = os.path.join(ctx["dir"], name + ".mesh")
    log = os.path.join(ctx["dir"], name + ".log")
    cmd = [exe, "-in", ctx["input"], "-out", outb, "-optim", "-nosurf", "-v", "1"] + ([] if insert else ["-noinsert"])
    rc, wall = run_sub(cmd, ctx["timeout"], log)
    if rc != 0 or not os.path.exists(outb):
        return None, wall, f"mmg3d failed ({rc}): {tail(log)}"
    # .meshb -> .mesh for the referee with tetopt's converter (17 digits: exact).
    conv = subprocess.run([ctx["tetopt"], "convert", outb, out], capture_output=True, text=True)
    if conv.returncode != 0:
        return None, wall, f"converting MMG's .meshb failed: {conv.stderr.strip()[-200:]}"
    return out, wall, "mmg3d " + " ".join(cmd[5:]) + " (whole process; .meshb, converted exactly)"


def tool_tetopt(ctx, extra=()):
    exe = ctx["tetopt"]
    if not exe or not os.access(exe, os.X_OK):
        return None, None, f"skipped: no tetopt binary at {exe!r} (--tetopt)"
    if subprocess.run([exe, "improve", "--help"], capture_output=True).returncode != 0:
        return None, None, "skipped: this tetopt has no working 'improve' command"
    tag = "tetopt" + "".join(extra).replace("--", "-")
    out = os.path.join(ctx["dir"], tag + ".mesh")
    log = os.path.join(ctx["dir"], tag + ".log")
    threads = ctx.get("tetopt_threads", 1)
    note = f"tetopt improve {' '.join(extra)} --threads {threads} (whole process)".replace("  ", " ")
    src = ctx["source"]
    report = os.path.join(ctx["dir"], tag + ".report.json")
    for attempt in (0, 1):
        rc, wall = run_sub([exe, "improve", src, "-o", out, "--threads", str(threads), "--report", report, *extra],
                           ctx["timeout"], log)
        # exit 2 = input error: if tetopt cannot read this format, give it the
        # canonical .mesh copy (same tets, same orientation, exact coordinates)
        if rc == 2 and attempt == 0 and ctx["sign"] > 0 and src != ctx["input"]:
            first = tail(log, 1)
            src = ctx["input"]
            note += f"; on input.mesh (the original gave: {first})"
            continue
        break
    if rc != 0:
        return None, wall, f"tetopt improve failed ({rc}): {tail(log)}"
    try:  # the improve call alone, comparable with the gmsh / netgen seconds
        with open(report) as f:
            note += "; improve call %.2f s" % json.load(f)["seconds"]["total"]
    except (OSError, ValueError, KeyError):
        pass
    return out, wall, note


TOOLS = {"gmsh": tool_gmsh, "tetgen": tool_tetgen,
         "tetgen-opt": lambda ctx: tool_tetgen(ctx, "tetgen-opt"), "netgen": tool_netgen, "tetopt": tool_tetopt,
         "tetopt-polish": lambda ctx: tool_tetopt(ctx, ("--polish",)),
         "mmg": lambda ctx: tool_mmg(ctx, False), "mmg-insert": lambda ctx: tool_mmg(ctx, True)}


# --------------------------------------------------------------------------
# judging and reporting
# --------------------------------------------------------------------------

def judge(meshcheck, before, after, timeout):
    try:
        p = subprocess.run([PY, meshcheck, "compare", before, after, "--json"],
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, ["meshcheck timed out"]
    try:
        j = json.loads(p.stdout)
    except ValueError:
        return None, [f"meshcheck failed: {(p.stderr or p.stdout).strip()[-300:]}"]
    return j, j["problems"]


def row(tool, s, sec, problems, note):
    r = {"tool": tool, "note": note, "seconds": sec}
    if s is not None:
        r.update(alpha_worst=s["alpha_worst"], alpha_mean=s["alpha_mean"],
                 dihedral_min=s["dihedral_min"], dihedral_max=s["dihedral_max"],
                 tets=s["tets"], all_boundary_tets=s["all_boundary_tets"],
                 alpha_below_0_1=s["alpha_below_0.1"])
    if problems is not None:
        r["boundary_kept"] = not any(("boundary" in p or "tag" in p) for p in problems)
        r["violations"] = problems
    return r


def fmt(v, f):
    return "—" if v is None else format(v, f)


def markdown(results):
    out = []
    for res in results:
        out.append(f"### {res['name']}\n\n`{res['path']}`: {res['tets']} tets, "
                   f"{res['regions']} region(s)\n")
        out.append("| tool | worst α | mean α | dihedral min | dihedral max | tets | α<0.1 "
                   "| seconds | boundary kept | violations |")
        out.append("|---|---|---|---|---|---|---|---|---|---|")
        for r in res["rows"]:
            v = r.get("violations")
            vtxt = "—" if v is None else ("none" if not v else "; ".join(v))
            kept = r.get("boundary_kept")
            out.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
                r["tool"], fmt(r.get("alpha_worst"), ".4f"), fmt(r.get("alpha_mean"), ".4f"),
                fmt(r.get("dihedral_min"), ".2f"), fmt(r.get("dihedral_max"), ".2f"),
                fmt(r.get("tets"), "d"), fmt(r.get("alpha_below_0_1"), "d"),
                fmt(r.get("seconds"), ".2f"),
                "—" if kept is None else ("yes" if kept else "no"), vtxt))
        notes = [f"{r['tool']}: {r['note']}" for r in res["rows"] if r.get("note")]
        out.append("\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=textwrap.dedent(__doc__),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--out", default="out/peers")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per tool run")
    ap.add_argument("--tools", default=",".join(ALL_TOOLS))
    ap.add_argument("--tetopt", default=os.path.join(REPO, "build", "tetopt"))
    ap.add_argument("--tetopt-threads", type=int, default=1,
                    help="tetopt's --threads (default 1; the peers' optimisers are serial)")
    ap.add_argument("--mmg", default=os.environ.get("MMG3D", ""), help="an mmg3d binary (tools mmg, mmg-insert)")
    ap.add_argument("--meshcheck", default=os.path.join(REPO, "..", "shared", "tools", "meshcheck.py"))
    args = ap.parse_args()
    tools = [t.strip() for t in args.tools.split(",") if t.strip()]
    bad = [t for t in tools if t not in TOOLS]
    if bad:
        ap.error(f"unknown tool(s) {bad}; choose from {ALL_TOOLS}")
    if not os.path.exists(args.meshcheck):
        ap.error(f"meshcheck not found at {args.meshcheck} (--meshcheck)")
    os.makedirs(args.out, exist_ok=True)

    results = []
    for path in args.meshes:
        name = os.path.basename(path).split(".")[0]
        d = os.path.join(args.out, name)
        os.makedirs(d, exist_ok=True)
        pts, tets, tt, tris, ft = load(path)
        sign = orientation(pts, tets)
        rt = tets if sign > 0 else flip(tets)       # right-handed from here on
        faces, din, dout = constrained_faces(rt, tt)
        # keep the input's triangles and their refs; add constrained faces it lacks
        have = {tuple(sorted(f)): r for f, r in zip(tris.tolist(), ft.tolist())}
        ftags = np.array([have.get(tuple(sorted(f)), 0) for f in faces.tolist()], dtype=np.int64)
        inp = os.path.join(d, "input.mesh")
        write_medit(inp, pts, rt, tt, faces, ftags)
        ctx = {"dir": d, "input": inp, "mesh": (pts, rt, tt, faces, ftags), "dom_in": din,
               "dom_out": dout, "timeout": args.timeout, "tetopt": args.tetopt,
               "tetopt_threads": args.tetopt_threads, "mmg": args.mmg,
               "source": path, "sign": sign}
        print(f"== {path}: {len(tets)} tets, {len(np.unique(tt))} region(s), "
              f"{len(faces)} constrained faces", flush=True)
        rows = []
        j, _ = judge(args.meshcheck, path, path, args.timeout)
        rows.append(row("input", j["before"] if j else None, None, None, None))
        for t in tools:
            try:
                out, sec, note = TOOLS[t](ctx)
            except Exception as e:  # a peer's failure is a result, not a crash
                out, sec, note = None, None, f"{t} failed: {type(e).__name__}: {e}"
            if out is None:
                rows.append(row(t, None, sec, None, note))
                print(f"  {t:7s} {note}", flush=True)
                continue
            if sign < 0 and t != "tetopt":
                # give the file back in the input's own orientation
                p2, t2, g2, f2, r2 = load(out)
                write_medit(out, p2, flip(t2), g2, f2, r2)
            j, problems = judge(args.meshcheck, path, out, args.timeout)
            r = row(t, j["after"] if j else None, sec, problems, note)
            rows.append(r)
            print(f"  {t:7s} worst α {fmt(r.get('alpha_worst'), '.4f')} mean "
                  f"{fmt(r.get('alpha_mean'), '.4f')} tets {fmt(r.get('tets'), 'd')} "
                  f"{fmt(sec, '.2f')} s, violations: {problems or 'none'}", flush=True)
        results.append({"name": name, "path": path, "tets": int(len(tets)),
                        "regions": int(len(np.unique(tt))), "rows": rows})

    with open(os.path.join(args.out, "peers.json"), "w") as fh:
        json.dump(results, fh, indent=1)
    md = markdown(results)
    with open(os.path.join(args.out, "peers.md"), "w") as fh:
        fh.write("# Peers on the same meshes (judged by meshcheck compare)\n\n" + md)
    print("\n" + md)
    print(f"wrote {args.out}/peers.json and {args.out}/peers.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
