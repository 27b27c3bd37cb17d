"""Triangle-mesh primitives shared by every module: input checks, edges, boundary edges.

One home for each: ``puppet.geom.laplacian`` (weights), ``puppet.geom.geodesic``
(distances), ``puppet.deform`` (all deformers) and ``puppet.render`` use these.
"""
from __future__ import annotations

import numpy as np

__all__ = ["check_vertices", "check_faces", "check_pins", "check_mesh", "edges", "boundary_edges"]


def check_vertices(V, *, dims: tuple[int, ...] = (2,), finite: bool = True,
                   name: str = "V") -> np.ndarray:
    """Vertex positions as a C-contiguous float64 array (a copy).

    Parameters
    ----------
    V : (n, d) array_like
    dims : tuple of int
        Accepted numbers of coordinates ``d``.
    finite : bool
        Reject NaN and infinite coordinates.
    name : str
        Name in the error messages.

    Returns
    -------
    V : (n, d) float64

    Raises
    ------
    ValueError
        Wrong shape, or non-finite values when ``finite``.
    """
    V = np.array(V, dtype=np.float64, order="C")
    if V.ndim != 2 or V.shape[1] not in dims:
        want = " or ".join(f"(n, {d})" for d in dims)
        raise ValueError(f"{name} must have shape {want}, got {V.shape}")
    if finite and not np.isfinite(V).all():
        raise ValueError(f"{name} must be finite")
    return V


def check_faces(F, n: int | None = None) -> np.ndarray:
    """Triangles as an int64 array; an empty input gives shape (0, 3).

    Parameters
    ----------
    F : (m, 3) array_like of int
    n : int, optional
        Number of vertices: every index must be below it.

    Returns
    -------
    F : (m, 3) int64

    Raises
    ------
    ValueError
        Wrong shape, a non-integer dtype, or an index out of range.
    """
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


def check_pins(b, n: int, *, unique: bool = True) -> np.ndarray:
    """Pinned vertex indices as an int64 array of shape (k,).

    Raises
    ------
    ValueError
        A non-integer dtype, an index outside ``0 .. n-1``, or (``unique``) a repeat.
    """
    b = np.asarray(b)
    if b.size == 0:
        return np.zeros(0, dtype=np.int64)
    if not np.issubdtype(b.dtype, np.integer):
        raise ValueError(f"b must hold integer vertex indices, got dtype {b.dtype}")
    b = b.astype(np.int64).reshape(-1)
    if b.min() < 0 or b.max() >= n:
        raise ValueError("b refers to a vertex index out of range")
    if unique and len(np.unique(b)) != len(b):
        raise ValueError("b has repeated vertex indices")
    return b


def check_mesh(V, F, b=None, *, dims: tuple[int, ...] = (2,), finite: bool = True):
    """Check a mesh (and its pins) once: :func:`check_vertices`, :func:`check_faces`
    with the vertex count, :func:`check_pins` when ``b`` is given.

    Returns
    -------
    (V, F) or (V, F, b)
        ``V (n, d) float64``, ``F (m, 3) int64``, ``b (k,) int64`` (distinct).
    """
    V = check_vertices(V, dims=dims, finite=finite)
    F = check_faces(F, len(V))
    if b is None:
        return V, F
    return V, F, check_pins(b, len(V))


def edges(F) -> np.ndarray:
    """Unique undirected edges of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) int
        Triangles as vertex indices.

    Returns
    -------
    E : (e, 2) int64
        Each edge once, with ``E[:, 0] < E[:, 1]``, sorted lexicographically (an edge
        of a triangle with a repeated vertex, ``i == j``, is left out).
    """
    F = check_faces(F)
    if len(F) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i = F.ravel()
    j = F[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    n = int(hi.max()) + 1
    key = np.unique((lo * n + hi)[lo != hi])  # 1-D unique: much faster than unique(axis=0)
    return np.stack([key // n, key % n], axis=1)


def boundary_edges(F) -> np.ndarray:
    """Directed boundary edges of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) int

    Returns
    -------
    E : (b, 2) int64
        Every edge used by exactly one triangle, directed as in that triangle (so the
        mesh is on the same side of all of them), sorted by first vertex.
    """
    F = check_faces(F)
    if len(F) == 0:
        return np.zeros((0, 2), np.int64)
    H = np.stack([F.ravel(), F[:, [1, 2, 0]].ravel()], axis=1)  # half-edges
    n = int(F.max()) + 1
    key = np.minimum(H[:, 0], H[:, 1]) * n + np.maximum(H[:, 0], H[:, 1])
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    E = H[counts[inverse] == 1]
    return E[np.lexsort((E[:, 1], E[:, 0]))]
