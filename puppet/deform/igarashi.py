"""Two-step as-rigid-as-possible shape manipulation (Igarashi, Moscovich & Hughes 2005).

The two closed-form steps of the paper ("step one: scale-free construction", "step two:
scale adjustment"), in the edge-based form of Igarashi & Igarashi, "Implementing
As-Rigid-As-Possible Shape Manipulation and Surface Flattening" (JGT 14(1), 2009),
with hard pins. Both steps are linear least squares whose matrices depend only on the
mesh and the pin set, so each is factorised once in :func:`igarashi_precompute`, and a
drag (:func:`igarashi_solve`) is two back-substitutions plus a few sparse products.

Notation. Edge ``k = (i, j)`` has rest vector ``e_k = v_j - v_i`` and deformed vector
``u_j - u_i``. Its *edge neighbourhood* ``N_k`` is ``{i, j}`` plus the vertex opposite
the edge in every triangle containing it: ``{i, j, l, r}`` inside the mesh, ``{i, j, l}``
on the boundary. A 2D similarity (rotation times uniform scale) is ``T(a, b) = [[a, -b],
[b, a]]``; ``I`` is the identity.

Similarity fit of an edge neighbourhood (the paper's ``G_k`` matrices). The paper fits
``(a, b, t)`` minimising ``sum_{m in N_k} |T(a, b) v_m + t - u_m|^2`` with the normal
equations of a ``(2|N_k|, 4)`` matrix ``G_k``. Centring on the neighbourhood centroid
``c_k`` decouples the translation and makes ``G_k^T G_k`` diagonal; with ``p_m = v_m - c_k``
and ``S_k = sum_m |p_m|^2``::

    a_k = sum_m  p_m . u_m        / S_k
    b_k = sum_m (p_m x u_m)       / S_k        (x: 2D cross product, p_x u_y - p_y u_x)

(the centroid of ``u`` drops out because ``sum_m p_m = 0``). Both are linear in ``U``:
``[a - 1; b] = Phi @ [X_x; X_y]`` for the displacement ``X = U - V``, with a sparse
``Phi`` (2e, 2n) built once; ``a = 1, b = 0`` exactly at rest.

Step 1 (similarity). ``E1(U) = sum_k |(u_j - u_i) - T(a_k(U), b_k(U)) e_k|^2``. The
residual of edge ``k`` is linear in ``U``; stacking both components of all edges gives
``H`` (2e, 2n) with ``H V = 0`` (x and y coupled through the similarity), so
``E1 = |H X|^2`` and ``A1 = H^T H``. Pins are eliminated: ``A1_ff X_f = -A1_fb X_b``.
A global similarity costs nothing, so the result follows the pins with edge
neighbourhoods that rotate *and scale*.

Step 2 (scale adjustment). From the step-1 result, every edge neighbourhood's similarity
``(a_k, b_k)`` is fitted again and normalised to a rotation ``R_k = T(a_k, b_k) / |(a_k,
b_k)|`` (identity when the fit vanishes). Then ``E2(U) = sum_k |(u_j - u_i) - R_k e_k|^2``
decouples x and y: with the edge-incidence matrix ``D`` (e, n), ``E2 = |D X - (R - I)e|^2``
and ``L = D^T D`` is the uniform (graph) Laplacian, whose free block is factorised once
and used for both coordinates: ``L_ff X_f = D_f^T (R - I)e - L_fb X_b``.

Working with displacements makes rest pins give back the rest mesh exactly (all
right-hand sides are exactly zero). Per component of the mesh: no pin -> held at rest;
one pin -> translated with it (a similarity about one point is not determined); two or
more pins -> solved.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from puppet.deform.arap import _check_bc
from puppet.deform.factor import SOLVERS
from puppet.deform.factor import factorize as _factorize
from puppet.deform.threads import blas_capped
from puppet.geom.geodesic import connected_components
from puppet.geom.mesh import check_mesh, edges

__all__ = ["IgarashiData", "igarashi_precompute", "igarashi_solve", "edge_neighbourhoods",
           "edge_similarities"]


@dataclass(eq=False)
class IgarashiData:
    """Everything the two-step solver needs that depends only on the mesh and the pins.

    Attributes
    ----------
    V : (n, 2) float
        Rest positions.
    F : (m, 3) int
        Triangles.
    b : (k,) int
        Pinned vertex indices (hard constraints).
    E : (e, 2) int
        Undirected edges ``(i, j)``, ``i < j``; ``ev`` (e, 2) their rest vectors
        ``V[j] - V[i]``.
    Phi : (2e, 2n) csr
        Similarity fit of the edge neighbourhoods: ``Phi @ [X_x; X_y] = [a - 1; b]``.
    D : (e, n) csr
        Edge incidence, ``(D U)_k = u_j - u_i``.
    free : (nf,) int
        Vertices solved for (components with at least two pins).
    held : (nh,) int
        Vertices of components without a pin: kept at rest.
    moved : (nt,) int
        Vertices of components with exactly one pin; ``moved_pin`` (nt,) is the position
        of that pin in ``b``: they follow its translation.
    A1_fb : (2nf, 2k) csr
        Step-1 coupling of the free unknowns ``[x_f; y_f]`` to the pinned ``[x_b; y_b]``.
    factor1 : object or None
        The one factorisation of the step-1 free block ``A1_ff`` (2nf, 2nf).
    Dt_f : (nf, e) csr
        ``D[:, free].T``: maps the per-edge targets to the step-2 right-hand side.
    L_fb : (nf, k) csr
        Step-2 (uniform Laplacian) coupling of free rows to pinned columns.
    factor2 : object or None
        The one factorisation of the step-2 free block ``L_ff`` (nf, nf).
    """

    V: np.ndarray
    F: np.ndarray
    b: np.ndarray
    E: np.ndarray
    ev: np.ndarray
    Phi: sp.csr_matrix
    D: sp.csr_matrix
    free: np.ndarray
    held: np.ndarray
    moved: np.ndarray
    moved_pin: np.ndarray
    A1_fb: sp.csr_matrix
    factor1: object | None
    Dt_f: sp.csr_matrix
    L_fb: sp.csr_matrix
    factor2: object | None

    @property
    def n(self) -> int:
        return self.V.shape[0]


def edge_neighbourhoods(F: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edges and their neighbourhoods (both end points and every opposite vertex).

    Parameters
    ----------
    F : (m, 3) int
        Triangles.
    n : int
        Number of vertices.

    Returns
    -------
    E : (e, 2) int
        Unique undirected edges, ``E[:, 0] < E[:, 1]`` (as :func:`puppet.geom.mesh.edges`).
    k : (p,) int
        Edge index of each (edge, vertex) membership, sorted.
    m : (p,) int
        Vertex of each membership: ``{i, j, l, r}`` for an interior edge, ``{i, j, l}``
        for a boundary edge (more on a non-manifold edge), each vertex once per edge.
    """
    E = edges(F)
    ne = len(E)
    if ne == 0:
        return E, np.zeros(0, np.int64), np.zeros(0, np.int64)
    key = E[:, 0] * n + E[:, 1]
    opp_k, opp_m = [], []
    for c in range(3):  # corner c is opposite the edge of the two other corners
        a, o = F[:, (c + 1) % 3], F[:, (c + 2) % 3]
        opp_k.append(np.searchsorted(key, np.minimum(a, o) * n + np.maximum(a, o)))
        opp_m.append(F[:, c])
    k = np.concatenate([np.arange(ne), np.arange(ne)] + opp_k)
    m = np.concatenate([E[:, 0], E[:, 1]] + opp_m)
    pair = np.unique(k * n + m)  # drops repeats from degenerate triangles; sorts by edge
    return E, pair // n, pair % n


def _similarity_fit(V: np.ndarray, E: np.ndarray, k: np.ndarray, m: np.ndarray) -> sp.csr_matrix:
    """``Phi`` (2e, 2n) with ``Phi @ [X_x; X_y] = [a - 1; b]`` per edge neighbourhood."""
    n, ne = V.shape[0], len(E)
    cnt = np.bincount(k, minlength=ne).astype(np.float64)
    cx = np.bincount(k, V[m, 0], minlength=ne) / cnt
    cy = np.bincount(k, V[m, 1], minlength=ne) / cnt
    px, py = V[m, 0] - cx[k], V[m, 1] - cy[k]
    S = np.bincount(k, px * px + py * py, minlength=ne)
    inv = np.divide(1.0, S, out=np.zeros(ne), where=S > 0)[k]  # S = 0: all coincide
    gx, gy = px * inv, py * inv
    # a - 1 = sum gx X_x + gy X_y;  b = sum gx X_y - gy X_x
    rows = np.concatenate([k, k, ne + k, ne + k])
    cols = np.concatenate([m, n + m, m, n + m])
    vals = np.concatenate([gx, gy, -gy, gx])
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * ne, 2 * n))


def _incidence(E: np.ndarray, n: int) -> sp.csr_matrix:
    ne = len(E)
    r = np.arange(ne)
    return sp.csr_matrix((np.r_[-np.ones(ne), np.ones(ne)], (np.r_[r, r], np.r_[E[:, 0], E[:, 1]])),
                         shape=(ne, n))


def _step1_matrix(D: sp.csr_matrix, ev: np.ndarray, Phi: sp.csr_matrix) -> sp.csr_matrix:
    """``A1 = H^T H`` with ``H = blockdiag(D, D) - [[ex, -ey], [ey, ex]] Phi`` (2e, 2n)."""
    ex, ey = sp.diags(ev[:, 0]), sp.diags(ev[:, 1])
    Te = sp.bmat([[ex, -ey], [ey, ex]], format="csr")  # [a; b] -> T(a, b) e_k, per edge
    H = (sp.block_diag([D, D], format="csr") - Te @ Phi).tocsr()
    return (H.T @ H).tocsr()


def _partition(n: int, F: np.ndarray, b: np.ndarray):
    """Split vertices by the number of pins of their component: 0 held, 1 moved, 2+ free."""
    ncomp, labels = connected_components(n, F)
    npin = np.bincount(labels[b], minlength=ncomp)
    pin_of_comp = np.full(ncomp, -1, np.int64)
    pin_of_comp[labels[b]] = np.arange(len(b))  # the only pin where npin == 1
    count = npin[labels]
    held = np.flatnonzero(count == 0)
    moved = np.flatnonzero(count == 1)
    moved_pin = pin_of_comp[labels[moved]]
    is_pin = np.zeros(n, bool)
    is_pin[b] = True
    keep = ~is_pin[moved]
    free = np.flatnonzero((count >= 2) & ~is_pin)
    return free, held, moved[keep], moved_pin[keep]


@blas_capped
def igarashi_precompute(V, F, b, *, solver: str = "cholespy") -> IgarashiData:
    """Build and factorise both steps of the two-step solver for a mesh and a pin set.

    Step 1 matrix ``A1 = H^T H`` (2n, 2n; x and y coupled), from the edge-neighbourhood
    similarity fits (see the module docstring), and step 2 matrix ``L = D^T D`` (the
    uniform Laplacian, n x n). Pins are hard constraints, eliminated; the free block of
    each matrix is factorised exactly once here and never in :func:`igarashi_solve`.

    Parameters
    ----------
    V : (n, 2) float
        Rest vertex positions.
    F : (m, 3) int
        Triangles.
    b : (k,) int
        Pinned vertex indices, distinct (may be empty: everything stays at rest).
    solver : {"cholespy", "splu"}
        Factoriser; "cholespy" falls back to SuperLU if CHOLMOD refuses the matrix.

    Returns
    -------
    data : IgarashiData

    Raises
    ------
    ValueError
        Bad shapes or indices, or a singular free block (e.g. degenerate triangles, or
        pieces of a component joined by a single vertex with no pin of their own).

    Notes
    -----
    Boundary edges have a three-vertex neighbourhood ``{i, j, l}``: the similarity fit
    is then over three points (still over-determined: 6 equations, 4 unknowns), so they
    need no special case. A component with a single pin only translates.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    V, F, b = check_mesh(V, F, b)
    n = V.shape[0]
    E, k, m = edge_neighbourhoods(F, n)
    ev = V[E[:, 1]] - V[E[:, 0]]
    Phi = _similarity_fit(V, E, k, m)
    D = _incidence(E, n)
    free, held, moved, moved_pin = _partition(n, F, b)
    f2, b2 = np.r_[free, n + free], np.r_[b, n + b]
    factor1 = factor2 = None
    A1 = _step1_matrix(D, ev, Phi)
    A1_f = A1[f2]
    L = (D.T @ D).tocsr()
    L_f = L[free]
    if len(free):
        try:
            factor1 = _factorize(A1_f[:, f2], solver)
            factor2 = _factorize(L_f[:, free], solver)
        except ValueError as err:
            raise ValueError("Igarashi system is singular: degenerate triangles, or part of "
                             "a component attached to its pins by a single vertex") from err
    return IgarashiData(V=V, F=F, b=b, E=E, ev=ev, Phi=Phi, D=D, free=free, held=held,
                        moved=moved, moved_pin=moved_pin, A1_fb=A1_f[:, b2].tocsr(),
                        factor1=factor1, Dt_f=D[:, free].T.tocsr(), L_fb=L_f[:, b].tocsr(),
                        factor2=factor2)


def edge_similarities(data: IgarashiData, U) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares similarity of every edge neighbourhood from rest to ``U``.

    Parameters
    ----------
    data : IgarashiData
    U : (n, 2) float
        Deformed positions.

    Returns
    -------
    am1, b : (e,) float
        ``a - 1`` and ``b`` of ``T(a, b) = [[a, -b], [b, a]]`` minimising
        ``sum_{m in N_k} |T v_m + t - u_m|^2`` over ``T`` and ``t`` (exactly ``0, 0`` at rest).
    """
    X = np.asarray(U, dtype=np.float64) - data.V
    ab = data.Phi @ np.concatenate([X[:, 0], X[:, 1]])
    ne = len(data.E)
    return ab[:ne], ab[ne:]


def _rotations(am1: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalise similarities ``(1 + am1, b)`` to rotations: ``(cos - 1, sin)``."""
    a = 1.0 + am1
    r = np.hypot(a, b)
    ok = r > 0
    r = np.where(ok, r, 1.0)
    # cos - 1 without cancellation near the identity (exactly 0 at rest)
    cm1 = np.where(a >= 0, -(b * b) / (r * (np.abs(a) + r)), a / r - 1.0)
    return np.where(ok, cm1, 0.0), np.where(ok, b / r, 0.0)


@blas_capped
def igarashi_solve(data: IgarashiData, bc, *, steps: int = 2) -> np.ndarray:
    """Deform the mesh so the pins reach their targets, as rigidly as possible.

    Step 1 solves ``A1_ff X_f = -A1_fb X_b`` (similarity-invariant); step 2 fits a
    rotation to every edge neighbourhood of that result and solves
    ``L_ff X_f = D_f^T (R - I) e - L_fb X_b`` for both coordinates with one factor.
    No factorisation happens here.

    Parameters
    ----------
    data : IgarashiData
        From :func:`igarashi_precompute`.
    bc : (k, 2) float
        Targets of the pinned vertices ``data.b``.
    steps : {1, 2}
        ``2``: the full algorithm. ``1``: stop after the similarity step (edge
        neighbourhoods may scale; useful to inspect or compare).

    Returns
    -------
    U : (n, 2) float
        Deformed positions; ``U[b] == bc`` exactly, components without pins at rest,
        components with one pin translated with it.
    """
    if steps not in (1, 2):
        raise ValueError(f"steps must be 1 or 2, got {steps!r}")
    bc = _check_bc(data, bc)
    V, b, free = data.V, data.b, data.free
    U = V.copy()
    Xb = bc - V[b]
    U[data.moved] += Xb[data.moved_pin]
    U[b] = bc
    if data.factor1 is None:
        return U
    nf = len(free)
    x1 = data.factor1.solve(-(data.A1_fb @ np.r_[Xb[:, 0], Xb[:, 1]]))
    U[free, 0] = V[free, 0] + x1[:nf]
    U[free, 1] = V[free, 1] + x1[nf:]
    if steps == 1:
        return U
    cm1, s = _rotations(*edge_similarities(data, U))
    ex, ey = data.ev[:, 0], data.ev[:, 1]
    t = np.stack([cm1 * ex - s * ey, s * ex + cm1 * ey], axis=1)  # (R - I) e_k
    X2 = data.factor2.solve(data.Dt_f @ t - data.L_fb @ Xb)
    U[free] = V[free] + X2
    return U
