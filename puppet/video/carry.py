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
    """

    xy: np.ndarray
    support: int
    resid: float
    how: str


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
        self.tri = None
        if len(self.src) >= 3:
            from scipy.spatial import Delaunay, QhullError

            try:
                self.tri = Delaunay(self.src)
            except (QhullError, ValueError):
                self.tri = None

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
        if len(mine) >= 2:
            c, mx, my = similarity_fit(self.src[mine], self.dst[mine], wm)
            pred = apply_similarity(c, mx, my, self.src[mine])
            resid = float(np.sqrt((wm / wm.sum()) @ ((pred - self.dst[mine]) ** 2).sum(axis=1)))
            local = apply_similarity(c, mx, my, p[None])[0]
        else:
            resid = 0.0
            local = p + self.dst[mine[0]] - self.src[mine[0]]
        if self.tri is not None:
            s = int(self.tri.find_simplex(p))
            if s >= 0:
                v = self.tri.simplices[s]
                if np.all(self.groups[v] == g):
                    return Carried(self._barycentric(s, v, p), support, resid, "triangle")
        return Carried(local, support, resid, "local")

    def _barycentric(self, s: int, v: np.ndarray, p: np.ndarray) -> np.ndarray:
        T = self.tri.transform[s]
        b = T[:2] @ (p - T[2])
        bary = np.array([b[0], b[1], 1.0 - b.sum()])
        return bary @ self.dst[v]
