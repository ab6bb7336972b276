#!/usr/bin/env python3
"""A surface Medit .mesh (Vertices, Triangles with refs) as a TetGen .smesh
with hole points, so that `tetgen -p` meshes the volume between the
surfaces and leaves the holes empty (a Medit file cannot name holes; TetGen
1.5 manual, section 5.2.2, .smesh: nodes, facets with boundary markers,
holes, regions).  Standard library only.
usage: mesh_to_smesh.py IN.mesh OUT.smesh X,Y,Z [X,Y,Z ...]"""
import sys


def read_medit(path):
    tok = open(path).read().split()
    verts, tris, i = [], [], 0
    while i < len(tok):
        k = tok[i]
        if k == "Vertices":
            n = int(tok[i + 1])
            verts = [tok[i + 2 + 4 * j:i + 5 + 4 * j] for j in range(n)]
            i += 2 + 4 * n
        elif k == "Triangles":
            n = int(tok[i + 1])
            tris = [tok[i + 2 + 4 * j:i + 6 + 4 * j] for j in range(n)]
            i += 2 + 4 * n
        else:
            i += 1
    return verts, tris


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    verts, tris = read_medit(sys.argv[1])
    if not verts or not tris:
        sys.exit(f"{sys.argv[1]}: no Vertices or no Triangles")
    holes = [h.split(",") for h in sys.argv[3:]]
    with open(sys.argv[2], "w") as f:
        f.write(f"{len(verts)} 3 0 0\n")
        for j, v in enumerate(verts):
            f.write(f"{j + 1} {v[0]} {v[1]} {v[2]}\n")
        f.write(f"{len(tris)} 1\n")
        for t in tris:
            f.write(f"3 {t[0]} {t[1]} {t[2]} {t[3]}\n")
        f.write(f"{len(holes)}\n")
        for j, h in enumerate(holes):
            f.write(f"{j + 1} {h[0]} {h[1]} {h[2]}\n")
        f.write("0\n")


main()
