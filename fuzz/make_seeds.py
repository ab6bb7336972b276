#!/usr/bin/python3
"""Writes the seed corpora of the reader fuzz targets: fuzz/corpus/TARGET/seed-*.

Every seed is a VALID file of one variant of its format (the fuzzer mutates
from there; a variant no seed holds is a reader path it may never reach: the
zlib VTU overflow of issue 25 was such a path).  The meshes are tiny boxes
made here (Kuhn subdivision of a grid of cubes, two regions), written by hand
from the format specifications, so that variants the library's writers never
emit (zlib blocks, appended data, big-endian, UInt32 headers, GMF version 1,
MSH 4.1 with 4-byte size_t, VTK 5.1 OFFSETS/CONNECTIVITY ...) are covered.
Each seed stays below the fuzz run's -max_len (8192 bytes).

    /usr/bin/python3 fuzz/make_seeds.py [OUTDIR]      (default: fuzz/corpus)

Check that every seed is accepted with fuzz/check_seeds.sh (it runs each
fuzz target on its seeds with TETOPT_FUZZ_STRICT=1, which aborts on a
refused input).  Only the standard library is used.
"""
import base64
import os
import struct
import sys
import zlib

MAX_LEN = 8192


# ------------------------------------------------------------------ mesh ----

class Mesh:
    pass


def box(nx, ny, nz):
    """A box of nx*ny*nz unit cubes, 6 positive tets each; the cubes with
    i < nx/2 (rounded up) are region 1, the others region 2.  Boundary
    triangles carry the side's number (1..6), the interface ref 7; the 12
    box edges ref 1..12 split into grid edges; the 8 box corners."""
    m = Mesh()
    vid = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)
    m.xyz = [(float(i), float(j), float(k)) for k in range(nz + 1) for j in range(ny + 1) for i in range(nx + 1)]
    m.tets, m.tet_ref = [], []
    perms = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    half = (nx + 1) // 2
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                for p in perms:
                    c = [i, j, k]
                    t = [vid(*c)]
                    for a in p:
                        c[a] += 1
                        t.append(vid(*c))
                    if orient(m.xyz, t) < 0:
                        t[2], t[3] = t[3], t[2]
                    m.tets.append(t)
                    m.tet_ref.append(1 if (nx == 1 or i < half) else 2)
    # faces seen once (boundary) or between regions (interface)
    faces = {}
    for ti, t in enumerate(m.tets):
        for f in ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)):  # outward for a positive tet
            tri = tuple(t[x] for x in f)
            faces.setdefault(tuple(sorted(tri)), []).append((tri, ti))
    m.tris, m.tri_ref = [], []
    for key in sorted(faces):
        lst = faces[key]
        tri = lst[0][0]
        if len(lst) == 1:
            pts = [m.xyz[v] for v in tri]
            side = 0
            for ax, hi in ((0, nx), (1, ny), (2, nz)):
                if all(p[ax] == 0 for p in pts):
                    side = 2 * ax + 1
                elif all(p[ax] == hi for p in pts):
                    side = 2 * ax + 2
            m.tris.append(tri)
            m.tri_ref.append(side)
        elif m.tet_ref[lst[0][1]] != m.tet_ref[lst[1][1]]:
            m.tris.append(tri)
            m.tri_ref.append(7)
    # box edges, split at grid points
    m.edges, m.edge_ref = [], []
    n = (nx, ny, nz)
    r = 0
    for ax in range(3):
        o1, o2 = [a for a in range(3) if a != ax]
        for s1 in (0, n[o1]):
            for s2 in (0, n[o2]):
                r += 1
                for s in range(n[ax]):
                    a, b = [0, 0, 0], [0, 0, 0]
                    a[ax], b[ax] = s, s + 1
                    a[o1] = b[o1] = s1
                    a[o2] = b[o2] = s2
                    m.edges.append((vid(*a), vid(*b)))
                    m.edge_ref.append(r)
    m.corners = [vid(i, j, k) for k in (0, nz) for j in (0, ny) for i in (0, nx)]
    m.vert_ref = [0] * len(m.xyz)
    for c in m.corners:
        m.vert_ref[c] = 1
    return m


def orient(xyz, t):
    a, b, c, d = (xyz[v] for v in t)
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    w = [d[i] - a[i] for i in range(3)]
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]))


def jittered(m, amount=0.11):
    """The same mesh scaled and moved to coordinates that are not whole
    numbers (float formatting and float32 rounding are exercised), with the
    vertices strictly inside moved a little (the box stays a box)."""
    out = Mesh()
    out.__dict__.update(m.__dict__)
    hi = [max(p[a] for p in m.xyz) for a in range(3)]
    xyz = []
    for i, p in enumerate(m.xyz):
        inside = all(0 < p[a] < hi[a] for a in range(3))
        d = (((i * 37) % 11 - 5) / 5.0 + 0.3) * amount if inside else 0.0
        q = (p[0] + d, p[1] - d / 2, p[2] + d / 3)
        xyz.append((0.3 * q[0] - 1.25, 1.7 * q[1] + 3.5, 0.1 * q[2] + 1e-3))
    out.xyz = xyz
    return out


def fmt(x):
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


# ---------------------------------------------------------------- medit ----

def medit_ascii(m, version=2, extras=True, comments=False, skip=False):
    o = []
    if comments:
        o.append("# made by fuzz/make_seeds.py\n")
    o.append("MeshVersionFormatted %d\n\nDimension %s3\n\n" % (version, "\n" if comments else ""))
    if skip:
        o.append("Identifier\n\"seed box\"\nBoundingBox\n0 2 0 1 0 1\n")
    o.append("Vertices\n%d\n" % len(m.xyz))
    for p, r in zip(m.xyz, m.vert_ref):
        o.append("%s %s %s %d\n" % (fmt(p[0]), fmt(p[1]), fmt(p[2]), r))
    if extras:
        o.append("\nEdges\n%d\n" % len(m.edges))
        for e, r in zip(m.edges, m.edge_ref):
            o.append("%d %d %d\n" % (e[0] + 1, e[1] + 1, r))
        o.append("\nTriangles\n%d\n" % len(m.tris))
        for t, r in zip(m.tris, m.tri_ref):
            o.append("%d %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1, r))
    o.append("\nTetrahedra\n%d\n" % len(m.tets))
    for t, r in zip(m.tets, m.tet_ref):
        o.append("%d %d %d %d %d%s\n" % (t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1, r, "  # tet" if comments else ""))
    if extras:
        o.append("\nCorners\n%d\n%s\n" % (len(m.corners), "\n".join(str(c + 1) for c in m.corners)))
        o.append("\nRequiredVertices\n2\n1 %d\n" % len(m.xyz))
        o.append("\nRidges\n3\n1 2 3\nRequiredEdges\n2\n1 %d\n" % len(m.edges))
        o.append("\nRequiredTriangles\n2\n1 %d\n" % len(m.tris))
    if skip:
        o.append("Normals\n1\n0 0 1\nNormalAtVertices\n1\n1 1\nQuadrilaterals\n0\nHexahedra\n0\n")
    o.append("\nEnd\n")
    return "".join(o).encode()


# GMF keyword codes (libMeshb)
GMF = dict(Dimension=3, Vertices=4, Edges=5, Triangles=6, Tetrahedra=8, Hexahedra=10, Corners=13, Ridges=14,
           RequiredVertices=15, RequiredEdges=16, RequiredTriangles=17, Normals=60, End=54)


def meshb(m, ver, big=False, extras=True, unknown=False, order=None):
    """GMF binary: version 1 float32/int32/int32 positions, 2 float64/int32/
    int32, 3 float64/int32/int64, 4 float64/int64/int64."""
    e = ">" if big else "<"
    pos_f = e + ("q" if ver >= 3 else "i")
    int_f = e + ("q" if ver == 4 else "i")
    real_f = e + ("f" if ver == 1 else "d")
    out = bytearray(struct.pack(e + "ii", 1, ver))

    def kw(code, body):
        out.extend(struct.pack(e + "i", code))
        at = len(out)
        out.extend(struct.pack(pos_f, 0))
        out.extend(body)
        struct.pack_into(pos_f, out, at, len(out))

    def ints(*v):
        return b"".join(struct.pack(int_f, x) for x in v)

    kw(GMF["Dimension"], struct.pack(e + "i", 3))
    sections = []
    b = bytearray(ints(len(m.xyz)))
    for p, r in zip(m.xyz, m.vert_ref):
        b += b"".join(struct.pack(real_f, x) for x in p) + ints(r)
    sections.append(("Vertices", b))
    if extras:
        b = bytearray(ints(len(m.edges)))
        for t, r in zip(m.edges, m.edge_ref):
            b += ints(*(x + 1 for x in t), r)
        sections.append(("Edges", b))
        b = bytearray(ints(len(m.tris)))
        for t, r in zip(m.tris, m.tri_ref):
            b += ints(*(x + 1 for x in t), r)
        sections.append(("Triangles", b))
    b = bytearray(ints(len(m.tets)))
    for t, r in zip(m.tets, m.tet_ref):
        b += ints(*(x + 1 for x in t), r)
    sections.append(("Tetrahedra", b))
    if extras:
        sections.append(("Corners", ints(len(m.corners), *(c + 1 for c in m.corners))))
        sections.append(("RequiredVertices", ints(2, 1, len(m.xyz))))
        sections.append(("Ridges", ints(2, 1, 2)))
        sections.append(("RequiredEdges", ints(1, len(m.edges))))
        sections.append(("RequiredTriangles", ints(2, 1, len(m.tris))))
    if unknown:  # a keyword the reader skips through its position, and an empty Hexahedra
        sections.insert(1, ("Normals", ints(1) + b"".join(struct.pack(real_f, x) for x in (0, 0, 1))))
        sections.append(("Hexahedra", ints(0)))
    if order:
        sections.sort(key=lambda s: order.index(s[0]) if s[0] in order else len(order))
    for name, body in sections:
        kw(GMF[name], body)
    out.extend(struct.pack(e + "i", GMF["End"]) + struct.pack(pos_f, 0))
    return bytes(out)


# ----------------------------------------------------------------- gmsh ----

def gmsh_elements(m, corners=True, lines=True):
    """(type, entity dim, entity tag, physical, nodes) per element, in block order."""
    el = []
    if corners:
        for i, c in enumerate(m.corners):
            el.append((15, 0, i + 1, 1, (c,)))
    if lines:
        for e, r in zip(m.edges, m.edge_ref):
            el.append((1, 1, r, 100 + r, e))
    for t, r in zip(m.tris, m.tri_ref):
        el.append((2, 2, r, 200 + r, t))
    for t, r in zip(m.tets, m.tet_ref):
        el.append((4, 3, r, 300 + r, t))
    return el


def gmsh22(m, binary=False, physnames=False, comment=False):
    el = gmsh_elements(m)
    o = bytearray(b"$MeshFormat\n2.2 %d 8\n" % (1 if binary else 0))
    if binary:
        o += struct.pack("<i", 1) + b"\n"
    o += b"$EndMeshFormat\n"
    if physnames:
        o += b'$PhysicalNames\n3\n2 201 "xmin"\n3 301 "left"\n3 302 "right part"\n$EndPhysicalNames\n'
    if comment:
        o += b"$Comments\nmade by make_seeds.py\n$EndComments\n"
    o += b"$Nodes\n%d\n" % len(m.xyz)
    for i, p in enumerate(m.xyz):
        if binary:
            o += struct.pack("<i3d", i + 1, *p)
        else:
            o += ("%d %s %s %s\n" % (i + 1, fmt(p[0]), fmt(p[1]), fmt(p[2]))).encode()
    if binary:
        o += b"\n"
    o += b"$EndNodes\n$Elements\n%d\n" % len(el)
    if binary:
        i = 0
        while i < len(el):  # blocks of one type, 2 tags
            j = i
            while j < len(el) and el[j][0] == el[i][0]:
                j += 1
            o += struct.pack("<3i", el[i][0], j - i, 2)
            for k in range(i, j):
                typ, dim, ent, phys, nodes = el[k]
                o += struct.pack("<%di" % (3 + len(nodes)), k + 1, phys, ent, *(v + 1 for v in nodes))
            i = j
        o += b"\n"
    else:
        for k, (typ, dim, ent, phys, nodes) in enumerate(el):
            o += ("%d %d 2 %d %d %s\n" % (k + 1, typ, phys, ent, " ".join(str(v + 1) for v in nodes))).encode()
    o += b"$EndElements\n"
    return bytes(o)


def gmsh41(m, binary=False, dsize=8, entities=True, physnames=False, sparse=False):
    el = gmsh_elements(m)
    st = "<" + ("Q" if dsize == 8 else "I")
    sz = lambda *v: b"".join(struct.pack(st, x) for x in v)
    i32 = lambda *v: struct.pack("<%di" % len(v), *v)
    f64 = lambda *v: struct.pack("<%dd" % len(v), *v)
    ntag = (lambda i: 10 + 3 * i) if sparse else (lambda i: i + 1)
    o = bytearray(b"$MeshFormat\n4.1 %d %d\n" % (1 if binary else 0, dsize))
    if binary:
        o += i32(1) + b"\n"
    o += b"$EndMeshFormat\n"
    if physnames:
        o += b'$PhysicalNames\n2\n3 301 "left"\n3 302 "right"\n$EndPhysicalNames\n'
    ents = [sorted({(e[1], e[2], e[3]) for e in el if e[1] == d}) for d in range(4)]
    if entities:
        o += b"$Entities\n"
        if binary:
            o += sz(*(len(x) for x in ents))
            for d in range(4):
                for (_, tag, phys) in ents[d]:
                    o += i32(tag) + f64(*([0.0] * (3 if d == 0 else 6)))
                    o += sz(1) + i32(phys) if d > 0 or phys else sz(0)
                    if d > 0:
                        o += sz(0)
            o += b"\n"
        else:
            o += ("%d %d %d %d\n" % tuple(len(x) for x in ents)).encode()
            for d in range(4):
                for (_, tag, phys) in ents[d]:
                    box = "0 0 0" if d == 0 else "0 0 0 2 1 1"
                    ph = ("1 %d" % phys) if (d > 0 or phys) else "0"
                    o += ("%d %s %s%s\n" % (tag, box, ph, " 0" if d > 0 else "")).encode()
        o += b"$EndEntities\n"
    # nodes: all in one volume block (entity 3, tag 1), or split in two blocks
    n = len(m.xyz)
    blocks = [(3, 1, list(range(n // 2))), (2, 1, list(range(n // 2, n)))]
    o += b"$Nodes\n"
    tags = [ntag(i) for i in range(n)]
    if binary:
        o += sz(len(blocks), n, min(tags), max(tags))
        for dim, etag, ids in blocks:
            o += i32(dim, etag, 0) + sz(len(ids)) + sz(*(tags[i] for i in ids))
            for i in ids:
                o += f64(*m.xyz[i])
        o += b"\n"
    else:
        o += ("%d %d %d %d\n" % (len(blocks), n, min(tags), max(tags))).encode()
        for dim, etag, ids in blocks:
            o += ("%d %d 0 %d\n" % (dim, etag, len(ids))).encode()
            o += "".join("%d\n" % tags[i] for i in ids).encode()
            o += "".join("%s %s %s\n" % tuple(fmt(x) for x in m.xyz[i]) for i in ids).encode()
    o += b"$EndNodes\n$Elements\n"
    # element blocks: one per (type, entity)
    eb = []
    for k, e in enumerate(el):
        if not eb or (eb[-1][0], eb[-1][1], eb[-1][2]) != (e[0], e[1], e[2]):
            eb.append([e[0], e[1], e[2], []])
        eb[-1][3].append((k + 1, e[4]))
    if binary:
        o += sz(len(eb), len(el), 1, len(el))
        for typ, dim, ent, recs in eb:
            o += i32(dim, ent, typ) + sz(len(recs))
            for tag, nodes in recs:
                o += sz(tag, *(tags[v] for v in nodes))
        o += b"\n"
    else:
        o += ("%d %d 1 %d\n" % (len(eb), len(el), len(el))).encode()
        for typ, dim, ent, recs in eb:
            o += ("%d %d %d %d\n" % (dim, ent, typ, len(recs))).encode()
            for tag, nodes in recs:
                o += ("%d %s\n" % (tag, " ".join(str(tags[v]) for v in nodes))).encode()
    o += b"$EndElements\n"
    return bytes(o)


# ------------------------------------------------------------ VTK cells ----

def vtk_cells(m, lower=True):
    """(type, nodes, ref) of every cell: tets, then (optionally) triangles,
    lines and vertices, as tetopt's writers order them."""
    c = [(10, t, r) for t, r in zip(m.tets, m.tet_ref)]
    if lower:
        c += [(5, t, r) for t, r in zip(m.tris, m.tri_ref)]
        c += [(3, e, r) for e, r in zip(m.edges, m.edge_ref)]
        c += [(1, (v,), 0) for v in m.corners]
    return c


def vtk_legacy(m, binary=False, layout51=False, float32=False, data=True, lower=True):
    cells = vtk_cells(m, lower)
    be = lambda f, *v: struct.pack(">%d%s" % (len(v), f), *v)
    o = bytearray(b"# vtk DataFile Version %s\nseed box\n%s\nDATASET UNSTRUCTURED_GRID\n" %
                  (b"5.1" if layout51 else b"3.0", b"BINARY" if binary else b"ASCII"))
    o += b"POINTS %d %s\n" % (len(m.xyz), b"float" if float32 else b"double")
    if binary:
        o += b"".join(be("f" if float32 else "d", *p) for p in m.xyz) + b"\n"
    else:
        o += "".join("%s %s %s\n" % tuple(fmt(x) for x in p) for p in m.xyz).encode()
    if layout51:
        offs = [0]
        for _, nodes, _ in cells:
            offs.append(offs[-1] + len(nodes))
        conn = [v for _, nodes, _ in cells for v in nodes]
        o += b"CELLS %d %d\nOFFSETS vtktypeint64\n" % (len(offs), len(conn))
        o += be("q", *offs) + b"\n" if binary else (" ".join(map(str, offs)) + "\n").encode()
        o += b"CONNECTIVITY vtktypeint64\n"
        o += be("q", *conn) + b"\n" if binary else (" ".join(map(str, conn)) + "\n").encode()
    else:
        flat = [x for _, nodes, _ in cells for x in (len(nodes),) + tuple(nodes)]
        o += b"CELLS %d %d\n" % (len(cells), len(flat))
        if binary:
            o += be("i", *flat) + b"\n"
        else:
            o += "".join("%d %s\n" % (len(nd), " ".join(map(str, nd))) for _, nd, _ in cells).encode()
    o += b"CELL_TYPES %d\n" % len(cells)
    o += be("i", *(c[0] for c in cells)) + b"\n" if binary else "".join("%d\n" % c[0] for c in cells).encode()
    if data:
        refs = [c[2] for c in cells]
        o += b"CELL_DATA %d\nSCALARS ref int 1\nLOOKUP_TABLE default\n" % len(cells)
        o += be("i", *refs) + b"\n" if binary else (" ".join(map(str, refs)) + "\n").encode()
        o += b"FIELD FieldData 1\ngmsh:geometrical 1 %d int\n" % len(cells)
        o += be("i", *refs) + b"\n" if binary else (" ".join(map(str, refs)) + "\n").encode()
        o += b"POINT_DATA %d\nSCALARS height double\nLOOKUP_TABLE default\n" % len(m.xyz)
        o += be("d", *(p[2] for p in m.xyz)) + b"\n" if binary else (" ".join(fmt(p[2]) for p in m.xyz) + "\n").encode()
        o += b"VECTORS disp float\n"
        vec = [x * 0.5 for p in m.xyz for x in p]
        o += be("f", *vec) + b"\n" if binary else (" ".join(fmt(x) for x in vec) + "\n").encode()
    return bytes(o)


# ------------------------------------------------------------------ VTU ----

class VtuArray:
    def __init__(self, section, name, typ, values, comps=1):
        self.section, self.name, self.typ, self.values, self.comps = section, name, typ, values, comps


XML_FMT = {"Float32": "f", "Float64": "d", "Int8": "b", "UInt8": "B", "Int16": "h", "UInt16": "H",
           "Int32": "i", "UInt32": "I", "Int64": "q", "UInt64": "Q"}


def vtu_arrays(m, float32=False, conn_type="Int64", lower=True, pointdata=True):
    cells = vtk_cells(m, lower)
    offs, conn = [], []
    for _, nodes, _ in cells:
        conn += list(nodes)
        offs.append(len(conn))
    a = [VtuArray("CellData", "ref", "Int32", [c[2] for c in cells]),
         VtuArray("CellData", "gmsh:geometrical", "Int16", [c[2] for c in cells])]
    if pointdata:
        a.append(VtuArray("PointData", "height", "Float64", [p[2] for p in m.xyz]))
        a.append(VtuArray("PointData", "disp", "Float32", [x * 0.5 for p in m.xyz for x in p], 3))
    a.append(VtuArray("Points", "Points", "Float32" if float32 else "Float64", [x for p in m.xyz for x in p], 3))
    a.append(VtuArray("Cells", "connectivity", conn_type, conn))
    a.append(VtuArray("Cells", "offsets", "Int64" if conn_type == "Int64" else "Int32", offs))
    a.append(VtuArray("Cells", "types", "UInt8", [c[0] for c in cells]))
    return a, len(m.xyz), len(cells)


def vtu_payload(raw, header64, big, zlib_bs, last_full_as_bs=False):
    """The bytes of one binary DataArray: [len] + raw, or VTK's compressed
    layout [nb][bs][last][cs...] + zlib blocks.  Returns (header, data)."""
    e = ">" if big else "<"
    hw = e + ("Q" if header64 else "I")
    if zlib_bs is None:
        return struct.pack(hw, len(raw)), raw
    bs = zlib_bs
    blocks = [raw[i:i + bs] for i in range(0, len(raw), bs)]
    last = len(raw) % bs
    if last == 0 and last_full_as_bs and blocks:
        last = bs
    comp = [zlib.compress(b, 9) for b in blocks]
    head = struct.pack(hw, len(blocks)) + struct.pack(hw, bs) + struct.pack(hw, last)
    head += b"".join(struct.pack(hw, len(c)) for c in comp)
    return head, b"".join(comp)


def vtu(m, mode="binary", header64=True, big=False, zlib_bs=None, last_full_as_bs=False, float32=False,
        conn_type="Int64", lower=True, pointdata=True, one_b64_run=False, comment=False, info_key=False):
    """mode: ascii | binary (inline base64) | raw (appended raw) | base64 (appended base64)."""
    arrays, npts, ncells = vtu_arrays(m, float32, conn_type, lower, pointdata)
    e = ">" if big else "<"
    attrs = 'type="UnstructuredGrid" version="1.0" byte_order="%s"' % ("BigEndian" if big else "LittleEndian")
    if mode != "ascii" or header64 is not None:
        attrs += ' header_type="%s"' % ("UInt64" if header64 else "UInt32")
    if zlib_bs is not None:
        attrs += ' compressor="vtkZLibDataCompressor"'
    o = ['<?xml version="1.0"?>\n']
    if comment:
        o.append("<!-- made by fuzz/make_seeds.py -->\n")
    o.append("<VTKFile %s>\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n" %
             (attrs, npts, ncells))
    appended = bytearray()
    for sec in ("PointData", "CellData", "Points", "Cells"):
        sa = [a for a in arrays if a.section == sec]
        if not sa:
            continue
        o.append("      <%s%s>\n" % (sec, ' Scalars="ref"' if sec == "CellData" else ""))
        for a in sa:
            nc = ' NumberOfComponents="%d"' % a.comps if a.comps != 1 else ""
            raw = struct.pack(e + "%d%s" % (len(a.values), XML_FMT[a.typ]), *a.values)
            if mode == "ascii":
                vals = " ".join(fmt(v) if a.typ.startswith("Float") else str(int(v)) for v in a.values)
                # VTK 9 puts <InformationKey> elements before the values
                info = ('\n          <InformationKey name="L2_NORM_RANGE" location="vtkDataArray" length="2">'
                        '\n            <Value index="0">\n              0\n            </Value>'
                        '\n            <Value index="1">\n              2.5\n            </Value>'
                        '\n          </InformationKey>') if info_key and sec == "Points" else ""
                o.append('        <DataArray type="%s" Name="%s"%s format="ascii">%s\n          %s\n        </DataArray>\n'
                         % (a.typ, a.name, nc, info, vals))
                continue
            head, data = vtu_payload(raw, header64, big, zlib_bs, last_full_as_bs)
            if mode == "binary":
                if one_b64_run:
                    text = base64.b64encode(head + data).decode()
                else:  # the way VTK writes it: header and data as separate base64 runs
                    text = base64.b64encode(head).decode() + base64.b64encode(data).decode()
                o.append('        <DataArray type="%s" Name="%s"%s format="binary">\n          %s\n        </DataArray>\n'
                         % (a.typ, a.name, nc, text))
            else:
                off = len(appended)
                if mode == "raw":
                    appended += head + data
                else:
                    appended += base64.b64encode(head) + base64.b64encode(data)
                o.append('        <DataArray type="%s" Name="%s"%s format="appended" offset="%d"/>\n'
                         % (a.typ, a.name, nc, off))
        o.append("      </%s>\n" % sec)
    o.append("    </Piece>\n  </UnstructuredGrid>\n")
    out = "".join(o).encode()
    if mode in ("raw", "base64"):
        out += b'  <AppendedData encoding="%s">\n   _' % mode.encode() + bytes(appended) + b"\n  </AppendedData>\n"
    return out + b"</VTKFile>\n"


# --------------------------------------------------------------- TetGen ----

def tetgen(m, base=0, attrs=True, markers=True, face=True, comments=False, negative=True):
    """node NUL ele [NUL face], as fuzz/tetgen_fuzz.cpp splits its input.
    TetGen's .ele convention is the negative orientation (negative=True)."""
    nd = ["# seed .node\n" if comments else ""]
    nd.append("%d 3 %d %d\n" % (len(m.xyz), 1 if attrs else 0, 1 if markers else 0))
    for i, p in enumerate(m.xyz):
        nd.append("%d %s %s %s%s%s\n" % (i + base, fmt(p[0]), fmt(p[1]), fmt(p[2]), " 0.5" if attrs else "",
                                         " %d" % m.vert_ref[i] if markers else ""))
    el = ["%d 4 %d\n" % (len(m.tets), 1 if attrs else 0)]
    for i, (t, r) in enumerate(zip(m.tets, m.tet_ref)):
        tt = (t[0], t[1], t[3], t[2]) if negative else t
        el.append("%d %s%s%s\n" % (i + base, " ".join(str(v + base) for v in tt), " %d" % r if attrs else "",
                                   "  # tet" if comments else ""))
    out = "".join(nd).encode() + b"\0" + "".join(el).encode()
    if face:
        fc = ["%d %d\n" % (len(m.tris), 1 if markers else 0)]
        for i, (t, r) in enumerate(zip(m.tris, m.tri_ref)):
            fc.append("%d %s%s\n" % (i + base, " ".join(str(v + base) for v in t), " %d" % r if markers else ""))
        out += b"\0" + "".join(fc).encode()
    return out


FOAM_SEP = b"\n@@FILE@@\n"   # as fuzz/openfoam_fuzz.cpp splits its input


def polymesh(m, binary=False, msb=False, label=32, scalar=64, compact=None, zones=True, comments=False,
             old_neighbour=False, uniform_flip=False):
    """OpenFOAM polyMesh files (points, faces, owner, neighbour, boundary,
    cellZones, faceZones, pointZones) joined by FOAM_SEP, written from the
    OpenFOAM user guide (sections 4.1 and 5.1): faces out of their owner,
    internal faces in upper-triangular order, then the patches (the box's
    sides by ref); the interface (ref 7) a faceZone with a flipMap, the
    regions cellZones, vertex 0 a pointZone.  compact: faceCompactList
    (default in binary, as OpenFOAM writes it); old_neighbour: a neighbour
    per face, -1 on the boundary (old files)."""
    if compact is None:
        compact = binary
    fv = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))  # outward faces of a positive tet
    faces = {}
    for ti, t in enumerate(m.tets):
        for f in fv:
            tri = tuple(t[x] for x in f)
            faces.setdefault(tuple(sorted(tri)), []).append((ti, tri))
    internal = sorted((min(l[0][0], l[1][0]), max(l[0][0], l[1][0]), k) for k, l in faces.items() if len(l) == 2)
    flist, owner, neigh = [], [], []
    for o, n, k in internal:
        tri = [tri for (ti, tri) in faces[k] if ti == o][0]
        flist.append(tri); owner.append(o); neigh.append(n)
    tri_ref = {}
    for tri, r in zip(m.tris, m.tri_ref):
        tri_ref.setdefault(tuple(sorted(tri)), r)
    patches = {}
    for k, l in sorted(faces.items()):
        if len(l) == 1:
            patches.setdefault(tri_ref.get(k, 0), []).append(l[0])
    plist = []
    for r in sorted(patches):
        plist.append(("side%d" % r, len(flist), len(patches[r])))
        for ti, tri in patches[r]:
            flist.append(tri); owner.append(ti)
    index = {tuple(sorted(f)): i for i, f in enumerate(flist)}
    iface = [(index[tuple(sorted(t))], t) for t, r in zip(m.tris, m.tri_ref) if r == 7]
    order = ">" if msb else "<"
    lch, sch = ("q" if label == 64 else "i"), ("d" if scalar == 64 else "f")

    def head(cls, obj):
        h = "/* seed: %s */\n" % obj if comments else ""
        h += "FoamFile\n{\n    version 2.0;\n    format %s;\n" % ("binary" if binary else "ascii")
        if binary or label != 32:
            h += '    arch "%s;label=%d;scalar=%d";\n' % ("MSB" if msb else "LSB", label, scalar)
        return h + "    class %s;\n    object %s;\n}\n// * * * //\n\n" % (cls, obj)

    def labels(v):
        if binary:
            return ("%d\n(" % len(v)).encode() + b"".join(struct.pack(order + lch, x) for x in v) + b")"
        return ("%d\n(\n%s)" % (len(v), "".join("%d\n" % x for x in v))).encode()

    pts = head("vectorField", "points").encode()
    if binary:
        pts += ("%d\n(" % len(m.xyz)).encode() + b"".join(struct.pack(order + sch * 3, *p) for p in m.xyz) + b")\n"
    else:
        pts += ("%d\n(\n%s)\n" % (len(m.xyz), "".join("(%s %s %s)\n" % tuple(fmt(x) for x in p) for p in m.xyz))).encode()
    fcs = head("faceCompactList" if compact else "faceList", "faces").encode()
    if compact:
        fcs += labels([3 * i for i in range(len(flist) + 1)]) + b"\n" + labels([v for f in flist for v in f]) + b"\n"
    elif binary:
        fcs += ("%d\n(" % len(flist)).encode() + b"".join(b"3(" + b"".join(struct.pack(order + lch, v) for v in f) + b")"
                                                        for f in flist) + b")\n"
    else:
        fcs += ("%d\n(\n%s)\n" % (len(flist), "".join("3(%d %d %d)\n" % f for f in flist))).encode()
    own = head("labelList", "owner").encode() + labels(owner) + b"\n"
    nb = neigh + ([-1] * (len(flist) - len(neigh)) if old_neighbour else [])
    nei = head("labelList", "neighbour").encode() + labels(nb) + b"\n"
    bnd = head("polyBoundaryMesh", "boundary") + "%d\n(\n" % len(plist)
    for i, (name, start, n) in enumerate(plist):
        extra = "        inGroups List<word> 1(wall);\n" if i == 0 else ""
        bnd += "    %s\n    {\n        type %s;\n%s        nFaces %d;\n        startFace %d;\n    }\n" % (
            name, "wall" if i == 0 else "patch", extra, n, start)
    files = [pts, fcs, own, nei, (bnd + ")\n").encode()]
    if zones:
        cz = head("regIOobject", "cellZones").encode() + b"2\n(\n"
        for r, name in ((1, "left"), (2, "right")):
            cz += ("%s\n{\n    type cellZone;\n    cellLabels List<label> " % name).encode()
            cz += labels([i for i, x in enumerate(m.tet_ref) if x == r]) + b";\n}\n"
        cz += b")\n"
        fz = head("regIOobject", "faceZones").encode() + b"1\n(\niface\n{\n    type faceZone;\n    faceLabels List<label> "
        fz += labels([i for i, t in iface]) + b";\n    flipMap List<bool> "
        flips = [0 if tuple(t) in (tuple(flist[i][j:] + flist[i][:j]) for j in range(3)) else 1 for i, t in iface]
        if uniform_flip and len(set(flips)) == 1:
            fz += ("%d{%d}" % (len(flips), flips[0])).encode()
        elif binary:
            fz += ("%d\n(" % len(flips)).encode() + bytes(flips) + b")"
        else:
            fz += ("%d\n(%s)" % (len(flips), " ".join(str(x) for x in flips))).encode()
        fz += b";\n}\n)\n"
        pz = head("regIOobject", "pointZones").encode() + b"1\n(\ncorner\n{\n    type pointZone;\n    pointLabels List<label> "
        pz += labels([0]) + b";\n}\n)\n"
        files += [cz, fz, pz]
    return FOAM_SEP.join(files)


def fluent(m, binary=False, single=False, mixed=False, zones45=False, two_node_zones=False):
    """ANSYS Fluent mesh, from the Fluent User's Guide appendix B (sections
    B.2, B.3.1-B.3.7, B.4.1): hexadecimal header and body integers, 1-based
    node and cell indices, each face "n0 n1 n2 c0 c1" with its right-hand
    normal toward c0 (c1 = 0 on the boundary), cells grouped by zone (the
    box's regions), the sides as boundary zones, the interface in an
    interior zone of its own; binary: 3010/3013 (2010 single precision)
    sections with 32-bit ints.  mixed: face type 0 and a mixed cell zone
    with a body of element types."""
    fv = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
    order = sorted(range(len(m.tets)), key=lambda t: (m.tet_ref[t], t))
    cell = {t: i + 1 for i, t in enumerate(order)}
    faces = {}
    for ti, t in enumerate(m.tets):
        for f in fv:
            tri = tuple(t[x] for x in f)
            faces.setdefault(tuple(sorted(tri)), []).append((ti, tri))
    side = {}
    for tri, r in zip(m.tris, m.tri_ref):
        side.setdefault(tuple(sorted(tri)), r)
    zones = {}
    for k in sorted(faces):
        l = faces[k]
        if len(l) == 2:
            (ta, tri), (tb, _) = l
            # tri points out of ta: toward c0 = tb
            z = 27 if m.tet_ref[ta] != m.tet_ref[tb] else 20
            zones.setdefault(z, []).append((tri, cell[tb], cell[ta]))
        else:
            ta, tri = l[0]
            zones.setdefault(10 + side.get(k, 0), []).append(((tri[0], tri[2], tri[1]), cell[ta], 0))
    nv, nc = len(m.xyz), len(m.tets)
    nf = sum(len(v) for v in zones.values())
    out = [b'(0 "seed written by make_seeds.py")\n(1 "make_seeds")\n(2 3)\n']
    out.append(("(10 (0 1 %x 0 3))\n(12 (0 1 %x 0 0))\n(13 (0 1 %x 0 0))\n" % (nv, nc, nf)).encode())
    cuts = [(1, nv)] if not two_node_zones else [(1, nv // 2), (nv // 2 + 1, nv)]
    for zi, (a, b) in enumerate(cuts):
        if binary:
            idx = 2010 if single else 3010
            out.append(("(%d (%x %x %x 1 3)(" % (idx, 30 + zi, a, b)).encode())
            out.append(b"".join(struct.pack("<" + ("f" if single else "d") * 3, *m.xyz[i - 1]) for i in range(a, b + 1)))
            out.append((")\nEnd of Binary Section %d)\n" % idx).encode())
        else:
            out.append(("(10 (%x %x %x 1 3)(\n" % (30 + zi, a, b)).encode())
            out.append("".join("%s %s %s\n" % tuple(fmt(x) for x in m.xyz[i - 1]) for i in range(a, b + 1)).encode())
            out.append(b"))\n")
    first = 1
    for r in sorted(set(m.tet_ref)):
        n = sum(1 for t in order if m.tet_ref[t] == r)
        if mixed:
            out.append(("(12 (%x %x %x 1 0)(\n%s\n))\n" % (r, first, first + n - 1, " ".join(["2"] * n))).encode())
        else:
            out.append(("(12 (%x %x %x 1 2))\n" % (r, first, first + n - 1)).encode())
        first += n
    first = 1
    for z in sorted(zones):
        fs = zones[z]
        bc = 2 if z in (20, 27) else 3
        ft = 0 if mixed else 3
        if binary:
            out.append(("(3013 (%x %x %x %x %x)(" % (z, first, first + len(fs) - 1, bc, ft)).encode())
            for tri, c0, c1 in fs:
                vals = ([3] if mixed else []) + [v + 1 for v in tri] + [c0, c1]
                out.append(struct.pack("<%di" % len(vals), *vals))
            out.append(b")\nEnd of Binary Section 3013)\n")
        else:
            out.append(("(13 (%x %x %x %x %x)(\n" % (z, first, first + len(fs) - 1, bc, ft)).encode())
            out.append("".join(("3 " if mixed else "") + "%x %x %x %x %x\n" % (tri[0] + 1, tri[1] + 1, tri[2] + 1, c0, c1)
                               for tri, c0, c1 in fs).encode())
            out.append(b"))\n")
        first += len(fs)
    sec = 45 if zones45 else 39
    for r in sorted(set(m.tet_ref)):
        out.append(("(%d (%d fluid region-%d)())\n" % (sec, r, r)).encode())
    for z in sorted(zones):
        t = "interior" if z in (20, 27) else ("velocity-inlet" if z == 11 else "wall")
        out.append(("(%d (%d %s zone-%d)(\n(some-condition . 1)\n))\n" % (sec, z, t, z)).encode())
    return b"".join(out)


def abaqus(m, sparse=False, generate=False, by_elset=False, continuation=False, lower=False, refs=False):
    """Abaqus / CalculiX input from the Abaqus Keywords Reference (*NODE,
    *ELEMENT TYPE=C3D4, *ELSET with GENERATE, *NSET, *SURFACE TYPE=ELEMENT
    with C3D4 faces S1 = 1-2-3, S2 = 1-4-2, S3 = 2-4-3, S4 = 3-4-1): the
    regions as element sets, the box corners as a node set, each side as a
    surface of element faces; sparse: ids 10 apart; by_elset: the ELSET=
    parameter of *ELEMENT; refs: "**tetopt ref=" comments."""
    nid = (lambda i: 10 * i + 7) if sparse else (lambda i: i + 1)
    eid = (lambda i: 10 * i + 3) if sparse else (lambda i: i + 1)
    kw = (lambda s: s.lower()) if lower else (lambda s: s)
    out = ["** seed written by make_seeds.py\n", kw("*HEADING") + "\n box\n", kw("*NODE") + "\n"]
    for i, p in enumerate(m.xyz):
        out.append("%d, %s, %s, %s\n" % (nid(i), fmt(p[0]), fmt(p[1]), fmt(p[2])))
    regions = sorted(set(m.tet_ref))
    if by_elset:
        for r in regions:
            out.append(kw("*ELEMENT, TYPE=C3D4, ELSET=") + "R%d\n" % r)
            for i, t in enumerate(m.tets):
                if m.tet_ref[i] == r:
                    out.append(("%d, %d, %d,\n%d, %d\n" if continuation else "%d, %d, %d, %d, %d\n") % ((eid(i),) + tuple(nid(v) for v in t)))
    else:
        out.append(kw("*ELEMENT, TYPE=C3D4") + "\n")
        for i, t in enumerate(m.tets):
            out.append(("%d, %d, %d,\n%d, %d\n" if continuation else "%d, %d, %d, %d, %d\n") % ((eid(i),) + tuple(nid(v) for v in t)))
        for r in regions:
            ids = [eid(i) for i, x in enumerate(m.tet_ref) if x == r]
            if refs:
                out.append("**tetopt ref=%d\n" % (r * 10))
            if generate and ids == list(range(ids[0], ids[-1] + 1, (ids[1] - ids[0]) if len(ids) > 1 else 1)):
                out.append(kw("*ELSET, ELSET=") + "R%d, GENERATE\n%d, %d, %d\n" % (r, ids[0], ids[-1], (ids[1] - ids[0]) if len(ids) > 1 else 1))
            else:
                out.append(kw("*ELSET, ELSET=") + "R%d\n" % r + "".join("%d,\n" % x for x in ids))
    out.append(kw("*NSET, NSET=") + "CORNERS\n" + ", ".join(str(nid(v)) for v in m.corners) + "\n")
    fv = {(0, 1, 2): 1, (0, 3, 1): 2, (1, 3, 2): 3, (2, 3, 0): 4}
    faces = {}
    for i, t in enumerate(m.tets):
        for loc, sname in fv.items():
            faces.setdefault(tuple(sorted(t[x] for x in loc)), (i, sname))
    sides = {}
    for tri, r in zip(m.tris, m.tri_ref):
        sides.setdefault(r, []).append(faces[tuple(sorted(tri))])
    for r in sorted(sides):
        out.append(kw("*SURFACE, NAME=") + "SIDE%d, TYPE=ELEMENT\n" % r)
        out.append("".join("%d, S%d\n" % (eid(i), f) for i, f in sides[r]))
    out.append(kw("*MATERIAL, NAME=") + "STEEL\n" + kw("*ELASTIC") + "\n210000., 0.3\n")
    return "".join(out).encode()


# ----------------------------------------------------------------- main ----

def seeds():
    one = box(1, 1, 1)          # 8 vertices, 6 tets
    two = box(2, 1, 1)          # 12 vertices, 12 tets, two regions
    twoj = jittered(box(2, 2, 2))  # 27 vertices, 48 tets, coordinates not whole numbers
    s = {}

    # Medit ASCII
    s["medit/seed-mesh-v2-full"] = medit_ascii(two)
    s["medit/seed-mesh-v1-min"] = medit_ascii(one, version=1, extras=False)
    s["medit/seed-mesh-v3-comments-skip"] = medit_ascii(two, version=3, comments=True, skip=True)
    s["medit/seed-mesh-v2-jitter"] = medit_ascii(twoj, extras=False)

    # Medit binary: versions 1..4, little and big endian, skipped keywords
    for v in (1, 2, 3, 4):
        s["meditb/seed-meshb-v%d-full" % v] = meshb(two, v)
    s["meditb/seed-meshb-v2-min"] = meshb(one, 2, extras=False)
    s["meditb/seed-meshb-v2-bigendian"] = meshb(two, 2, big=True)
    s["meditb/seed-meshb-v3-bigendian"] = meshb(two, 3, big=True)
    s["meditb/seed-meshb-v4-bigendian"] = meshb(one, 4, big=True)
    s["meditb/seed-meshb-v3-unknown-kwd"] = meshb(two, 3, unknown=True)
    s["meditb/seed-meshb-v4-tets-first"] = meshb(two, 4, order=["Tetrahedra", "Triangles", "Vertices"])
    s["meditb/seed-meshb-v1-jitter"] = meshb(twoj, 1, extras=False)

    # Gmsh
    s["gmsh/seed-msh22-ascii"] = gmsh22(two)
    s["gmsh/seed-msh22-ascii-physnames-comments"] = gmsh22(two, physnames=True, comment=True)
    s["gmsh/seed-msh22-binary"] = gmsh22(two, binary=True)
    s["gmsh/seed-msh41-ascii"] = gmsh41(two)
    s["gmsh/seed-msh41-ascii-noentities-sparse"] = gmsh41(two, entities=False, sparse=True)
    s["gmsh/seed-msh41-ascii-physnames"] = gmsh41(one, physnames=True)
    s["gmsh/seed-msh41-binary-size8"] = gmsh41(two, binary=True)
    s["gmsh/seed-msh41-binary-size4"] = gmsh41(two, binary=True, dsize=4)
    s["gmsh/seed-msh41-binary-size4-sparse-jitter"] = gmsh41(twoj, binary=True, dsize=4, sparse=True)

    # legacy VTK
    s["vtk/seed-vtk-ascii-cells"] = vtk_legacy(two)
    s["vtk/seed-vtk-binary-cells"] = vtk_legacy(two, binary=True)
    s["vtk/seed-vtk51-ascii-offsets"] = vtk_legacy(two, layout51=True)
    s["vtk/seed-vtk51-binary-offsets"] = vtk_legacy(two, binary=True, layout51=True)
    s["vtk/seed-vtk-ascii-float-tetsonly"] = vtk_legacy(one, float32=True, data=False, lower=False)
    s["vtk/seed-vtk-binary-float-jitter"] = vtk_legacy(twoj, binary=True, float32=True, lower=False)

    # VTU: ascii, inline base64, appended raw / base64, zlib, big endian
    s["vtu/seed-vtu-ascii"] = vtu(two, "ascii", header64=None, comment=True)
    s["vtu/seed-vtu-ascii-infokey"] = vtu(two, "ascii", header64=None, info_key=True, pointdata=False)
    s["vtu/seed-vtu-ascii-float32-int32"] = vtu(one, "ascii", header64=None, float32=True, conn_type="Int32",
                                                 pointdata=False)
    s["vtu/seed-vtu-base64-u64"] = vtu(two, "binary", header64=True)
    s["vtu/seed-vtu-base64-u32"] = vtu(two, "binary", header64=False)
    s["vtu/seed-vtu-base64-u32-onerun"] = vtu(one, "binary", header64=False, one_b64_run=True)
    s["vtu/seed-vtu-base64-u64-bigendian"] = vtu(two, "binary", header64=True, big=True)
    s["vtu/seed-vtu-appended-raw-u64"] = vtu(two, "raw", header64=True)
    s["vtu/seed-vtu-appended-raw-u32"] = vtu(two, "raw", header64=False, float32=True, conn_type="Int32")
    s["vtu/seed-vtu-appended-raw-u32-bigendian"] = vtu(two, "raw", header64=False, big=True)
    s["vtu/seed-vtu-appended-base64-u64"] = vtu(two, "base64", header64=True)
    s["vtu/seed-vtu-appended-base64-u32"] = vtu(one, "base64", header64=False)
    # zlib (VTK's layout [nb][bs][last][cs_0..cs_nb-1] + nb zlib streams).  In `two`
    # Points are 36 Float64 = 288 bytes, offsets 48 Int64 = 384, ref 48 Int32 = 192:
    #   bs 112: Points 3 blocks (112, 112, 64: a partial last block), offsets 4 (last 48)
    #   bs 96:  Points 3 full blocks (last = 0, as VTK writes it), offsets 4 full blocks
    #   bs 144: Points 2 full blocks written with last = bs; ref 2 blocks (last 48)
    #   bs 100: Points 3 blocks (last 88), values straddling blocks (VTK reads
    #           blocks as one byte stream; meshio cannot read this one)
    #   bs 4096: every array in 1 block
    s["vtu/seed-vtu-zlib-u64-3blocks-partial"] = vtu(two, "binary", header64=True, zlib_bs=112)
    s["vtu/seed-vtu-zlib-u32-3blocks-partial"] = vtu(two, "binary", header64=False, zlib_bs=112)
    s["vtu/seed-vtu-zlib-u64-3blocks-full"] = vtu(two, "binary", header64=True, zlib_bs=96)
    s["vtu/seed-vtu-zlib-u32-3blocks-full"] = vtu(two, "binary", header64=False, zlib_bs=96)
    s["vtu/seed-vtu-zlib-u64-2blocks-last-eq-bs"] = vtu(two, "binary", header64=True, zlib_bs=144, last_full_as_bs=True)
    s["vtu/seed-vtu-zlib-u64-3blocks-straddle"] = vtu(two, "binary", header64=True, zlib_bs=100)
    s["vtu/seed-vtu-zlib-u64-1block"] = vtu(one, "binary", header64=True, zlib_bs=4096)
    s["vtu/seed-vtu-zlib-u64-bigendian-3blocks"] = vtu(two, "binary", header64=True, big=True, zlib_bs=112)
    s["vtu/seed-vtu-zlib-u32-bigendian-3blocks-full"] = vtu(two, "binary", header64=False, big=True, zlib_bs=96)
    # header and blocks as one base64 run (tetopt's reader accepts it; VTK writes two runs)
    s["vtu/seed-vtu-zlib-u32-onerun-4blocks"] = vtu(two, "binary", header64=False, zlib_bs=80, one_b64_run=True)
    s["vtu/seed-vtu-zlib-appended-raw-u64-3blocks"] = vtu(two, "raw", header64=True, zlib_bs=112)
    s["vtu/seed-vtu-zlib-appended-raw-u32-3blocks-full"] = vtu(two, "raw", header64=False, zlib_bs=96)
    s["vtu/seed-vtu-zlib-appended-raw-u64-bigendian"] = vtu(two, "raw", header64=True, big=True, zlib_bs=112)
    s["vtu/seed-vtu-zlib-appended-base64-u64-3blocks"] = vtu(two, "base64", header64=True, zlib_bs=112)
    s["vtu/seed-vtu-zlib-appended-base64-u32-2blocks"] = vtu(two, "base64", header64=False, zlib_bs=144)

    # TetGen (node NUL ele NUL face)
    s["tetgen/seed-tetgen-0based-full"] = tetgen(two)
    s["tetgen/seed-tetgen-1based-full"] = tetgen(two, base=1)
    s["tetgen/seed-tetgen-noface-noattr"] = tetgen(one, attrs=False, markers=False, face=False)
    s["tetgen/seed-tetgen-comments-positive"] = tetgen(two, comments=True, negative=False, base=1)
    s["tetgen/seed-tetgen-jitter"] = tetgen(twoj)

    # OpenFOAM polyMesh (the files joined by FOAM_SEP)
    s["openfoam/seed-foam-ascii-zones-comments"] = polymesh(two, comments=True)
    s["openfoam/seed-foam-ascii-nozones-oldneighbour"] = polymesh(one, zones=False, old_neighbour=True)
    s["openfoam/seed-foam-ascii-compact-uniformflip"] = polymesh(two, compact=True, uniform_flip=True)
    s["openfoam/seed-foam-binary-lsb-32-64"] = polymesh(two, binary=True)
    s["openfoam/seed-foam-binary-msb-64-32"] = polymesh(two, binary=True, msb=True, label=64, scalar=32)
    s["openfoam/seed-foam-binary-facelist"] = polymesh(one, binary=True, compact=False, zones=False)
    s["openfoam/seed-foam-ascii-jitter"] = polymesh(twoj, zones=False)

    # Fluent .msh
    s["fluent/seed-fluent-ascii"] = fluent(two)
    s["fluent/seed-fluent-ascii-mixed-45-nodezones"] = fluent(two, mixed=True, zones45=True, two_node_zones=True)
    s["fluent/seed-fluent-binary-double"] = fluent(two, binary=True)
    s["fluent/seed-fluent-binary-single-mixed"] = fluent(one, binary=True, single=True, mixed=True)
    s["fluent/seed-fluent-ascii-jitter"] = fluent(twoj)

    # Abaqus / CalculiX .inp
    s["abaqus/seed-inp-flat"] = abaqus(two)
    s["abaqus/seed-inp-sparse-generate-refs"] = abaqus(two, sparse=True, generate=True, refs=True)
    s["abaqus/seed-inp-elset-continuation-lower"] = abaqus(two, by_elset=True, continuation=True, lower=True)
    s["abaqus/seed-inp-jitter"] = abaqus(twoj)
    return s


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    outdir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "corpus")
    too_big = []
    for name, data in sorted(seeds().items()):
        if len(data) >= MAX_LEN:
            too_big.append("%s (%d bytes)" % (name, len(data)))
        path = os.path.join(outdir, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(data)
        print("%6d  %s" % (len(data), name))
    if too_big:
        sys.exit("make_seeds: over the fuzz -max_len of %d bytes: %s" % (MAX_LEN, ", ".join(too_big)))


if __name__ == "__main__":
    main()
