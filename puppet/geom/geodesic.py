"""Distances along mesh edges and connected components.

``geodesic_distances`` is the edge-graph approximation of the interior (geodesic)
distance: Dijkstra over the mesh edges weighted by their Euclidean length. On a
triangulated shape it follows the inside of the shape, so a pin on one leg does not
pull the other leg that happens to be close in the image plane.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from puppet.geom.mesh import check_faces, edges

__all__ = ["edge_graph", "grid_graph", "geodesic_distances", "connected_components"]


def edge_graph(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Symmetric sparse graph of the mesh edges weighted by Euclidean length.

    Parameters
    ----------
    V : (n, d) float
    F : (m, 3) int

    Returns
    -------
    G : (n, n) scipy.sparse.csr_matrix
        ``G[i, j] = |V[i] - V[j]|`` for every edge ``ij`` (explicitly stored even when
        zero, which ``scipy.sparse.csgraph`` treats as an edge of length 0).
    """
    V = np.asarray(V, dtype=np.float64)
    n = V.shape[0]
    E = edges(check_faces(F, n))
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    rows = np.concatenate([E[:, 0], E[:, 1]])
    cols = np.concatenate([E[:, 1], E[:, 0]])
    return sp.csr_matrix((np.concatenate([length, length]), (rows, cols)), shape=(n, n))


def grid_graph(on: np.ndarray, step: float = 1.0) -> tuple[np.ndarray, sp.csr_matrix]:
    """The 8-neighbour graph of the cells of a grid that are ``on``: (idx (h, w) node number
    of each cell, -1 off; the graph, edges of length ``step`` across and ``step`` sqrt 2
    diagonally, each pair once: use it undirected)."""
    h, w = on.shape
    idx = -np.ones((h, w), np.int64)
    idx[on] = np.arange(int(on.sum()))
    rows, cols, lens = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = idx[0:h - di, max(0, -dj):w - max(0, dj)]  # cell (i, j) ...
        b = idx[di:h, max(0, dj):w - max(0, -dj)]  # ... and (i + di, j + dj)
        ok = (a >= 0) & (b >= 0)
        rows.append(a[ok])
        cols.append(b[ok])
        lens.append(np.full(ok.sum(), step * np.hypot(di, dj)))
    n = int(on.sum())
    return idx, sp.csr_matrix((np.concatenate(lens), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def geodesic_distances(V: np.ndarray, F: np.ndarray, sources) -> np.ndarray:
    """Shortest-path distances along mesh edges from each source vertex.

    Parameters
    ----------
    V : (n, 2) or (n, 3) float
        Vertex positions.
    F : (m, 3) int
        Triangles.
    sources : (k,) int
        Source vertex indices (repeats allowed).

    Returns
    -------
    D : (k, n) float64
        ``D[s, v]`` = length of the shortest edge path from ``sources[s]`` to ``v``;
        ``0`` at the source itself, ``inf`` where ``v`` is not reachable.
    """
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    V = np.asarray(V, dtype=np.float64)
    n = V.shape[0]
    src = np.asarray(sources, dtype=np.int64).reshape(-1)
    if len(src) and (src.min() < 0 or src.max() >= n):
        raise ValueError("source index out of range")
    if len(src) == 0:
        return np.zeros((0, n))
    G = edge_graph(V, F)
    D = csgraph.dijkstra(G, directed=False, indices=src)
    return np.asarray(D, dtype=np.float64).reshape(len(src), n)


def connected_components(n: int, F: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of the mesh (vertices joined by triangle edges).

    Parameters
    ----------
    n : int
        Number of vertices; vertices used by no triangle are components of their own.
    F : (m, 3) int
        Triangles.

    Returns
    -------
    ncomp : int
        Number of components.
    labels : (n,) int
        Component index of every vertex, in ``0 .. ncomp-1``.
    """
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    E = edges(check_faces(F, n))
    A = sp.csr_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    ncomp, labels = csgraph.connected_components(A, directed=False)
    return int(ncomp), labels.astype(np.int64)
