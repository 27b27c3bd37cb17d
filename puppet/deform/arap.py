"""As-rigid-as-possible deformation in 2D (Sorkine & Alexa 2007, per-vertex "spokes").

Energy, with ``e_ij = v_i - v_j`` (rest) and ``u_ij = u_i - u_j`` (deformed)::

    E(U) = sum_i min_{R_i in SO(2)} sum_{j in N(i)} w_ij |u_ij - R_i e_ij|^2

Local step: for all cells at once, ``S_i = sum_j w_ij e_ij u_ij^T`` and the best
rotation has angle ``atan2(S01 - S10, S00 + S11)``; both sums are one sparse product
``C @ U`` with a precomputed ``C`` (2n, n).
Global step: ``L X = K Z - L_fb (bc - V_b)`` on the free vertices, for the displacement
``X = U - V`` (zero right-hand side at rest, so rest pins give back the rest mesh
exactly), where ``Z`` stacks ``(cos - 1, sin)`` of the rotations and ``K`` (nf, 2n) is
precomputed; one sparse product and one solve with the single Cholesky factor of
``L_ff`` for both coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from puppet.deform.mls import mls_object_space
from puppet.geom.geodesic import connected_components, geodesic_distances
from puppet.geom.laplacian import cotangent_weights, laplacian_from_weights, uniform_weights

__all__ = ["ArapData", "arap_precompute", "arap_solve", "arap_energy", "FACTORIZATIONS"]

#: Number of sparse factorisations done by this module (a drag must not add any).
FACTORIZATIONS = 0

SOLVERS = ("cholespy", "splu")


class _CholespyFactor:
    """CHOLMOD (supernodal, AMD/METIS ordering) Cholesky factor via cholespy."""

    kind = "cholespy"

    def __init__(self, A: sp.csc_matrix):
        import cholespy

        A = sp.csc_matrix(A)
        self.n = A.shape[0]
        self._solver = cholespy.CholeskySolverD(
            self.n, A.indptr.astype(np.int32), A.indices.astype(np.int32),
            A.data.astype(np.float64), cholespy.MatrixType.CSC)

    def solve(self, B: np.ndarray) -> np.ndarray:
        B = np.ascontiguousarray(B, dtype=np.float64)
        X = np.empty_like(B)
        self._solver.solve(B, X)
        return X


class _SpluFactor:
    """SuperLU factor (scipy), symmetric mode with a minimum-degree ordering on A+A^T."""

    kind = "splu"

    def __init__(self, A: sp.csc_matrix):
        self.n = A.shape[0]
        self._lu = spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A",
                             diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def solve(self, B: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(B, dtype=np.float64))


def _factorize(A: sp.spmatrix, solver: str):
    """Factorise the SPD matrix A once; cholespy first, SuperLU if that fails."""
    global FACTORIZATIONS
    FACTORIZATIONS += 1
    A = sp.csc_matrix(A)
    if solver == "cholespy":
        try:
            return _CholespyFactor(A)
        except (ValueError, RuntimeError, ImportError):
            pass  # e.g. "Matrix is not positive definite": try LU below
    try:
        return _SpluFactor(A)
    except RuntimeError as err:  # exactly singular
        raise ValueError(f"ARAP system is singular ({err}); degenerate triangles?") from err


@dataclass(eq=False)
class ArapData:
    """Everything ARAP needs that depends only on the mesh and the set of pins.

    Attributes
    ----------
    V : (n, 2) float
        Rest positions.
    F : (m, 3) int
        Triangles.
    b : (k,) int
        Pinned vertex indices (hard constraints).
    weights : str
        ``"cotangent"`` or ``"uniform"``.
    alpha : float
        Exponent of the MLS initial guess weights.
    W : (n, n) csr
        Symmetric edge weights.
    L : (n, n) csr
        ``diag(W 1) - W``.
    free : (nf,) int
        Vertices solved for.
    held : (nh,) int
        Vertices of connected components without any pin: kept at rest.
    C : (2n, n) csr
        ``C @ U`` gives the per-cell covariance sums ``[S00 + S11 | S01 - S10]``.
    K : (nf, 2n) csr
        Maps stacked rotations ``[[cos-1, sin], [-sin, cos-1]]`` to the right-hand side.
    L_fb : (nf, k) csr
        Coupling of the free rows to the pinned columns.
    factor : object or None
        The one factorisation of ``L[free][:, free]`` (``factor.kind`` names it).
    D : (k, n) float
        Geodesic (edge-path) distances from the pins, for the MLS initial guess.
    ei, ej : (2e,) int
        Directed edges (both directions) of the cells; ``ew`` their weights and
        ``ev`` (2e, 2) the rest edge vectors ``V[ei] - V[ej]``.
    """

    V: np.ndarray
    F: np.ndarray
    b: np.ndarray
    weights: str
    alpha: float
    W: sp.csr_matrix
    L: sp.csr_matrix
    free: np.ndarray
    held: np.ndarray
    C: sp.csr_matrix
    K: sp.csr_matrix
    L_fb: sp.csr_matrix
    factor: object | None
    D: np.ndarray
    ei: np.ndarray = field(repr=False)
    ej: np.ndarray = field(repr=False)
    ew: np.ndarray = field(repr=False)
    ev: np.ndarray = field(repr=False)

    @property
    def n(self) -> int:
        return self.V.shape[0]


def _check_inputs(V, F, b):
    V = np.array(V, dtype=np.float64, order="C")
    if V.ndim != 2 or V.shape[1] != 2:
        raise ValueError(f"V must have shape (n, 2), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("V must be finite")
    n = V.shape[0]
    F = np.asarray(F)
    if F.size == 0:
        F = np.zeros((0, 3), dtype=np.int64)
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise ValueError(f"F must be an integer array of shape (m, 3), got {F.shape} {F.dtype}")
    F = F.astype(np.int64)
    if len(F) and (F.min() < 0 or F.max() >= n):
        raise ValueError("F refers to a vertex index out of range")
    b = np.asarray(b)
    if b.size == 0:
        b = np.zeros(0, dtype=np.int64)
    if not np.issubdtype(b.dtype, np.integer):
        raise ValueError(f"b must hold integer vertex indices, got dtype {b.dtype}")
    b = b.astype(np.int64).reshape(-1)
    if len(b) and (b.min() < 0 or b.max() >= n):
        raise ValueError("b refers to a vertex index out of range")
    if len(np.unique(b)) != len(b):
        raise ValueError("b has repeated vertex indices")
    return V, F, b


def _cell_operators(V, W, free):
    """Covariance operator C (2n, n), rotation->rhs operator K (nf, 2n), edge lists."""
    n = V.shape[0]
    Wc = W.tocoo()
    ei, ej, ew = Wc.row.astype(np.int64), Wc.col.astype(np.int64), Wc.data
    ev = V[ei] - V[ej]
    blocks = []
    for c in range(2):
        we = ew * ev[:, c]
        Cc = sp.coo_matrix((np.concatenate([-we, we]), (np.concatenate([ei, ei]),
                            np.concatenate([ej, ei]))), shape=(n, n))
        blocks.append(Cc)
    C = sp.vstack(blocks, format="csr")
    C.sum_duplicates()
    K = (0.5 * C.T).tocsr()[free]
    return C, K, ei, ej, ew, ev


def arap_precompute(V, F, b, *, weights: str = "cotangent", alpha: float = 1.0,
                    solver: str = "cholespy") -> ArapData:
    """Prepare ARAP for a mesh and a set of pinned vertices (factorises once).

    Parameters
    ----------
    V : (n, 2) float
        Rest vertex positions.
    F : (m, 3) int
        Triangles.
    b : (k,) int
        Pinned vertex indices, distinct (may be empty: everything stays at rest).
    weights : {"cotangent", "uniform"}
        Edge weights of the cells.
    alpha : float
        Weight exponent of the MLS initial guess used by :func:`arap_solve`.
    solver : {"cholespy", "splu"}
        Factoriser of the free block; "cholespy" falls back to SuperLU if CHOLMOD
        refuses the matrix (e.g. not positive definite).

    Returns
    -------
    data : ArapData
        Vertices of connected components that contain no pin are held at rest.
    """
    if weights not in ("cotangent", "uniform"):
        raise ValueError(f"weights must be 'cotangent' or 'uniform', got {weights!r}")
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    V, F, b = _check_inputs(V, F, b)
    n = V.shape[0]
    W = cotangent_weights(V, F) if weights == "cotangent" else uniform_weights(V, F)
    L = laplacian_from_weights(W)
    ncomp, labels = connected_components(n, F)
    has_pin = np.zeros(ncomp, dtype=bool)
    has_pin[labels[b]] = True
    held = np.flatnonzero(~has_pin[labels])
    known = np.zeros(n, dtype=bool)
    known[b] = True
    known[held] = True
    free = np.flatnonzero(~known)
    L_f = L[free]
    factor = _factorize(L_f[:, free], solver) if len(free) else None
    C, K, ei, ej, ew, ev = _cell_operators(V, W, free)
    return ArapData(V=V, F=F, b=b, weights=weights, alpha=float(alpha), W=W, L=L,
                    free=free, held=held, C=C, K=K, L_fb=L_f[:, b].tocsr(), factor=factor,
                    D=geodesic_distances(V, F, b), ei=ei, ej=ej, ew=ew, ev=ev)


def _rotations(data: ArapData, U: np.ndarray):
    """Best rotation of every cell: (cos - 1, sin), each (n,)."""
    n = data.n
    CU = data.C @ U
    a = CU[:n, 0] + CU[n:, 1]  # S00 + S11
    s = CU[:n, 1] - CU[n:, 0]  # S01 - S10
    r = np.hypot(a, s)
    ok = r > 0
    r = np.where(ok, r, 1.0)
    # cos - 1 without cancellation near the identity
    cm1 = np.where(a >= 0, -(s * s) / (r * (np.abs(a) + r)), a / r - 1.0)
    return np.where(ok, cm1, 0.0), np.where(ok, s / r, 0.0)


def _check_bc(data: ArapData, bc) -> np.ndarray:
    bc = np.asarray(bc, dtype=np.float64)
    if bc.size == 0 and len(data.b) == 0:
        return np.zeros((0, 2))
    if bc.shape != (len(data.b), 2):
        raise ValueError(f"bc must have shape (k, 2) = {(len(data.b), 2)}, got {bc.shape}")
    if not np.isfinite(bc).all():
        raise ValueError("bc must be finite")
    return bc


def arap_solve(data: ArapData, bc, *, iterations: int = 20, U0=None,
               callback: Callable[[int, np.ndarray], None] | None = None) -> np.ndarray:
    """Deform the mesh so that the pins reach their targets, as rigidly as possible.

    Parameters
    ----------
    data : ArapData
        From :func:`arap_precompute`; never refactorised here.
    bc : (k, 2) float
        Targets of the pinned vertices ``data.b``.
    iterations : int
        Number of local/global iterations.
    U0 : (n, 2) float, optional
        Initial guess. ``None``: object-space rigid MLS over the geodesic distances
        from the pins (``mls_object_space(V, data.D, bc, V[b], kind="rigid")``), so
        the result depends only on ``bc`` (trajectory invariance).
    callback : callable, optional
        ``callback(iteration, U)`` after each iteration with a copy of the iterate.

    Returns
    -------
    U : (n, 2) float
        Deformed positions; ``U[b] == bc`` exactly, held components at rest.
    """
    bc = _check_bc(data, bc)
    V, b = data.V, data.b
    if U0 is None:
        U = mls_object_space(V, data.D, bc, V[b], kind="rigid", alpha=data.alpha)
    else:
        U = np.array(U0, dtype=np.float64, order="C")
        if U.shape != V.shape:
            raise ValueError(f"U0 must have shape {V.shape}, got {U.shape}")
    U[data.held] = V[data.held]
    U[b] = bc
    if data.factor is None:
        return U
    free = data.free
    Vf = V[free]
    rhs_b = data.L_fb @ (bc - V[b]) if len(b) else 0.0
    n = data.n
    Z = np.empty((2 * n, 2))
    for it in range(int(iterations)):
        cm1, s = _rotations(data, U)
        Z[:n, 0] = cm1
        Z[:n, 1] = s
        Z[n:, 0] = -s
        Z[n:, 1] = cm1
        X = data.factor.solve(data.K @ Z - rhs_b)
        U[free] = Vf + X
        if callback is not None:
            callback(it, U.copy())
    return U


def arap_energy(data: ArapData, U) -> float:
    """Sorkine-Alexa ARAP energy of a deformation, with the optimal cell rotations.

    Parameters
    ----------
    data : ArapData
    U : (n, 2) float
        Deformed positions.

    Returns
    -------
    E : float
        ``sum_i sum_j w_ij |(u_i - u_j) - R_i (v_i - v_j)|^2`` (each undirected edge
        counted once in each of its two cells), 0 for a rigid motion.
    """
    U = np.asarray(U, dtype=np.float64)
    if U.shape != data.V.shape:
        raise ValueError(f"U must have shape {data.V.shape}, got {U.shape}")
    cm1, s = _rotations(data, U)
    c, s = (cm1 + 1.0)[data.ei], s[data.ei]
    ex, ey = data.ev[:, 0], data.ev[:, 1]
    du = U[data.ei] - U[data.ej]
    rx = du[:, 0] - (c * ex - s * ey)
    ry = du[:, 1] - (s * ex + c * ey)
    return float(np.sum(data.ew * (rx * rx + ry * ry)))
