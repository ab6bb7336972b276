#!/usr/bin/python3
"""The discretisation error of CalculiX's linear tets (C3D4) on a mesh.

The FEM twin of bench/foam_laplace.py: the harmonic function
u = exp(0.7 x) cos(0.7 y) + x y z is imposed at every vertex of a boundary
triangle, CalculiX (`ccx`, Debian's calculix-ccx) solves steady heat
conduction with conductivity 1 (the Laplace equation) on C3D4 elements,
and the error of the piecewise-linear solution at the tets' centroids is
measured against u: the volume-weighted RMS and the largest, relative to
the largest |u| at the centroids.  Where every vertex is on the boundary
(raw `tetgen -p` output) nothing is solved and the error is that of the
boundary values' interpolation.

usage: ccx_laplace.py MESH WORKDIR     (MESH: what meshio reads, with its
                                        boundary triangles; Debian's
                                        python3-meshio and python3-numpy)
Prints one line: nodes, free nodes, tets, fem_rms=..., fem_max=..."""
import math
import os
import subprocess
import sys

import meshio
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import foam_laplace  # noqa: E402  (the harmonic function, one definition)


def exact(p):
    return np.array([foam_laplace.exact(*q) for q in np.reshape(p, (-1, 3))])


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    m = meshio.read(sys.argv[1])
    work = sys.argv[2]
    os.makedirs(work, exist_ok=True)
    P = np.asarray(m.points, dtype=float)
    T = np.concatenate([c.data for c in m.cells if c.type == "tetra"]).astype(np.int64)
    F = np.concatenate([c.data for c in m.cells if c.type == "triangle"]).astype(np.int64)
    used = np.unique(T)
    fixed = np.intersect1d(np.unique(F), used)
    # C3D4: (n2 - n1) x (n3 - n1) . (n4 - n1) > 0 (CalculiX manual, element C3D4).
    a, b, c, d = (P[T[:, k]] for k in range(4))
    det = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    T = np.where((det < 0)[:, None], T[:, [0, 2, 1, 3]], T)
    vol = np.abs(det) / 6
    # CalculiX reads at most 20 characters a field: 14 significant digits.
    with open(os.path.join(work, "job.inp"), "w") as f:
        f.write("*NODE, NSET=NALL\n")
        for i in used:
            f.write("%d, %.13e, %.13e, %.13e\n" % (i + 1, *P[i]))
        f.write("*ELEMENT, TYPE=C3D4, ELSET=EALL\n")
        for e, t in enumerate(T):
            f.write("%d, %d, %d, %d, %d\n" % (e + 1, *(t + 1)))
        f.write("*MATERIAL, NAME=M\n*CONDUCTIVITY\n1.\n*SOLID SECTION, ELSET=EALL, MATERIAL=M\n")
        f.write("*STEP\n*HEAT TRANSFER, STEADY STATE\n1., 1.\n*BOUNDARY\n")
        uf = exact(P[fixed])
        for i, v in zip(fixed, uf):
            f.write("%d, 11, 11, %.13e\n" % (i + 1, v))
        f.write("*NODE FILE\nNT\n*END STEP\n")
    r = subprocess.run(["ccx", "-i", "job"], cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0 or not os.path.exists(os.path.join(work, "job.frd")):
        sys.exit("ccx failed:\n" + r.stdout[-2000:])
    u = np.full(len(P), np.nan)
    block = False
    for line in open(os.path.join(work, "job.frd")):
        if line.startswith(" -4  NDTEMP"):
            block = True
            continue
        if block and line.startswith(" -3"):
            break
        if block and line.startswith(" -1"):
            u[int(line[3:13]) - 1] = float(line[13:25])
    if np.isnan(u[used]).any():
        sys.exit("ccx's .frd lacks temperatures of some nodes")
    cen = P[T].mean(axis=1)
    ue = exact(cen)
    uh = u[T].mean(axis=1)
    scale = np.abs(ue).max()
    rms = math.sqrt(float((vol * (uh - ue) ** 2).sum() / vol.sum())) / scale
    mx = float(np.abs(uh - ue).max()) / scale
    print("nodes=%d free=%d tets=%d fem_rms=%.3e fem_max=%.3e" % (len(used), len(used) - len(fixed), len(T), rms, mx))


main()
