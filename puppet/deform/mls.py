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

Line segments (paper section 5, :func:`mls_deform_lines`): each control is a segment
``p_i(t) = (1-t) a_i + t b_i`` mapped to ``q_i(t) = (1-t) c_i + t d_i`` and the sums
become integrals with ``w_i(t) = |p_i'(t)| / |p_i(t) - v|^(2 alpha)``. Every quantity
of the fit is the integral of a polynomial of degree <= 2 in ``t`` against ``w_i``, so
it is reproduced exactly by three virtual point controls per segment, at ``t = 0, 1/2,
1``, with the signed weights ``omega_ij = int w_i(t) l_j(t) dt`` (``l_j`` the quadratic
Lagrange basis of those nodes). :func:`segment_weights` computes them (closed form for
alpha = 1, sinh-substituted Gauss-Legendre otherwise) and the same core does the rest.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "mls_deform",
    "mls_object_space",
    "mls_from_weights",
    "inverse_distance_weights",
    "mls_deform_lines",
    "segment_weights",
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
        Finite weights; every column must have a positive sum. Normally
        non-negative; signed columns are fine when they are the exact quadrature
        weights of a positive measure (the virtual controls of
        :func:`segment_weights`), since every sum below is linear in ``W``.
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


# ---- line segments (section 5) ----------------------------------------------------

# l_j(t) for the nodes t = 0, 1/2, 1 as coefficients of (1, t, t^2)
_LAGRANGE = np.array([[1.0, -3.0, 2.0], [0.0, 4.0, -4.0], [0.0, -1.0, 2.0]])
_HIT = 1e-12      # a point closer than _HIT * L to a segment is on it
_NEAR = 2.0       # closed form while |v - midpoint| <= _NEAR * L, quadrature beyond
_GL = np.polynomial.legendre.leggauss(8)


def _check_segments(P, Q=None):
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 3 or P.shape[1:] != (2, 2):
        raise ValueError(f"segments must have shape (k, 2, 2), got {P.shape}")
    if Q is not None:
        Q = np.asarray(Q, dtype=np.float64)
        if Q.shape != P.shape:
            raise ValueError(f"P and Q must have the same shape, got {P.shape}, {Q.shape}")
    if len(P) and not (np.hypot(*(P[:, 1] - P[:, 0]).T) > 0).all():
        raise ValueError("rest segments must have positive length")
    return P, Q


def _lagrange_at(t, c0, c1, c2):
    """Sum_j of c*(l_j, l_j', l_j''/2) at t, per node j: (3,) + t.shape."""
    A = _LAGRANGE.reshape((3, 3) + (1,) * np.ndim(t))
    l = A[:, 0] + t[None] * (A[:, 1] + A[:, 2] * t[None])
    dl = A[:, 1] + 2.0 * A[:, 2] * t[None]
    return l * c0[None] + dl * c1[None] + A[:, 2] * c2[None]


def _closed_form(t0, h, L, da, db):
    """alpha = 1: omega_j from I0 = int w, K1 = int w (t-t0), K2 = int w (t-t0)^2."""
    x = h * h + (L * t0) * (L * t0 - L)       # h^2 + u0 u1 with u = L (t - t0)
    y = h * L
    pos = x > 0
    r = y / np.where(pos, x, 1.0)
    atanc = np.where(r > 0, np.arctan(r) / np.where(r > 0, r, 1.0), 1.0)
    I0 = np.where(pos, L / np.where(pos, x, 1.0) * atanc,
                  np.arctan2(y, x) / np.where(pos, 1.0, h))
    K1 = np.log(db / da) / L
    K2 = (1.0 - h * h * I0 / L) / L
    return _lagrange_at(t0, I0, K1, K2)


def _quadrature(t0, h, L, alpha):
    """omega_j by Gauss-Legendre after u = L (t - t0) = h sinh(s) (smooth in s).

    The s-interval is cut into panels of length <= 1 (poles of the integrand sit at
    distance pi/2 from the real s axis), pairs grouped by power-of-two panel counts.
    """
    hh = np.maximum(h, _HIT * L)
    s0, s1 = np.arcsinh(-L * t0 / hh), np.arcsinh(L * (1.0 - t0) / hh)
    level = np.ceil(np.log2(np.clip(s1 - s0, 1.0, 64.0))).astype(int)
    out = np.zeros((3,) + t0.shape)
    for lev in np.unique(level):
        m, panels = level == lev, 2**lev
        width = (s1[m] - s0[m]) / panels
        for i in range(panels):
            s = s0[m, None] + width[:, None] * (i + 0.5 * (_GL[0] + 1.0))
            t = t0[m, None] + (hh[m] / L[m])[:, None] * np.sinh(s)
            f = (hh[m, None] * np.cosh(s)) ** (1.0 - 2.0 * alpha) * _GL[1]  # w dt / ds
            zero = np.zeros_like(f)
            out[:, m] += 0.5 * width[None] * _lagrange_at(t, f, zero, zero).sum(-1)
    return out


def _line_weights(X, P, alpha):
    """(W (k, 3, n) summing to 1 per column, hit (n,) segment or -1, t (n,))."""
    a, e = P[:, 0, None, :], (P[:, 1] - P[:, 0])[:, None, :]
    L = np.broadcast_to(np.hypot(e[..., 0], e[..., 1]), (len(P), len(X)))
    r = X[None] - a
    t0 = (r * e).sum(-1) / L**2
    h = np.abs(e[..., 0] * r[..., 1] - e[..., 1] * r[..., 0]) / L
    dseg = np.hypot(h, L * np.maximum(np.maximum(-t0, t0 - 1.0), 0.0))
    on = dseg <= _HIT * L
    hit = np.where(on.any(0), on.argmax(0), -1)
    W = np.zeros((len(P), 3, len(X)))
    near = (np.hypot(h, L * (t0 - 0.5)) <= _NEAR * L) & (alpha == 1.0) & ~on
    far = ~near & ~on
    if near.any():
        da = np.linalg.norm(r, axis=-1)
        db = np.linalg.norm(X[None] - P[:, 1, None, :], axis=-1)
        W.transpose(1, 0, 2)[:, near] = _closed_form(t0[near], h[near], L[near], da[near], db[near])
    if far.any():
        W.transpose(1, 0, 2)[:, far] = _quadrature(t0[far], h[far], L[far], alpha)
    cols = hit >= 0
    t = np.where(cols, np.clip(t0[np.maximum(hit, 0), np.arange(len(X))], 0.0, 1.0), np.nan)
    W[:, :, cols] = 0.0
    one, zero = np.ones(cols.sum()), np.zeros(cols.sum())  # the limit: a point mass at t
    W[hit[cols], :, np.flatnonzero(cols)] = _lagrange_at(t[cols], one, zero, zero).T
    W /= W.sum(axis=(0, 1))
    return W, hit, t


def _nodes(S):
    """The virtual point controls of segments S (k, 2, 2): (3k, 2) at t = 0, 1/2, 1."""
    return np.stack([S[:, 0], 0.5 * (S[:, 0] + S[:, 1]), S[:, 1]], 1).reshape(-1, 2)


def segment_weights(X, P, *, alpha: float = 1.0) -> np.ndarray:
    """Integrated MLS weights of control segments, as three virtual point controls each.

    Parameters
    ----------
    X : (n, 2) float
        Points.
    P : (k, 2, 2) float
        Control segments ``[[a_i, b_i], ...]`` (positive lengths).
    alpha : float
        Weight exponent, ``w_i(t) = |b_i - a_i| / |p_i(t) - x|^(2 alpha)``.

    Returns
    -------
    W : (k, 3, n) float
        ``W[i, j, x] = int_0^1 w_i(t) l_j(t) dt`` for the quadratic Lagrange basis
        ``l_j`` of the nodes ``t = 0, 1/2, 1``, divided by the column total
        ``sum_i int w_i`` (so every column sums to 1; entries may be negative). Exact
        for alpha = 1 (closed form near the segment, 8-point Gauss-Legendre in the
        sinh variable away from it, where the closed form would cancel); other alpha
        use the sinh-substituted Gauss-Legendre rule everywhere (panels of length <= 1
        in the sinh variable, relative error ~1e-13). A point on a
        segment (closer than ``1e-12 * length``) gets its limit, ``l_j(t)`` at its foot
        point on the first such segment.
    """
    if not alpha > 0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    X = _check_points(X)
    P, _ = _check_segments(P)
    return _line_weights(X, P, float(alpha))[0]


def mls_deform_lines(X, P, Q, *, kind: str = "rigid", alpha: float = 1.0) -> np.ndarray:
    """Image-space MLS deformation with line-segment controls (Schaefer et al. 2006, s.5).

    Parameters
    ----------
    X : (n, 2) float
        Points to deform.
    P, Q : (k, 2, 2) float
        Rest and deformed control segments ``[[start, end], ...]``; ``P`` segments must
        have positive length, ``Q`` ones may be degenerate.
    kind : {"rigid", "similarity", "affine"}
    alpha : float
        Weight exponent: ``w_i(t) = |p_i'(t)| / |p_i(t) - x|^(2 alpha)``.

    Returns
    -------
    U : (n, 2) float
        Deformed points. A point on a rest segment at parameter ``t`` maps exactly to
        ``(1-t) Q[i, 0] + t Q[i, 1]``; ``Q == P`` gives ``X`` back (exactly for rigid and
        similarity); with no segments ``U = X``.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    if not alpha > 0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    X = _check_points(X)
    P, Q = _check_segments(P, Q)
    if len(P) == 0:
        return X.copy()
    W, hit, t = _line_weights(X, P, float(alpha))
    U = X.copy()
    todo = hit < 0
    if todo.any():
        U[todo] = mls_from_weights(X[todo], _nodes(P), _nodes(Q),
                                   W.reshape(-1, len(X))[:, todo], kind=kind)
    on = ~todo
    U[on] = (1.0 - t[on, None]) * Q[hit[on], 0] + t[on, None] * Q[hit[on], 1]
    return U
