"""As-rigid-as-possible deformation in 2D (Sorkine & Alexa 2007, per-vertex "spokes").

Energy, with ``e_ij = v_i - v_j`` (rest) and ``u_ij = u_i - u_j`` (deformed)::

    E(U) = sum_i min_{R_i in SO(2)} sum_{j in N(i)} w_ij |u_ij - R_i e_ij|^2

The solver writes points as complex numbers ``x + iy``, rotations as unit complex
numbers ``rho`` and works on the displacement ``x = u - v`` (zero at rest, so rest
pins give back the rest mesh exactly).
Local step: ``q = S0 + S x``, i.e. ``q_i = sum_j w_ij conj(e_ij) u_ij``, which is
``(S00 + S11) + i (S01 - S10)`` of the cell's 2x2 covariance; ``rho_i = q_i / |q_i|``.
Global step: ``L_ff x_f = R (rho - 1) - L_fb (bc - v_b)`` with
``(R sigma)_i = sum_j w_ij / 2 (sigma_i + sigma_j) e_ij``.
``L``, ``S`` and ``R`` share one sparsity pattern, built once from the triangles'
corners together with the edge lists and the edge-length graph of the geodesic
distances. An iteration is two complex sparse products and one solve per coordinate
with the single factor of ``L_ff``.

Factoriser: QDLDL (``qdldl`` wheel, AMD ordering) by default. It factorises 2.5-3x
faster than CHOLMOD as cholespy configures it (the ordering analysis dominates there),
solves about 2x slower, and releases the GIL: the factorisation runs on a second
thread while the operators and the geodesic distances are built, and on large meshes
the two coordinates are solved on two threads (``THREADS``, ``PARALLEL_MIN_FREE``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp

from puppet.deform import factor
from puppet.deform.mls import DistanceWeights, distance_weights, mls_object_space
from puppet.deform.modes import mode_operators, mode_rhs
from puppet.deform.threads import blas_capped, one_blas_thread
from puppet.geom.laplacian import cotangent_weights, spring_weights, uniform_weights
from puppet.geom.mesh import check_mesh

__all__ = ["ArapData", "arap_precompute", "arap_solve", "arap_energy", "WEIGHTS"]

#: Edge weights ``arap_precompute`` accepts.
WEIGHTS = ("cotangent", "cotangent-raw", "uniform")

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
        ``"cotangent"`` (clamped at 0), ``"cotangent-raw"`` or ``"uniform"``.
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
        ``C @ U`` gives the per-cell covariance sums ``[S00 + S11 | S01 - S10]``
        (real form of ``S``; built on first access, the solver does not use it).
    K : (nf, 2n) csr
        Maps stacked rotations ``[[cos-1, sin], [-sin, cos-1]]`` to the right-hand side
        (real form of ``R``; built on first access, the solver does not use it).
    L_fb : (nf, k) csr
        Coupling of the free rows to the pinned columns.
    factor : object or None
        The one factorisation of ``L[free][:, free]`` (``factor.kind`` names it).
    D : (k, n) float
        Geodesic (edge-path) distances from the pins, for the MLS initial guess.
    ei, ej : (2e,) int
        Directed edges (both directions) of the cells; ``ew`` their weights and
        ``ev`` (2e, 2) the rest edge vectors ``V[ei] - V[ej]``.
    S0 : (n,) float
        ``sum_j w_ij |e_ij|^2``: the covariance sums at rest.
    S : (n, n) complex csr
        ``S0 + S @ x`` (``x = u - v`` as complex numbers) gives every cell's
        ``(S00 + S11) + i (S01 - S10)``; ``S_f``, ``S_b`` its free and pinned columns.
    R : (nf, n) complex csr
        ``R @ (rho - 1)`` is the right-hand side of the free rows for cell rotations
        ``rho`` (unit complex numbers), as ``x + iy`` (times the cell weights ``k``).
    k : (n,) float or None
        Cell weights (painted stiffness); None = all 1. ``L`` then has the edge weights
        ``w_ij (k_i + k_j) / 2`` while ``W``, ``S``, ``ew`` keep the plain ``w_ij``.
    mix : (n, 3) float or None
        Per-cell weights of the rigid, similar and affine energies
        (:mod:`puppet.deform.modes`); None = rigid everywhere.
    modes : ModeOps or None
        The extra operators the non-rigid modes need (built when ``mix`` is given).
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
    C: sp.csr_matrix | None = field(repr=False)
    K: sp.csr_matrix | None = field(repr=False)
    L_fb: sp.csr_matrix
    factor: object | None
    D: np.ndarray
    ei: np.ndarray = field(repr=False)
    ej: np.ndarray = field(repr=False)
    ew: np.ndarray = field(repr=False)
    ev: np.ndarray = field(repr=False)
    S0: np.ndarray | None = field(default=None, repr=False)
    S: sp.csr_matrix | None = field(default=None, repr=False)
    S_f: sp.csr_matrix | None = field(default=None, repr=False)
    S_b: sp.csr_matrix | None = field(default=None, repr=False)
    R: sp.csr_matrix | None = field(default=None, repr=False)
    k: np.ndarray | None = field(default=None, repr=False)
    mix: np.ndarray | None = field(default=None, repr=False)
    modes: object | None = field(default=None, repr=False)

    def __post_init__(self):
        for name in ("C", "K"):
            if self.__dict__[name] is None:
                del self.__dict__[name]  # built on first access (__getattr__)

    def __getattr__(self, name):
        if name in ("C", "K"):
            self.C, self.K = _cell_operators(self.V, self.W, self.free)[:2]
            if self.k is not None:  # stiffened cells weigh more on the right-hand side
                self.K = (self.K @ sp.diags(np.concatenate([self.k, self.k]))).tocsr()
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def n(self) -> int:
        return self.V.shape[0]

    def mls_weights(self) -> DistanceWeights:
        """The weights of the MLS initial guess over ``D`` (they depend on the mesh and the
        pins, never on a pose): computed on first use, then kept."""
        w = self.__dict__.get("_mls_weights")
        if w is None:
            w = self.__dict__["_mls_weights"] = distance_weights(self.D, alpha=self.alpha)
        return w


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


def _edge_weights(V, F, weights: str) -> sp.csr_matrix:
    """Symmetric edge weights W (n, n) with every mesh edge stored (``puppet.geom.laplacian``).

    Obtuse triangles beside constrained edges (links, thin parts) give negative cotangent
    weights; a cell whose weights sum negative would fit a 180-degree "rotation" even at
    rest. "cotangent" clamps them at 0, which keeps every cell well posed and L an
    M-matrix (meshes without negative weights are unchanged); "cotangent-raw" keeps them.
    """
    if weights == "uniform":
        return uniform_weights(V, F)
    return cotangent_weights(V, F, clamp=weights == "cotangent")


class _Pattern:
    """The sparsity of ``L`` (W's plus the diagonal), shared by L, S and R."""

    def __init__(self, W: sp.csr_matrix):
        n = W.shape[0]
        self.n = n
        deg = np.diff(W.indptr)
        wrows = np.repeat(np.arange(n), deg)
        below = np.zeros(len(W.indices) + 1, dtype=np.int64)
        np.cumsum(W.indices < wrows, out=below[1:])
        nbelow = below[W.indptr[1:]] - below[W.indptr[:-1]]
        self.indptr = W.indptr + np.arange(n + 1)
        self.diag = self.indptr[:-1] + nbelow  # position of (i, i) in the data arrays
        self.off = np.ones(len(W.indices) + n, dtype=bool)
        self.off[self.diag] = False  # positions of W's entries
        self.indices = np.empty(len(W.indices) + n, dtype=W.indices.dtype)
        self.indices[self.off] = W.indices
        self.indices[self.diag] = np.arange(n)
        self.rows = np.repeat(np.arange(n), deg + 1)
        self.wrows = wrows

    def data(self, off, diag, dtype=np.float64) -> np.ndarray:
        out = np.empty(len(self.indices), dtype=dtype)
        out[self.off] = off
        out[self.diag] = diag
        return out

    def matrix(self, data) -> sp.csr_matrix:
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def block(self, data, rowmap, colmap, shape) -> sp.csr_matrix:
        """Rows r with rowmap[r] >= 0 and columns c with colmap[c] >= 0, renumbered."""
        keep = np.ones(len(data), dtype=bool) if rowmap is None else rowmap[self.rows] >= 0
        if colmap is not None:
            keep &= colmap[self.indices] >= 0
        r = self.rows[keep] if rowmap is None else rowmap[self.rows[keep]]
        c = self.indices[keep] if colmap is None else colmap[self.indices[keep]]
        indptr = np.zeros(shape[0] + 1, dtype=np.int64)
        np.cumsum(np.bincount(r, minlength=shape[0]), out=indptr[1:])
        return sp.csr_matrix((data[keep], c, indptr), shape=shape)


@blas_capped
def arap_precompute(V, F, b, *, weights: str = "cotangent", alpha: float = 1.0,
                    solver: str = "qdldl", stiffness=None, mix=None, couple=None) -> ArapData:
    """Prepare ARAP for a mesh and a set of pinned vertices (factorises once).

    Parameters
    ----------
    V : (n, 2) float
        Rest vertex positions.
    F : (m, 3) int
        Triangles.
    b : (k,) int
        Pinned vertex indices, distinct (may be empty: everything stays at rest).
    weights : {"cotangent", "cotangent-raw", "uniform"}
        Edge weights of the cells. "cotangent" clamps negative cotangent weights
        (obtuse triangles) at 0, which keeps every cell well posed; "cotangent-raw"
        keeps them as they are, like libigl's ``arap_precomputation`` (SPOKES), whose
        results it reproduces from the same start; it may leave the free block
        indefinite (then factorised by SuperLU).
    alpha : float
        Weight exponent of the MLS initial guess used by :func:`arap_solve`.
    solver : {"qdldl", "cholespy", "splu"}
        Factoriser of the free block. "qdldl" falls back to cholespy when the wheel is
        missing; "cholespy" to SuperLU if CHOLMOD refuses the matrix (e.g. not
        positive definite). QDLDL and SuperLU factorise on a second thread while the
        operators and the geodesic distances ``D`` are built (they release the GIL;
        cholespy does not, so it runs on the caller's thread).
    stiffness : (n,) float, optional
        Weight ``k_i > 0`` of each cell's energy (painted rigidity; see
        :func:`puppet.deform.modes.stiffness_from_grey`). None: all 1, exactly as before.
    mix : (n, 3) float, optional
        Rigid / similar / affine weights of each cell (:func:`puppet.deform.modes.mode_mix`).
        None: rigid everywhere (the plain ARAP loop).
    couple : tuple ((p, 2) int, (p,) float), optional
        Springs ``kappa |u_a - u_b|^2`` between vertices at the same rest point (links of
        strength below 1): extra edges of rest length 0, so they enter ``L`` only.

    Returns
    -------
    data : ArapData
        Vertices of connected components that contain no pin are held at rest.
    """
    if weights not in WEIGHTS:
        raise ValueError(f"weights must be one of {WEIGHTS}, got {weights!r}")
    if solver not in factor.SOLVERS:
        raise ValueError(f"solver must be one of {factor.SOLVERS}, got {solver!r}")
    V, F, b = check_mesh(V, F, b)
    W = _edge_weights(V, F, weights)
    if couple is not None and len(couple[0]):  # springs: edges of rest length 0
        W = (W + spring_weights(len(V), *couple)).tocsr()
        W.sort_indices()
    P = _Pattern(W)
    k = None if stiffness is None else np.asarray(stiffness, np.float64).reshape(len(V))
    wl = W.data if k is None else W.data * 0.5 * (k[P.wrows] + k[W.indices])
    L = P.matrix(P.data(-wl, np.bincount(P.wrows, weights=wl, minlength=len(V))))
    free, held, fmap, bmap = _free_vertices(W, b)
    nf = len(free)
    A = P.block(L.data, fmap, fmap, (nf, nf))
    # QDLDL and SuperLU release the GIL; cholespy holds it (a thread would only add contention)
    threaded = factor.THREADS and nf > 0 and solver != "cholespy"
    worker = factor.SolveThread(lambda A: factor.factorize(A, solver), threaded=threaded)
    try:
        if nf:  # symmetric: its csr arrays are its csc arrays
            worker.submit(sp.csc_matrix((A.data, A.indices, A.indptr), shape=A.shape))
        data = _arap_data(V, F, b, weights, alpha, W, P, L, free, held, fmap, bmap)
        if k is not None:
            data.k = k
            data.R = (data.R @ sp.diags(k)).tocsr()
        if mix is not None:
            data.mix = np.asarray(mix, np.float64).reshape(len(V), 3)
            data.modes = mode_operators(data, P, fmap, bmap)
        data.factor = worker.result() if nf else None  # built meanwhile
    finally:
        worker.close()
    return data


def _free_vertices(W, b):
    """free, held (components without a pin) and the maps vertex -> free / pin index."""
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    n = W.shape[0]
    graph = sp.csr_matrix((np.ones(len(W.indices)), W.indices, W.indptr), shape=(n, n))
    ncomp, labels = csgraph.connected_components(graph, directed=False)
    has_pin = np.zeros(ncomp, dtype=bool)
    has_pin[labels[b]] = True
    held = np.flatnonzero(~has_pin[labels])
    fmap = np.full(n, -1, dtype=np.int64)
    fmap[b] = -2
    fmap[held] = -3
    free = np.flatnonzero(fmap == -1)
    fmap[free] = np.arange(len(free))
    bmap = np.full(n, -1, dtype=np.int64)
    bmap[b] = np.arange(len(b))
    return free, held, fmap, bmap


def _arap_data(V, F, b, weights, alpha, W, P, L, free, held, fmap, bmap) -> ArapData:
    """Operators, edge lists and geodesic distances (while the factorisation runs)."""
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    n, nf, k = len(V), len(free), len(b)
    z = V[:, 0] + 1j * V[:, 1]
    e = z[P.wrows] - z[W.indices]  # e_ij = v_i - v_j on W's entries
    m = W.data * e.conj()  # w_ij conj(e_ij)
    h = np.bincount(P.wrows, weights=m.real, minlength=n) \
        + 1j * np.bincount(P.wrows, weights=m.imag, minlength=n)
    S = P.matrix(P.data(-m, h, np.complex128))
    R = P.block(P.data(0.5 * m.conj(), 0.5 * h.conj(), np.complex128), fmap, None, (nf, n))
    # springs join points at the same place: a tiny length keeps them edges of the graph
    length = sp.csr_matrix((np.maximum(np.abs(e), 1e-9), W.indices, W.indptr), shape=(n, n))
    D = csgraph.dijkstra(length, directed=True, indices=b).reshape(k, n) if k else np.zeros((0, n))
    return ArapData(
        V=V, F=F, b=b, weights=weights, alpha=float(alpha), W=W, L=L, free=free, held=held,
        C=None, K=None, L_fb=P.block(L.data, fmap, bmap, (nf, k)), factor=None, D=D,
        ei=P.wrows, ej=W.indices.astype(np.int64), ew=W.data, ev=np.stack([e.real, e.imag], 1),
        S0=np.bincount(P.wrows, weights=W.data * (e.real**2 + e.imag**2), minlength=n),
        S=S, S_f=P.block(S.data, None, fmap, (n, nf)), S_b=P.block(S.data, None, bmap, (n, k)),
        R=R)


def _rotation_minus_one(q: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``rho - 1 = q / |q| - 1`` into complex ``out``: (cos - 1) + i sin, 0 where q == 0.

    Exactly 0 at rest (q real and positive); elsewhere cos - 1 has the absolute error of
    cos itself (~1e-16), which is all the global step needs.
    """
    r = np.abs(q)
    if not r.all():
        zero = r == 0
        q = np.where(zero, 1.0, q)
        r[zero] = 1.0
    np.divide(q.real, r, out=out.real)
    np.divide(q.imag, r, out=out.imag)
    out.real -= 1.0
    return out


def _rotations(data: ArapData, U: np.ndarray):
    """Best rotation of every cell: (cos - 1, sin), each (n,)."""
    X = np.asarray(U, dtype=np.float64) - data.V
    q = data.S0 + data.S @ (X[:, 0] + 1j * X[:, 1])
    rho = _rotation_minus_one(q, np.empty_like(q))
    return rho.real.copy(), rho.imag.copy()


def _check_bc(data: ArapData, bc) -> np.ndarray:
    bc = np.asarray(bc, dtype=np.float64)
    if bc.size == 0 and len(data.b) == 0:
        return np.zeros((0, 2))
    if bc.shape != (len(data.b), 2):
        raise ValueError(f"bc must have shape (k, 2) = {(len(data.b), 2)}, got {bc.shape}")
    if not np.isfinite(bc).all():
        raise ValueError("bc must be finite")
    return bc


def _rigid_rhs(data: ArapData, xb):
    """``rhs(x_f)`` of the global step for the best rotations of ``x_f`` (pins at ``xb``)."""
    q0 = data.S0 + data.S_b @ xb  # pinned displacements are fixed
    rb = data.L_fb @ xb
    sigma = np.empty(data.n, dtype=np.complex128)

    def rhs_of(xf):
        q = data.S_f @ xf
        q += q0
        rhs = data.R @ _rotation_minus_one(q, sigma)
        rhs -= rb
        return rhs
    return rhs_of


def arap_solve(data: ArapData, bc, *, iterations: int = 20, U0=None,
               callback: Callable[[int, np.ndarray], None] | None = None, held=None, scale=None) -> np.ndarray:
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
    held : tuple ((h,) int, (h,) complex), optional
        Cells whose map is held at a rotation (unit complex numbers) instead of fitted;
        only with ``data.mix`` (the rigid loop holds cells in :mod:`puppet.deform.rotate`).
    scale : (lo, hi), optional
        Bounds of the scale of the cells in mode ``similar`` (their fit is the best
        similarity whose scale lies in [lo, hi]); None: unbounded.

    Returns
    -------
    U : (n, 2) float
        Deformed positions; ``U[b] == bc`` exactly, held components at rest; always
        finite (an iteration whose solve breaks down ends the loop at the last finite
        iterate). Work: ``iterations`` units of :mod:`puppet.deform.budget` plus the
        initial guess.
    """
    with one_blas_thread():  # a context, not the decorator: no extra frame in every drag's stack
        return _arap_solve(data, bc, iterations, U0, callback, held, scale)


def initial_positions(data: ArapData, bc: np.ndarray, U0=None) -> np.ndarray:
    """The start of the iteration (a new array): ``U0`` (non-finite rows at rest) or the
    MLS guess; held components at rest and the pins on their (checked) targets ``bc``."""
    V, b = data.V, data.b
    if U0 is None:
        U = mls_object_space(V, data.D, bc, V[b], kind="rigid", alpha=data.alpha, weights=data.mls_weights())
    else:
        U = np.array(U0, dtype=np.float64, order="C")
        if U.shape != V.shape:
            raise ValueError(f"U0 must have shape {V.shape}, got {U.shape}")
    lost = ~np.isfinite(U).all(axis=1)
    U[lost] = V[lost]
    U[data.held] = V[data.held]
    U[b] = bc
    return U


def _arap_solve(data, bc, iterations, U0, callback, held, scale) -> np.ndarray:
    """The body of :func:`arap_solve`, run under one BLAS thread."""
    bc = _check_bc(data, bc)
    V, b = data.V, data.b
    U = initial_positions(data, bc, U0)
    if data.factor is None or int(iterations) <= 0:
        return U
    free = data.free
    nf = len(free)
    xf = (U[free, 0] - V[free, 0]) + 1j * (U[free, 1] - V[free, 1])
    xb = (bc[:, 0] - V[b, 0]) + 1j * (bc[:, 1] - V[b, 1])
    rhs_of = _rigid_rhs(data, xb)
    if data.mix is not None:  # other modes (puppet.deform.modes): another local step
        rhs_of = mode_rhs(data, xb, held, scale)
    elif held is not None:
        raise ValueError("held cells need data.mix (see puppet.deform.rotate for rigid ARAP)")
    solve, close = factor.pair_solver(data.factor, nf, int(iterations))
    try:
        for it in range(int(iterations)):
            x_new = solve(rhs_of(xf))
            if not np.isfinite(x_new).all():  # a breakdown (e.g. indefinite raw weights):
                break  # keep the last finite iterate
            xf = x_new
            if callback is not None:
                U[free, 0], U[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
                callback(it, U.copy())
    finally:
        close()
    U[free, 0], U[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
    return U


@blas_capped
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
