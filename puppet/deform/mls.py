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

Line segments (paper section 5, :func:`puppet.deform.mls_lines.mls_deform_lines`, which
imports this module and not the other way round): each control is a segment
``p_i(t) = (1-t) a_i + t b_i`` mapped to ``q_i(t) = (1-t) c_i + t d_i`` and the sums
become integrals with ``w_i(t) = |p_i'(t)| / |p_i(t) - v|^(2 alpha)``. Every quantity
of the fit is the integral of a polynomial of degree <= 2 in ``t`` against ``w_i``, so
it is reproduced exactly by three virtual point controls per segment, at ``t = 0, 1/2,
1``, with the signed weights ``omega_ij = int w_i(t) l_j(t) dt`` (``l_j`` the quadratic
Lagrange basis of those nodes). ``mls_lines.segment_weights`` computes them (closed form for
alpha = 1, sinh-substituted Gauss-Legendre otherwise) and the same core does the rest.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from puppet.deform.threads import blas_capped

__all__ = [
    "mls_deform",
    "mls_object_space",
    "mls_from_weights",
    "inverse_distance_weights",
    "distance_weights",
    "DistanceWeights",
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


class DistanceWeights(NamedTuple):
    """The pose-independent part of object-space MLS (and of the depth field): the
    weights of :func:`inverse_distance_weights` kept for the points that need the fit.

    They depend only on the distances and ``alpha``, never on the targets, so a solver
    computes them once per mesh and pin set (:func:`distance_weights`) and passes them to
    every pose (``weights=`` of :func:`mls_object_space`, of
    :func:`puppet.deform.depth.depth_field`); the results are bit for bit those of
    computing them again.
    """

    W: np.ndarray  #: (k, t) weights of the ``t`` points in ``todo``, C order
    todo: np.ndarray  #: (n,) bool: reachable and on no control
    exact: np.ndarray  #: (n,) int: the first control at distance 0, -1 if none


def distance_weights(D: np.ndarray, *, alpha: float = 1.0) -> DistanceWeights:
    """:class:`DistanceWeights` of distances ``D`` (k, n) (see :func:`inverse_distance_weights`)."""
    W, exact, reachable = inverse_distance_weights(D, alpha=alpha)
    todo = reachable & (exact < 0)
    return DistanceWeights(W[:, todo], todo, exact)


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


def _moment_columns(p, dq, kind):
    """Per-control columns whose weighted sums give every moment of the fit, (k, m).

    With ``dq = q - p`` the control displacements: 1, px, py, dx, dy, p.d, p x d, |p|^2
    and, for affine, px px, px py, py py, px dx, px dy, py dx, py dy. Working with
    displacements makes ``q == p`` give exactly zero motion (every d-moment is 0).
    """
    px, py, dx, dy = p[:, 0], p[:, 1], dq[:, 0], dq[:, 1]
    cols = [np.ones_like(px), px, py, dx, dy, px * dx + py * dy, px * dy - py * dx, px * px + py * py]
    if kind == "affine":
        cols += [px * px, px * py, py * py, px * dx, px * dy, py * dx, py * dy]
    return np.stack(cols, axis=1)


@blas_capped
def mls_from_weights(X, p, q, W, *, kind: str = "rigid") -> np.ndarray:
    """MLS core: deform points with given per-point control weights.

    Every sum the closed forms need is linear in the weights, and the centred ones
    expand into plain weighted moments, e.g. ``sum w p^.d^ = sum w p.d - (sum w p).d*``
    with ``d = q - p``. So all of them come from ONE matrix product ``W^T M`` with the
    per-control columns of :func:`_moment_columns` (a BLAS call), after centring the
    coordinates on the controls' mean to keep the subtractions well conditioned. In
    terms of displacements: similarity ``a - 1 = (sum w p^.d^ + i sum w p^ x d^) /
    sum w |p^|^2``; rigid normalises ``sum w |p^|^2 + sum w p^.d^ + i sum w p^ x d^``;
    affine ``M - I = (sum w p^ p^T)^-1 sum w p^ d^T``.

    Parameters
    ----------
    X : (n, 2) float
        Points to deform.
    p, q : (k, 2) float
        Rest and target positions of the controls.
    W : (k, n) float
        Finite weights; every column must have a positive sum. Normally
        non-negative; signed columns are fine when they are the exact quadrature
        weights of a positive measure (the virtual controls of
        ``puppet.deform.mls_lines.segment_weights``), since every sum below is linear in ``W``.
    kind : {"affine", "similarity", "rigid"}

    Returns
    -------
    U : (n, 2) float
        Deformed points, computed as ``X + displacement`` so that ``q == p`` returns
        ``X`` exactly. Degenerate fits (a single effective control, all controls
        coincident, collinear controls for "affine") fall back to similarity and then
        to a pure translation.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    X = _check_points(X)
    p, q = _check_controls(p, q)
    W = np.asarray(W, dtype=np.float64)
    c = p.mean(axis=0)
    pc, Xc = p - c, X - c
    S = W.T @ _moment_columns(pc, q - p, kind)  # (n, m)
    ws = S[:, 0]
    Sp = S[:, 1:3]
    pstar = Sp / ws[:, None]
    dstar = S[:, 3:5] / ws[:, None]  # = q* - p*
    d = Xc - pstar
    pp = S[:, 7] - (Sp[:, 0] * pstar[:, 0] + Sp[:, 1] * pstar[:, 1])   # sum w |p^|^2
    pd = S[:, 5] - (Sp[:, 0] * dstar[:, 0] + Sp[:, 1] * dstar[:, 1])   # sum w p^.d^
    px = S[:, 6] - (Sp[:, 0] * dstar[:, 1] - Sp[:, 1] * dstar[:, 0])   # sum w p^ x d^
    span = max(np.ptp(np.concatenate([pc, q - c, Xc]), axis=0).max(), 1e-300)
    tol = np.abs(ws) * (1e-12 * span) ** 2
    if kind == "rigid":
        re = pp + pd
        r = np.hypot(re, px)
        ok = r > tol
        r = np.where(ok, r, 1.0)
        # cos - 1 without cancellation near the identity
        am1 = np.where(re >= 0, -(px * px) / (r * (np.abs(re) + r)), re / r - 1.0)
        a_im = px / r
    else:
        ok = pp > tol
        den = np.where(ok, pp, 1.0)
        am1, a_im = pd / den, px / den
    am1 = np.where(ok, am1, 0.0)  # degenerate fit (one control, all coincide)
    a_im = np.where(ok, a_im, 0.0)  # -> no rotation/scale, pure translation
    disp = np.stack([am1 * d[:, 0] - a_im * d[:, 1], a_im * d[:, 0] + am1 * d[:, 1]], axis=1) + dstar
    if kind == "affine":
        P00 = S[:, 8] - Sp[:, 0] * pstar[:, 0]
        P01 = S[:, 9] - Sp[:, 0] * pstar[:, 1]
        P11 = S[:, 10] - Sp[:, 1] * pstar[:, 1]
        Dm = np.stack([np.stack([S[:, 11] - Sp[:, 0] * dstar[:, 0], S[:, 12] - Sp[:, 0] * dstar[:, 1]], -1),
                       np.stack([S[:, 13] - Sp[:, 1] * dstar[:, 0], S[:, 14] - Sp[:, 1] * dstar[:, 1]], -1)], 1)
        det = P00 * P11 - P01 * P01
        okA = det > 1e-10 * (P00 + P11) ** 2
        inv = np.stack([np.stack([P11, -P01], -1), np.stack([-P01, P00], -1)], 1)
        inv /= np.where(okA, det, 1.0)[:, None, None]
        aff = np.einsum("na,nab->nb", d, inv @ Dm) + dstar
        disp = np.where(okA[:, None], aff, disp)
    return X + disp


def _mls_distances(X, D, p, q, kind, alpha, weights=None):
    """Shared driver: weights from distances (or given), exact hits, unreachable points."""
    w = distance_weights(D, alpha=alpha) if weights is None else weights
    U = X.copy()
    if w.todo.any():
        U[w.todo] = mls_from_weights(X[w.todo], p, q, w.W, kind=kind)
    hit = w.exact >= 0
    U[hit] = q[w.exact[hit]]
    return U


@blas_capped
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
    if not alpha > 0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    n = len(X)
    if n <= 2 * CHUNK:
        return _mls_image_chunk(X, p, q, kind, float(alpha))
    # cache-sized chunks: the (k, CHUNK) temporaries stay in cache (measured 2.5x faster
    # than one pass over 512x512 points; a second thread gained nothing more)
    return np.concatenate([_mls_image_chunk(X[i:i + CHUNK], p, q, kind, float(alpha))
                           for i in range(0, n, CHUNK)], axis=0)


#: points per chunk in image-space MLS
CHUNK = 16384


def _mls_image_chunk(X, p, q, kind, alpha):
    """Image-space MLS of a block of points: weights (d_min / d)^(2 alpha) per column,
    from squared distances (no square root; no power for alpha = 1)."""
    dx = X[None, :, 0] - p[:, 0, None]
    dy = X[None, :, 1] - p[:, 1, None]
    d2 = dx * dx
    d2 += dy * dy
    d2min = d2.min(axis=0)
    exact = d2min == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        W = np.divide(d2min, d2, out=dx)
        if alpha != 1.0:
            np.power(W, alpha, out=W)
    if exact.any():
        hit = np.flatnonzero(exact)
        first = d2[:, hit].argmin(axis=0)
        W[:, hit] = 0.0
        W[first, hit] = 1.0
    U = mls_from_weights(X, p, q, W, kind=kind)
    if exact.any():
        U[hit] = q[first]  # exactly on the target
    return U


@blas_capped
def mls_object_space(V, D, q, p=None, *, kind: str = "rigid", alpha: float = 1.0,
                     weights: DistanceWeights | None = None) -> np.ndarray:
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
    weights : DistanceWeights, optional
        ``distance_weights(D, alpha=alpha)`` computed before (pose-independent; the
        same result, without their cost). None: computed here.

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
    if weights is not None and weights.todo.shape != (len(V),):
        raise ValueError(f"weights are for {weights.todo.shape[0]} points, not {len(V)}")
    return _mls_distances(V, D, p, q, kind, alpha, weights)
