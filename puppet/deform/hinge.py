"""Initial guess for meshes whose parts are joined at single points (hinges).

Object-space MLS over geodesic distance (garment paper §3.1.1) lets every pin pull on
every vertex it reaches; through a hinge that makes a body bend toward an arm turned
about its shoulder, and 20 ARAP iterations do not undo it (35 px on the test arm; 200
iterations would). Here each part is guessed from its own pins plus its hinges, as
articulated figures move:

1. each hinge is placed where the parts that pin it down carry it: the MLS of a part's
   own pins, weighted by (pins - 1), so a part with two pins or more decides and a part
   hanging on one pin follows; when no part has two pins, the MLS of all the pins;
2. each part is then bent by rigid MLS over its own pins and its hinges (two controls,
   a hinge and a tip, turn a part rigidly about the hinge).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from puppet.deform.mls import DistanceWeights, distance_weights, mls_object_space

__all__ = ["hinge_guess", "hinge_weights", "HingeWeights"]


class HingeWeights(NamedTuple):
    """The pose-independent weights of :func:`hinge_guess` (:func:`hinge_weights`): of all
    the pins over the mesh, and of each part's own pins and hinges over its vertices."""

    all: DistanceWeights
    parts: list  # per part: DistanceWeights, or None for a part without pins or hinges


def hinge_weights(D, pin_part, parts, H, DH, *, alpha: float = 1.0) -> HingeWeights:
    """The weights :func:`hinge_guess` computes for every pose, once (same arguments)."""
    pin_part, H = np.asarray(pin_part, np.int64), np.asarray(H, np.int64).reshape(-1, 2)
    member = _members(parts, np.asarray(D).shape[1])
    per = []
    for li, idx in enumerate(parts):
        sel, sides = _part_controls(member[li], li, pin_part, H)
        per.append(None if sel.sum() + len(sides) == 0 else
                   distance_weights(_part_distances(D, DH, sel, sides, idx), alpha=alpha))
    return HingeWeights(distance_weights(D, alpha=alpha), per)


def hinge_guess(V, D, P, bc, pin_part, parts, H, DH, *, alpha: float = 1.0,
                weights: HingeWeights | None = None) -> np.ndarray:
    """Initial guess of a hinged mesh.

    Parameters
    ----------
    V : (n, 2) float
        Rest vertices (or a similarity of them).
    D : (k, n) float
        Geodesic distances from the pins.
    P : (k, 2) float
        The pins' rest positions (in the frame of V).
    bc : (k, 2) float
        The pins' targets.
    pin_part : (k,) int
        The part of each pin.
    parts : list of (n_l,) int arrays
        Vertices of each part (a shared hinge vertex belongs to every part it joins).
    H : (h, 2) int
        Hinges, each as the vertices of its two sides: the same vertex twice for a shared
        vertex, two vertices at the same rest point for a hinge of strength < 1 (a spring).
    DH : (h, 2, n) float
        Geodesic distances from each hinge's two vertices.
    alpha : float
        MLS weight exponent.
    weights : HingeWeights, optional
        ``hinge_weights(D, pin_part, parts, H, DH, alpha=alpha)`` computed before (they do
        not depend on the pose; the same result without their cost). None: computed here.

    Returns
    -------
    U : (n, 2) float
        Pins exactly on ``bc``; a part without pins or hinges takes the plain MLS guess.
    """
    V = np.asarray(V, np.float64)
    U = mls_object_space(V, D, bc, P, kind="rigid", alpha=alpha, weights=None if weights is None else weights.all)
    H = np.asarray(H, np.int64).reshape(-1, 2)
    if len(H) == 0:
        return U
    pin_part = np.asarray(pin_part, np.int64)
    counts = np.bincount(pin_part, minlength=len(parts))
    member = _members(parts, len(V))
    HT = U[H[:, 0]].copy()
    for j, h in enumerate(H):
        acc, wsum = np.zeros(2), 0.0
        for li in range(len(parts)):
            side = _side(member[li], h)
            w = counts[li] - 1.0
            if side is not None and w > 0:
                v, sel = h[side], pin_part == li
                acc += w * mls_object_space(V[[v]], D[sel][:, [v]], bc[sel], P[sel], kind="rigid", alpha=alpha)[0]
                wsum += w
        if wsum > 0:
            HT[j] = acc / wsum
    for li, idx in enumerate(parts):
        sel, sides = _part_controls(member[li], li, pin_part, H)
        if sel.sum() + len(sides) == 0:
            continue
        hs = np.array([j for j, _ in sides], np.int64)
        Dl = _part_distances(D, DH, sel, sides, idx)
        Q = np.vstack([bc[sel], HT[hs]])
        Pl = np.vstack([P[sel], V[H[hs, 0]]])
        U[idx] = mls_object_space(V[idx], Dl, Q, Pl, kind="rigid", alpha=alpha,
                                  weights=None if weights is None else weights.parts[li])
    U[H[:, 0]] = HT
    U[H[:, 1]] = HT
    return U


def _members(parts, n: int) -> list[np.ndarray]:
    """Per part, which of the n vertices belong to it."""
    member = [np.zeros(n, bool) for _ in parts]
    for m, idx in zip(member, parts):
        m[idx] = True
    return member


def _part_controls(member: np.ndarray, li: int, pin_part: np.ndarray, H: np.ndarray):
    """The controls of part ``li``: its pins (bool (k,)) and its hinges' (index, side)."""
    sides = [(j, _side(member, h)) for j, h in enumerate(H)]
    return pin_part == li, [(j, s) for j, s in sides if s is not None]


def _part_distances(D, DH, sel, sides, idx) -> np.ndarray:
    """Distances from part's controls (its pins, then its hinges' sides) to its vertices."""
    Dh = np.array([DH[j, s][idx] for j, s in sides]).reshape(len(sides), len(idx))
    return np.vstack([D[sel][:, idx], Dh])


def _side(member: np.ndarray, h: np.ndarray) -> int | None:
    """Which vertex of hinge ``h`` (2,) lies in the part (``member`` (n,) bool), or None."""
    return 0 if member[h[0]] else (1 if member[h[1]] else None)
