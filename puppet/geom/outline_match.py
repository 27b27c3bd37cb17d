"""Aligning two closed outlines by a similarity, and their nearest-point distance.

Used to carry the pins of a template garment over to another picture of the same kind
of garment (the catalogue workflow of the garment-retargeting paper; the correspondence
along the aligned outlines is :mod:`puppet.geom.outline_corr`). Arrays in, arrays out;
points are ``(n, 2)`` float in pixel coordinates (x right, y down).

A similarity is stored as two complex numbers: ``z -> a z + b`` with ``z = x + i y``, so
``|a|`` is the scale and ``arg(a)`` the rotation (in raw coordinates; no reflection).

Alignment (:func:`alignment_candidates`): both outlines are normalised by their area
centroid and ``sqrt(area)``; candidate rotations come from the principal axes (both
ways), from the best cyclic shifts of a cyclic Procrustes fit of the two uniformly
resampled outlines (computed for every shift at once with an FFT), and from a few fixed
angles; each is refined by a symmetric ICP similarity fit (nearest points both ways,
Umeyama's closed form), and they are ranked by symmetric mean distance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.geom.contour import ring_area
from puppet.geom.curvature import contour_length, resample_closed

__all__ = [
    "Similarity",
    "oriented",
    "ring_centroid",
    "similarity_fit",
    "symmetric_mean_distance",
    "alignment_candidates",
    "align_outlines",
]


def _c(P: np.ndarray) -> np.ndarray:
    P = np.asarray(P, np.float64)
    return P[..., 0] + 1j * P[..., 1]


def _xy(z: np.ndarray) -> np.ndarray:
    return np.stack([z.real, z.imag], axis=-1)


@dataclass(frozen=True)
class Similarity:
    """``z -> a z + b`` on ``z = x + i y``: scale ``|a|``, rotation ``arg(a)``, shift ``b``."""

    a: complex = 1.0 + 0.0j
    b: complex = 0.0j

    def apply(self, P) -> np.ndarray:
        """Map points. ``P`` (..., 2) -> (..., 2)."""
        return _xy(self.a * _c(P) + self.b)

    def inverse(self) -> "Similarity":
        """``z -> (z - b) / a``."""
        return Similarity(a=1.0 / self.a, b=-self.b / self.a)

    def apply_vector(self, D) -> np.ndarray:
        """Map displacements (scaled and rotated, not shifted). (..., 2) -> (..., 2)."""
        return _xy(self.a * _c(D))

    @property
    def scale(self) -> float:
        return float(abs(self.a))

    @property
    def angle(self) -> float:
        """Rotation in degrees, in raw (x, y-down) coordinates: positive turns x towards y,
        i.e. clockwise as seen on screen."""
        return float(np.degrees(np.angle(self.a)))


def oriented(P) -> np.ndarray:
    """The ring with positive shoelace area (reversed if needed), (n, 2)."""
    P = np.asarray(P, np.float64)
    return P if ring_area(P) >= 0 else P[::-1].copy()


def ring_centroid(P) -> tuple[np.ndarray, float]:
    """Area centroid (2,) and unsigned area of the polygon bounded by a ring (n, 2)."""
    P = np.asarray(P, np.float64)
    x, y = P[:, 0], P[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    A = 0.5 * cr.sum()
    if abs(A) < 1e-12:
        return P.mean(axis=0), 0.0
    c = np.array([((x + xn) * cr).sum(), ((y + yn) * cr).sum()]) / (6.0 * A)
    return c, float(abs(A))


def _principal_angle(P: np.ndarray) -> float:
    """Angle of the major axis of the ring's points' second moments, radians."""
    Z = P - P.mean(axis=0)
    C = Z.T @ Z
    w, v = np.linalg.eigh(C)
    return float(np.arctan2(v[1, 1], v[0, 1]))


def similarity_fit(A, B) -> Similarity:
    """Least-squares similarity taking points ``A`` onto ``B`` (paired rows), (k, 2) each.

    Closed form in complex numbers: ``a = sum(conj(A~) B~) / sum(|A~|^2)`` on the
    centred points, ``b = mean(B) - a mean(A)`` (Umeyama's solution without reflection).
    """
    za, zb = _c(A), _c(B)
    ma, mb = za.mean(), zb.mean()
    da, db = za - ma, zb - mb
    den = float(np.vdot(da, da).real)
    a = complex(np.vdot(da, db) / den) if den > 0 else 1.0 + 0j
    return Similarity(a, complex(mb - a * ma))


def _dense(P: np.ndarray, step: float) -> np.ndarray:
    L = contour_length(P)
    return resample_closed(P, max(16, int(np.ceil(L / step))))


def symmetric_mean_distance(P, Q, *, step: float = 0.5) -> float:
    """Mean of the two mean distances from each outline to the other.

    Both rings are resampled every ``step`` (same units as the points), and distances
    are taken to the nearest sample of the other ring (so within ``step / 2`` of the
    distance to the polyline).
    """
    from scipy.spatial import cKDTree

    A, B = _dense(np.asarray(P, float), step), _dense(np.asarray(Q, float), step)
    dab = cKDTree(B).query(A)[0].mean()
    dba = cKDTree(A).query(B)[0].mean()
    return float(0.5 * (dab + dba))


def _icp(A: np.ndarray, B: np.ndarray, tree_b, S: Similarity, iterations: int) -> tuple[Similarity, float]:
    """Symmetric ICP from ``S``; returns the similarity and the mean nearest-sample
    distance (both ways) it was last fitted from."""
    from scipy.spatial import cKDTree

    resid = np.inf
    for _ in range(iterations):
        TA = S.apply(A)
        dj, j = tree_b.query(TA)
        di, i = cKDTree(TA).query(B)
        resid = 0.5 * (dj.mean() + di.mean())
        S_new = similarity_fit(np.vstack([A, A[i]]), np.vstack([B[j], B]))
        done = abs(S_new.a - S.a) < 1e-7 * abs(S.a) and abs(S_new.b - S.b) < 1e-4
        S = S_new
        if done:
            break
    return S, float(resid)


def _candidate_angles(A: np.ndarray, B: np.ndarray, cA: np.ndarray, cB: np.ndarray, fixed: int) -> list[float]:
    zA, zB = _c(A) - complex(*cA), _c(B) - complex(*cB)
    corr = np.fft.ifft(np.conj(np.fft.fft(zA)) * np.fft.fft(zB))  # corr[m] = sum conj(zA_k) zB_(k+m)
    resid = float(np.vdot(zB, zB).real) - np.abs(corr) ** 2 / float(np.vdot(zA, zA).real)
    n = len(resid)
    local = [m for m in range(n) if resid[m] <= resid[m - 1] and resid[m] <= resid[(m + 1) % n]]
    best = sorted(local, key=lambda m: resid[m])[:4]
    th = _principal_angle(B) - _principal_angle(A)
    angles = [float(np.angle(corr[m])) for m in best] + [th, th + np.pi]
    angles += [2 * np.pi * k / fixed for k in range(fixed)]
    return angles


def alignment_candidates(P, Q, *, samples: int = 256, iterations: int = 40, fixed_angles: int = 8,
                         keep: int = 3) -> list[tuple[float, Similarity]]:
    """Similarities taking outline ``P`` onto outline ``Q``, best first.

    Every candidate rotation (module doc) gets 6 ICP iterations; then, best first, they
    are refined by up to ``iterations`` more until ``keep`` different ones are found.

    Parameters
    ----------
    P, Q : (n, 2), (m, 2) float
        Closed rings (any orientation, any sampling).
    samples : points of each resampled ring used by the fit.
    fixed_angles : extra candidate rotations, evenly spaced over the full turn.

    Returns
    -------
    list of (distance, S): ``S`` maps ``P``'s coordinates into ``Q``'s; ``distance`` is
    the :func:`symmetric_mean_distance` of ``S(P)`` and ``Q`` (coarsely sampled), sorted.
    """
    from scipy.spatial import cKDTree

    P, Q = oriented(P), oriented(Q)
    cP, aP = ring_centroid(P)
    cQ, aQ = ring_centroid(Q)
    if aP <= 0 or aQ <= 0:
        raise ValueError("an outline encloses no area")
    A, B = resample_closed(P, samples), resample_closed(Q, samples)
    s0 = np.sqrt(aQ / aP)
    tree_b = cKDTree(B)
    step = np.sqrt(aQ) / 200.0
    coarse: list[tuple[float, Similarity]] = []
    for th in _candidate_angles(A, B, cP, cQ, fixed_angles):
        a = s0 * np.exp(1j * th)
        S, resid = _icp(A, B, tree_b, Similarity(complex(a), complex(*cQ) - a * complex(*cP)), 6)
        coarse.append((resid, S))
    coarse.sort(key=lambda c: c[0])
    out: list[tuple[float, Similarity]] = []
    for _, S in coarse:
        if len(out) == keep:
            break
        S, _ = _icp(A, B, tree_b, S, iterations)
        if any(abs(S.a - T.a) < 0.01 * abs(T.a) and abs(S.b - T.b) < 0.01 * np.sqrt(aQ) for _, T in out):
            continue  # converged to one already kept
        out.append((symmetric_mean_distance(S.apply(A), B, step=step), S))
    return sorted(out, key=lambda c: c[0])


def align_outlines(P, Q, **options) -> tuple[Similarity, float]:
    """The similarity that best takes outline ``P`` onto outline ``Q`` (nearest points).

    Returns ``(S, d)``: ``d`` is :func:`symmetric_mean_distance` between ``S(P)`` and
    ``Q`` divided by ``sqrt(area(Q))`` (0 for the same shape; scale-free). Options as
    :func:`alignment_candidates`.
    """
    S = alignment_candidates(P, Q, **options)[0][1]
    Q = np.asarray(Q, float)
    return S, symmetric_mean_distance(S.apply(P), Q, step=0.5) / np.sqrt(ring_centroid(Q)[1])
