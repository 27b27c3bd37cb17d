"""MLS with line-segment controls (Schaefer, McPhail & Warren 2006, section 5).

Each control is a segment ``p_i(t) = (1-t) a_i + t b_i`` mapped to ``q_i(t)``; the sums of
point MLS become integrals with weight ``w_i(t) = |p_i'(t)| / |p_i(t) - v|^(2 alpha)``.
Every quantity of the fit is the integral of a polynomial of degree <= 2 in ``t``, so it
is reproduced exactly by three virtual point controls per segment (t = 0, 1/2, 1) with
signed weights; the point-MLS core :func:`puppet.deform.mls.mls_from_weights` does the rest.
"""
from __future__ import annotations

import numpy as np

from puppet.deform.mls import KINDS, _check_points, mls_from_weights
from puppet.deform.threads import blas_capped

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


@blas_capped
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
