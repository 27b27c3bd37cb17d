"""Edge weights and graph/cotangent Laplacians of a triangle mesh.

Convention: ``L = D - W`` with ``W`` the symmetric edge-weight matrix (zero diagonal)
and ``D = diag(W.sum(1))``, so ``L`` is positive semi-definite and its rows sum to 0.
The cotangent weights are ``w_ij = (cot a_ij + cot b_ij) / 2`` with ``a_ij``, ``b_ij``
the angles opposite the edge ``ij`` (a boundary edge has only one), which makes ``L``
the P1 finite-element stiffness matrix (libigl's ``-cotmatrix``).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = [
    "edges",
    "cotangent_weights",
    "uniform_weights",
    "cotangent_laplacian",
    "uniform_laplacian",
]


def _check_faces(F: np.ndarray, n: int | None = None) -> np.ndarray:
    F = np.asarray(F)
    if F.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must have shape (m, 3), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise ValueError(f"F must hold integer vertex indices, got dtype {F.dtype}")
    F = F.astype(np.int64, copy=False)
    if F.min() < 0 or (n is not None and F.max() >= n):
        raise ValueError("F refers to a vertex index out of range")
    return F


def _check_vertices(V: np.ndarray) -> np.ndarray:
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise ValueError(f"V must have shape (n, 2) or (n, 3), got {V.shape}")
    return V


def edges(F: np.ndarray) -> np.ndarray:
    """Unique undirected edges of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) int
        Triangles as vertex indices.

    Returns
    -------
    E : (e, 2) int64
        Each edge once, with ``E[:, 0] < E[:, 1]``, sorted lexicographically.
    """
    F = _check_faces(F)
    if len(F) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i = F.ravel()
    j = F[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    n = int(hi.max()) + 1
    key = np.unique(lo * n + hi)  # 1-D unique: much faster than unique(axis=0)
    return np.stack([key // n, key % n], axis=1)


def _symmetric(n: int, i: np.ndarray, j: np.ndarray, w: np.ndarray) -> sp.csr_matrix:
    """Sum ``w`` into entries (i, j) and (j, i) of an (n, n) csr matrix."""
    rows = np.concatenate([i, j])
    cols = np.concatenate([j, i])
    vals = np.concatenate([w, w])
    W = sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    W.sum_duplicates()
    return W


def cotangent_weights(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Symmetric cotangent edge weights.

    Parameters
    ----------
    V : (n, 2) or (n, 3) float
        Vertex positions.
    F : (m, 3) int
        Triangles (orientation does not matter).

    Returns
    -------
    W : (n, n) scipy.sparse.csr_matrix
        ``W[i, j] = (cot a + cot b) / 2`` for every mesh edge ``ij`` (one angle on
        the boundary), zero diagonal. Weights can be negative (obtuse angles) or
        exactly zero (two right angles). A degenerate (zero-area) triangle adds 0.
    """
    V = _check_vertices(V)
    n = V.shape[0]
    F = _check_faces(F, n)
    cots = []
    pairs = []
    for c in range(3):
        o, a, b = F[:, c], F[:, (c + 1) % 3], F[:, (c + 2) % 3]
        e1 = V[a] - V[o]
        e2 = V[b] - V[o]
        dot = np.einsum("ij,ij->i", e1, e2)
        if V.shape[1] == 2:
            cross = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        else:
            cross = np.linalg.norm(np.cross(e1, e2), axis=1)
        cot = np.divide(dot, cross, out=np.zeros_like(dot), where=cross > 0)
        cots.append(0.5 * cot)
        pairs.append((a, b))
    i = np.concatenate([p[0] for p in pairs])
    j = np.concatenate([p[1] for p in pairs])
    return _symmetric(n, i, j, np.concatenate(cots))


def uniform_weights(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Weight 1 on every mesh edge (graph adjacency).

    Parameters
    ----------
    V : (n, d) float
        Vertex positions (only ``n`` is used).
    F : (m, 3) int
        Triangles.

    Returns
    -------
    W : (n, n) scipy.sparse.csr_matrix
        Symmetric 0/1 adjacency, zero diagonal.
    """
    n = np.asarray(V).shape[0]
    E = edges(_check_faces(F, n))
    return _symmetric(n, E[:, 0], E[:, 1], np.ones(len(E)))


def laplacian_from_weights(W: sp.spmatrix) -> sp.csr_matrix:
    """``L = diag(W.sum(1)) - W`` (rows sum to 0), csr."""
    W = sp.csr_matrix(W)
    d = np.asarray(W.sum(axis=1)).ravel()
    return (sp.diags(d, format="csr") - W).tocsr()


def cotangent_laplacian(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Cotangent Laplacian ``L = D - W`` (positive semi-definite).

    Parameters
    ----------
    V : (n, 2) or (n, 3) float
    F : (m, 3) int

    Returns
    -------
    L : (n, n) scipy.sparse.csr_matrix
        Symmetric, rows sum to zero; equals minus libigl's ``cotmatrix``.
    """
    return laplacian_from_weights(cotangent_weights(V, F))


def uniform_laplacian(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Graph (umbrella) Laplacian ``L = D - A``, csr (n, n), positive semi-definite."""
    return laplacian_from_weights(uniform_weights(V, F))
