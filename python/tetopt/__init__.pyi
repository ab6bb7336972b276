"""Type stubs of the tetopt package (docstrings in __init__.py mirror include/tetopt/*.hpp)."""
import os
from typing import Any, Callable, Dict, List, Optional, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

LogCallback = Callable[[str, str], Any]
ProgressCallback = Callable[[str, int, float, float], Any]
PathLike = Union[str, os.PathLike[str]]
ArrayLike = npt.ArrayLike

class Mesh:
    """A tetrahedral mesh with everything its file carried (mirrors tetopt::TetMesh); 0-based indices."""

    points: npt.NDArray[np.float64]
    """(n, 3) coordinates."""
    tets: npt.NDArray[np.int32]
    """(m, 4) vertex ids, positively oriented."""
    refs: Optional[npt.NDArray[np.int32]]
    """(m,) region ref per tet."""
    point_refs: Optional[npt.NDArray[np.int32]]
    triangles: Optional[npt.NDArray[np.int32]]
    """(k, 3) listed triangles; every listed triangle is constrained."""
    triangle_refs: Optional[npt.NDArray[np.int32]]
    edges: Optional[npt.NDArray[np.int32]]
    edge_refs: Optional[npt.NDArray[np.int32]]
    required_vertices: Optional[npt.NDArray[np.int32]]
    required_triangles: Optional[npt.NDArray[np.int32]]
    required_edges: Optional[npt.NDArray[np.int32]]
    corners: Optional[npt.NDArray[np.int32]]
    ridges: Optional[npt.NDArray[np.int32]]
    groups: List[Tuple[int, int, str]]
    """Physical names as (dim, tag, name)."""
    tet_entities: Optional[npt.NDArray[np.int32]]
    triangle_entities: Optional[npt.NDArray[np.int32]]
    point_data: Dict[str, np.ndarray]
    flipped_on_read: bool
    source_format: str
    def __init__(
        self,
        points: ArrayLike,
        tets: ArrayLike,
        refs: Optional[ArrayLike] = ...,
        point_refs: Optional[ArrayLike] = ...,
        triangles: Optional[ArrayLike] = ...,
        triangle_refs: Optional[ArrayLike] = ...,
        edges: Optional[ArrayLike] = ...,
        edge_refs: Optional[ArrayLike] = ...,
        required_vertices: Optional[ArrayLike] = ...,
        required_triangles: Optional[ArrayLike] = ...,
        required_edges: Optional[ArrayLike] = ...,
        corners: Optional[ArrayLike] = ...,
        ridges: Optional[ArrayLike] = ...,
        groups: List[Tuple[int, int, str]] = ...,
        tet_entities: Optional[ArrayLike] = ...,
        triangle_entities: Optional[ArrayLike] = ...,
        point_data: Dict[str, ArrayLike] = ...,
        flipped_on_read: bool = ...,
        source_format: str = ...,
    ) -> None: ...
    def validate(self) -> None:
        """Raises ValueError when the arrays do not form a valid tetopt mesh."""
    @classmethod
    def from_meshio(cls, m: Any, ref_key: Optional[str] = None) -> Mesh:
        """A Mesh from a meshio.Mesh (see from_meshio)."""
    def to_meshio(self) -> Any:
        """This mesh as a meshio.Mesh (see to_meshio)."""

@overload
def improve(
    points: Any,
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
    progress: Optional[ProgressCallback] = None,
) -> Any:
    """improve(meshio_mesh) -> meshio.Mesh (see improve_meshio)."""
@overload
def improve(
    points: ArrayLike,
    tets: ArrayLike,
    refs: Optional[ArrayLike] = None,
    *,
    mode: str = "best",
    weight: float = 0.75,
    threshold: float = 0.3,
    iterations: int = 10,
    seed: int = 0,
    threads: int = 0,
    constrained_faces: Optional[ArrayLike] = None,
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
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int32], npt.NDArray[np.int32], Dict[str, Any]]:
    """Improves a tetrahedral mesh without touching its constrained vertices and faces.

    Returns (points (n,3) float64, tets (m',4) int32, refs (m',) int32, report),
    report having the keys of `tetopt improve --report` JSON.  Raises ValueError
    on bad arguments, RuntimeError on an invariant failure (a bug),
    KeyboardInterrupt on Ctrl-C.  GIL released.  progress(phase, round,
    fraction, worst) returning False stops the run (report["stopped_early"]).
    """

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
    """Improves a whole Mesh as `tetopt improve` does (listed entities constrained, everything kept)."""

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
    """meshio.Mesh in, meshio.Mesh out: cell blocks, cell data and cell sets kept by name; report in info["tetopt_report"]."""

@overload
def quality(points: Mesh, *, diagnose: bool = False, threshold: float = 0.3) -> Dict[str, Any]: ...
@overload
def quality(
    points: ArrayLike,
    tets: ArrayLike,
    refs: Optional[ArrayLike] = None,
    *,
    constrained_faces: Optional[ArrayLike] = None,
    diagnose: bool = False,
    threshold: float = 0.3,
) -> Dict[str, Any]:
    """Statistics (keys of `tetopt quality --json`) plus per_tet arrays alpha, dihedral_min, dihedral_max, kind."""

def read(path: PathLike) -> Mesh:
    """Reads .mesh/.meshb/.msh/.vtk/.vtu/.node/.ele (format by extension). OSError / ValueError on failure."""

def write(path: PathLike, mesh: Any, *, msh_version: int = 41, binary: bool = False, meshb_version: int = 3) -> None:
    """Writes a Mesh (or meshio.Mesh) atomically; format by extension."""

def from_meshio(m: Any, ref_key: Optional[str] = None) -> Mesh:
    """meshio.Mesh -> Mesh (tetra, triangle and line cells; refs, groups, point data)."""

@overload
def to_meshio(mesh: Mesh) -> Any: ...
@overload
def to_meshio(mesh: ArrayLike, tets: ArrayLike, refs: Optional[ArrayLike] = None) -> Any:
    """Mesh or (points, tets[, refs]) -> meshio.Mesh (refs as medit:ref and gmsh:physical)."""
