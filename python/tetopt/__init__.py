"""tetopt: improve tetrahedral meshes without touching their boundary.

Python bindings of the tetopt C++ library (Liu et al. 2012: weighted
optimisation-based smoothing and quality-driven topological transformations,
combined).  NumPy arrays in, NumPy arrays out:

    points  (n, 3) float64   vertex coordinates
    tets    (m, 4) int32     0-based vertex ids, positively oriented
                             (det(v1-v0, v2-v0, v3-v0) > 0; see
                             include/tetopt/conventions.hpp)
    refs    (m,)   int32     region ref per tet (Medit ref, Gmsh physical
                             volume, VTK/TetGen region attribute)

Constrained entities (never changed): a face is constrained when it lies on
one tet (the boundary), between tets of different refs (an interface), or is
listed (``constrained_faces`` / ``Mesh.triangles``).  A vertex is constrained
when it lies on a constrained face, a listed edge, or is listed as required /
corner.  Constrained vertices never move, bit for bit; constrained faces are
never removed.  Every improve() run ends by proving it (see the report's
``boundary_unchanged``).

Errors: bad arguments (wrong shape or dtype, index out of range, NaN,
non-manifold meshes) raise ValueError with a message
naming the array, the 0-based row and the value; unreadable files raise
OSError; an invariant failure (a bug in tetopt) raises RuntimeError.

Example::

    import tetopt
    mesh = tetopt.read("part.mesh")
    points, tets, refs, report = tetopt.improve(mesh.points, mesh.tets, mesh.refs,
                                                constrained_faces=mesh.triangles)
    print(report["before"]["alpha_worst"], "->", report["after"]["alpha_worst"])
"""
from __future__ import annotations

import dataclasses
import json
import os
import warnings
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _tetopt

__all__ = [
    "Mesh",
    "improve",
    "improve_mesh",
    "improve_meshio",
    "quality",
    "read",
    "write",
    "from_meshio",
    "to_meshio",
    "__version__",
]

__version__: str = _tetopt.__version__

LogCallback = Callable[[str, str], Any]
#: progress(phase, round, fraction, worst) -> False to stop (None or True go on)
ProgressCallback = Callable[[str, int, float, float], Any]
PathLike = Union[str, "os.PathLike[str]"]


@dataclasses.dataclass(eq=False)
class Mesh:
    """A tetrahedral mesh with everything its file carried (mirrors tetopt::TetMesh).

    All index arrays are 0-based.  Optional fields may be None (meaning
    "none"); :func:`read` fills every field.

    Attributes:
        points: (n, 3) float64 coordinates.
        tets: (m, 4) int32 vertex ids, positively oriented.
        refs: (m,) int32 region ref per tet (zeros when None).
        point_refs: (n,) int32 vertex refs (Medit), written back unchanged.
        triangles: (k, 3) int32 listed triangles; every listed triangle is
            constrained (kept with its ref).
        triangle_refs: (k,) int32 refs of the listed triangles.
        edges: (e, 2) int32 listed edges; their vertices are constrained.
        edge_refs: (e,) int32 refs of the listed edges.
        required_vertices: vertex ids listed as required (constrained).
        required_triangles: indices into ``triangles``.
        required_edges: indices into ``edges``.
        corners: vertex ids listed as corners (constrained).
        ridges: indices into ``edges``.
        groups: physical names as ``(dim, tag, name)`` tuples (Gmsh
            $PhysicalNames), in file order.
        tet_entities: (m,) Gmsh elementary entity tag per tet, or empty.
        triangle_entities: (k,) Gmsh elementary entity tag per triangle, or empty.
        point_data: per-vertex arrays the file carried (VTK point data), name ->
            (n,) or (n, c) array; integer dtypes are written as integers.
        flipped_on_read: True when the file stored tets in the opposite
            orientation; a writer of the same format (``source_format``)
            flips them back so the file keeps its convention.
        source_format: the format the mesh was read from: '', 'medit',
            'meditb', 'gmsh', 'vtk', 'vtu' or 'tetgen'.
    """

    points: np.ndarray
    tets: np.ndarray
    refs: Optional[np.ndarray] = None
    point_refs: Optional[np.ndarray] = None
    triangles: Optional[np.ndarray] = None
    triangle_refs: Optional[np.ndarray] = None
    edges: Optional[np.ndarray] = None
    edge_refs: Optional[np.ndarray] = None
    required_vertices: Optional[np.ndarray] = None
    required_triangles: Optional[np.ndarray] = None
    required_edges: Optional[np.ndarray] = None
    corners: Optional[np.ndarray] = None
    ridges: Optional[np.ndarray] = None
    groups: List[Tuple[int, int, str]] = dataclasses.field(default_factory=list)
    tet_entities: Optional[np.ndarray] = None
    triangle_entities: Optional[np.ndarray] = None
    point_data: Dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    flipped_on_read: bool = False
    source_format: str = ""

    def _as_dict(self) -> Dict[str, Any]:
        # Shallow: the arrays themselves are handed to the C++ layer, which
        # reads them in place (one copy into the library's own storage).
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def _from_dict(cls, d: Dict[str, Any]) -> "Mesh":
        return cls(**d)

    def validate(self) -> None:
        """Raises ValueError when the arrays do not form a valid tetopt mesh
        (shapes, dtypes, index ranges, finite coordinates)."""
        _tetopt.validate_mesh(self._as_dict())

    @classmethod
    def from_meshio(cls, m: Any, ref_key: Optional[str] = None) -> "Mesh":
        """A Mesh from a ``meshio.Mesh``: :func:`from_meshio`."""
        return from_meshio(m, ref_key)

    def to_meshio(self) -> Any:
        """This mesh as a ``meshio.Mesh``: :func:`to_meshio`."""
        return to_meshio(self)

    def __repr__(self) -> str:
        def n(a: Any) -> int:
            return 0 if a is None else len(a)

        return (
            f"tetopt.Mesh({n(self.points)} points, {n(self.tets)} tets, "
            f"{n(self.triangles)} triangles, {n(self.edges)} edges, "
            f"{len(self.groups)} groups, source_format={self.source_format!r})"
        )


def _options(mode: str, optimizer: str, weight: float, threshold: float, iterations: int, seed: int,
             threads: int, check: bool, diagnose: bool, allow_insert: bool = False,
             allow_remove: bool = False, objective: str = "alpha", guard: bool = True,
             polish: bool = False, size: float = 0.0, remesh: bool = True,
             gradation: float = 0.0) -> Any:
    o = _tetopt.ImproveOptions()
    for name, value, kind in (("mode", mode, str), ("optimizer", optimizer, str)):
        if not isinstance(value, kind):
            raise ValueError(f"{name}: expected a str, got {value!r}")
        setattr(o, name, value)
    for name, value in (("weight", weight), ("threshold", threshold)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name}: expected a number, got {value!r}")
        setattr(o, name, float(value))
    for name, value in (("iterations", iterations), ("seed", seed), ("threads", threads)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{name}: expected an int, got {value!r}")
        if not -(2**63) <= int(value) < 2**63:
            raise ValueError(f"{name}: {value} is out of range")
        setattr(o, name, int(value))
    o.check = bool(check)
    o.diagnose = bool(diagnose)
    for name, value in (("allow_insert", allow_insert), ("allow_remove", allow_remove)):
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name}: expected a bool, got {value!r}")
        setattr(o, name, bool(value))
        if value and mode != "best":
            raise ValueError(f"{name} works in mode 'best' only (the default), not in mode {mode!r}")
    if not isinstance(objective, str):
        raise ValueError(f"objective: expected a str, got {objective!r}")
    o.objective = objective
    if not isinstance(guard, (bool, np.bool_)):
        raise ValueError(f"guard: expected a bool, got {guard!r}")
    o.guard = bool(guard)
    if not isinstance(polish, (bool, np.bool_)):
        raise ValueError(f"polish: expected a bool, got {polish!r}")
    o.polish = bool(polish)
    if isinstance(size, bool) or not isinstance(size, (int, float, np.integer, np.floating)) or not (size >= 0) \
            or not np.isfinite(size):
        raise ValueError(f"size: expected a length >= 0 (0: the size field of the boundary), got {size!r}")
    o.size = float(size)
    if isinstance(gradation, bool) or not isinstance(gradation, (int, float, np.integer, np.floating)) \
            or not (gradation == 0 or gradation > 1) or not np.isfinite(gradation):
        raise ValueError(f"gradation: expected a ratio above 1, or 0 for the default 1.16, got {gradation!r}")
    o.gradation = float(gradation)
    if not isinstance(remesh, (bool, np.bool_)):
        raise ValueError(f"remesh: expected a bool, got {remesh!r}")
    o.remesh = bool(remesh)
    return o


def _check_callable(name: str, f: Any) -> None:
    if f is not None and not callable(f):
        raise ValueError(f"{name}: expected a callable or None, got {f!r}")


def _is_meshio(m: Any) -> bool:
    return hasattr(m, "cells") and hasattr(m, "points") and hasattr(m, "cell_data") and not isinstance(m, Mesh)


def _with_diagnosis(js: str, dj: Optional[str]) -> Dict[str, Any]:
    report: Dict[str, Any] = json.loads(js)
    if dj is not None:
        d = json.loads(dj)
        if "insertion_hint" in d and "diagnosis" in d:  # improve's: the hint, then the diagnosis (as the CLI's)
            report["insertion_hint"] = d["insertion_hint"]
            d = d["diagnosis"]
        report["diagnosis"] = d
    ops = report.get("operations", {})
    if ops.get("untangled", 0) or ops.get("still_inverted", 0):
        # What `tetopt improve` prints as its "untangling:" line.
        warnings.warn(f"untangling: {ops.get('untangled', 0)} inverted or flat input tets made positive, "
                      f"{ops.get('still_inverted', 0)} could not be (log=print lists their ids)",
                      RuntimeWarning, stacklevel=3)
    return report


def improve(
    points: Any,
    tets: Any = None,
    refs: Any = None,
    *,
    mode: str = "best",
    weight: float = 0.75,
    threshold: float = 0.3,
    iterations: int = 10,
    seed: int = 0,
    threads: int = 0,
    constrained_faces: Any = None,
    optimizer: str = "paper",
    check: bool = True,
    diagnose: bool = False,
    log: Optional[LogCallback] = None,
    allow_insert: bool = False,
    allow_remove: bool = False,
    objective: str = "alpha",
    guard: bool = True,
    polish: bool = False,
    size: float = 0.0,
    gradation: float = 0.0,
    remesh: bool = True,
    progress: Optional[ProgressCallback] = None,
) -> Any:
    """Improves a tetrahedral mesh; returns ``(points, tets, refs, report)``.

    ``improve(m)`` with a ``meshio.Mesh`` returns a new ``meshio.Mesh``
    instead (the report in its ``info["tetopt_report"]``): see
    :func:`improve_meshio`.

    Mirrors ``tetopt::improve`` (include/tetopt/improve.hpp) and ``tetopt
    improve``: constrained vertices never move (bit for bit), constrained
    faces are never removed, every tet stays positive under the exact
    orient3d, the volume of every region is kept; the run ends by checking
    all of this (``check=False`` skips the proof, not recommended).

    Args:
        points: (n, 3) coordinates, float64 (other real dtypes are converted).
        tets: (m, 4) integer vertex ids, 0-based.  All positively oriented,
            or all negatively oriented (TetGen's convention; the result then
            comes back in that convention too).  Inverted or flat tets among
            positive ones are untangled first by moving free vertices, as
            ``tetopt improve`` does; a RuntimeWarning says how many were
            made positive and how many could not be (report["operations"]
            "untangled" and "still_inverted").
        refs: (m,) integer region refs, or None for a single region (zeros).
            Faces between different refs are interfaces and stay.
        mode: 'best' (default: rounds of Algorithm 4, flips everywhere,
            smoothing with both optimisers, rising thresholds, until nothing
            improves), 'combined' (the paper's loop, §2), 'smooth' (weighted
            smoothing alone, §3) or 'topo' (quality-driven flips alone, §4).
        weight: C of eq. (3.4), the weight of boundary elements in the
            smoothing objective, 0.5 <= C < 1 (0.5 = unweighted).
        threshold: gamma, tets with alpha < gamma are poor, in (0, 1].
        iterations: rounds (sweeps of the loop), 1..1000000.
        seed: visiting order; same input and seed, same output.
        threads: worker threads (0 = library default); results are identical
            for any count.
        constrained_faces: (k, 3) integer vertex triples of extra faces to keep
            (e.g. the file's listed triangles, ``Mesh.triangles``).
        optimizer: 'paper' (gradient + golden-section line search) or
            'maxmin' (Freitag's nonsmooth max-min), for 'smooth'/'combined'.
        check: prove the invariants at the end (recommended).
        diagnose: also classify the tets still below ``threshold`` after the
            run (include/tetopt/diagnose.hpp: locked by a constrained
            triangle, locked by constrained neighbours, or improvable) and
            bound the best reachable quality; adds ``report["diagnosis"]``
            as ``tetopt improve --report`` does.  Can take long on meshes
            with many constrained triangles, hence off by default.
        log: optional callable ``log(level, message)``, level one of
            'debug', 'info', 'progress', 'warning'.
        allow_insert: mode 'best' may add free vertices inside the volume
            (appended after the input's, which keep their ids).
        allow_remove: mode 'best' may remove free vertices (edge
            contraction where it raises the worst alpha of their star); the
            remaining vertices keep their order, so ids after a removed one
            shift down.  ``report["operations"]`` counts ``insertions`` and
            ``vertex_removals``.
        objective: what every stage optimises: 'alpha' (default, the
            paper's), 'sine' (Stellar's minimum sine of the dihedral angles),
            'jacobian' (Verdict's scaled Jacobian), 'skewness' (1 - Fluent's
            equivolume skewness) or 'openfoam' (alpha, then a pass lowering
            OpenFOAM checkMesh's largest face non-orthogonality; the report's
            ``face_pass`` gives it before and after); ``threshold`` applies to it.
        guard: no operation may create a tet worse than the current worst of
            the mesh on any per-tet measure (alpha, minimum sine, dihedral
            angles, scaled Jacobian, radius ratio, mean ratio, skewness);
            ``report["guards"]`` counts what each refused.  False lifts it
            (``tetopt improve --no-guard``).
        polish: end with the guarded mean polish whatever the mean alpha
            (``tetopt improve --polish``): raises the mean, every worst kept.
        size: with allow_insert, the remesher's target edge length everywhere
            (``--size``); 0: the size field of the boundary triangles (or a
            point field named 'size').
        gradation: with allow_insert on a raw mesh (no interior vertex, as
            raw tetgen output), the most the interior's size may grow per edge
            length away from the surface's (``--gradation``, MMG's hgrad); 0:
            the default, 1.16.  1.3 or more: fewer, larger tets.
        remesh: with allow_insert, run the interior remesher first
            (circumcentres of the tets too large for the size field, then
            edge splits and collapses toward it); False is
            ``--no-remesh``: insertion in the worst tets' cavities only.
        progress: ``callable(phase, round, fraction, worst)`` called at every
            phase boundary (``tetopt::ImproveOptions::progress``): phase
            'start', 'relax', 'all-boundary', 'flips', 'pairs', 'insert',
            'smooth', 'smooth-maxmin', 'dihedral', 'polish' or 'done';
            round 1-based (0 outside the rounds); fraction a rough share of
            the run done, 0..1; worst the current worst q of the objective
            (NaN until known).  Returning False stops the run there: the
            mesh comes back valid and checked, with
            ``report["stopped_early"]`` True (otherwise False).  It runs on
            the library's worker thread, with the GIL; an exception in it
            stops the run and is re-raised.

    Returns:
        points: (n, 3) float64, the same vertices (constrained ones bit-identical;
            plus inserted, minus removed ones with allow_insert / allow_remove).
        tets: (m', 4) int32, the new connectivity (flips change m); as
            ``tetopt improve`` writes them, the tets of each region are put
            together, regions in the input's order, each region's tets in
            the order improve left them.
        refs: (m',) int32 region ref per new tet.
        report: dict with the keys of ``tetopt improve --report`` JSON:
            tool, version, input, output, options, before, after (quality
            statistics as ``quality()``), operations, seconds,
            boundary_unchanged, seconds_end_to_end, tets_reordered (always
            False: the tets are improved in the order given, where ``tetopt
            improve`` may first put a large mesh in Morton order),
            dropped_on_write (always empty: no file is written),
            guards (what each measure's guard refused), measures_before_after
            (every measure's worst before and after, faces included, and
            whether the run kept it) (and diagnosis when ``diagnose``).

    Raises:
        ValueError: bad arguments or an invalid mesh (message names it).
        RuntimeError: an invariant failed (a bug in tetopt).
        KeyboardInterrupt: Ctrl-C.  The run goes on a worker thread; the
            calling thread runs Python's signal handlers every 10 ms and on
            Ctrl-C stops the library (polled between phases and inside the
            passes), waits for the worker to end and raises: no thread is
            left running (python/tests/test_interrupt.py measures it).

    The GIL is released while the library runs; the inputs are copied once
    into the library's own arrays and the outputs are handed over without a
    copy.
    """
    if _is_meshio(points):
        if tets is not None or refs is not None or constrained_faces is not None:
            raise ValueError("improve(meshio_mesh) takes no other array arguments")
        return improve_meshio(points, mode=mode, weight=weight, threshold=threshold, iterations=iterations,
                              seed=seed, threads=threads, optimizer=optimizer, check=check, diagnose=diagnose,
                              log=log, allow_insert=allow_insert, allow_remove=allow_remove, objective=objective,
                              guard=guard, polish=polish, size=size, gradation=gradation, remesh=remesh,
                              progress=progress)
    if tets is None:
        raise ValueError("tets: required (or pass a meshio.Mesh)")
    o = _options(mode, optimizer, weight, threshold, iterations, seed, threads, check, diagnose,
                 allow_insert, allow_remove, objective, guard, polish, size, remesh, gradation)
    _check_callable("progress", progress)
    p, t, r, js, dj = _tetopt.improve_arrays(points, tets, refs, constrained_faces, o, log, progress)
    return p, t, r, _with_diagnosis(js, dj)


def improve_mesh(
    mesh: Mesh,
    *,
    mode: str = "best",
    weight: float = 0.75,
    threshold: float = 0.3,
    iterations: int = 10,
    seed: int = 0,
    threads: int = 0,
    optimizer: str = "paper",
    check: bool = True,
    diagnose: bool = False,
    log: Optional[LogCallback] = None,
    allow_insert: bool = False,
    allow_remove: bool = False,
    objective: str = "alpha",
    guard: bool = True,
    polish: bool = False,
    size: float = 0.0,
    gradation: float = 0.0,
    remesh: bool = True,
    progress: Optional[ProgressCallback] = None,
) -> Tuple[Mesh, Dict[str, Any]]:
    """Improves a whole :class:`Mesh` (as :func:`read` returns it); returns ``(mesh, report)``.

    Same options and guarantees as :func:`improve`, and what the command
    line does: every listed triangle and edge, required vertex and corner is
    constrained, and refs, groups, Gmsh entities and point data come back so
    that ``write()`` produces the file ``tetopt improve`` would.  The input
    mesh is not modified.
    """
    o = _options(mode, optimizer, weight, threshold, iterations, seed, threads, check, diagnose,
                 allow_insert, allow_remove, objective, guard, polish, size, remesh, gradation)
    if not isinstance(mesh, Mesh):
        raise ValueError(f"mesh: expected a tetopt.Mesh, got {type(mesh).__name__}")
    _check_callable("progress", progress)
    d, js, dj = _tetopt.improve_mesh(mesh._as_dict(), o, log, progress)
    return Mesh._from_dict(d), _with_diagnosis(js, dj)


def quality(points: Any, tets: Any = None, refs: Any = None, *, constrained_faces: Any = None,
            diagnose: bool = False, threshold: float = 0.3) -> Dict[str, Any]:
    """Quality statistics and per-tet measures of a mesh.

    Call as ``quality(points, tets[, refs], constrained_faces=...)`` or
    ``quality(mesh)`` with a :class:`Mesh`.  Measures (include/tetopt/quality.hpp):
    alpha = 6*sqrt(6)*V / (sum of face areas * longest edge), Liu et al. eq.
    3.1: 1 for the regular tet, 0 when flat, negative when inverted; dihedral
    angles in degrees (70.53 for the regular tet).

    Returns:
        A dict with the keys of ``tetopt quality --json`` (vertices, tets,
        boundary_tets, kind_counts, alpha_worst, alpha_mean,
        alpha_boundary_worst, ..., dihedral_min, dihedral_max, histograms;
        NaN statistics come out as None, as in the JSON) plus ``per_tet``, a
        dict of (m,) arrays: ``alpha`` (float64), ``dihedral_min`` and
        ``dihedral_max`` (float64, degrees) and ``kind`` (int8, the number
        of constrained vertices, 0..4; 4 = the paper's all-boundary element).
        With ``diagnose``, also ``diagnosis`` (as ``tetopt quality --json
        --threshold``: counts per class, the mesh-wide bound, the 100 worst
        tets) and ``per_tet["diagnosis"]`` (int8: 0 good, 1 locked by a
        triangle, 2 locked by neighbours, 3 improvable; ``threshold`` is the
        gamma below which a tet is classified).

    Like the CLI, a mesh whose tets are mostly negative is taken as stored in
    the opposite convention and measured flipped; inverted tets are allowed
    (their alpha is negative).
    """
    if isinstance(points, Mesh):
        if tets is not None or refs is not None or constrained_faces is not None:
            raise ValueError("quality(mesh) takes no other array arguments")
        d = points._as_dict()
    else:
        if tets is None:
            raise ValueError("tets: required (or pass a tetopt.Mesh)")
        d = {"points": points, "tets": tets, "refs": refs, "triangles": constrained_faces}
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float, np.integer, np.floating)):
        raise ValueError(f"threshold: expected a number, got {threshold!r}")
    js, dj, classes, alpha, dmin, dmax, kind = _tetopt.quality_mesh(d, bool(diagnose), float(threshold))
    out = _with_diagnosis(js, dj)
    out["per_tet"] = {"alpha": alpha, "dihedral_min": dmin, "dihedral_max": dmax, "kind": kind}
    if classes is not None:
        out["per_tet"]["diagnosis"] = classes
    return out


def read(path: PathLike) -> Mesh:
    """Reads a mesh file; format by extension.

    .mesh/.meshb (Medit), .msh (Gmsh 2.2/4.1, ASCII and binary), .vtk/.vtu
    (VTK), .node/.ele[/.face] (TetGen).  Tets are normalised to positive
    orientation (``Mesh.flipped_on_read`` remembers the file's convention);
    refs, listed triangles and edges, required entities, physical names,
    Gmsh entities and VTK point data are kept.  Inverted or flat tets give a
    RuntimeWarning naming them (0-based ids).

    Raises:
        OSError: the file cannot be read.
        ValueError: the file is malformed or the mesh invalid ("FILE:LINE: what").
    """
    d, inverted, flat = _tetopt.read(path)
    for ids, what in ((inverted, "inverted"), (flat, "flat (zero-volume)")):
        if len(ids):
            shown = ", ".join(str(int(i)) for i in ids[:10]) + (", ..." if len(ids) > 10 else "")
            warnings.warn(f"{os.fspath(path)}: {len(ids)} {what} tets (0-based ids {shown})", RuntimeWarning,
                          stacklevel=2)
    return Mesh._from_dict(d)


def write(path: PathLike, mesh: Any, *, msh_version: int = 41, binary: bool = False, meshb_version: int = 3) -> None:
    """Writes a :class:`Mesh` (or a meshio.Mesh, converted by :func:`from_meshio`).

    Format by extension, as :func:`read`; tets are written in the file's own
    convention (see ``Mesh.flipped_on_read``); coordinates with 17
    significant digits (or raw doubles), so they read back bit-identical.
    The file is written to a temporary name and renamed, so a failure never
    leaves half a file.  What the format cannot hold (vertex refs in .msh,
    .vtk and .vtu, required entities outside Medit, listed edges in TetGen,
    ...; docs/formats.md, "What is kept") is left out with a UserWarning
    naming it, as ``tetopt convert`` does.

    Args:
        msh_version: 22 or 41 for .msh.
        binary: binary .msh / .vtk (.meshb is always binary).
        meshb_version: GMF version of .meshb output: 2, 3 or 4.
    """
    if not isinstance(mesh, Mesh):
        if hasattr(mesh, "cells") and hasattr(mesh, "points"):
            mesh = from_meshio(mesh)
        else:
            raise ValueError(f"mesh: expected a tetopt.Mesh or meshio.Mesh, got {type(mesh).__name__}")
    if not isinstance(binary, (bool, np.bool_)):
        raise ValueError(f"binary: expected a bool, got {binary!r}")
    for name, value in (("msh_version", msh_version), ("meshb_version", meshb_version)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{name}: expected an int, got {value!r}")
    lost = _tetopt.write(path, mesh._as_dict(), int(msh_version), bool(binary), int(meshb_version))
    if lost:
        warnings.warn(f"{os.fspath(path)}: this format cannot hold the mesh's {', '.join(lost)}: left out "
                      "(docs/formats.md, 'What is kept')", UserWarning, stacklevel=2)


# ---------------------------------------------------------------- meshio

_REF_KEYS = ("medit:ref", "gmsh:physical", "cell_tags", "CellEntityIds", "tetgen:ref", "ref")
# meshio's own bookkeeping, not data of the mesh.
_MESHIO_POINT_KEYS = ("medit:ref", "gmsh:dim_tags")


def from_meshio(m: Any, ref_key: Optional[str] = None) -> Mesh:
    """Converts a ``meshio.Mesh`` to a :class:`Mesh`.

    Takes the "tetra" cells (required), "triangle" cells as listed triangles
    and "line" cells as listed edges.  Refs come from ``cell_data[ref_key]``,
    by default the first of 'medit:ref', 'gmsh:physical', 'cell_tags',
    'CellEntityIds', 'tetgen:ref', 'ref' (tetopt's VTK files) present; Gmsh entities from
    'gmsh:geometrical'; vertex refs from ``point_data['medit:ref']``; groups
    from ``field_data`` (name -> [tag, dim]); other point data is kept.
    Higher-order cells ('tetra10', ...) raise ValueError.
    """
    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"meshio points: expected shape (n, 3), got {points.shape}")
    if points.shape[1] == 2:
        raise ValueError("meshio points are 2-D; tetopt needs 3-D points")
    cell_data = dict(getattr(m, "cell_data", {}) or {})
    key = ref_key
    if key is None:
        key = next((k for k in _REF_KEYS if k in cell_data), None)
    elif key not in cell_data:
        raise ValueError(f"ref_key {key!r} is not in the meshio cell_data ({', '.join(cell_data) or 'none'})")
    parts: Dict[str, List[np.ndarray]] = {"tetra": [], "triangle": [], "line": []}
    refs: Dict[str, List[np.ndarray]] = {"tetra": [], "triangle": [], "line": []}
    ents: Dict[str, List[np.ndarray]] = {"tetra": [], "triangle": [], "line": []}
    has_ent = "gmsh:geometrical" in cell_data
    for i, block in enumerate(m.cells):
        ctype, data = block.type, np.asarray(block.data)
        if ctype in ("tetra10", "tetra20", "tetra35", "tetra56"):
            raise ValueError(f"meshio cell block {i} is {ctype}; tetopt handles linear tets only")
        if ctype not in parts:
            continue
        parts[ctype].append(data)
        n = len(data)
        refs[ctype].append(np.asarray(cell_data[key][i]).reshape(n) if key else np.zeros(n, np.int32))
        if has_ent:
            ents[ctype].append(np.asarray(cell_data["gmsh:geometrical"][i]).reshape(n))

    def cat(lst: List[np.ndarray], cols: int) -> np.ndarray:
        if not lst:
            return np.zeros((0, cols) if cols else (0,), np.int32)
        return np.concatenate(lst)

    if not parts["tetra"]:
        raise ValueError("the meshio mesh has no 'tetra' cells")
    point_data = {k: np.asarray(v) for k, v in (getattr(m, "point_data", {}) or {}).items()
                  if k not in _MESHIO_POINT_KEYS}
    pr = (getattr(m, "point_data", {}) or {}).get("medit:ref")
    groups = []
    for name, v in (getattr(m, "field_data", {}) or {}).items():
        v = np.asarray(v).reshape(-1)
        if len(v) >= 2:
            groups.append((int(v[1]), int(v[0]), str(name)))
    return Mesh(
        points=points,
        tets=cat(parts["tetra"], 4),
        refs=cat(refs["tetra"], 0),
        point_refs=None if pr is None else np.asarray(pr),
        triangles=cat(parts["triangle"], 3),
        triangle_refs=cat(refs["triangle"], 0),
        edges=cat(parts["line"], 2),
        edge_refs=cat(refs["line"], 0),
        groups=groups,
        tet_entities=cat(ents["tetra"], 0) if has_ent else None,
        triangle_entities=cat(ents["triangle"], 0) if has_ent else None,
        point_data=point_data,
    )


def to_meshio(mesh: Any, tets: Any = None, refs: Any = None) -> Any:
    """Converts to a ``meshio.Mesh``: ``to_meshio(mesh)`` or ``to_meshio(points, tets[, refs])``.

    Cells: "tetra" (+ "triangle" and "line" for listed triangles and edges).
    Refs go to cell_data 'medit:ref' and 'gmsh:physical', Gmsh entities (or
    the refs when there are none) to 'gmsh:geometrical', so meshio writes
    them to Medit and Gmsh files; vertex refs to point_data 'medit:ref';
    groups to field_data (name -> [tag, dim]).  Requires meshio.
    """
    try:
        import meshio  # type: ignore[import-not-found]
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError("to_meshio needs meshio (Debian: python3-meshio, or pip install meshio)") from e
    if not isinstance(mesh, Mesh):
        if tets is None:
            raise ValueError("tets: required (or pass a tetopt.Mesh)")
        mesh = Mesh(points=mesh, tets=tets, refs=refs)
    elif tets is not None or refs is not None:
        raise ValueError("to_meshio(mesh) takes no other array arguments")
    mesh.validate()
    points = np.asarray(mesh.points, dtype=np.float64)
    t = np.asarray(mesh.tets)
    blocks = [("tetra", t)]
    r = [np.zeros(len(t), np.int32) if mesh.refs is None else np.asarray(mesh.refs)]
    e = [np.asarray(mesh.tet_entities) if mesh.tet_entities is not None and len(mesh.tet_entities) else r[0]]
    if mesh.triangles is not None and len(mesh.triangles):
        tri = np.asarray(mesh.triangles).reshape(-1, 3)
        blocks.append(("triangle", tri))
        tr = np.zeros(len(tri), np.int32) if mesh.triangle_refs is None or not len(mesh.triangle_refs) \
            else np.asarray(mesh.triangle_refs)
        r.append(tr)
        te = mesh.triangle_entities
        e.append(np.asarray(te) if te is not None and len(te) else tr)
    if mesh.edges is not None and len(mesh.edges):
        ed = np.asarray(mesh.edges).reshape(-1, 2)
        blocks.append(("line", ed))
        er = np.zeros(len(ed), np.int32) if mesh.edge_refs is None or not len(mesh.edge_refs) \
            else np.asarray(mesh.edge_refs)
        r.append(er)
        e.append(er)
    point_data = dict(mesh.point_data or {})
    if mesh.point_refs is not None and len(mesh.point_refs):
        point_data["medit:ref"] = np.asarray(mesh.point_refs)
    # meshio's Gmsh 4.1 writer needs the entity (dim, tag) of every node when
    # there is more than one cell type: the lowest-dimensional cell holding it.
    dim_tags = np.zeros((len(points), 2), dtype=np.int64)
    for (kind, cells_), ent in zip(blocks, e):  # tets first: lower dimensions overwrite
        dim = {"tetra": 3, "triangle": 2, "line": 1}[kind]
        flat = np.asarray(cells_).ravel()
        dim_tags[flat, 0] = dim
        dim_tags[flat, 1] = np.repeat(np.asarray(ent), np.asarray(cells_).shape[1])
    point_data["gmsh:dim_tags"] = dim_tags
    field_data = {name: np.array([tag, dim]) for dim, tag, name in mesh.groups}
    return meshio.Mesh(
        points,
        blocks,
        point_data=point_data,
        cell_data={"medit:ref": r, "gmsh:physical": r, "gmsh:geometrical": e},
        field_data=field_data,
    )


def improve_meshio(
    m: Any,
    *,
    mode: str = "best",
    weight: float = 0.75,
    threshold: float = 0.3,
    iterations: int = 10,
    seed: int = 0,
    threads: int = 0,
    optimizer: str = "paper",
    check: bool = True,
    diagnose: bool = False,
    log: Optional[LogCallback] = None,
    allow_insert: bool = False,
    allow_remove: bool = False,
    objective: str = "alpha",
    guard: bool = True,
    polish: bool = False,
    size: float = 0.0,
    gradation: float = 0.0,
    remesh: bool = True,
    progress: Optional[ProgressCallback] = None,
) -> Any:
    """Improves the tets of a ``meshio.Mesh``; returns a new ``meshio.Mesh``.

    ``tetopt.improve(m)`` calls this for a meshio.Mesh.  Options as
    :func:`improve`; the report is in the result's ``info["tetopt_report"]``.

    What comes back: every cell block in its order, the "tetra" blocks with
    their new tets, every other block (triangles, lines, vertices, ...)
    unchanged; every cell data array and every cell set, with their names,
    and point data, point sets, field data.  The points of non-tetra cells
    never move (triangles and lines are constrained faces and edges, other
    blocks' points required vertices).  A new tet has no value of its own:
    each distinct combination of (tetra block, value of every cell data
    array, membership of every cell set) over the input's tets is made a
    region, whose interfaces are constrained like any region interface, so
    each new tet lies in one region and takes that region's values and
    memberships.  A per-tet field of many distinct values therefore
    freezes its tets (every face an interface): drop such data first.
    """
    try:
        import meshio  # type: ignore[import-not-found]
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError("improve_meshio needs meshio (Debian: python3-meshio)") from e
    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"meshio points: expected shape (n, 3), got {points.shape}")
    cells = list(m.cells)
    for i, c in enumerate(cells):
        if c.type in ("tetra10", "tetra20", "tetra35", "tetra56"):
            raise ValueError(f"meshio cell block {i} is {c.type}; tetopt handles linear tets only")
    tb = [i for i, c in enumerate(cells) if c.type == "tetra"]
    if not tb:
        raise ValueError("the meshio mesh has no 'tetra' cells")
    cell_data = {k: list(v) for k, v in (getattr(m, "cell_data", None) or {}).items()}
    cell_sets = {k: list(v) for k, v in (getattr(m, "cell_sets", None) or {}).items()}
    counts = [len(cells[i].data) for i in tb]
    nt = int(sum(counts))
    tets = np.concatenate([np.asarray(cells[i].data).reshape(-1, 4) for i in tb]).astype(np.int64)

    # The region key of every tet, as rows of bytes: block, data values, set memberships.
    def as_bytes(a: np.ndarray) -> np.ndarray:
        a = np.ascontiguousarray(a.reshape(nt, -1))
        return a.view(np.uint8).reshape(nt, -1)

    key = [as_bytes(np.repeat(np.arange(len(tb), dtype=np.int32), counts))]
    data_cat: Dict[str, np.ndarray] = {}
    for name, blocks in cell_data.items():
        if len(blocks) != len(cells):
            raise ValueError(f"cell_data[{name!r}]: {len(blocks)} arrays for {len(cells)} cell blocks")
        data_cat[name] = np.concatenate([np.asarray(blocks[i]).reshape(counts[j], *np.shape(blocks[i])[1:])
                                         for j, i in enumerate(tb)])
        key.append(as_bytes(data_cat[name]))
    member: Dict[str, np.ndarray] = {}
    offsets = np.concatenate([[0], np.cumsum(counts)])
    for name, blocks in cell_sets.items():
        inside = np.zeros(nt, dtype=np.uint8)
        for j, i in enumerate(tb):
            if i < len(blocks) and blocks[i] is not None and len(blocks[i]):
                inside[offsets[j] + np.asarray(blocks[i], dtype=np.int64)] = 1
        member[name] = inside
        key.append(inside.reshape(nt, 1))
    rows = np.concatenate(key, axis=1)
    _, first, region = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    region = region.reshape(-1)
    if len(first) > 2**31 - 1:
        raise ValueError("too many distinct regions")
    block_of_region = np.repeat(np.arange(len(tb)), counts)[first]

    def gather(kind: str, cols: int) -> np.ndarray:
        parts = [np.asarray(c.data).reshape(-1, cols) for c in cells if c.type == kind]
        return np.concatenate(parts).astype(np.int64) if parts else np.zeros((0, cols), np.int64)

    other = [np.asarray(c.data).ravel() for c in cells if c.type not in ("tetra", "triangle", "line")]
    required = np.unique(np.concatenate(other)).astype(np.int64) if other else None
    point_data = {k: np.asarray(v) for k, v in (getattr(m, "point_data", None) or {}).items()}
    mesh = Mesh(points=points, tets=tets, refs=region.astype(np.int32), triangles=gather("triangle", 3),
                edges=gather("line", 2), required_vertices=required, point_data=point_data)
    out, report = improve_mesh(mesh, mode=mode, weight=weight, threshold=threshold, iterations=iterations,
                               seed=seed, threads=threads, optimizer=optimizer, check=check, diagnose=diagnose,
                               log=log, allow_insert=allow_insert, allow_remove=allow_remove,
                               objective=objective, guard=guard, polish=polish, size=size, gradation=gradation,
                               remesh=remesh, progress=progress)
    new_tets = np.asarray(out.tets)
    if out.flipped_on_read:  # back to the input's own orientation (as improve() does)
        new_tets = new_tets[:, [0, 1, 3, 2]]
    new_region = np.asarray(out.refs, dtype=np.int64)
    removed = np.asarray(report.get("removed_vertices", []), dtype=np.int64)

    def renumber(ids: np.ndarray) -> np.ndarray:
        return ids - np.searchsorted(removed, ids) if len(removed) else ids

    new_cells: List[Any] = []
    new_data: Dict[str, List[np.ndarray]] = {k: [] for k in cell_data}
    new_sets: Dict[str, List[Any]] = {k: [] for k in cell_sets}
    for i, c in enumerate(cells):
        if c.type == "tetra":
            j = tb.index(i)
            mine = np.flatnonzero(block_of_region[new_region] == j)
            t_reg = new_region[mine]
            new_cells.append(meshio.CellBlock("tetra", new_tets[mine].astype(np.asarray(c.data).dtype)))
            for name in cell_data:
                new_data[name].append(data_cat[name][first[t_reg]])
            for name in cell_sets:
                new_sets[name].append(np.flatnonzero(member[name][first[t_reg]]))
        else:
            d = np.asarray(c.data)
            new_cells.append(meshio.CellBlock(c.type, renumber(d.astype(np.int64)).astype(d.dtype)))
            for name in cell_data:
                new_data[name].append(np.asarray(cell_data[name][i]))
            for name in cell_sets:
                blocks = cell_sets[name]
                new_sets[name].append(blocks[i] if i < len(blocks) else None)
    point_sets = {k: renumber(np.asarray(v, dtype=np.int64)) for k, v in (getattr(m, "point_sets", None) or {}).items()}
    info = dict(getattr(m, "info", None) or {})
    info["tetopt_report"] = report
    return meshio.Mesh(np.asarray(out.points), new_cells, point_data=dict(out.point_data or {}), cell_data=new_data,
                       field_data=dict(getattr(m, "field_data", None) or {}), point_sets=point_sets,
                       cell_sets=new_sets, info=info)
