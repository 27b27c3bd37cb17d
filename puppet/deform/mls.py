"""Moving least squares deformation (Schaefer, McPhail, Warren 2006).

For a point ``v`` with control weights ``w_i``, the best affine / similarity / rigid map
``l_v`` taking the rest controls ``p_i`` to their targets ``q_i`` in the weighted
least-squares sense is applied to ``v``:

* weighted centroids ``p* = sum w_i p_i / sum w_i``, ``q*`` likewise,
  ``p^_i = p_i - p*``, ``q^_i = q_i - q*``;
* affine: ``l_v(v) = (v - p*) (sum w p^_i^T p^_i)^-1 (sum w p^_i^T q^_i) + q*``
  (row vectors);
* similarity: with points as complex numbers, ``l_v(v) = a (v - p*) + q*`` where
  ``a = sum w conj(p^_i) q^_i / sum w |p^_i|^2`` (paper's eq. for mu_s);
* rigid: ``l_v(v) = (c / |c|) (v - p*) + q*`` with ``c = sum w conj(p^_i) q^_i``
  (the paper's normalisation ``|v - p*| f(v) / |f(v)|`` is exactly this rotation).

The weights are ``w_i = d_i^(-2 alpha)`` where ``d_i`` is the Euclidean distance
|p_i - v| (image space, :func:`mls_deform`) or a given, e.g. geodesic, distance
(object space, :func:`mls_object_space`). Both go through the same core
:func:`mls_from_weights` with the weights of :func:`inverse_distance_weights`.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "mls_deform",
    "mls_object_space",
    "mls_from_weights",
    "inverse_distance_weights",
    "KINDS",
]

KINDS = ("affine", "similarity", "rigid")


def inverse_distance_weights(D: np.ndarray, *, alpha: float = 1.0):
    """Scale-free inverse-distance weights ``D^(-2 alpha)`` per column.

    Parameters
    ----------
    D : (k, n) float
        Non-negative distances from k controls to n points; ``inf`` = unreachable.
    alpha : float
        Weight exponent (``w = d^(-2 alpha)``), must be > 0.

    Returns
    -------
    W : (k, n) float
        Weights divided by their column maximum (so every reachable column has max 1,
        nothing overflows, and MLS, which is invariant to a per-point scale of the
        weights, is unchanged). Controls at ``inf`` get 0. A column whose point
        coincides with a control (``D == 0``) is one-hot on the first such control;
        an unreachable column is all zero.
    exact : (n,) int
        Index of the first control at distance 0 from each point, ``-1`` if none.
    reachable : (n,) bool
        Whether at least one control has finite distance.
    """
    D = np.asarray(D, dtype=np.float64)
    if D.ndim != 2:
        raise ValueError(f"D must have shape (k, n), got {D.shape}")
    if not alpha > 0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    k, n = D.shape
    if k == 0:
        return np.zeros((0, n)), np.full(n, -1, dtype=np.int64), np.zeros(n, dtype=bool)
    if np.isnan(D).any() or (D < 0).any():
        raise ValueError("distances must be non-negative (inf allowed), got NaN or < 0")
    dmin = D.min(axis=0)
    reachable = np.isfinite(dmin)
    zero = D == 0
    exact = np.where(zero.any(axis=0), zero.argmax(axis=0), -1).astype(np.int64)
    ok = reachable & (exact < 0)
    W = np.zeros_like(D)
    W[:, ok] = (dmin[ok] / D[:, ok]) ** (2.0 * alpha)  # in [0, 1]; inf -> 0
    cols = np.flatnonzero(exact >= 0)
    W[exact[cols], cols] = 1.0
    return W, exact, reachable


def _check_controls(p, q):
    p = np.asarray(p, dtype=np.float64).reshape(-1, 2)
    q = np.asarray(q, dtype=np.float64).reshape(-1, 2)
    if p.shape != q.shape:
        raise ValueError(f"p and q must have the same shape (k, 2), got {p.shape}, {q.shape}")
    return p, q


def _check_points(X):
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {X.shape}")
    return X


def _complex_fit(W, ph, qh, kind, tol):
    """Per-point complex factor ``a`` of the similarity / rigid fit, (n,) re, im."""
    # products formed before weighting, so q == p gives im == 0 and re == den exactly
    re = np.einsum("kn,kn->n", W, ph[..., 0] * qh[..., 0] + ph[..., 1] * qh[..., 1])
    im = np.einsum("kn,kn->n", W, ph[..., 0] * qh[..., 1] - ph[..., 1] * qh[..., 0])
    if kind == "similarity":
        den = np.einsum("kn,kn->n", W, ph[..., 0] * ph[..., 0] + ph[..., 1] * ph[..., 1])
    else:
        den = np.hypot(re, im)
    ok = den > tol
    safe = np.where(ok, den, 1.0)
    a_re = np.where(ok, re / safe, 1.0)  # degenerate fit (one control, all coincide)
    a_im = np.where(ok, im / safe, 0.0)  # -> no rotation/scale, pure translation
    return a_re, a_im


def mls_from_weights(X, p, q, W, *, kind: str = "rigid") -> np.ndarray:
    """MLS core: deform points with given per-point control weights.

    Parameters
    ----------
    X : (n, 2) float
        Points to deform.
    p, q : (k, 2) float
        Rest and target positions of the controls.
    W : (k, n) float
        Non-negative finite weights; every column must have a positive sum.
    kind : {"affine", "similarity", "rigid"}

    Returns
    -------
    U : (n, 2) float
        Deformed points, computed as ``X + displacement`` so that ``q == p`` returns
        ``X`` exactly (rigid, similarity). Degenerate fits (a single effective
        control, all controls coincident, collinear controls for "affine") fall back
        to similarity and then to a pure translation.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    X = _check_points(X)
    p, q = _check_controls(p, q)
    W = np.asarray(W, dtype=np.float64)
    wsum = W.sum(axis=0)
    pstar = (W.T @ p) / wsum[:, None]
    qstar = (W.T @ q) / wsum[:, None]
    d = X - pstar
    shift = qstar - pstar
    ph = p[:, None, :] - pstar[None]
    qh = q[:, None, :] - qstar[None]
    span = max(np.ptp(np.concatenate([p, q, X]), axis=0).max(), 1e-300)
    tol = wsum * (1e-12 * span) ** 2
    kfit = "similarity" if kind == "affine" else kind
    a_re, a_im = _complex_fit(W, ph, qh, kfit, tol)
    disp = np.stack([(a_re - 1.0) * d[:, 0] - a_im * d[:, 1],
                     a_im * d[:, 0] + (a_re - 1.0) * d[:, 1]], axis=1) + shift
    if kind == "affine":
        pw = ph * W[:, :, None]
        P = np.einsum("kna,knb->nab", pw, ph)
        Q = np.einsum("kna,knb->nab", pw, qh)
        det = P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] * P[:, 1, 0]
        tr = P[:, 0, 0] + P[:, 1, 1]
        ok = det > 1e-10 * tr**2
        inv = np.stack([np.stack([P[:, 1, 1], -P[:, 0, 1]], -1),
                        np.stack([-P[:, 1, 0], P[:, 0, 0]], -1)], 1)
        inv /= np.where(ok, det, 1.0)[:, None, None]
        M = inv @ Q - np.eye(2)
        aff = np.einsum("na,nab->nb", d, M) + shift
        disp = np.where(ok[:, None], aff, disp)
    return X + disp


def _mls_distances(X, D, p, q, kind, alpha):
    """Shared driver: weights from distances, exact hits, unreachable points."""
    W, exact, reachable = inverse_distance_weights(D, alpha=alpha)
    U = X.copy()
    todo = reachable & (exact < 0)
    if todo.any():
        U[todo] = mls_from_weights(X[todo], p, q, W[:, todo], kind=kind)
    hit = exact >= 0
    U[hit] = q[exact[hit]]
    return U


def mls_deform(X, p, q, *, kind: str = "rigid", alpha: float = 1.0) -> np.ndarray:
    """Image-space MLS deformation of points (Schaefer et al. 2006).

    Parameters
    ----------
    X : (n, 2) float
        Points to deform.
    p : (k, 2) float
        Rest positions of the control points.
    q : (k, 2) float
        Their targets.
    kind : {"rigid", "similarity", "affine"}
        Family of the local best-fit map.
    alpha : float
        Weight exponent: ``w_i = 1 / |p_i - x|^(2 alpha)``.

    Returns
    -------
    U : (n, 2) float
        Deformed points. A point equal to ``p_i`` maps exactly to ``q_i``; with one
        control point every point is translated by ``q_0 - p_0``; with none, ``U = X``.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    X = _check_points(X)
    p, q = _check_controls(p, q)
    if len(p) == 0:
        return X.copy()
    D = np.hypot(p[:, 0, None] - X[None, :, 0], p[:, 1, None] - X[None, :, 1])
    return _mls_distances(X, D, p, q, kind, alpha)


def mls_object_space(V, D, q, p=None, *, kind: str = "rigid", alpha: float = 1.0) -> np.ndarray:
    """Object-space MLS: the MLS closed forms with weights from given distances.

    Parameters
    ----------
    V : (n, 2) float
        Rest vertex positions.
    D : (k, n) float
        Distance (typically geodesic, see ``puppet.geom.geodesic``) from each control
        point to each vertex; ``inf`` where unreachable.
    q : (k, 2) float
        Targets of the control points.
    p : (k, 2) float
        Rest positions of the control points (required).
    kind : {"rigid", "similarity", "affine"}
    alpha : float
        Weight exponent: ``w_i(v) = D[i, v]^(-2 alpha)``.

    Returns
    -------
    U : (n, 2) float
        Deformed vertices. ``D[i, v] == 0`` maps ``v`` exactly to ``q_i``; a vertex no
        control reaches (column all ``inf``) stays at ``V[v]``; controls at ``inf`` in
        a column get weight 0 there.
    """
    if p is None:
        raise ValueError("mls_object_space needs p, the rest positions of the controls")
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    V = _check_points(V)
    p, q = _check_controls(p, q)
    D = np.asarray(D, dtype=np.float64)
    if D.shape != (len(p), len(V)):
        raise ValueError(f"D must have shape (k, n) = {(len(p), len(V))}, got {D.shape}")
    if len(p) == 0:
        return V.copy()
    return _mls_distances(V, D, p, q, kind, alpha)
