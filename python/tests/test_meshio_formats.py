"""meshio in and out: a round trip through every file format both tetopt and
meshio can write, and tetopt.improve(meshio.Mesh) keeping cell data and cell
sets by name (skipped when meshio is absent)."""
import os
import warnings

import numpy as np
import pytest

import tetopt

meshio = pytest.importorskip("meshio")
from meshio._helpers import extension_to_filetypes  # noqa: E402  (meshio 5: extension -> its file types)

# Writer options worth a file of their own (binary / ASCII, format versions).
TETOPT_VARIANTS = {".msh": [dict(msh_version=22), dict(msh_version=22, binary=True), dict(msh_version=41),
                            dict(msh_version=41, binary=True)],
                   ".vtk": [dict(binary=False), dict(binary=True)],
                   ".meshb": [dict(meshb_version=2), dict(meshb_version=3), dict(meshb_version=4)]}
MESHIO_VARIANTS = {"gmsh": [dict(file_format="gmsh22", binary=False), dict(file_format="gmsh22", binary=True),
                            dict(file_format="gmsh", binary=False), dict(file_format="gmsh", binary=True)],
                   "vtk": [dict(file_format="vtk", binary=False), dict(file_format="vtk", binary=True)]}


def common_formats(mesh, tmp):
    """(extension, meshio file type) pairs both write: tetopt.write accepts
    the extension, and meshio reads tetopt's file as that file type."""
    out = []
    for ext, types in sorted(extension_to_filetypes.items()):
        path = os.path.join(tmp, "probe" + ext)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                tetopt.write(path, mesh)
        except ValueError as e:
            assert "unknown extension" in str(e) or "extension" in str(e), e
            continue
        for ft in types:
            try:
                meshio.read(path, file_format=ft)
            except (Exception, SystemExit):  # meshio 5 exits when no reader takes a file
                continue
            out.append((ext, ft))
    return out


@pytest.fixture(scope="module")
def rich(cli, tmp_path_factory):
    from conftest import run_cli
    d = tmp_path_factory.mktemp("fmt")
    run_cli(cli, "generate", d / "r.mesh", "--cells", 4, 4, 4, "--jitter", 0.3, "--regions", 2, "--seed", 5)
    return tetopt.read(d / "r.mesh")


# Formats whose region refs meshio carries as cell data both ways (others,
# e.g. Abaqus element sets, come through meshio without them).
REFS_KEPT = {"medit", "gmsh", "vtk", "vtu", "tetgen"}
# meshio writes the triangles of these as elements tetopt's reader refuses
# (Abaqus: R3D3; tetopt reads C3D4 tets): the round trip is of the tets only.
TETS_ONLY = {"abaqus"}


def same(a, b, refs=True, vertex_order=True):
    if vertex_order:
        assert np.array_equal(a.points, b.points), "points differ"
        assert np.array_equal(a.tets, b.tets), "tets differ"
    else:  # the same tets, bit for bit, with the vertices in another order
        assert len(a.points) == len(b.points)
        assert np.array_equal(a.points[a.tets], b.points[b.tets]), "tets differ"
    if refs:
        assert np.array_equal(a.refs, b.refs), "refs differ"


def test_round_trip_through_every_common_format(rich, tmp_path):
    pairs = common_formats(rich, str(tmp_path))
    exts = {e for e, _ in pairs}
    # What both write today (the list grows with either side's formats).
    assert {".mesh", ".meshb", ".msh", ".vtk", ".vtu", ".node", ".ele"} <= exts, pairs
    tried = 0
    for ext, ft in pairs:
        # tetopt writes, meshio reads.
        for kw in TETOPT_VARIANTS.get(ext, [{}]):
            p = tmp_path / f"t_{ft}_{len(kw)}_{tried}{ext}"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                tetopt.write(p, rich, **kw)
            back = tetopt.from_meshio(meshio.read(p, file_format=ft))
            same(rich, back, refs=ft in REFS_KEPT)
            tried += 1
        # meshio writes, tetopt reads.
        for kw in MESHIO_VARIANTS.get(ft, [dict(file_format=ft)]):
            p = tmp_path / f"m_{ft}_{len(kw)}_{tried}{ext}"
            mm = tetopt.to_meshio(rich.points, rich.tets, rich.refs) if ft in TETS_ONLY else tetopt.to_meshio(rich)
            if ft == "tetgen":  # meshio's TetGen writer takes 1-column point data only
                del mm.point_data["gmsh:dim_tags"]
            meshio.write(p, mm, **kw)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                back = tetopt.read(p)
            # meshio 5.0's Gmsh 4.1 writer orders the nodes by entity and
            # gives every volume entity the physical tag of the first one.
            gmsh41 = kw.get("file_format") == "gmsh"
            same(rich, back, refs=ft in REFS_KEPT and not gmsh41, vertex_order=not gmsh41)
            tried += 1
    print(f"{tried} round trips through {sorted(pairs)}")


def two_block_meshio(rich):
    """The box as meshio holds a Gmsh file: one tetra block per region, a
    triangle block, cell data per block, cell sets and field data."""
    r1, r2 = np.flatnonzero(rich.refs == 1), np.flatnonzero(rich.refs == 2)
    tri = np.asarray(rich.triangles)
    cells = [meshio.CellBlock("tetra", rich.tets[r1]), meshio.CellBlock("triangle", tri),
             meshio.CellBlock("tetra", rich.tets[r2])]
    cell_data = {
        "gmsh:physical": [np.full(len(r1), 7), np.full(len(tri), 3), np.full(len(r2), 8)],
        "conductivity": [np.full(len(r1), 1.5), np.zeros(len(tri)), np.full(len(r2), 2.5)],
        "face_id": [np.zeros(len(r1), np.int32), np.arange(len(tri), dtype=np.int32), np.zeros(len(r2), np.int32)],
    }
    # "core": half of block 0's tets (not a region of its own); "skin": triangles.
    core = np.sort(np.argsort(rich.points[rich.tets[r1]].mean(axis=1)[:, 0])[: len(r1) // 2])
    cell_sets = {"core": [core, None, None], "skin": [None, np.arange(0, len(tri), 2), None],
                 "right": [None, None, np.arange(len(r2))]}
    return meshio.Mesh(rich.points, cells, point_data={"temperature": rich.points[:, 0] * 2.0}, cell_data=cell_data,
                       cell_sets=cell_sets, field_data={"left": np.array([7, 3]), "right": np.array([8, 3])})


def tet_volumes(points, tets):
    p = points[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6


def test_improve_meshio_keeps_cell_data_and_sets(rich):
    m = two_block_meshio(rich)
    out = tetopt.improve(m)
    assert isinstance(out, meshio.Mesh)
    report = out.info["tetopt_report"]
    assert report["boundary_unchanged"]["ok"]
    assert report["after"]["alpha_worst"] > report["before"]["alpha_worst"]
    assert [c.type for c in out.cells] == ["tetra", "triangle", "tetra"]
    assert set(out.cell_data) == set(m.cell_data) and set(out.cell_sets) == set(m.cell_sets)
    assert set(out.field_data) == {"left", "right"}
    assert np.array_equal(out.point_data["temperature"], m.point_data["temperature"])
    # The triangle block and its data are untouched; tets did change.
    assert np.array_equal(out.cells[1].data, m.cells[1].data)
    assert np.array_equal(out.cell_data["face_id"][1], m.cell_data["face_id"][1])
    assert np.array_equal(out.cell_sets["skin"][1], m.cell_sets["skin"][1])
    assert not (len(out.cells[0].data) == len(m.cells[0].data) and np.array_equal(out.cells[0].data, m.cells[0].data))
    for b, (phys, cond) in ((0, (7, 1.5)), (2, (8, 2.5))):
        assert np.all(out.cell_data["gmsh:physical"][b] == phys)
        assert np.all(out.cell_data["conductivity"][b] == cond)
        assert len(out.cell_data["conductivity"][b]) == len(out.cells[b].data)
    assert len(out.cell_sets["right"][2]) == len(out.cells[2].data)  # the whole block, as before
    # "core" is no region of the input: it became one, its boundary kept,
    # so it holds the same volume with different tets.
    core_in = tet_volumes(m.points, m.cells[0].data[m.cell_sets["core"][0]]).sum()
    core_out = tet_volumes(out.points, out.cells[0].data[out.cell_sets["core"][0]]).sum()
    assert core_out == pytest.approx(core_in, rel=1e-12)
    assert 0 < len(out.cell_sets["core"][0]) < len(out.cells[0].data)
    # Same through the Mesh methods and back through a file meshio writes.
    back = tetopt.Mesh.from_meshio(out)
    assert len(back.tets) == sum(len(c.data) for c in out.cells if c.type == "tetra")
    assert isinstance(back.to_meshio(), meshio.Mesh)


def test_improve_meshio_refuses_other_arguments(rich):
    with pytest.raises(ValueError, match="no other array arguments"):
        tetopt.improve(two_block_meshio(rich), rich.tets)
