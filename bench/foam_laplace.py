#!/usr/bin/env python3
"""The discretisation error of OpenFOAM's Laplacian on a mesh (bench/solver.sh).

A harmonic function u = exp(0.7 x) cos(0.7 y) + x y z is imposed on every
boundary face (its value at the face centre, fixedValue) and laplacianFoam
solves the Laplace equation in one steady step with the schemes OpenFOAM's
steady tutorials use (Gauss linear corrected, three non-orthogonal
correctors, PCG to 1e-12): what is left of u - u_h at the cell centres is
the discretisation error of the mesh alone, with no flow physics.  Prints
one line: cells, the volume-weighted RMS and the largest error, both
relative to the largest |u| at the cell centres.

usage: foam_laplace.py write CASE      (after bench/foam_case.sh's foam_case:
                                        adds 0/T and the Laplace settings)
       foam_laplace.py error CASE      (after laplacianFoam ran in CASE)
Standard library only; the polyMesh must be ASCII (tetopt's default)."""
import math
import os
import re
import sys


def exact(x, y, z):
    return math.exp(0.7 * x) * math.cos(0.7 * y) + x * y * z


def foam_list(path):
    """The entries of an ASCII OpenFOAM list file, as strings."""
    text = open(path).read()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    body = text[text.index("}") + 1:] if "FoamFile" in text else text
    m = re.search(r"(\d+)\s*\(", body)
    n, start = int(m.group(1)), m.end()
    depth, i = 1, start
    while depth:
        c = body[i]
        depth += c == "("
        depth -= c == ")"
        i += 1
    inner = body[start:i - 1]
    return n, inner


def read_points(case):
    n, inner = foam_list(os.path.join(case, "constant/polyMesh/points"))
    pts = [tuple(map(float, t.split())) for t in re.findall(r"\(([^()]*)\)", inner)]
    assert len(pts) == n
    return pts


def read_faces(case):
    n, inner = foam_list(os.path.join(case, "constant/polyMesh/faces"))
    faces = [tuple(map(int, t.split())) for t in re.findall(r"\d+\(([^()]*)\)", inner)]
    assert len(faces) == n
    return faces


def read_labels(case, name):
    n, inner = foam_list(os.path.join(case, "constant/polyMesh", name))
    v = list(map(int, inner.split()))
    assert len(v) == n
    return v


def read_boundary(case):
    text = open(os.path.join(case, "constant/polyMesh/boundary")).read()
    text = text[text.index("}") + 1:]
    return [(name, int(nf), int(sf)) for name, nf, sf in
            re.findall(r"(\w+)\s*\{[^{}]*?nFaces\s+(\d+);[^{}]*?startFace\s+(\d+);[^{}]*\}", text)]


def centroid(pts, ids):
    k = len(ids)
    return tuple(sum(pts[i][d] for i in ids) / k for d in range(3))


def cells(case, pts):
    """Centre and volume of every cell (tets: the vertex average, |det|/6)."""
    faces = read_faces(case)
    owner = read_labels(case, "owner")
    neigh = read_labels(case, "neighbour")
    verts = {}
    for f, c in enumerate(owner):
        verts.setdefault(c, set()).update(faces[f])
    for f, c in enumerate(neigh):
        verts.setdefault(c, set()).update(faces[f])
    out = []
    for c in range(len(verts)):
        v = sorted(verts[c])
        if len(v) != 4:
            sys.exit(f"cell {c} is not a tet")
        a, b, cc, d = (pts[i] for i in v)
        u = [b[k] - a[k] for k in range(3)]
        w = [cc[k] - a[k] for k in range(3)]
        z = [d[k] - a[k] for k in range(3)]
        vol = abs(u[0] * (w[1] * z[2] - w[2] * z[1]) - u[1] * (w[0] * z[2] - w[2] * z[0]) +
                  u[2] * (w[0] * z[1] - w[1] * z[0])) / 6
        out.append((centroid(pts, v), vol))
    return out


def write(case):
    pts = read_points(case)
    faces = read_faces(case)
    patches = read_boundary(case)
    h = "FoamFile { version 2.0; format ascii; class dictionary; object"
    with open(os.path.join(case, "0/T"), "w") as f:
        f.write("FoamFile { version 2.0; format ascii; class volScalarField; object T; }\n")
        f.write("dimensions [0 0 0 1 0 0 0]; internalField uniform 0;\nboundaryField\n{\n")
        for name, nf, sf in patches:
            vals = [exact(*centroid(pts, faces[sf + k])) for k in range(nf)]
            f.write(f"    {name} {{ type fixedValue; value nonuniform List<scalar> {nf}(\n")
            f.write("\n".join("%.17g" % v for v in vals))
            f.write("\n); }\n")
        f.write("}\n")
    with open(os.path.join(case, "system/controlDict"), "w") as f:
        f.write(f"{h} controlDict; }}\napplication laplacianFoam; startFrom startTime; startTime 0; "
                "stopAt endTime; endTime 1; deltaT 1; writeControl timeStep; writeInterval 1; "
                "writeFormat ascii; writePrecision 17; runTimeModifiable false;\n")
    with open(os.path.join(case, "system/fvSchemes"), "w") as f:
        f.write(f"{h} fvSchemes; }}\nddtSchemes {{ default steadyState; }} gradSchemes {{ default Gauss linear; }}\n"
                "divSchemes { default none; } laplacianSchemes { default Gauss linear corrected; }\n"
                "interpolationSchemes { default linear; } snGradSchemes { default corrected; }\n")
    with open(os.path.join(case, "system/fvSolution"), "w") as f:
        f.write(f"{h} fvSolution; }}\nsolvers {{ T {{ solver PCG; preconditioner DIC; tolerance 1e-12; relTol 0; "
                "maxIter 5000; } }\nSIMPLE { nNonOrthogonalCorrectors 3; }\n")
    with open(os.path.join(case, "constant/transportProperties"), "w") as f:
        f.write(f"{h} transportProperties; }}\nDT DT [0 2 -1 0 0 0 0] 1;\n")


def error(case):
    pts = read_points(case)
    cs = cells(case, pts)
    n, inner = foam_list(os.path.join(case, "1/T"))
    vals = list(map(float, inner.split()))
    assert len(vals) == len(cs) == n
    se = sv = 0.0
    mx = umax = 0.0
    for (c, vol), v in zip(cs, vals):
        u = exact(*c)
        e = v - u
        se += vol * e * e
        sv += vol
        mx = max(mx, abs(e))
        umax = max(umax, abs(u))
    print("cells=%d laplace_rms=%.3e laplace_max=%.3e" % (len(cs), math.sqrt(se / sv) / umax, mx / umax))


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("write", "error"):
        sys.exit(__doc__)
    (write if sys.argv[1] == "write" else error)(sys.argv[2])
