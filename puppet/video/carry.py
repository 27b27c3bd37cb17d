"""Carry points from one frame to another through matched key points (Shen et al. 2010 eq. 17-19).

Inside the Delaunay triangulation of the matched key points of the source frame, a point moves
with the affine map of the triangle that contains it: with the triangle ``T1 T2 T3`` going to
``T1' T2' T3'``, ``B = [T1'-T3', T2'-T3'] [T1-T3, T2-T3]^-1`` and ``P' = B (P - T3) + T3'``,
which is the same as keeping ``P``'s barycentric coordinates. Outside it, or where the triangle
mixes key points of differently moving parts, the point moves with a similarity fitted to its
nearest matches of one motion group, weighted by ``1 / (d^2 + h^2)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.video.features import apply_similarity, similarity_fit


@dataclass
class Carried:
    """Where one point went.

    Attributes
    ----------
    xy : (2,) float array
        Its position in the second frame.
    support : int
        Matches of its motion group among its ``k`` nearest within ``radius``.
    resid : float
        Weighted RMS residual (pixels) of the local similarity over its nearest matches.
    how : str
        ``"triangle"`` (eq. 19) or ``"local"`` (similarity of the nearest matches).
    affine : (2, 3) float array
        The map that carried it (``xy = affine @ [p, 1]``), for warping the point's neighbourhood.
    """

    xy: np.ndarray
    support: int
    resid: float
    how: str
    affine: np.ndarray


class PairMap:
    """Matched, RANSAC-filtered key points of two frames, ready to carry points.

    Parameters
    ----------
    src, dst : (n, 2) float arrays
        Inlier matches (first frame, second frame).
    groups : (n,) int array
        Motion group of each match (from :func:`puppet.video.features.motion_groups`).
    radius : float
        Neighbourhood radius in pixels for support and the local fit.
    k : int
        Nearest matches used by the local fit.
    """

    def __init__(self, src: np.ndarray, dst: np.ndarray, groups: np.ndarray, *, radius: float = 60.0,
                 k: int = 8, h: float = 8.0):
        self.src = np.asarray(src, np.float64)
        self.dst = np.asarray(dst, np.float64)
        self.groups = np.asarray(groups)
        self.radius, self.k, self.h = float(radius), int(k), float(h)
        self.simplices = np.zeros((0, 3), int)
        if len(self.src) >= 3:
            from scipy.spatial import Delaunay, QhullError

            try:
                self.simplices = Delaunay(self.src).simplices
            except (QhullError, ValueError):
                pass
        # barycentric set-up of every triangle, vectorised (scipy's find_simplex builds its
        # transforms through LAPACK, seconds under load)
        t = self.src[self.simplices]  # (m, 3, 2)
        self._e1, self._e2, self._o = t[:, 0] - t[:, 2], t[:, 1] - t[:, 2], t[:, 2]
        det = self._e1[:, 0] * self._e2[:, 1] - self._e1[:, 1] * self._e2[:, 0]
        self._det = np.where(np.abs(det) > 1e-12, det, np.nan)

    def __len__(self) -> int:
        return len(self.src)

    def carry(self, p) -> Carried | None:
        """Carry point ``p`` ((2,)) to the second frame; ``None`` with fewer than two matches."""
        if len(self.src) < 2:
            return None
        p = np.asarray(p, np.float64)
        d2 = ((self.src - p) ** 2).sum(axis=1)
        near = np.argsort(d2)[: self.k]
        w = 1.0 / (d2[near] + self.h ** 2)
        # the motion group that dominates the neighbourhood
        gs = self.groups[near]
        totals = {g: w[gs == g].sum() for g in np.unique(gs)}
        g = max(totals, key=totals.get)
        mine = near[gs == g]
        wm = w[gs == g]
        inside = d2[mine] <= self.radius ** 2
        support = int(inside.sum())
        c = 0j
        if len(mine) >= 2:
            c, mx, my = similarity_fit(self.src[mine], self.dst[mine], wm)
        if 0.5 <= abs(c) <= 2.0:
            pred = apply_similarity(c, mx, my, self.src[mine])
            resid = float(np.sqrt((wm / wm.sum()) @ ((pred - self.dst[mine]) ** 2).sum(axis=1)))
            R = np.array([[c.real, -c.imag], [c.imag, c.real]])
        else:  # one match, or a few bunched ones giving a wild scale: their mean move
            resid = 0.0
            wn = wm / wm.sum()
            R, mx, my = np.eye(2), wn @ self.src[mine], wn @ self.dst[mine]
        local = np.hstack([R, (my - R @ mx)[:, None]])
        s = self._find(p)
        if s >= 0:
            v = self.simplices[s]
            if np.all(self.groups[v] == g):
                A = _triangle_affine(self.src[v], self.dst[v])
                if A is not None:
                    return Carried(A @ np.append(p, 1.0), support, resid, "triangle", A)
        return Carried(local @ np.append(p, 1.0), support, resid, "local", local)

    def _find(self, p: np.ndarray, eps: float = 1e-9) -> int:
        """Index of the triangle containing ``p`` (-1 outside the triangulation)."""
        if not len(self.simplices):
            return -1
        d = p - self._o
        b1 = (d[:, 0] * self._e2[:, 1] - d[:, 1] * self._e2[:, 0]) / self._det
        b2 = (self._e1[:, 0] * d[:, 1] - self._e1[:, 1] * d[:, 0]) / self._det
        inside = (b1 >= -eps) & (b2 >= -eps) & (b1 + b2 <= 1 + eps)
        hits = np.flatnonzero(inside)
        return int(hits[0]) if len(hits) else -1


def _triangle_affine(T0: np.ndarray, T1: np.ndarray) -> np.ndarray | None:
    """The affine map of triangle ``T0`` ((3, 2)) onto ``T1`` (eq. 17-18): ``[B | T*]`` (2, 3).

    ``B = U V^-1`` with ``V = [T1 - T3, T2 - T3]`` of the source and ``U`` of the target (2x2
    inverses written out: LAPACK calls on tiny matrices are slow when threads are contended).
    ``None`` for a folded or strongly sheared map (mismatched vertices, not a moving part).
    """
    V = (T0[:2] - T0[2]).T
    U = (T1[:2] - T1[2]).T
    det = V[0, 0] * V[1, 1] - V[0, 1] * V[1, 0]
    if abs(det) < 1e-9:
        return None
    Vinv = np.array([[V[1, 1], -V[0, 1]], [-V[1, 0], V[0, 0]]]) / det
    B = U @ Vinv
    a, b, c, d = B[0, 0], B[0, 1], B[1, 0], B[1, 1]
    detB = a * d - b * c
    if detB <= 0:
        return None
    # singular values of a 2x2 matrix: sqrt of (q +- sqrt(q^2 - detB^2)) with q = |B|_F^2 / 2
    q = 0.5 * (a * a + b * b + c * c + d * d)
    root = np.sqrt(max(q * q - detB * detB, 0.0))
    s1, s2 = np.sqrt(q + root), np.sqrt(max(q - root, 0.0))
    if s1 > 2.0 * s2:
        return None
    return np.hstack([B, (T1[2] - B @ T0[2])[:, None]])
