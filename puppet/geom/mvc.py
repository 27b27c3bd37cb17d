"""Mean value coordinates of points with respect to a closed polygon (Floater 2003;
Hormann & Floater 2006 for non-convex polygons).

For a point ``x`` and polygon vertices ``v_i`` with ``r_i = |v_i - x|`` and ``alpha_i``
the signed angle at ``x`` from ``v_i`` to ``v_(i+1)``::

    w_i = (tan(alpha_(i-1) / 2) + tan(alpha_i / 2)) / r_i,   lambda_i = w_i / sum(w)

The coordinates sum to 1, reproduce linear functions (``sum lambda_i v_i = x``) and are
invariant under similarities of the plane, so a point expressed in them relative to one
polygon lands at the corresponding place of another polygon with corresponding vertices.
"""
from __future__ import annotations

import numpy as np

__all__ = ["mean_value_coordinates"]


def mean_value_coordinates(V, X) -> np.ndarray:
    """Mean value coordinates of points ``X`` relative to the polygon ``V``.

    Parameters
    ----------
    V : (n, 2) float
        Polygon vertices in order (either orientation), not closed.
    X : (k, 2) float
        Points, strictly inside the polygon (or at least not on its boundary).

    Returns
    -------
    L : (k, n) float
        Rows sum to 1 and ``L @ V == X``. A point on a vertex gets that vertex's unit
        row; a point on an edge gets the two endpoints' linear weights.
    """
    V = np.asarray(V, np.float64)
    X = np.atleast_2d(np.asarray(X, np.float64))
    D = V[None, :, :] - X[:, None, :]  # (k, n, 2)
    Dn = np.roll(D, -1, axis=1)
    r = np.linalg.norm(D, axis=2)
    cross = D[..., 0] * Dn[..., 1] - D[..., 1] * Dn[..., 0]
    dot = (D * Dn).sum(axis=2)
    alpha = np.arctan2(cross, dot)  # signed angle v_i -> v_(i+1) seen from x
    t = np.tan(alpha / 2.0)
    L = np.empty((len(X), len(V)))
    eps = 1e-10
    for k in range(len(X)):
        on_vertex = np.nonzero(r[k] < eps)[0]
        if len(on_vertex):
            L[k] = 0.0
            L[k, on_vertex[0]] = 1.0
            continue
        rn = np.roll(r[k], -1)
        on_edge = np.nonzero((np.abs(cross[k]) < eps * r[k] * rn) & (dot[k] < 0))[0]
        if len(on_edge):
            i = on_edge[0]
            j = (i + 1) % len(V)
            L[k] = 0.0
            L[k, i], L[k, j] = rn[i] / (r[k, i] + rn[i]), r[k, i] / (r[k, i] + rn[i])
            continue
        w = (np.roll(t[k], 1) + t[k]) / r[k]
        L[k] = w / w.sum()
    return L
