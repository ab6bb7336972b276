"""The Python API gives the command line's results, byte for byte."""
import dataclasses
import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import tetopt
from conftest import run_cli

# (CLI arguments, Python keyword arguments) describing the same run.
RUNS = [
    ([], {}),
    (["--mode", "combined", "--weight", "0.8", "--seed", "3"], {"mode": "combined", "weight": 0.8, "seed": 3}),
    (["--mode", "smooth", "--optimizer", "maxmin", "--iterations", "4"],
     {"mode": "smooth", "optimizer": "maxmin", "iterations": 4}),
    (["--mode", "topo", "--threshold", "0.5"], {"mode": "topo", "threshold": 0.5}),
]


def comparable(report):
    """The parts of a report that do not depend on timing, file names or thread count."""
    opts = {k: v for k, v in report["options"].items() if k != "threads"}
    return {"options": opts, "before": report["before"], "after": report["after"],
            "operations": report["operations"], "boundary_unchanged": report["boundary_unchanged"]}


@pytest.mark.parametrize("cli_args,kwargs", RUNS, ids=["best", "combined", "smooth-maxmin", "topo"])
def test_improve_arrays_matches_cli_bytes(cli, box, tmp_path, cli_args, kwargs):
    cli_out, py_out = tmp_path / "cli.mesh", tmp_path / "py.mesh"
    run_cli(cli, "improve", box, "-o", cli_out, "--report", tmp_path / "r.json", "-q", *cli_args)
    mesh = tetopt.read(box)
    p, t, r, rep = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles, **kwargs)
    tetopt.write(py_out, dataclasses.replace(mesh, points=p, tets=t, refs=r))
    assert py_out.read_bytes() == cli_out.read_bytes()
    cli_rep = json.loads((tmp_path / "r.json").read_text())
    # The CLI may add its diagnosis and insertion hint (improve(...,
    # diagnose=True) does too).
    assert set(rep) == set(cli_rep) - {"diagnosis", "insertion_hint"}
    assert comparable(rep) == comparable(cli_rep)
    assert rep["boundary_unchanged"]["ok"] is True


@pytest.mark.parametrize("ext", [".mesh", ".msh", ".vtu"])
def test_improve_mesh_matches_cli_bytes(cli, box, tmp_path, ext):
    src = tmp_path / ("in" + ext)
    run_cli(cli, "convert", box, src)
    cli_out, py_out = tmp_path / ("cli" + ext), tmp_path / ("py" + ext)
    run_cli(cli, "improve", src, "-o", cli_out, "-q", "--seed", "11")
    mesh = tetopt.read(src)
    improved, rep = tetopt.improve_mesh(mesh, seed=11)
    tetopt.write(py_out, improved)
    assert py_out.read_bytes() == cli_out.read_bytes()
    # The input Mesh is untouched.
    again = tetopt.read(src)
    assert np.array_equal(again.tets, mesh.tets) and np.array_equal(again.points, mesh.points)


def test_quality_matches_cli_json(cli, box):
    cli_stats = json.loads(run_cli(cli, "quality", box, "--json"))
    cli_stats.pop("diagnosis", None)  # see test_diagnosis_matches_cli
    q = tetopt.quality(tetopt.read(box))
    per_tet = q.pop("per_tet")
    assert q == cli_stats
    # Per-tet arrays agree with the summary.
    assert per_tet["alpha"].shape == (cli_stats["tets"],)
    assert per_tet["alpha"].min() == cli_stats["alpha_worst"]
    assert per_tet["dihedral_min"].min() == cli_stats["dihedral_min"]
    assert per_tet["dihedral_max"].max() == cli_stats["dihedral_max"]
    assert np.bincount(per_tet["kind"], minlength=5).tolist() == cli_stats["kind_counts"]
    assert int(np.argmin(per_tet["alpha"])) == cli_stats["worst_tet"]


def test_quality_arrays_equal_quality_mesh(box):
    mesh = tetopt.read(box)
    a = tetopt.quality(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles)
    b = tetopt.quality(mesh)
    for k in ("alpha", "dihedral_min", "dihedral_max", "kind"):
        assert np.array_equal(a["per_tet"][k], b["per_tet"][k])
    a.pop("per_tet"), b.pop("per_tet")
    assert a == b


def alpha_numpy(p):
    """Liu et al. eq. 3.1, written independently of the C++ code."""
    a, b, c, d = p
    vol = np.dot(np.cross(b - a, c - a), d - a) / 6.0
    faces = [(b, c, d), (a, c, d), (a, b, d), (a, b, c)]
    area = sum(0.5 * np.linalg.norm(np.cross(y - x, z - x)) for x, y, z in faces)
    longest = max(np.linalg.norm(u - v) for i, u in enumerate(p) for v in p[i + 1:])
    return 6.0 * math.sqrt(6.0) * vol / (area * longest)


def test_per_tet_alpha_matches_formula(box):
    mesh = tetopt.read(box)
    alpha = tetopt.quality(mesh)["per_tet"]["alpha"]
    for t in range(0, len(mesh.tets), 97):
        assert alpha[t] == pytest.approx(alpha_numpy(mesh.points[mesh.tets[t]]), rel=1e-12)
    regular = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    q = tetopt.quality(regular, [[0, 1, 2, 3]])
    assert q["per_tet"]["alpha"][0] == pytest.approx(1.0, rel=1e-14)
    assert q["per_tet"]["dihedral_min"][0] == pytest.approx(math.degrees(math.acos(1 / 3)), rel=1e-12)


@pytest.mark.parametrize("ext", [".mesh", ".meshb", ".msh", ".vtk", ".vtu", ".node"])
def test_read_write_round_trip_is_byte_identical(cli, box, tmp_path, ext):
    a, b = tmp_path / ("a" + ext), tmp_path / ("b" + ext)
    run_cli(cli, "convert", box, a)
    tetopt.write(b, tetopt.read(a))
    assert b.read_bytes() == a.read_bytes()
    if ext == ".node":
        assert (tmp_path / "b.ele").read_bytes() == (tmp_path / "a.ele").read_bytes()


def test_write_options_match_cli(cli, box, tmp_path):
    a, b = tmp_path / "a.msh", tmp_path / "b.msh"
    run_cli(cli, "convert", box, a, "--msh-version", "22", "--binary")
    tetopt.write(b, tetopt.read(box), msh_version=22, binary=True)
    assert b.read_bytes() == a.read_bytes()


def test_improve_keeps_the_promise(box):
    mesh = tetopt.read(box)
    before = tetopt.quality(mesh)
    p, t, r, rep = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles)
    assert p.dtype == np.float64 and p.shape == mesh.points.shape
    assert t.dtype == np.int32 and t.ndim == 2 and t.shape[1] == 4
    assert r.dtype == np.int32 and r.shape == (len(t),)
    after = tetopt.quality(p, t, r, constrained_faces=mesh.triangles)
    assert after["alpha_worst"] > before["alpha_worst"]
    assert rep["after"]["alpha_worst"] == after["alpha_worst"]
    # Constrained vertices (kind 4 tets' vertices include every boundary one)
    # keep their coordinates bit for bit.
    fixed = np.unique(mesh.triangles)
    assert np.array_equal(p[fixed], mesh.points[fixed])
    # Region volumes are kept.
    def volumes(pts, tets, refs):
        a, b, c, d = (pts[tets[:, i]] for i in range(4))
        v = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6
        return {int(k): v[refs == k].sum() for k in np.unique(refs)}
    v0, v1 = volumes(mesh.points, mesh.tets, mesh.refs), volumes(p, t, r)
    assert v0.keys() == v1.keys()
    for k in v0:
        assert v1[k] == pytest.approx(v0[k], rel=1e-9)
    assert after["inverted_or_flat"] == 0


def test_improve_is_deterministic_and_accepts_int64_and_strided(box):
    mesh = tetopt.read(box)
    a = tetopt.improve(mesh.points, mesh.tets, mesh.refs, seed=5)
    # int64 tets, a non-contiguous view of the points, refs as a Python list.
    big = np.zeros((len(mesh.points), 6))
    big[:, ::2] = mesh.points
    b = tetopt.improve(big[:, ::2], mesh.tets.astype(np.int64), mesh.refs.tolist(), seed=5)
    for x, y in zip(a[:3], b[:3]):
        assert np.array_equal(x, y)


def test_negative_convention_comes_back_negative(box):
    mesh = tetopt.read(box)
    neg = mesh.tets[:, [0, 1, 3, 2]]
    p1, t1, r1, _ = tetopt.improve(mesh.points, mesh.tets, mesh.refs, seed=2)
    p2, t2, r2, _ = tetopt.improve(mesh.points, neg, mesh.refs, seed=2)
    assert np.array_equal(p1, p2) and np.array_equal(r1, r2)
    assert np.array_equal(t2, t1[:, [0, 1, 3, 2]])


def test_log_callback_receives_messages(box):
    mesh = tetopt.read(box)
    seen = []
    tetopt.improve(mesh.points, mesh.tets, mesh.refs, log=lambda lvl, msg: seen.append((lvl, msg)))
    assert seen and all(lvl in ("debug", "info", "progress", "warning") for lvl, _ in seen)


def without_seconds(x):
    if isinstance(x, dict):
        return {k: without_seconds(v) for k, v in x.items() if k != "seconds"}
    if isinstance(x, list):
        return [without_seconds(v) for v in x]
    return x


@pytest.mark.skipif(not tetopt._tetopt.HAVE_DIAGNOSE, reason="library built without tetopt/diagnose.hpp")
def test_diagnosis_matches_cli(cli, tmp_path):
    # Small on purpose: the mesh-wide bound searches every constrained triangle.
    small = tmp_path / "small.mesh"
    run_cli(cli, "generate", small, "--cells", 2, 2, 1, "--jitter", 0.4, "--seed", 3)
    cli_q = json.loads(run_cli(cli, "quality", small, "--json", "--threshold", "0.5"))
    if "diagnosis" not in cli_q:
        pytest.skip("this CLI prints no diagnosis")
    mesh = tetopt.read(small)
    q = tetopt.quality(mesh, diagnose=True, threshold=0.5)
    per_tet = q.pop("per_tet")
    assert without_seconds(q) == without_seconds(cli_q)
    counts = np.bincount(per_tet["diagnosis"], minlength=4)
    d = q["diagnosis"]
    assert counts[1:].tolist() == [d["locked_by_triangle"], d["locked_by_neighbours"], d["improvable"]]

    run_cli(cli, "improve", small, "-o", tmp_path / "out.mesh", "-q", "--threshold", "0.5",
            "--report", tmp_path / "r.json")
    cli_rep = json.loads((tmp_path / "r.json").read_text())
    *_, rep = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles,
                             threshold=0.5, diagnose=True)
    assert list(rep) == list(cli_rep)
    assert without_seconds(rep["diagnosis"]) == without_seconds(cli_rep["diagnosis"])
    assert rep["insertion_hint"] == cli_rep["insertion_hint"]


def test_allow_insert_and_remove_match_cli_and_renumber(cli, tmp_path):
    """--allow-insert --allow-remove through Python: same bytes as the CLI, and
    report["removed_vertices"] (input ids) maps the input's triangles to the
    output numbering."""
    src = tmp_path / "rm.mesh"
    run_cli(cli, "generate", src, "--cells", 8, 8, 8, "--jitter", 0.45, "--seed", 3)
    cli_out, py_out = tmp_path / "cli.mesh", tmp_path / "py.mesh"
    run_cli(cli, "improve", src, "-o", cli_out, "--report", tmp_path / "r.json", "-q", "--allow-insert",
            "--allow-remove")
    cli_rep = json.loads((tmp_path / "r.json").read_text())
    mesh = tetopt.read(src)
    p, t, r, rep = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles,
                                  allow_insert=True, allow_remove=True)
    assert comparable(rep) == comparable(cli_rep)
    assert rep["options"]["allow_remove"] is True
    removed = np.array(rep["removed_vertices"], dtype=np.int64)
    assert rep["operations"]["vertex_removals"] == len(removed) > 0
    assert len(p) == len(mesh.points) + rep["operations"]["insertions"] - len(removed)
    # New id = old id - number of removed ids below it; triangles keep their coordinates.
    tri = mesh.triangles - np.searchsorted(removed, mesh.triangles)
    assert np.array_equal(p[tri], mesh.points[mesh.triangles])
    # Vertex refs: the kept input vertices' in order, then 0 for inserted ones.
    kept = np.delete(mesh.point_refs, removed[removed < len(mesh.points)])
    prefs = np.concatenate([kept, np.zeros(len(p) - len(kept), dtype=kept.dtype)])
    tetopt.write(py_out, dataclasses.replace(mesh, points=p, tets=t, refs=r, point_refs=prefs,
                                             triangles=tri.astype(mesh.triangles.dtype)))
    assert py_out.read_bytes() == cli_out.read_bytes()
    # Every output vertex is used by a tet.
    assert len(np.unique(t)) == len(p)


def test_remesher_size_and_no_remesh_match_cli(cli, tmp_path):
    """size= and remesh= are --size and --no-remesh: the same report (times
    aside) as the CLI; remesh=False splits nothing, a smaller size splits more."""
    src = tmp_path / "rs.mesh"
    run_cli(cli, "generate", src, "--cells", 5, 5, 5, "--jitter", 0.4, "--seed", 5)
    mesh = tetopt.read(src)
    reps = {}
    for name, kw, flags in (("size", {"size": 0.5}, ["--size", "0.5"]), ("off", {"remesh": False}, ["--no-remesh"]),
                            ("default", {}, [])):
        run_cli(cli, "improve", src, "-o", tmp_path / f"{name}.mesh", "--report", tmp_path / f"{name}.json", "-q",
                "--allow-insert", *flags)
        cli_rep = json.loads((tmp_path / f"{name}.json").read_text())
        *_, rep = tetopt.improve(mesh.points, mesh.tets, mesh.refs, constrained_faces=mesh.triangles,
                                 allow_insert=True, **kw)
        assert comparable(rep) == comparable(cli_rep), name
        reps[name] = rep
    assert reps["off"]["operations"]["edge_splits"] == 0
    assert reps["size"]["operations"]["edge_splits"] > reps["default"]["operations"]["edge_splits"]


def test_gradation_matches_cli_on_a_raw_mesh(cli, tmp_path):
    """gradation= is --gradation: on raw tetgen -pQ output of body_in_box.geo
    (no interior vertex) the same output bytes as the CLI, and a ratio of 1.5
    makes fewer tets than the default (1.16)."""
    if not (shutil.which("gmsh") and shutil.which("tetgen")):
        pytest.skip("gmsh and tetgen make the raw mesh")
    geo = Path(__file__).resolve().parents[2] / "tests" / "data" / "gmsh" / "body_in_box.geo"
    surf = tmp_path / "surf.mesh"
    subprocess.run(["gmsh", "-2", "-nt", "1", "-setnumber", "s", "1.0", "-format", "mesh", str(geo), "-o", str(surf)],
                   check=True, capture_output=True)
    subprocess.run(["tetgen", "-pQ", str(surf)], check=True, capture_output=True)
    raw = tmp_path / "surf.1.node"
    mesh = tetopt.read(raw)
    tets = {}
    for name, kw, flags in (("grad", {"gradation": 1.5}, ["--gradation", "1.5"]), ("default", {}, [])):
        cli_out, py_out = tmp_path / f"cli_{name}.mesh", tmp_path / f"py_{name}.mesh"
        run_cli(cli, "improve", raw, "-o", cli_out, "-q", "--allow-insert", "--allow-remove", *flags)
        improved, rep = tetopt.improve_mesh(mesh, allow_insert=True, allow_remove=True, **kw)
        tetopt.write(py_out, improved)
        assert py_out.read_bytes() == cli_out.read_bytes(), name
        assert rep["boundary_unchanged"]["ok"] is True
        tets[name] = rep["after"]["tets"]
    assert tets["grad"] < 0.8 * tets["default"]


@pytest.mark.parametrize("bad", [1.0, 0.5, -2.0, float("nan"), float("inf"), True, "1.3"])
def test_gradation_must_be_a_ratio_above_one(bad):
    with pytest.raises(ValueError, match=r"gradation: expected a ratio above 1"):
        tetopt.improve(np.zeros((4, 3)), np.array([[0, 1, 2, 3]]), allow_insert=True, gradation=bad)


def test_size_must_be_a_length():
    with pytest.raises(ValueError, match=r"size: expected a length"):
        tetopt.improve(np.zeros((4, 3)), np.array([[0, 1, 2, 3]]), allow_insert=True, size=-1.0)
