#!/usr/bin/python3
"""Tets near a point in several meshes: count, alpha, and their vertices
(B = on a boundary/listed triangle, I = free).  Used to compare what tetopt
and a peer did at the same place (docs/results.md, impeller vs Netgen).

usage: /usr/bin/python3 bench/near.py X Y Z RADIUS MESH [MESH ...]
A tet is near when its centroid is within RADIUS of (X, Y, Z).  Needs
Debian's python3-meshio and python3-numpy.
"""
import sys

import meshio
import numpy as np


def alpha(p, t):
    a, b, c, d = (p[t[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0

    def area(x, y, z):
        return 0.5 * np.linalg.norm(np.cross(y - x, z - x), axis=1)

    s = area(b, c, d) + area(a, c, d) + area(a, b, d) + area(a, b, c)
    lmax = np.max([np.linalg.norm(u - v, axis=1) for u, v in ((a, b), (a, c), (a, d), (b, c), (b, d), (c, d))], axis=0)
    return 6.0 * np.sqrt(6.0) * vol / (s * lmax)


def main(argv):
    if len(argv) < 6:
        print(__doc__.strip(), file=sys.stderr)
        return 1
    centre = np.array([float(x) for x in argv[1:4]])
    radius = float(argv[4])
    for path in argv[5:]:
        m = meshio.read(path)
        p = np.asarray(m.points, dtype=float)
        tets = np.vstack([c.data for c in m.cells if c.type == "tetra"])
        tris = [c.data for c in m.cells if c.type == "triangle"]
        on_tri = np.zeros(len(p), bool)
        if tris:
            on_tri[np.vstack(tris).ravel()] = True
        al = alpha(p, tets)
        near = np.where(np.linalg.norm(p[tets].mean(axis=1) - centre, axis=1) < radius)[0]
        verts = sorted(set(tets[near].ravel()))
        print(f"{path}: {len(near)} tets, alpha {np.round(np.sort(al[near]), 3).tolist()}")
        for v in verts:
            print("   %.6g %.6g %.6g %s" % (*p[v], "B" if on_tri[v] else "I"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
