"""read / write keep refs, groups and per-vertex data."""
import warnings

import numpy as np
import pytest

import tetopt


@pytest.fixture
def rich(box):
    mesh = tetopt.read(box)
    n = len(mesh.points)
    mesh.point_refs = (np.arange(n) % 3).astype(np.int32)
    mesh.groups = [(3, 1, "left half"), (3, 2, "right"), (2, 1, "skin")]
    mesh.edges = mesh.tets[:5, :2].copy()
    mesh.edge_refs = np.arange(5, dtype=np.int32) + 10
    mesh.required_vertices = np.array([0, 3], np.int32)
    mesh.corners = np.array([1], np.int32)
    mesh.ridges = np.array([2], np.int32)
    return mesh


@pytest.mark.parametrize("ext", [".mesh", ".meshb", ".msh"])
def test_refs_groups_and_lists_survive(rich, tmp_path, ext):
    a, b = tmp_path / ("a" + ext), tmp_path / ("b" + ext)
    tetopt.write(a, rich)
    back = tetopt.read(a)
    assert np.array_equal(back.points, rich.points)
    assert np.array_equal(back.tets, rich.tets)
    assert np.array_equal(back.refs, rich.refs)
    assert np.array_equal(back.triangles, rich.triangles)
    assert np.array_equal(back.triangle_refs, rich.triangle_refs)
    if ext != ".msh":  # Medit carries vertex refs and required entities
        assert np.array_equal(back.point_refs, rich.point_refs)
        assert np.array_equal(back.edges, rich.edges) and np.array_equal(back.edge_refs, rich.edge_refs)
        assert back.required_vertices.tolist() == [0, 3] and back.corners.tolist() == [1]
        assert back.ridges.tolist() == [2]
    else:  # Gmsh carries physical names
        assert back.groups == rich.groups
    tetopt.write(b, back)
    assert b.read_bytes() == a.read_bytes()


def test_point_data_survives_vtu(box, tmp_path):
    mesh = tetopt.read(box)
    n = len(mesh.points)
    mesh.point_data = {"fixed": (np.arange(n) % 2).astype(np.int32),
                       "velocity": np.linspace(0, 1, 3 * n).reshape(n, 3)}
    tetopt.write(tmp_path / "a.vtu", mesh)
    back = tetopt.read(tmp_path / "a.vtu")
    assert list(back.point_data) == ["fixed", "velocity"]
    assert back.point_data["fixed"].dtype.kind == "i"
    assert np.array_equal(back.point_data["fixed"], mesh.point_data["fixed"])
    assert np.array_equal(back.point_data["velocity"], mesh.point_data["velocity"])
    improved, _ = tetopt.improve_mesh(back)
    assert np.array_equal(improved.point_data["fixed"], mesh.point_data["fixed"])


def test_orientation_convention_is_kept(box, tmp_path):
    mesh = tetopt.read(box)
    tetopt.write(tmp_path / "a.node", mesh)  # positive, as TetGen 1.5 writes
    back = tetopt.read(tmp_path / "a.node")
    assert not back.flipped_on_read and back.source_format == "tetgen"
    assert np.array_equal(back.tets, mesh.tets)  # positive in memory
    # A negative (Stellar-style) .ele is flipped on read and written back negative.
    neg = tetopt.Mesh(mesh.points, mesh.tets[:, [0, 1, 3, 2]], mesh.refs)
    tetopt.write(tmp_path / "n.node", neg)
    n = tetopt.read(tmp_path / "n.node")
    assert n.flipped_on_read and np.array_equal(n.tets, mesh.tets)
    tetopt.write(tmp_path / "n2.node", n)
    assert (tmp_path / "n2.ele").read_text() == (tmp_path / "n.ele").read_text()
    q = tetopt.quality(back)
    assert q["inverted_or_flat"] == 0


def test_read_warns_about_inverted_tets(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [0, 0, -1.0]])
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [0, 1, 2, 5]])  # tet 2 inverted
    tetopt.write(tmp_path / "inv.mesh", tetopt.Mesh(pts, tets))
    with pytest.warns(RuntimeWarning, match=r"1 inverted tets \(0-based ids 2\)"):
        back = tetopt.read(tmp_path / "inv.mesh")
    assert np.array_equal(back.tets, tets)


def test_read_of_a_valid_mesh_does_not_warn(box):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tetopt.read(box)


def test_paths_may_be_pathlike_or_str(box, tmp_path):
    a = tetopt.read(str(box))
    b = tetopt.read(box)
    assert np.array_equal(a.tets, b.tets)
    tetopt.write(str(tmp_path / "s.mesh"), a)
    assert (tmp_path / "s.mesh").read_bytes() == box.read_bytes()


def test_write_warns_of_what_the_format_cannot_hold(rich, tmp_path):
    # As tetopt convert: the .msh file cannot hold the vertex refs, the
    # required vertices and the ridges; .mesh holds all but the group names.
    with pytest.warns(UserWarning, match=r"a\.msh: this format cannot hold the mesh's vertex refs \(\d+ nonzero\)"):
        tetopt.write(tmp_path / "a.msh", rich)
    with pytest.warns(UserWarning, match=r"physical names \(3\)") as rec:
        tetopt.write(tmp_path / "a.mesh", rich)
    assert "vertex refs" not in str(rec[0].message)
    plain = tetopt.read(tmp_path / "a.mesh")
    plain.groups = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tetopt.write(tmp_path / "b.mesh", plain)
