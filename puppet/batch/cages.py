"""A template's cage carried to a new picture (template mode, :mod:`puppet.batch.template`):
made to enclose the picture's mesh by pushing out the cage vertices whose edges cut it.

The carried cage keeps its vertex count and order (handle ``LAYER:cageK`` of the template
is handle ``LAYER:cageK`` of the picture); only the vertices that must move to hold the
mesh move, each along its outward vertex normal.
"""
from __future__ import annotations

import numpy as np

from puppet.deform.cage import check_cage, winding
from puppet.geom.contour import ring_area

__all__ = ["CageRefused", "enclose", "nearest_on_ring", "GROW_ROUNDS", "MARGIN"]

#: Rounds of pushing out the vertices of cutting edges before the cage is refused.
GROW_ROUNDS = 6
#: How far (px) beyond the farthest left-out mesh vertex a cutting edge is pushed.
MARGIN = 2.0


class CageRefused(ValueError):
    """The carried cage crosses itself, or still leaves mesh vertices out after growing:
    the message says which, in words (the caller names the file and the cage)."""


def _outward_normals(C: np.ndarray) -> np.ndarray:
    """(m, 2) unit outward normals at the vertices of the simple ring ``C`` (the mean of
    the two edges' outward normals, either orientation)."""
    E = np.roll(C, -1, axis=0) - C
    n = np.stack([E[:, 1], -E[:, 0]], axis=1) / np.hypot(E[:, 0], E[:, 1])[:, None]
    n *= np.sign(ring_area(C))  # (dy, -dx) points out of a ring of positive shoelace area
    N = n + np.roll(n, 1, axis=0)  # vertex i: edges i-1 and i
    return N / np.maximum(np.hypot(N[:, 0], N[:, 1]), 1e-12)[:, None]


def nearest_on_ring(R: np.ndarray, X: np.ndarray):
    """The nearest point of the closed polyline ``R`` (m, 2) to each point of ``X`` (k, 2):
    its edge's index i (edge i joins ``R[i]`` and ``R[i + 1]``), its parameter t on that
    edge, the point, the distance; and the edge vectors and squared lengths, (m, 2), (m,)."""
    E = np.roll(R, -1, axis=0) - R
    le2 = np.maximum((E * E).sum(axis=1), 1e-18)
    D = X[:, None, :] - R[None, :, :]
    t = np.clip((D * E[None]).sum(axis=2) / le2, 0.0, 1.0)
    F = R[None] + t[..., None] * E[None]
    d = np.linalg.norm(X[:, None, :] - F, axis=2)
    i = d.argmin(axis=1)
    k = np.arange(len(X))
    return i, t[k, i], F[k, i], d[k, i], E, le2


def enclose(C, V, *, reach: float, rounds: int = GROW_ROUNDS, margin: float = MARGIN,
            ) -> tuple[np.ndarray, list[int]]:
    """The cage ``C`` (m, 2) grown until it holds every point of ``V`` (n, 2) inside (a
    point on the cage may count either way, as for the scene build's check): each round, both ends of the edge nearest to each left-out point are pushed
    out along their vertex normals by that point's distance to the edge plus ``margin``;
    no vertex moves farther than ``reach`` px in all.

    Returns
    -------
    (m, 2) float, the cage (``C`` itself where nothing was left out); the indices of the
    vertices that moved, ascending.

    Raises
    ------
    CageRefused : the cage (as given or as grown) crosses itself, or points are still
        left out after ``rounds`` rounds or would need a vertex moved beyond ``reach``.
    """
    C = np.array(C, np.float64)
    V = np.asarray(V, np.float64).reshape(-1, 2)
    C0, moved = C, np.zeros(len(C), bool)
    for r in range(rounds + 1):
        msg = check_cage(C)
        if msg:
            raise CageRefused(msg if r == 0 else f"{msg} once grown round the picture's garment")
        out = np.flatnonzero(np.abs(winding(C, V)) < 0.75)  # outside, or on the cage
        if not len(out):
            return C, np.flatnonzero(moved).tolist()
        if r == rounds:
            break
        edge, _, _, dist, _, _ = nearest_on_ring(C, V[out])
        push = np.zeros(len(C))
        np.maximum.at(push, edge, dist + margin)
        np.maximum.at(push, (edge + 1) % len(C), dist + margin)
        C = C + push[:, None] * _outward_normals(C)
        moved |= push > 0
        far = np.hypot(*(C - C0).T)
        if far.max() > reach:
            j = int(far.argmax())
            raise CageRefused(f"leaves {len(out)} of the picture's {len(V)} mesh vertices outside (the first at "
                              f"[{V[out[0], 0]:g}, {V[out[0], 1]:g}]): holding them would move cage vertex {j} "
                              f"more than {reach:.0f} px")
    raise CageRefused(f"leaves {len(out)} of the picture's {len(V)} mesh vertices outside even grown "
                      f"{rounds} times (the first at [{V[out[0], 0]:g}, {V[out[0], 1]:g}])")
