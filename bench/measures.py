#!/usr/bin/python3
"""Every per-tet measure of a mesh, computed here with NumPy from the
formulas of docs/measures.md (an independent check of tetopt's own table):
worst and mean of alpha, min sine, dihedral min/max, scaled Jacobian,
radius ratio, mean ratio, equivolume skewness.

usage: bench/measures.py MESH [MESH...]   (anything meshio reads)
"""
import sys

import meshio
import numpy as np


def measures(path):
    m = meshio.read(path)
    p = m.points.astype(float)
    t = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    a, b, c, d = (p[t[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0
    if np.median(vol) < 0:  # file orientation opposite to ours
        b, c = c, b
        vol = -vol
    P = [a, b, c, d]
    E = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    L = {e: np.linalg.norm(P[e[1]] - P[e[0]], axis=1) for e in E}
    faces = [(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)]  # face k opposite vertex k
    A = [0.5 * np.linalg.norm(np.cross(P[f[1]] - P[f[0]], P[f[2]] - P[f[0]]), axis=1) for f in faces]
    Asum = sum(A)
    Lmax = np.max(np.stack(list(L.values())), axis=0)
    alpha = 6 * np.sqrt(6) * vol / (Asum * Lmax)
    # dihedral at edge (i,j): between faces opposite the other two vertices k,l
    sines, angles = [], []
    for (i, j) in E:
        k, l = [x for x in range(4) if x not in (i, j)]
        s = 3 * vol * L[(i, j)] / (2 * A[k] * A[l])
        sines.append(s)
        # angle from face normals (outward), via the vertices
        nk = np.cross(P[faces[k][1]] - P[faces[k][0]], P[faces[k][2]] - P[faces[k][0]])
        nl = np.cross(P[faces[l][1]] - P[faces[l][0]], P[faces[l][2]] - P[faces[l][0]])
        nk = nk * np.sign(np.einsum("ij,ij->i", nk, P[faces[k][0]] - P[k]))[:, None]
        nl = nl * np.sign(np.einsum("ij,ij->i", nl, P[faces[l][0]] - P[l]))[:, None]
        cosang = -np.einsum("ij,ij->i", nk, nl) / (np.linalg.norm(nk, axis=1) * np.linalg.norm(nl, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(cosang, -1, 1))))
    sine = np.min(np.stack(sines), axis=0)
    ang = np.stack(angles)
    corner = [L[(0, 1)] * L[(0, 2)] * L[(0, 3)], L[(0, 1)] * L[(1, 2)] * L[(1, 3)],
              L[(0, 2)] * L[(1, 2)] * L[(2, 3)], L[(0, 3)] * L[(1, 3)] * L[(2, 3)]]
    sj = np.sqrt(2) * 6 * vol / np.maximum(np.max(np.stack(corner), axis=0), np.abs(6 * vol))
    u, v, w = b - a, c - a, d - a
    num = (np.einsum("ij,ij->i", u, u)[:, None] * np.cross(v, w) + np.einsum("ij,ij->i", v, v)[:, None] * np.cross(w, u)
           + np.einsum("ij,ij->i", w, w)[:, None] * np.cross(u, v))
    R = np.linalg.norm(num, axis=1) / (12 * np.abs(vol))
    rr = 3 * (3 * vol / Asum) / R
    mr = 12 * np.cbrt(9 * vol * vol) / sum(x * x for x in L.values())
    skew = 1 - vol / (8 * np.sqrt(3) / 27 * R ** 3)
    return {"tets": len(t), "alpha": (alpha.min(), alpha.mean()), "sine_min": (sine.min(), sine.mean()),
            "dihedral_min": (ang.min(), None), "dihedral_max": (ang.max(), None), "scaled_jacobian": (sj.min(), sj.mean()),
            "radius_ratio": (rr.min(), rr.mean()), "mean_ratio": (mr.min(), mr.mean()),
            "equivolume_skewness": (skew.max(), skew.mean())}


if __name__ == "__main__":
    for path in sys.argv[1:]:
        r = measures(path)
        cells = " ".join(f"{k} {v[0]:.4f}" + (f"/{v[1]:.4f}" if v[1] is not None else "") for k, v in r.items() if k != "tets")
        print(f"{path}: {r['tets']} tets  {cells}")
