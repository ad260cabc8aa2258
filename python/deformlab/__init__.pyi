"""Type stubs of deformlab (see the docstrings in deformlab/__init__.py)."""

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt
import scipy.sparse

__version__: str

Float64Array = npt.NDArray[np.float64]
Int64Array = npt.NDArray[np.int64]
#: (V, F): V float64 (n, 3), F integer (m, 3).
MeshLike = Tuple[npt.ArrayLike, npt.ArrayLike]
PathLike = Union[str, os.PathLike]

TRANSFER_METHODS: Tuple[str, ...]
def method_kinds() -> List[Dict[str, Any]]: ...
COMPLETION_SOLVERS: Tuple[str, ...]

class Offenders(TypedDict):
    count: int
    first: List[Any]

class SelectionResult(TypedDict):
    keypoints: List[int]
    candidates: List[int]
    transforms: Float64Array  # (poses, k, 3, 4)
    error: float
    trace: List[Tuple[int, List[int], float]]
    seconds: float
    evaluations: int

class TransferResult(TypedDict, total=False):
    meshes: List[Float64Array]  # one (n_B, 3) per pose
    method: str
    keypoints: List[int]
    target_keypoints: List[int]
    trace: List[Tuple[int, List[int], float]]
    fit_error: float
    transforms: Float64Array  # (poses, k, 3, 4)
    registered: Float64Array  # (n_A, 3)
    registration_residual: float
    seconds: Dict[str, float]

class CorrespondenceResult(TypedDict):
    target_keypoints: List[int]
    surface_points: Float64Array  # (k, 3)
    registered: Float64Array  # (n_A, 3)
    residual: float
    alpha: float
    seconds: float

class RegisterResult(TypedDict):
    V: Float64Array  # (n, 3)
    alpha: float
    energy: float
    example: int
    iterations: int

class CompleteResult(TypedDict):
    V: Float64Array  # (n, 3)
    correspondence: Int64Array  # (n_partial,)
    distance: Float64Array  # (n_partial,)
    alpha: Optional[float]
    partial_residual: Optional[float]
    solver: str

class RunSummary(TypedDict):
    name: str
    dir: str
    computed: int
    reused: int
    failed: int
    wall_seconds: float
    complete: bool

class SyntheticSet(TypedDict):
    V: List[List[Float64Array]]  # [subject][pose] (n, 3)
    F: Int64Array  # (m, 3)
    labels: Int64Array  # (n,)

def read_mesh(path: PathLike) -> Tuple[Float64Array, Int64Array]: ...
def write_mesh(path: PathLike, V: npt.ArrayLike, F: npt.ArrayLike) -> None: ...
def inspect(V: Union[npt.ArrayLike, PathLike], F: Optional[npt.ArrayLike] = None) -> Dict[str, Any]: ...
def cotmatrix(V: npt.ArrayLike, F: npt.ArrayLike) -> scipy.sparse.csr_matrix: ...
def massmatrix(V: npt.ArrayLike, F: npt.ArrayLike, kind: Optional[str] = None) -> scipy.sparse.csr_matrix: ...
def lbo_eigenpairs(
    V: npt.ArrayLike, F: npt.ArrayLike, k: int, seed: Optional[int] = None
) -> Tuple[Float64Array, Float64Array]: ...
def heat_geodesic(
    V: npt.ArrayLike, F: npt.ArrayLike, sources: Union[int, Sequence[int]], time_factor: Optional[float] = None
) -> Float64Array: ...
def fps(
    V: npt.ArrayLike, F: npt.ArrayLike, k: int, metric: Optional[str] = None, seed: Optional[int] = None
) -> Int64Array: ...
def bbw(V: npt.ArrayLike, F: npt.ArrayLike, handles: Sequence[int], mode: Optional[str] = None, tol: Optional[float] = None) -> Float64Array: ...
def select_keypoints(
    A: MeshLike,
    A_primes: Sequence[npt.ArrayLike],
    *,
    n_candidates: Optional[int] = None,
    seed: Optional[int] = None,
    epsilon: Optional[float] = None,
    max_keypoints: Optional[int] = None,
    mode: Optional[str] = None,
    error_norm: Optional[str] = None,
    weights: Optional[str] = None,
) -> SelectionResult: ...
def transfer(
    A: MeshLike,
    A_primes: Sequence[npt.ArrayLike],
    B: MeshLike,
    target_keypoints: Optional[Sequence[int]] = None,
    *,
    keypoints: Optional[Sequence[int]] = None,
    correspondence: Optional[str] = None,
    landmarks: Optional[npt.ArrayLike] = None,
    method: Optional[str] = None,
    **options: Any,
) -> TransferResult: ...
def target_correspondence(
    A: MeshLike,
    keypoints: Sequence[int],
    B: MeshLike,
    *,
    landmarks: Optional[npt.ArrayLike] = None,
    seed: Optional[int] = None,
) -> CorrespondenceResult: ...

class FbtModel:
    F: Int64Array
    def __init__(
        self,
        examples: Sequence[npt.ArrayLike],
        F: npt.ArrayLike,
        *,
        rig: Optional[Sequence[npt.ArrayLike]] = None,
        pipeline: Optional[str] = None,
        m: Optional[int] = None,
        clusters: Optional[int] = None,
        bones: Optional[int] = None,
        nicp: Optional[bool] = None,
        seed: Optional[int] = None,
    ) -> None: ...
    @property
    def q(self) -> int: ...
    @property
    def n_vertices(self) -> int: ...
    def register(self, vertices: Sequence[int], targets: npt.ArrayLike) -> RegisterResult: ...
    def complete(
        self, partial_target: MeshLike, features: npt.ArrayLike, solver: Optional[str] = None
    ) -> CompleteResult: ...

def register(model: FbtModel, constraints: Tuple[Sequence[int], npt.ArrayLike]) -> RegisterResult: ...
def complete(
    model: FbtModel, partial_target: MeshLike, features: npt.ArrayLike, *, solver: Optional[str] = None
) -> CompleteResult: ...
def synthetic(
    subjects: Optional[int] = None,
    poses: Optional[int] = None,
    resolution: Optional[int] = None,
    seed: Optional[int] = None,
) -> SyntheticSet: ...
def run(
    config_path: Union[PathLike, Sequence[PathLike]],
    out: Optional[PathLike] = None,
    overrides: Optional[Union[Dict[str, Any], Sequence[str]]] = None,
    *,
    sweep: Optional[Union[Dict[str, Sequence[Any]], Sequence[str]]] = None,
    threads: Optional[int] = None,
    data_root: Optional[PathLike] = None,
    plots: bool = True,
    force: bool = False,
    retry_failed: bool = False,
    progress: bool = False,
    methods: Optional[Dict[str, Any]] = None,
) -> List[RunSummary]: ...
def load_results(folder: PathLike) -> Dict[str, Any]: ...
