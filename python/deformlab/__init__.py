"""deformlab from Python: mesh deformation transfer (BDT) and partial shape
registration (FBT) on numpy arrays.

A thin layer over the Rust library ``deformlab`` (the one implementation; the
command line, the experiment harness and this module call the same entry
points). Meshes are ``(V, F)`` pairs:

* ``V``: ``float64`` array of shape ``(n, 3)``, finite;
* ``F``: integer array of shape ``(m, 3)``, vertex indices in ``0..n``.

Inputs are checked before any work (shape, dtype, NaN/inf, index ranges):
a bad argument raises ``ValueError`` naming it. The GIL is released during
every library call. Every keyword left ``None`` takes the library's default
(``KeypointOptions::default()``, ``BdtOptions::default()``, ...), the same
default as the CLI flag or config key left out; string values are the CLI's
value names (``"per-handle"``, ``"unit-sphere"``; ``_`` works for ``-``).

Conventions that differ from libigl: :func:`cotmatrix` is *positive*
semi-definite (``cotmatrix(V, F) == -igl.cotmatrix(V, F)``).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import FbtModel as _NativeFbtModel

__version__: str = _native.__version__

__all__ = [
    "__version__",
    "read_mesh",
    "write_mesh",
    "inspect",
    "cotmatrix",
    "massmatrix",
    "lbo_eigenpairs",
    "heat_geodesic",
    "fps",
    "bbw",
    "select_keypoints",
    "transfer",
    "target_correspondence",
    "FbtModel",
    "register",
    "complete",
    "run",
    "load_results",
    "synthetic",
    "TRANSFER_METHODS",
    "COMPLETION_SOLVERS",
    "method_kinds",
]

def method_kinds() -> List[Dict[str, Any]]:
    """The registry of method kinds (as ``deformlab methods`` prints it):
    per kind its ``name`` (a config's ``kind``, ``transfer(method=...)``),
    ``family`` (``"transfer"``, ``"clustering"``, ``"fbt"``) and the option
    ``keys`` it takes."""
    return [{"name": n, "family": f, "keys": list(k)} for n, f, k in _native.method_kinds()]


#: Transfer methods, by the configs' ``kind`` names (read from the registry).
TRANSFER_METHODS = tuple(k["name"] for k in method_kinds() if k["family"] == "transfer")
#: Completion solvers, by the configs' ``solver`` names (FBT and baselines).
COMPLETION_SOLVERS = ("fbt", "der", "amberg", "template")

MeshLike = Tuple[Any, Any]


# ---------------------------------------------------------------------------
# Argument checks (numpy side; the Rust side checks again)


def _vertices(V: Any, name: str, n: Optional[int] = None) -> np.ndarray:
    try:
        a = np.asarray(V)
    except Exception as e:  # noqa: BLE001 - any conversion failure is bad input
        raise ValueError(f"{name}: not convertible to an array ({e})") from None
    if a.dtype == object or not (
        np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
    ):
        raise ValueError(f"{name}: expected a numeric (n, 3) array, got dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3), got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name}: no vertices")
    a = np.ascontiguousarray(a, dtype=np.float64)
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{name}: {int(bad.sum())} vertices with NaN or inf coordinates (first: vertex {i})"
        )
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name}: {a.shape[0]} vertices, expected {n}")
    return a


def _faces(F: Any, name: str, n: int) -> np.ndarray:
    try:
        a = np.asarray(F)
    except Exception as e:  # noqa: BLE001
        raise ValueError(f"{name}: not convertible to an array ({e})") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (m, 3), got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name}: no faces")
    if not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name}: expected an integer array of vertex indices, got dtype {a.dtype}")
    lo, hi = int(a.min()), int(a.max())
    if lo < 0 or hi >= n:
        bad = lo if lo < 0 else hi
        raise ValueError(f"{name}: vertex index {bad} out of range (the mesh has {n} vertices: 0..{n - 1})")
    return np.ascontiguousarray(a, dtype=np.int64)


def _mesh(M: Any, name: str) -> Tuple[np.ndarray, np.ndarray]:
    # A trimesh.Trimesh (or any object with .vertices and .faces) is a mesh too.
    if not isinstance(M, (tuple, list)) and hasattr(M, "vertices") and hasattr(M, "faces"):
        M = (np.asarray(M.vertices), np.asarray(M.faces))
    if not isinstance(M, (tuple, list)) or len(M) != 2:
        raise ValueError(f"{name}: expected a mesh as a (V, F) pair or an object with .vertices and .faces (e.g. trimesh.Trimesh)")
    V = _vertices(M[0], f"{name} V")
    return V, _faces(M[1], f"{name} F", V.shape[0])


def _poses(A_primes: Any, n: int, name: str = "A_primes") -> List[np.ndarray]:
    if isinstance(A_primes, np.ndarray) and A_primes.ndim == 2:
        raise ValueError(f"{name}: expected a list of (n, 3) vertex arrays (one per pose), got one array")
    if isinstance(A_primes, np.ndarray) and A_primes.ndim == 3:
        A_primes = list(A_primes)
    if not isinstance(A_primes, (list, tuple)) or len(A_primes) == 0:
        raise ValueError(f"{name}: expected a non-empty list of deformed poses")
    out = []
    for j, P in enumerate(A_primes):
        if isinstance(P, (tuple, list)) and len(P) == 2 and np.ndim(P[0]) == 2:
            P = P[0]  # a (V, F) pair: the faces are A's
        elif hasattr(P, "vertices") and not isinstance(P, np.ndarray):
            P = np.asarray(P.vertices)  # a trimesh-like object: the faces are A's
        out.append(_vertices(P, f"{name}[{j}]", n))
    return out


def _index_list(x: Any, name: str, n: Optional[int] = None) -> List[int]:
    a = np.asarray(x)
    if a.ndim != 1:
        raise ValueError(f"{name}: expected a 1-d list of vertex indices, got shape {a.shape}")
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name}: expected integer vertex indices, got dtype {a.dtype}")
    a = a.astype(np.int64)
    if n is not None and a.size and (a.min() < 0 or a.max() >= n):
        bad = int(a.min()) if a.min() < 0 else int(a.max())
        raise ValueError(f"{name}: vertex {bad} out of range (0..{n - 1})")
    return [int(i) for i in a]


def _pairs(x: Any, name: str) -> List[Tuple[int, int]]:
    a = np.asarray(x)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"{name}: expected (k, 2) vertex pairs, got shape {a.shape}")
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name}: expected integer vertex indices, got dtype {a.dtype}")
    return [(int(s), int(t)) for s, t in a]


def _transforms(flat: np.ndarray, poses: int) -> np.ndarray:
    k = flat.shape[0] // max(poses, 1)
    return flat.reshape(poses, k, 3, 4)


# ---------------------------------------------------------------------------
# Mesh I/O


def read_mesh(path: Union[str, os.PathLike]) -> Tuple[np.ndarray, np.ndarray]:
    """Read a mesh file: PLY (ASCII or binary), OFF, OBJ or TOSCA ``.vert``/``.tri``.

    Returns ``(V, F)``: ``V`` float64 ``(n, 3)``, ``F`` int64 ``(m, 3)``.
    A malformed file raises ``ValueError`` naming the file and where reading
    stopped; an unreadable one ``OSError``.
    """
    return _native.read_mesh(os.fspath(path))


def write_mesh(path: Union[str, os.PathLike], V: Any, F: Any) -> None:
    """Write ``(V, F)``; the format follows the extension (``.ply`` binary, ``.obj``, ``.off``).

    Written through a temporary file and a rename (never half a file).
    """
    V = _vertices(V, "V")
    _native.write_mesh(os.fspath(path), V, _faces(F, "F", V.shape[0]))


def inspect(V: Any, F: Any = None) -> Dict[str, Any]:
    """Defect report of a mesh as a dict (what ``deformlab inspect`` prints).

    ``inspect(V, F)`` takes arrays; ``inspect(path)`` reads a file first.
    Unlike every other function, NaN coordinates and out-of-range face
    indices are *reported* (``non_finite_vertices``, ``out_of_range_faces``),
    not refused. Keys: ``n_vertices``, ``n_faces``, ``n_edges``,
    ``euler_characteristic``, ``genus``, ``clean``, ``loadable``, ``summary``,
    the offender counts ``{count, first}`` (``duplicate_faces``,
    ``zero_area_faces``, ``non_manifold_edges``, ``boundary_edges``, ...) and
    ``components`` (one dict per connected component).
    """
    if F is None:
        if isinstance(V, (str, os.PathLike)):
            V, F = read_mesh(V)
        else:
            raise ValueError("inspect: give (V, F) arrays or a file path")
    a = np.asarray(V)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"V: expected shape (n, 3), got {a.shape}")
    f = np.asarray(F)
    if f.ndim != 2 or f.shape[1] != 3 or not (f.size == 0 or np.issubdtype(f.dtype, np.integer)):
        raise ValueError(f"F: expected an integer (m, 3) array, got shape {f.shape}, dtype {f.dtype}")
    if f.size and f.min() < 0:
        raise ValueError(f"F: negative vertex index {int(f.min())}")
    return _native.inspect(
        np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(f, dtype=np.int64)
    )


# ---------------------------------------------------------------------------
# Operators


def cotmatrix(V: Any, F: Any):
    """Cotangent Laplacian ``L`` (n × n, ``scipy.sparse.csr_matrix``).

    ``L_ij = -½ (cot α_ij + cot β_ij)`` for an edge ``ij``, ``L_ii = -Σ_j L_ij``:
    symmetric, positive semi-definite, zero row sums (the stiffness matrix of
    linear finite elements). Degenerate faces (``2·area < 1e-10·longest²``)
    contribute nothing. Sign: ``cotmatrix(V, F) == -igl.cotmatrix(V, F)``.
    """
    import scipy.sparse as sp

    V = _vertices(V, "V")
    data, indices, indptr, shape = _native.cotmatrix(V, _faces(F, "F", V.shape[0]))
    return sp.csr_matrix((data, indices, indptr), shape=shape)


def massmatrix(V: Any, F: Any, kind: Optional[str] = None):
    """Lumped mass matrix ``M`` (n × n diagonal ``scipy.sparse.csr_matrix``).

    ``kind``: ``"voronoi"`` (mixed Voronoi areas, Meyer et al. 2003; the
    library's default for ``None``) or ``"barycentric"`` (a third of each
    adjacent face). ``M`` sums to the area of the non-degenerate faces; it
    equals ``igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI)``.
    """
    import scipy.sparse as sp

    V = _vertices(V, "V")
    d = _native.massmatrix(V, _faces(F, "F", V.shape[0]), kind)
    return sp.diags(d, format="csr")


def lbo_eigenpairs(V: Any, F: Any, k: int, seed: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
    """The ``k`` smallest Laplace–Beltrami eigenpairs ``L φ = λ M φ``.

    ``L`` = :func:`cotmatrix`, ``M`` = Voronoi :func:`massmatrix`. Returns
    ``(lam, Phi)``: ``lam`` float64 ``(k,)`` ascending, ``Phi`` float64
    ``(n, k)`` with ``Phiᵀ M Phi = I``. Residuals, orthonormality and
    completeness (Sylvester inertia) are verified by the library, which
    raises ``RuntimeError`` rather than return unverified pairs.
    """
    V = _vertices(V, "V")
    return _native.lbo_eigenpairs(V, _faces(F, "F", V.shape[0]), int(k), seed)


def heat_geodesic(V: Any, F: Any, sources: Any, time_factor: Optional[float] = None) -> np.ndarray:
    """Geodesic distance from ``sources`` by the heat method (Crane et al. 2013).

    Heat ``(M + t L) u = δ`` with ``t = time_factor · h²`` (``h`` the mean edge
    length; ``None``: the library's 1), ``X = -∇u/|∇u|``, then the Poisson
    problem ``L φ = -∇·X`` shifted so the sources are at 0. Returns float64 ``(n,)``.
    """
    V = _vertices(V, "V")
    F = _faces(F, "F", V.shape[0])
    src = _index_list(np.atleast_1d(sources), "sources", V.shape[0])
    return _native.heat_geodesic(V, F, src, time_factor)


def fps(V: Any, F: Any, k: int, metric: Optional[str] = None, seed: Optional[int] = None) -> np.ndarray:
    """``k`` vertices by farthest point sampling (int64 ``(k,)``).

    Starts at a vertex drawn with ``ChaCha8(seed)``; each next sample maximises
    the distance to the samples so far (ties: lowest index). ``metric``:
    ``"euclidean"`` or ``"geodesic"`` (Dijkstra on edges); ``None`` and
    ``seed=None`` take the library's defaults (Euclidean, seed 0).
    """
    V = _vertices(V, "V")
    return _native.fps(V, _faces(F, "F", V.shape[0]), int(k), metric, seed)


def bbw(V: Any, F: Any, handles: Any, mode: Optional[str] = None, tol: Optional[float] = None) -> np.ndarray:
    """Bounded biharmonic weights of point handles (BDT Eq. 1; Jacobson et al. 2011).

    Minimises ``Σ_k ½ w_kᵀ Q w_k`` with ``Q = L M⁻¹ L`` subject to
    ``w_k(h_j) = δ_jk`` and ``0 ≤ w ≤ 1``. ``mode``:

    * ``"per-handle"`` (the library's default for ``None``, as in
      ``deformlab weights``, ``transfer`` and the configs): each ``w_k`` with
      its bounds, rows then normalised to sum to one (libigl's ``bbw`` +
      ``normalize_row_sums``);
    * ``"coupled"``: Eq. 1 as written, bounds and partition of unity
      ``Σ_k w_k = 1`` in one problem.

    ``tol`` is the active-set tolerance of that mode, in weight units
    (``None``: the library's, 1e-10 per-handle and 1e-8 coupled, as in
    ``deformlab weights --tol`` / ``--coupled-tol``); range 1e-15 to 1e-3.

    Returns float64 ``(n, len(handles))``; handles must be distinct vertices.
    """
    V = _vertices(V, "V")
    F = _faces(F, "F", V.shape[0])
    h = _index_list(np.atleast_1d(handles), "handles", V.shape[0])
    return _native.bbw(V, F, h, mode, None if tol is None else float(tol))


# ---------------------------------------------------------------------------
# BDT


def select_keypoints(
    A: MeshLike,
    A_primes: Sequence[Any],
    *,
    n_candidates: Optional[int] = None,
    seed: Optional[int] = None,
    epsilon: Optional[float] = None,
    max_keypoints: Optional[int] = None,
    mode: Optional[str] = None,
    error_norm: Optional[str] = None,
    weights: Optional[str] = None,
) -> Dict[str, Any]:
    """BDT key point selection (Algorithm 1), as ``deformlab keypoints``.

    ``A = (V, F)``; ``A_primes``: the deformed poses, each an ``(n, 3)``
    array with A's connectivity (or a ``(V, F)`` pair). Stage 1 adds the
    FPS candidate (``n_candidates``, paper ``n_c = 100``) that lowers the fit
    error most until it is below ``epsilon`` (paper 0.03, unit-sphere
    units); stage 2 swaps key points while one improves. The fit of a set
    ``S`` is ``D_S(A) = Σ_k w_k T_k`` (LBS, Eq. 2) with bounded biharmonic
    weights ``w`` and transforms ``T_k`` from clustered ARAP + E_diff
    (Eqs. 3–5). Every ``None`` keyword is the library's default.

    Returns a dict: ``keypoints`` (list of vertex ids), ``transforms``
    (float64 ``(poses, k, 3, 4)``: ``[L | t]`` per pose and key point, A's
    frame), ``error``, ``trace`` (list of ``(stage, keypoints, error)``),
    ``candidates``, ``seconds``, ``evaluations``.
    """
    AV, AF = _mesh(A, "A")
    poses = _poses(A_primes, AV.shape[0])
    r = _native.select_keypoints(
        AV, AF, poses, n_candidates, seed, epsilon, max_keypoints, mode, error_norm, weights
    )
    r["transforms"] = _transforms(r["transforms"], len(poses))
    return r


def transfer(
    A: MeshLike,
    A_primes: Sequence[Any],
    B: MeshLike,
    target_keypoints: Optional[Sequence[int]] = None,
    *,
    keypoints: Optional[Sequence[int]] = None,
    correspondence: Optional[str] = None,
    landmarks: Any = None,
    method: Optional[str] = None,
    **options: Any,
) -> Dict[str, Any]:
    """Deformation transfer ``A → A′_j`` onto ``B``, as ``deformlab transfer``.

    BDT (``method="bdt"``, the default): key points ``S`` on A (selected by
    Algorithm 1, or ``keypoints`` given), their transforms ``T_k`` fitted on
    the ``A′_j`` (Eqs. 2–5), bounded biharmonic weights ``w′`` on B at the
    target key points, and ``B′_j = Σ_k w′_k T_k(B)`` (Sec. 3.6) in the
    shared unit-sphere frame (``frame``). ``align`` (``"none"``, the
    default; ``"keypoints"``; ``"dense"``) rotates B onto A in that frame,
    as the CLI's ``--align``.

    Target key points: ``target_keypoints`` (a list in key point order; needs
    ``keypoints``, as the CLI's ``--target-keypoints`` needs ``--keypoints``),
    else ``correspondence="identity"`` (same vertex; the default, A and B
    share connectivity) or ``"auto"`` (registration of A onto B, any
    connectivity; ``landmarks``: optional ``(k, 2)`` vertex pairs guiding it).

    ``method`` is any transfer kind of the registry (``TRANSFER_METHODS``,
    ``method_kinds()``): ``"bdt"``, ``"bdt_random"``, ``"bdt_extremity"``,
    ``"sumner"`` (Sumner & Popović with the key point pairs as markers),
    ``"cage"`` (cage DT), ``"sumner_oracle"`` (identity triangle
    correspondence), ``"identity"`` (B unchanged). ``options`` are the
    keys of a config's ``[[methods]]`` entry of that kind (``n_candidates``,
    ``seed``, ``epsilon``, ``max_keypoints``, ``mode``, ``error_norm``,
    ``weights``, ``frame``, ``align``, ``target_weights``, ``refine``,
    ``count``, ...), checked against the same table and ranges: a key the
    kind does not use is a ``ValueError`` naming it. ``None`` means the
    library's default.

    Returns a dict: ``meshes`` (list of float64 ``(n_B, 3)``, one B′ per pose;
    faces are B's), ``keypoints``, ``target_keypoints``, ``fit_error`` and
    ``transforms`` (``(poses, k, 3, 4)``; BDT), ``trace`` (when selected),
    ``registered`` (A registered onto B; ``"auto"``), ``seconds`` per stage.
    """
    AV, AF = _mesh(A, "A")
    poses = _poses(A_primes, AV.shape[0])
    BV, BF = _mesh(B, "B")
    kp = None if keypoints is None else _index_list(keypoints, "keypoints", AV.shape[0])
    tk = None if target_keypoints is None else _index_list(target_keypoints, "target_keypoints", BV.shape[0])
    if kp is not None and tk is not None and len(kp) != len(tk):
        raise ValueError(
            f"target_keypoints: {len(tk)} target vertices for {len(kp)} key points; give one per key point"
        )
    if method is not None and method not in TRANSFER_METHODS:
        raise ValueError(f"method: unknown transfer method {method!r}; expected one of {', '.join(TRANSFER_METHODS)}")
    lm = None if landmarks is None else _pairs(landmarks, "landmarks")
    opts = {k: _option_value(k, v) for k, v in options.items() if v is not None}
    r = _native.transfer(
        AV, AF, poses, BV, BF, target_keypoints=tk, keypoints=kp, correspondence=correspondence,
        landmarks=lm, method=method, options=json.dumps(opts),
    )
    if "transforms" in r:
        r["transforms"] = _transforms(r["transforms"], len(poses))
    return r


def _option_value(key: str, v: Any) -> Any:
    """A keyword option as JSON: numpy scalars as Python numbers; NaN and
    infinities refused here (JSON has none)."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not np.isfinite(v):
        raise ValueError(f"{key}: expected a finite number, got {v!r}")
    if not isinstance(v, (bool, int, float, str)):
        raise ValueError(f"{key}: expected a number, a string or a bool, got {type(v).__name__}")
    return v


def target_correspondence(
    A: MeshLike,
    keypoints: Sequence[int],
    B: MeshLike,
    *,
    landmarks: Any = None,
    seed: Optional[int] = None,
) -> Dict[str, Any]:
    """The automatic target key points: register A onto B, snap to B's vertices.

    Coarse principal-axes alignment, then nonrigid ICP with blended
    transformations (FBT's energy, Eq. 10) and the closest point on B of each
    registered key point, snapped to a vertex. Returns ``target_keypoints``,
    ``surface_points`` (``(k, 3)``), ``registered`` (A's vertices on B,
    ``(n_A, 3)``), ``residual`` (√area(B) units), ``alpha``, ``seconds``.
    """
    AV, AF = _mesh(A, "A")
    BV, BF = _mesh(B, "B")
    kp = _index_list(keypoints, "keypoints", AV.shape[0])
    lm = None if landmarks is None else _pairs(landmarks, "landmarks")
    return _native.target_correspondence(AV, AF, kp, BV, BF, lm, seed)


# ---------------------------------------------------------------------------
# FBT


class FbtModel:
    """An FBT model built from example poses (FBT Sec. 4).

    ``examples``: list of ``(n, 3)`` vertex arrays of one template, the
    reference first; ``F``: the template faces. The template is deformed by
    blended transformations ``P = D T`` (Eq. 3) with the example-based
    dictionary ``D`` (LBO eigenfunctions ``m``), under the
    scaled/averaged/minimal ARAP energies (Eqs. 6-16) with ``clusters``
    rotation clusters. ``pipeline``: ``None`` is the library's default rule
    (``"skeleton_clusters"``: the LBO stages with rotation clusters from the
    skeleton weights of example-based skinning learnt from ``rig`` poses,
    by default the examples after the reference, once there are 3 of them;
    ``"lbo"`` below); ``"skeleton"`` is the paper's articulated pipeline
    (last stage the skeleton dictionary), ``"lbo"`` LBO only,
    ``"skeleton_dictionary"`` an ablation. Other ``None`` keywords: the
    library's ``FbtOptions`` defaults.
    """

    def __init__(
        self,
        examples: Sequence[Any],
        F: Any,
        *,
        rig: Optional[Sequence[Any]] = None,
        pipeline: Optional[str] = None,
        m: Optional[int] = None,
        clusters: Optional[int] = None,
        bones: Optional[int] = None,
        nicp: Optional[bool] = None,
        seed: Optional[int] = None,
    ) -> None:
        if isinstance(examples, np.ndarray) and examples.ndim == 3:
            examples = list(examples)
        if rig is not None and isinstance(rig, np.ndarray) and rig.ndim == 3:
            rig = list(rig)
        if not isinstance(examples, (list, tuple)) or len(examples) == 0:
            raise ValueError("examples: expected a non-empty list of (n, 3) vertex arrays")
        V0 = _vertices(examples[0], "examples[0]")
        n = V0.shape[0]
        ex = [V0] + [_vertices(e, f"examples[{j}]", n) for j, e in enumerate(examples) if j > 0]
        F = _faces(F, "F", n)
        rg = None if rig is None else [_vertices(e, f"rig[{j}]", n) for j, e in enumerate(rig)]
        self._m = _NativeFbtModel(ex, F, rg, pipeline, m, clusters, bones, nicp, seed)
        self.F = F

    @property
    def q(self) -> int:
        """Number of examples."""
        return self._m.q

    @property
    def n_vertices(self) -> int:
        """Template vertex count."""
        return self._m.n_vertices

    def register(self, vertices: Sequence[int], targets: Any) -> Dict[str, Any]:
        """See :func:`register`."""
        idx = _index_list(vertices, "vertices", self.n_vertices)
        Y = _vertices(targets, "targets", len(idx))
        return self._m.register(idx, Y)

    def complete(self, partial_target: MeshLike, features: Any, solver: Optional[str] = None) -> Dict[str, Any]:
        """See :func:`complete`."""
        PV, PF = _mesh(partial_target, "partial_target")
        pairs = _pairs(features, "features")
        if solver is not None and solver not in COMPLETION_SOLVERS:
            raise ValueError(f"solver: unknown value {solver!r}; expected one of {', '.join(COMPLETION_SOLVERS)}")
        return self._m.complete(PV, PF, pairs, solver)


def register(model: FbtModel, constraints: Tuple[Sequence[int], Any]) -> Dict[str, Any]:
    """Deform the model's template to position constraints (FBT Eq. 10).

    ``constraints = (vertices, targets)``: template vertex ids (``k``) and
    their target positions (float64 ``(k, 3)``), i.e. ``H = e_i`` rows and
    ``Y``. Minimises ``E = E_ARAP + β_lc ‖α H D T − Y‖² + β_sm E_sm`` over the
    transformations ``T`` and global scale ``α`` with the paper's schedule
    (average → minimal → rich stage). Returns ``V`` (the deformed template,
    ``(n, 3)``), ``alpha``, ``energy``, ``example`` (the ℓ* of E_mn),
    ``iterations``. The model's precomputation is built on first use.
    """
    if not isinstance(constraints, (tuple, list)) or len(constraints) != 2:
        raise ValueError("constraints: expected a (vertices, targets) pair")
    return model.register(constraints[0], constraints[1])


def complete(
    model: FbtModel, partial_target: MeshLike, features: Any, *, solver: Optional[str] = None
) -> Dict[str, Any]:
    """Shape completion of a partial target (FBT Sec. 5, Fig. 7).

    ``partial_target = (V, F)`` (any connectivity); ``features``: ``(k, 2)``
    pairs ``(template vertex, partial-target vertex)``. Constraints are the
    area-weighted averages over 10 geodesic circles per feature (up to
    0.15 √area), then the registration and NICP, retried pre-aligned when the
    result looks like a gross failure — exactly the harness's procedure.
    ``solver``: ``"fbt"`` (default) or the baselines ``"der"`` (Der et al.
    2006 on FBT's clusters), ``"amberg"`` (optimal-step NICP), ``"template"``
    (the undeformed floor).

    Returns ``V`` (the completed template, ``(n, 3)``), ``correspondence``
    (int64 ``(n_partial,)``: the template vertex nearest each partial-target
    vertex), ``distance`` (those distances), ``alpha``, ``partial_residual``.
    """
    return model.complete(partial_target, features, solver)


# ---------------------------------------------------------------------------
# Data and experiments


def synthetic(
    subjects: Optional[int] = None,
    poses: Optional[int] = None,
    resolution: Optional[int] = None,
    seed: Optional[int] = None,
) -> Dict[str, Any]:
    """The synthetic set of ``deformlab gen``, in memory (exact ground truth).

    An articulated creature, ``subjects`` × ``poses`` meshes of one
    connectivity (vertex ``i`` of every mesh corresponds); ``resolution``
    1..5 (1: ~1.7k vertices, 2: ~6.7k, the default). ``None``: the library's
    defaults (6 subjects, 8 poses, resolution 2, seed 0). Returns
    ``{"V": float64 (subjects, poses, n, 3), "F": int64 (m, 3), "labels":
    int64 (n,) bone of each vertex}``: ``V[s][p]`` (or ``V[s, p]``) is
    subject ``s`` in pose ``p``; pose 0 is the reference pose.
    """
    for name, x in (("subjects", subjects), ("poses", poses), ("resolution", resolution), ("seed", seed)):
        if x is not None and (not isinstance(x, (int, np.integer)) or isinstance(x, bool) or x < 0):
            raise ValueError(f"{name}: expected a non-negative integer, got {x!r}")
    V, F, labels = _native.synthetic(subjects, poses, resolution, seed)
    V = np.stack([np.stack([np.asarray(P, dtype=np.float64) for P in s]) for s in V])
    return {"V": V, "F": F, "labels": np.asarray(labels, dtype=np.int64)}


# ---------------------------------------------------------------------------
# Experiments


def run(
    config_path: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]]],
    out: Optional[Union[str, os.PathLike]] = None,
    overrides: Optional[Union[Dict[str, Any], Sequence[str]]] = None,
    *,
    sweep: Optional[Union[Dict[str, Sequence[Any]], Sequence[str]]] = None,
    threads: Optional[int] = None,
    data_root: Optional[Union[str, os.PathLike]] = None,
    plots: bool = True,
    force: bool = False,
    retry_failed: bool = False,
    progress: bool = False,
    methods: Optional[Dict[str, Any]] = None,
) -> List[Dict[str, Any]]:
    """Run experiment configs, as ``deformlab run CONFIG... --out OUT --set K=V``.

    ``overrides``: ``{"defaults.epsilon": 0.02}`` or ``["defaults.epsilon=0.02"]``
    (``--set``); ``sweep``: ``{"defaults.epsilon": [0.01, 0.02]}`` or
    ``["defaults.epsilon=0.01,0.02"]`` (``--sweep``). ``out`` defaults to the
    CLI's ``results``. Resumable and reproducible as the CLI is. Returns one
    summary dict per experiment (``name``, ``dir``, ``computed``, ``reused``,
    ``failed``, ``wall_seconds``, ``complete``); read its folder with
    :func:`load_results`.

    ``methods``: your own methods as Python functions, by the name a config
    entry gives them (``kind = "callable"``, ``function = "mine"``;
    ``markers = true`` passes BDT's key point pairs). Each is called per
    case as ``fn(A, poses, B, markers)`` with ``A = (V, F)``, ``poses`` a
    list of ``(n, 3)`` arrays, ``B = (V, F)``, ``markers`` a list of
    ``(source, target)`` vertex pairs or ``None``, and returns one
    ``(n_B, 3)`` array per pose (B's vertex order); its results are
    evaluated like every method's. An exception fails that case only. The
    store keys results on the function's name: rename it (or ``force=True``)
    when its code changes.
    """
    paths = [config_path] if isinstance(config_path, (str, os.PathLike)) else list(config_path)

    def kv(x: Any, name: str, join: bool) -> List[str]:
        if x is None:
            return []
        if isinstance(x, dict):
            out_ = []
            for k, v in x.items():
                if join and isinstance(v, (list, tuple)):
                    v = ",".join(_fmt(e) for e in v)
                else:
                    v = _fmt(v)
                out_.append(f"{k}={v}")
            return out_
        if isinstance(x, str):
            raise ValueError(f"{name}: expected a dict or a list of 'KEY=VALUE' strings, got a string")
        return [str(e) for e in x]

    return _native.run(
        [os.fspath(p) for p in paths],
        None if out is None else os.fspath(out),
        kv(overrides, "overrides", False),
        kv(sweep, "sweep", True),
        threads,
        None if data_root is None else os.fspath(data_root),
        plots,
        force,
        retry_failed,
        progress,
        _methods(methods),
    )


def _methods(methods: Optional[Dict[str, Any]]) -> Optional[List[Tuple[str, Any]]]:
    """``run(methods=...)``: names and callables, checked."""
    if methods is None:
        return None
    if not isinstance(methods, dict):
        raise ValueError("methods: expected a dict of name -> function")
    out = []
    for name, fn in methods.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"methods: expected names as strings, got {name!r}")
        if not callable(fn):
            raise ValueError(f"methods[{name!r}]: expected a function, got {type(fn).__name__}")
        out.append((name, fn))
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return v
    return repr(v) if isinstance(v, float) else str(v)


def _read_json(path: str) -> Optional[Any]:
    """The JSON document at ``path``, ``None`` when there is no such file."""
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        return json.load(fh)


def _index_array(cell: Any) -> np.ndarray:
    """A key point cell of cases.csv ("4663;4835", a number, or empty) as an int64 array."""
    if cell is None or (isinstance(cell, float) and np.isnan(cell)):
        return np.zeros(0, dtype=np.int64)
    if isinstance(cell, (int, np.integer, float, np.floating)):
        return np.array([int(cell)], dtype=np.int64)
    text = str(cell).strip()
    if not text:
        return np.zeros(0, dtype=np.int64)
    return np.array([int(t) for t in text.split(";") if t.strip()], dtype=np.int64)


def load_results(folder: Union[str, os.PathLike]) -> Dict[str, Any]:
    """Read a results folder (``deformlab run``'s ``ROOT/<name>/``) into pandas.

    ``cases``' key point columns (``keypoints``, ``target_keypoints``) hold
    int64 arrays. Returns ``{"cases": DataFrame, "summary": DataFrame, "curves": DataFrame,
    "manifest": dict, "timings": DataFrame, "timing_summary": DataFrame,
    "runs": dict}`` (a table missing from the folder is ``None``). The
    timings (``seconds_*`` columns per case and summarised) and the log of
    invocations (``runs``) are the volatile files of ``timings/``: they
    differ between two runs of one config, everything else does not. Needs
    pandas (``pip install deformlab[results]``): ``ImportError`` otherwise.
    """
    try:
        import pandas as pd
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("load_results needs pandas: pip install pandas") from e
    folder = os.fspath(folder)
    if not os.path.isdir(folder):
        raise ValueError(f"folder: {folder} is not a folder")
    out: Dict[str, Any] = {}
    for name in ("cases", "summary", "curves"):
        p = os.path.join(folder, f"{name}.csv")
        out[name] = pd.read_csv(p) if os.path.exists(p) else None
    if out["cases"] is not None:
        # Key points as integer arrays (the CSV writes "4663;4835").
        for col in ("keypoints", "target_keypoints"):
            if col in out["cases"].columns:
                out["cases"][col] = out["cases"][col].map(_index_array)
    out["manifest"] = _read_json(os.path.join(folder, "manifest.json"))
    timings = os.path.join(folder, "timings")
    for key, name in (("timings", "cases.csv"), ("timing_summary", "summary.csv")):
        p = os.path.join(timings, name)
        out[key] = pd.read_csv(p) if os.path.exists(p) else None
    out["runs"] = _read_json(os.path.join(timings, "runs.json"))
    if all(out[k] is None for k in ("cases", "summary", "curves", "manifest")):
        raise ValueError(f"folder: {folder} holds no results (no cases.csv, summary.csv, curves.csv nor manifest.json)")
    return out
