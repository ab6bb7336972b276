"""Round trips between tetopt and meshio (skipped when meshio is absent)."""
import numpy as np
import pytest

import tetopt

meshio = pytest.importorskip("meshio")


def assert_same_mesh(a, b, extras=True):
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.tets, b.tets)
    assert np.array_equal(a.refs, b.refs)
    if extras:
        assert np.array_equal(np.asarray(a.triangles).reshape(-1, 3), np.asarray(b.triangles).reshape(-1, 3))
        assert np.array_equal(np.asarray(a.triangle_refs).ravel(), np.asarray(b.triangle_refs).ravel())


def test_to_and_from_meshio_in_memory(box):
    mesh = tetopt.read(box)
    mesh.groups = [(3, 1, "left"), (3, 2, "right"), (2, 1, "skin")]
    m = tetopt.to_meshio(mesh)
    assert isinstance(m, meshio.Mesh)
    assert [c.type for c in m.cells] == ["tetra", "triangle"]
    assert m.field_data["left"].tolist() == [1, 3]
    back = tetopt.from_meshio(m)
    assert_same_mesh(mesh, back)
    assert np.array_equal(back.point_refs, mesh.point_refs)
    assert back.groups == mesh.groups


@pytest.mark.parametrize("ext,fmt", [(".mesh", "medit"), (".msh", "gmsh"), (".vtu", "vtu")])
def test_files_written_by_meshio_read_by_tetopt(box, tmp_path, ext, fmt):
    mesh = tetopt.read(box)
    path = tmp_path / ("via_meshio" + ext)
    kwargs = {"file_format": "gmsh22", "binary": False} if fmt == "gmsh" else {}
    meshio.write(path, tetopt.to_meshio(mesh), **kwargs)
    back = tetopt.read(path)
    assert np.array_equal(back.points, mesh.points)
    assert np.array_equal(back.tets, mesh.tets)
    if fmt != "vtu":  # meshio's .vtu keeps refs as generic cell data
        assert np.array_equal(back.refs, mesh.refs)


@pytest.mark.parametrize("ext", [".mesh", ".msh", ".vtu"])
def test_files_written_by_tetopt_read_by_meshio(box, tmp_path, ext):
    mesh = tetopt.read(box)
    p, t, r, _ = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles)
    path = tmp_path / ("improved" + ext)
    tetopt.write(path, tetopt.Mesh(points=p, tets=t, refs=r, triangles=mesh.triangles,
                                   triangle_refs=mesh.triangle_refs))
    m = meshio.read(path)
    back = tetopt.from_meshio(m)
    assert np.array_equal(back.points, p)
    assert np.array_equal(back.tets, t)
    if ext != ".vtu":
        assert np.array_equal(back.refs, r)


def test_write_accepts_meshio_mesh_and_arrays_form(box, tmp_path):
    mesh = tetopt.read(box)
    m = tetopt.to_meshio(mesh.points, mesh.tets, mesh.refs)
    assert [c.type for c in m.cells] == ["tetra"]
    tetopt.write(tmp_path / "a.mesh", m)
    back = tetopt.read(tmp_path / "a.mesh")
    assert_same_mesh(mesh, back, extras=False)


def test_from_meshio_errors():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    with pytest.raises(ValueError, match="no 'tetra' cells"):
        tetopt.from_meshio(meshio.Mesh(pts, [("triangle", np.array([[0, 1, 2]]))]))
    with pytest.raises(ValueError, match="linear tets only"):
        tetopt.from_meshio(meshio.Mesh(np.zeros((10, 3)), [("tetra10", np.arange(10)[None, :])]))
    with pytest.raises(ValueError, match="ref_key 'nope'"):
        tetopt.from_meshio(meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))]), ref_key="nope")
    with pytest.raises(ValueError, match="2-D"):
        tetopt.from_meshio(meshio.Mesh(pts[:, :2], [("tetra", np.array([[0, 1, 2, 3]]))]))
    # Out-of-range cells surface as ValueError once used.
    bad = tetopt.from_meshio(meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 7]]))]))
    with pytest.raises(ValueError, match=r"tets\[0, 3\] = 7 is out of range"):
        bad.validate()
