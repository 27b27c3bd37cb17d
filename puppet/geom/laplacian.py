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

from puppet.geom.mesh import check_faces, check_vertices, edges

__all__ = [
    "edges",
    "cotangent_weights",
    "uniform_weights",
    "laplacian_from_weights",
    "cotangent_laplacian",
    "uniform_laplacian",
    "spring_weights",
]


def _corner_weights(V: np.ndarray, F: np.ndarray, w: np.ndarray) -> sp.csr_matrix:
    """Symmetric W from ``w[c, t]``, the weight triangle t gives the edge opposite its
    corner c; every mesh edge is stored (also where the weights sum to 0), no loops."""
    n = V.shape[0]
    T = F.T.astype(np.int32) if n < 2**31 else F.T  # int32: a faster coo -> csr
    i, j = T[[1, 2, 0]].ravel(), T[[2, 0, 1]].ravel()  # corner c sees the edge (c+1, c+2)
    w = w.ravel()
    if (i == j).any():  # a triangle with a repeated vertex: its loops cancel out of L
        i, j, w = i[i != j], j[i != j], w[i != j]
    W = sp.coo_matrix((np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                      shape=(n, n)).tocsr()
    W.sum_duplicates()
    return W


def cotangent_weights(V, F, *, clamp: bool = False) -> sp.csr_matrix:
    """Symmetric cotangent edge weights, in one pass over the triangles' corners.

    Parameters
    ----------
    V : (n, 2) or (n, 3) float
        Vertex positions.
    F : (m, 3) int
        Triangles (orientation does not matter).
    clamp : bool
        Clamp negative weights (obtuse triangles) at 0, as ARAP's default does.

    Returns
    -------
    W : (n, n) scipy.sparse.csr_matrix
        ``W[i, j] = (cot a + cot b) / 2`` for every mesh edge ``ij`` (one angle on
        the boundary), zero diagonal. Weights can be negative (obtuse angles, unless
        ``clamp``) or exactly zero (two right angles); zero weights stay stored, so the
        pattern of ``W`` is exactly the mesh's edges. A degenerate (zero-area) triangle
        adds 0.
    """
    V = check_vertices(V, dims=(2, 3), finite=False)
    F = check_faces(F, V.shape[0])
    T = F.T.astype(np.int32) if V.shape[0] < 2**31 else F.T  # int32 gathers are faster
    cols = [V[:, k].copy() for k in range(V.shape[1])]  # contiguous coordinates
    P = [[col[t] for t in T] for col in cols]  # per coordinate, the 3 corners' values (m,)
    d = [[p[(c + 2) % 3] - p[(c + 1) % 3] for c in range(3)] for p in P]  # edge c: opposite c
    if len(P) == 2:
        cross = np.abs(d[0][1] * d[1][2] - d[1][1] * d[0][2])
    else:
        cx = [d[(k + 1) % 3][1] * d[(k + 2) % 3][2] - d[(k + 2) % 3][1] * d[(k + 1) % 3][2]
              for k in range(3)]
        cross = np.sqrt(cx[0] ** 2 + cx[1] ** 2 + cx[2] ** 2)
    half = np.divide(-0.5, cross, out=np.zeros_like(cross), where=cross > 0)
    w = np.empty((3, len(F)))
    for c in range(3):  # the angle at corner c lies between edges c+1 and c+2
        a, b = (c + 1) % 3, (c + 2) % 3
        dot = d[0][a] * d[0][b]
        for dk in d[1:]:
            dot += dk[a] * dk[b]
        np.multiply(dot, half, out=w[c])
    W = _corner_weights(V, F, w)
    if clamp:
        np.maximum(W.data, 0.0, out=W.data)
    return W


def uniform_weights(V, F) -> sp.csr_matrix:
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
        Symmetric 0/1 adjacency, zero diagonal; the same pattern as
        :func:`cotangent_weights`.
    """
    V = np.asarray(V)
    F = check_faces(F, V.shape[0])
    W = _corner_weights(V, F, np.ones((3, len(F))))
    W.data[:] = 1.0
    return W


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


def spring_weights(n: int, pairs, kappa) -> sp.csr_matrix:
    """Symmetric weights (n, n) csr: ``kappa`` at each of ``pairs`` (p, 2) int and its
    mirror (springs between vertices, e.g. the two sides of a loose link)."""
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    kappa = np.broadcast_to(np.asarray(kappa, np.float64), (len(pairs),))
    r = np.concatenate([pairs[:, 0], pairs[:, 1]])
    c = np.concatenate([pairs[:, 1], pairs[:, 0]])
    return sp.csr_matrix((np.concatenate([kappa, kappa]), (r, c)), shape=(n, n))
